// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mgc::sim {

//! What can go wrong on the simulated machine (docs/simulator.md §Faults).
enum class FaultKind : std::uint8_t {
  EncoderDropout,  //!< the joint's encoder stops sending positions; its heartbeat goes on
  EncoderStuck,    //!< the encoder keeps sending the position it had when the fault began
  TagNoise,        //!< a tag's fixes get extra noise (sigma_m) the gateway does not report
  UwbSilent,       //!< the UWB gateway sends no fixes; its heartbeat goes on
  FrameDelay,      //!< every frame the machine sends leaves delay_ms late
  BusOff,          //!< the machine's CAN controller goes bus-off: an error frame, then silence
  HeartbeatLost,   //!< one node stops its heartbeat; its other messages go on
  ValveIgnore,     //!< the valve node ignores new commands and keeps applying the last one
};

[[nodiscard]] const char* to_string(FaultKind kind) noexcept;

//! Which device a fault hits.
struct FaultTarget {
  enum class Kind : std::uint8_t { None, Joint, Tag, UwbGateway, Valve };
  Kind kind = Kind::None;
  int index = -1;  //!< joint index or tag id
};

struct Fault {
  FaultKind kind = FaultKind::EncoderDropout;
  FaultTarget target{};
  double start_s = 0.0;                                         //!< simulation time [s]
  double duration_s = std::numeric_limits<double>::infinity();  //!< [s]
  double sigma_m = 2.0;   //!< TagNoise: extra 1-sigma noise per axis [m]
  double delay_ms = 50.0; //!< FrameDelay [ms]

  [[nodiscard]] bool active(double t_s) const noexcept { return t_s >= start_s && t_s < start_s + duration_s; }
};

//! Parses "KIND[:TARGET][@START_S[+DURATION_S]][,key=value]" (e.g. "encoder-stuck:boom_elevation@20+5",
//! "tag-noise:2@10,sigma_m=3", "frame-delay@5+2,delay_ms=80"). joint_names resolve joint targets.
//! Throws std::invalid_argument naming the text, the part at fault and what was expected.
[[nodiscard]] Fault parse_fault(std::string_view text, std::span<const std::string> joint_names);

//! The accepted kinds and their targets, one line each, for --help and error messages.
[[nodiscard]] std::string fault_syntax();

}  // namespace mgc::sim
