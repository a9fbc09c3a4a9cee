// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/status.hpp"

//! Who is on the bus for one machine, and the timing defaults (docs/protocol.md). Both the
//! controller and the simulator build from the same plan.
namespace mgc::hal {

inline constexpr std::size_t kMaxBusJoints = 8;  //!< joints one plan (and one valve node) serves

inline constexpr std::uint8_t kControllerNodeId = 0x01;
inline constexpr std::uint8_t kFirstEncoderNodeId = 0x11;  //!< joint i's encoder is 0x11 + i
inline constexpr std::uint8_t kUwbGatewayNodeId = 0x20;
inline constexpr std::uint8_t kValveNodeId = 0x30;
inline constexpr std::uint8_t kCutoffNodeId = 0x31;  //!< pilot-pressure cut-off: the second shut-off channel
//! The boom's inclinometer: a second source of the boom's angle, beside its encoder.
inline constexpr std::uint8_t kInclinometerNodeId = 0x19;

//! One joint's encoder node.
struct JointEncoder {
  const char* joint = "";  //!< joint name as in the machine model (static string)
  std::uint8_t node_id = 0;
  pdo::EncoderKind kind = pdo::EncoderKind::Rotary;
};

//! Timing defaults; the numbers and their reasons are in docs/protocol.md §Timing.
struct BusTiming {
  std::int64_t sync_period_us = 10'000;                  //!< controller SYNC, 100 Hz [µs]
  std::uint8_t sync_counter_overflow = 240;              //!< SYNC counter runs 1..240 [-]
  std::int64_t controller_heartbeat_period_us = 50'000;  //!< controller heartbeat producer [µs]
  std::int64_t device_heartbeat_period_us = 100'000;     //!< every device's heartbeat producer [µs]
  std::int64_t valve_heartbeat_timeout_us = 150'000;     //!< valve consumer of the controller [µs]
  std::int64_t valve_command_timeout_us = 50'000;        //!< valve RPDO timeout, 5 SYNC periods [µs]
  std::int64_t cutoff_heartbeat_timeout_us = 150'000;    //!< cut-off node's consumer of the controller [µs]
  std::int64_t cutoff_command_timeout_us = 50'000;       //!< cut-off RPDO timeout, 5 SYNC periods [µs]
  std::int64_t device_heartbeat_timeout_us = 250'000;    //!< controller consumer of each device [µs]
  std::int64_t encoder_stale_after_us = 30'000;          //!< no encoder PDO for 3 SYNC periods [µs]
  std::int64_t uwb_tag_stale_after_us = 500'000;         //!< no fix of a tag for 5 nominal periods [µs]
};

//! Node ids of one machine.
struct BusPlan {
  const char* machine = "";  //!< machine kind as in the scenario files (static string)
  std::uint8_t controller_node_id = kControllerNodeId;
  std::array<JointEncoder, kMaxBusJoints> encoders{};
  std::uint8_t num_joints = 0;
  std::uint8_t uwb_gateway_node_id = kUwbGatewayNodeId;
  std::uint8_t valve_node_id = kValveNodeId;
  std::uint8_t cutoff_node_id = kCutoffNodeId;
  //! An inclinometer on the link that joint inclinometer_joint raises, reporting the link's angle to
  //! the horizontal in the rotary encoders' format (docs/protocol.md); 0 / -1: none.
  std::uint8_t inclinometer_node_id = 0;
  std::int8_t inclinometer_joint = -1;
  BusTiming timing{};
};

//! Mobile telescopic crane: swing, boom_elevation, boom_length, cable_length; a boom inclinometer.
[[nodiscard]] BusPlan mobile_crane_bus_plan() noexcept;
//! Tower crane: slew, trolley_radius, hook_height.
[[nodiscard]] BusPlan tower_crane_bus_plan() noexcept;
//! Excavator: swing, boom, arm, bucket; a boom inclinometer.
[[nodiscard]] BusPlan excavator_bus_plan() noexcept;

//! The plan of a machine kind as the scenario files name it ("mobile_crane", "tower_crane",
//! "excavator"), checked against the machine's joint names in order. Start-up only: throws
//! std::invalid_argument saying which kind or joint does not fit.
[[nodiscard]] BusPlan bus_plan_for(std::string_view machine_kind, std::span<const std::string> joint_names);

//! What a frame is, by its id alone.
enum class MessageKind : std::uint8_t {
  Unknown,
  Nmt,
  Sync,
  Emcy,
  Heartbeat,
  EncoderPosition,
  InclinometerAngle,
  UwbTagPosition,
  ValveCommand,
  ValveStatus,
  ValveApplied,
  CutoffCommand,
  CutoffStatus,
};

[[nodiscard]] const char* to_string(MessageKind kind) noexcept;

struct Classified {
  MessageKind kind = MessageKind::Unknown;
  std::uint8_t node_id = 0;  //!< the producing node (consuming node for NMT targets and RPDOs)
  std::int8_t index = -1;    //!< joint for EncoderPosition, bank for ValveCommand/ValveApplied
};

//! Classifies by COB-ID against the plan: Sync/Nmt by id; Emcy/Heartbeat for any node of the
//! plan; PDOs only for the node and PDO number the plan assigns. Extended, RTR and error frames,
//! and ids wider than 11 bits, are Unknown. RT-safe.
[[nodiscard]] Classified classify(const CanFrame& frame, const BusPlan& plan) noexcept;

//! Per-outcome decode counters for the receiving side (unknown ids are counted, never fatal).
struct CodecCounters {
  std::uint64_t decoded = 0;        //!< frames decoded without error [frames]
  std::uint64_t unknown_id = 0;     //!< classify() said Unknown [frames]
  std::uint64_t wrong_length = 0;   //!< [frames]
  std::uint64_t wrong_id = 0;       //!< [frames]
  std::uint64_t out_of_range = 0;   //!< [frames]
  std::uint64_t reserved_bits = 0;  //!< [frames]
  std::uint64_t other = 0;          //!< any other status [frames]
  //! Decoded (and counted in decoded), but the value lies outside what the receiver was told is
  //! plausible, e.g. an encoder position outside its joint's range (Hal::set_joint_plausible_range) [frames].
  std::uint64_t implausible = 0;

  //! Counts one decode outcome. RT-safe.
  void record(Status status) noexcept;
  //! Frames refused as malformed (wrong length, id, range, reserved bits, other) [frames].
  [[nodiscard]] std::uint64_t malformed() const noexcept {
    return wrong_length + wrong_id + out_of_range + reserved_bits + other;
  }
};

}  // namespace mgc::hal
