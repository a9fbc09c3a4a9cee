// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/limits.hpp>
#include <mgc/planning/machine_model.hpp>

#include <array>
#include <cstdint>
#include <limits>
#include <type_traits>

//! What the control loop hands to the LCM I/O thread once per cycle (docs/operator-feed.md): a
//! plain, trivially copyable, fixed-size struct, so the hand-over is a memcpy into a queue slot.
//! Enumerations use the values of the matching lcm_types constants, so the I/O thread copies them.
namespace mgc::firmware {

inline constexpr int kSnapshotMaxAlerts = 16;      //!< active alerts carried per snapshot [-]
inline constexpr int kSnapshotMaxWaypoints = 32;   //!< plan waypoints carried per snapshot [-]
inline constexpr int kInstructionTextBytes = 96;   //!< operator words incl. the terminating NUL [bytes]
inline constexpr int kSnapshotMaxObstacles = 8;    //!< tracked obstacles carried per snapshot (obstacle_poses_t::MAX_OBSTACLES) [-]

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

//! One active alert, as alert_t without the publish time.
struct SnapshotAlert {
  std::int32_t alert_id = 0;          //!< stable from raise to clear [-]
  std::int8_t severity = 0;           //!< alert_t::SEVERITY_* [enum]
  std::int8_t source = 0;             //!< alert_t::SOURCE_* [enum]
  std::int8_t clear_condition = 0;    //!< alert_t::CLEAR_* [enum]
  std::int8_t value_unit = 0;         //!< alert_t::UNIT_* [enum]
  double value = kNaN;                //!< [value_unit]
  double limit = kNaN;                //!< [value_unit]
  std::int32_t index = -1;            //!< obstacle or limit index, -1 = none [-]
  double min_clearance_m = kNaN;      //!< [m]
};

//! The active plan, small enough to travel every cycle; plan_id changes when a new plan is accepted.
struct SnapshotPlan {
  std::uint32_t plan_id = 0;          //!< 0 = no plan [-]
  std::int8_t status = 0;             //!< plan_t::STATUS_* [enum]
  int num_joints = 0;                 //!< [-]
  int num_waypoints = 0;              //!< 0..kSnapshotMaxWaypoints [-]
  std::array<std::array<double, kMaxJoints>, kSnapshotMaxWaypoints> positions{};  //!< [rad | m]
  std::array<std::int8_t, kSnapshotMaxWaypoints> moving_joint{};  //!< plan_t::moving_joint [-]
  double path_length = kNaN;          //!< normalized joint-space length [-]
  double execution_time_s = kNaN;     //!< [s]
};

//! One tracked dynamic obstacle, as obstacle_poses_t carries it.
struct SnapshotObstacle {
  std::int32_t obstacle_index = -1;   //!< in the scenario's dynamic_obstacles [-]
  bool valid = false;                 //!< the tracker's pose is current (ObstacleTracker::valid) [-]
  bool still = false;                 //!< ObstacleTracker::still [-]
  std::array<double, 3> position_m{kNaN, kNaN, kNaN};  //!< frame origin, site frame [m]
  double yaw_rad = kNaN;              //!< about the site's z [rad]
  double position_sigma_m = kNaN;     //!< 1-sigma [m]
  double speed_m_s = kNaN;            //!< frame origin, as the stop check estimates it; NaN until its window fills [m/s]
  double yaw_rate_rad_s = kNaN;       //!< about z, likewise [rad/s]
  std::int64_t fix_us = 0;            //!< last accepted tag fix, 0 = never [µs]
};

//! The loop's timing counters (ExecutiveStats reduced to numbers), plus the queue's drops.
struct SnapshotTiming {
  std::int64_t period_us = 0;
  std::uint64_t cycles = 0;
  std::uint64_t deadline_misses = 0;
  std::uint64_t skipped_periods = 0;
  std::uint64_t watchdog_trips = 0;
  std::int64_t compute_p99_us = 0;
  std::int64_t compute_max_us = 0;
  std::int64_t lateness_p99_us = 0;
  std::int64_t lateness_max_us = 0;
  std::uint64_t snapshots_dropped = 0;  //!< filled by whoever reads the queue's counter [-]
};

//! The hal's decode counters since start (hal::CodecCounters), for health_counters_t.
struct SnapshotBus {
  std::uint64_t decoded = 0;        //!< [frames]
  std::uint64_t unknown_id = 0;     //!< [frames]
  std::uint64_t wrong_length = 0;   //!< [frames]
  std::uint64_t wrong_id = 0;       //!< [frames]
  std::uint64_t out_of_range = 0;   //!< [frames]
  std::uint64_t reserved_bits = 0;  //!< [frames]
  std::uint64_t other = 0;          //!< [frames]
  std::uint64_t implausible = 0;    //!< [frames]
};

struct GuidanceSnapshot {
  std::int64_t utime_us = 0;          //!< cycle start, monotonic [µs]
  std::int64_t utime_sample_us = 0;   //!< oldest joint sample used [µs]
  std::uint64_t cycle_index = 0;      //!< [-]

