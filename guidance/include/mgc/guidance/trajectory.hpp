// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>

#include "mgc/guidance/profile.hpp"

namespace mgc::guidance {

//! Outcome of a trajectory calculation or cycle. Positive: progress; negative: errors (guidance -200…).
enum class TrajectoryStatus : std::int16_t {
  Working = 0,                //!< a motion is under way
  Finished = 1,               //!< the target state is reached (and held)
  ErrorInvalidInput = -200,   //!< a limit is not positive and finite, or a state value is not finite
  ErrorNoSolution = -201,     //!< numerical failure: no profile met the end-state tolerances
  ErrorDuration = -202,       //!< a requested duration is shorter than the time-optimal one
};

//! Which input made a calculation fail (ErrorInvalidInput), so the reason is not lost.
enum class InvalidField : std::int8_t {
  None = 0,
  MaxVelocity,
  MaxAcceleration,
  MaxJerk,
  CurrentPosition,
  CurrentVelocity,
  CurrentAcceleration,
  TargetPosition,
  Duration,
  CycleTime,    //!< the online cycle time dt_s
  JointCount,   //!< no joints, or more than the online wrapper holds
  MovingJoint,  //!< the selected joint is not one of the joints
};

//! Symmetric kinematic limits of one joint: |v| <= max_velocity, |a| <= max_acceleration, |j| <= max_jerk.
struct JointLimits {
  double max_velocity = 1.0;      //!< [m/s] or [rad/s], > 0
  double max_acceleration = 1.0;  //!< [m/s²] or [rad/s²], > 0
  double max_jerk = 1.0;          //!< [m/s³] or [rad/s³], > 0
};

//! Result of a calculation: the status and, on ErrorInvalidInput, the offending field.
struct CalculationResult {
  TrajectoryStatus status = TrajectoryStatus::Working;
  InvalidField field = InvalidField::None;
  [[nodiscard]] bool ok() const noexcept { return status == TrajectoryStatus::Working; }
};

//! Time-optimal jerk-limited motion of one joint from `start` to rest at `target_position`
//! (target velocity and acceleration zero). A start whose acceleration is beyond max acceleration,
//! or whose velocity is or will be beyond max velocity whatever the jerk does, is first brought
//! within them at the earliest instant from which it can stay within (a braking segment, closed
//! form); the rest is the fastest profile of the seven-phase family (docs/trajectory.md). RT-safe:
//! no alloc, no lock, no throw, no iteration beyond fixed bounds.
[[nodiscard]] CalculationResult calculate_time_optimal(const JointState& start, double target_position,
                                                       const JointLimits& limits, Profile& out) noexcept;

//! Time-optimal stop of one joint: the braking segment if needed, then the fastest velocity change
//! to rest (wherever it ends). RT-safe.
[[nodiscard]] CalculationResult calculate_stop(const JointState& start, const JointLimits& limits, Profile& out) noexcept;

//! The same move taking exactly duration_s [s] from `start` (braking segment included): the
//! time-optimal change to a cruise velocity, the cruise, the time-optimal change to rest; or, for
//! durations just above the minimum that this form cannot take, the time-optimal profile under a
//! lowered jerk limit (docs/trajectory.md). ErrorDuration when duration_s is shorter than the
//! time-optimal duration or no such profile takes it; `out` then holds the time-optimal profile.
//! RT-safe; at most 100 time-optimal calculations (the lowered jerk's search).
[[nodiscard]] CalculationResult calculate_for_duration(const JointState& start, double target_position,
                                                       const JointLimits& limits, double duration_s,
                                                       Profile& out) noexcept;

//! Joints a synchronized calculation holds (fixed arrays, no allocation).
inline constexpr std::size_t kMaxSynchronizedJoints = 8;

//! Result of a synchronized calculation: the status, the offending joint and field on error, and
//! the common duration.
struct SynchronizedResult {
  TrajectoryStatus status = TrajectoryStatus::Working;
  InvalidField field = InvalidField::None;
  std::size_t joint = 0;    //!< the joint that failed; joint_count for the joint count itself
  double duration_s = 0.0;  //!< [s] the common duration
  //! Synchronization::Phase was asked for and taken: every joint on one straight line in joint space.
  bool phase_synchronized = false;
  [[nodiscard]] bool ok() const noexcept { return status == TrajectoryStatus::Working; }
};

//! How synchronized joints move together.
enum class Synchronization : std::uint8_t {
  Time,   //!< they end together, each on its own profile
  Phase,  //!< on one straight line in joint space (every joint a scaled copy of one profile), where
          //!< the start allows it (every joint's velocity and acceleration in proportion to its
          //!< distance to go, no braking needed); otherwise as Time
};

//! Synchronized move of joint_count (1..kMaxSynchronizedJoints) joints, each to rest at its target:
//! every profile out[i] lasts the least duration that all joints can take, which is the slowest
//! joint's time-optimal duration unless another joint cannot take it (docs/trajectory.md). Arrays
//! hold joint_count entries. RT-safe: no alloc, no lock, no throw, bounded iterations.
[[nodiscard]] SynchronizedResult calculate_synchronized(const JointState* start, const double* target_position,
                                                        const JointLimits* limits, std::size_t joint_count,
                                                        Profile* out) noexcept;

//! As above, with the mode: Synchronization::Phase puts every joint on one straight line in joint
//! space (each joint's profile a copy of one profile scaled by its distance to go, which is
//! time-optimal under the joints' limits divided by their distances; no shorter profile keeps them
//! on the line) when every joint's start velocity and acceleration are in proportion to its
//! distance to go (to 1e-12 of its limits) and the line's start needs no braking, and falls back
//! to Synchronization::Time otherwise (SynchronizedResult::phase_synchronized says which). RT-safe.
[[nodiscard]] SynchronizedResult calculate_synchronized(const JointState* start, const double* target_position,
                                                        const JointLimits* limits, std::size_t joint_count,
                                                        Profile* out, Synchronization mode) noexcept;

}  // namespace mgc::guidance
