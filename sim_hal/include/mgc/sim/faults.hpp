// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mgc/planning/joint.hpp"

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
  EncoderOffset,   //!< the encoder lies: it reports the true position plus offset + rate × time since the fault began
  CutoffFail,      //!< the cut-off's dump valve sticks closed: pilot pressure stays whatever the node is told
  JointCreep,      //!< the joint creeps at offset_rate, whatever its spool, while pilot pressure is on
};

[[nodiscard]] const char* to_string(FaultKind kind) noexcept;

//! Which device a fault hits.
struct FaultTarget {
  //! Inclinometer: the boom inclinometer (encoder-stuck, encoder-offset, encoder-dropout and
  //! heartbeat-lost accept it as their target).
  enum class Kind : std::uint8_t { None, Joint, Tag, UwbGateway, Valve, Cutoff, Inclinometer };
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
  //! EncoderOffset: the lie at the fault's start, and how fast it grows (JointCreep: the creep's
  //! speed); in the joint's unit as the
  //! fault text gives it (deg for a revolute joint, m for a prismatic one), stored in SI. [rad | m, /s]
  double offset = 0.0;
  double offset_rate = 0.0;

  [[nodiscard]] bool active(double t_s) const noexcept { return t_s >= start_s && t_s < start_s + duration_s; }
};

//! Parses "KIND[:TARGET][@START_S[+DURATION_S]][,key=value]" (e.g. "encoder-stuck:boom_elevation@20+5",
//! "tag-noise:2@10,sigma_m=3", "frame-delay@5+2,delay_ms=80", "encoder-offset:swing@4,offset=-20").
//! joint_names resolve joint targets. An encoder-offset's values are in degrees for a revolute
//! joint and metres for a prismatic one; parse_fault without the specs refuses that kind.
//! Throws std::invalid_argument naming the text, the part at fault and what was expected.
[[nodiscard]] Fault parse_fault(std::string_view text, std::span<const std::string> joint_names);
//! The same with the machine's joints, which also give the unit of an encoder-offset.
[[nodiscard]] Fault parse_machine_fault(std::string_view text, std::span<const planning::JointSpec> joints);

//! The accepted kinds and their targets, one line each, for --help and error messages.
[[nodiscard]] std::string fault_syntax();

}  // namespace mgc::sim