  // Machine state.
  planning::MachineKind machine_kind = planning::MachineKind::MobileCrane;
  int num_joints = 0;                 //!< 0..kMaxJoints [-]
  std::array<double, kMaxJoints> joint_position{};      //!< [rad | m]
  std::array<double, kMaxJoints> joint_velocity{};      //!< [rad/s | m/s]
  std::array<double, kMaxJoints> joint_acceleration{};  //!< [rad/s² | m/s²]
  std::array<std::int8_t, kMaxJoints> joint_fault_flags{};  //!< machine_state_t::JOINT_* bits
  std::array<double, 3> tool_position_m{kNaN, kNaN, kNaN};  //!< site frame [m]
  std::int8_t supervisor_state = 0;   //!< machine_state_t::SUPERVISOR_* [enum]
  double load_moment_pct = kNaN;      //!< of rated capacity [%]

  // Plan and the next instruction.
  SnapshotPlan plan{};
  std::int8_t instruction = 0;        //!< operator_guidance_t::INSTRUCTION_* [enum]
  std::int32_t segment_index = -1;    //!< [-]
  std::int8_t moving_joint = -1;      //!< [-]
  double target_position = kNaN;      //!< [rad | m]
  double joint_distance_remaining = kNaN;  //!< [rad | m]
  double path_distance_remaining = kNaN;   //!< [-]
  double time_remaining_s = kNaN;     //!< [s]
  double speed_scale = kNaN;          //!< 0..1 [-]
  std::array<char, kInstructionTextBytes> instruction_text{};  //!< NUL-terminated operator words

  // Clearances.
  double obstacle_clearance_m = kNaN; //!< to the nearest obstacle [m]
  std::int32_t obstacle_index = -1;   //!< [-]
  double limit_margin = kNaN;         //!< nearest joint to its range limit [rad | m]
  std::int8_t limit_joint = -1;       //!< [-]
  double envelope_distance_m = kNaN;  //!< nearest monitored point to a working-envelope limit, positive inside [m]
  std::int8_t envelope_limit = 0;     //!< operator_instruction_t::ENVELOPE_* [enum]
  std::int8_t envelope_wall = -1;     //!< [-]

  // Tracked dynamic obstacles: the first kSnapshotMaxObstacles trackers; num_tracked counts all.
  int num_tracked = 0;                //!< the controller's trackers [-]
  int num_obstacles = 0;              //!< 0..kSnapshotMaxObstacles [-]
  std::array<SnapshotObstacle, kSnapshotMaxObstacles> obstacles{};

  // Alerts active this cycle.
  int num_alerts = 0;                 //!< 0..kSnapshotMaxAlerts [-]
  std::array<SnapshotAlert, kSnapshotMaxAlerts> alerts{};

  SnapshotTiming timing{};
  SnapshotBus bus{};                  //!< filled by whoever owns the hal
};

static_assert(std::is_trivially_copyable_v<GuidanceSnapshot>);

}  // namespace mgc::firmware
