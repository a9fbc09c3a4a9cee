// SPDX-License-Identifier: Apache-2.0
#pragma once

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
//! (target velocity and acceleration zero). A start state beyond the limits (|a| > max
//! acceleration, or a velocity that is or will be beyond max velocity) is first brought inside
//! them by a braking pre-phase; the rest is the fastest profile of the seven-phase family
//! (docs/trajectory.md). RT-safe: no alloc, no lock, no throw.
[[nodiscard]] CalculationResult calculate_time_optimal(const JointState& start, double target_position,
                                                       const JointLimits& limits, Profile& out) noexcept;

//! Time-optimal stop of one joint: the braking pre-phase if needed, then the fastest velocity change
//! to rest (wherever it ends). RT-safe.
[[nodiscard]] CalculationResult calculate_stop(const JointState& start, const JointLimits& limits, Profile& out) noexcept;

}  // namespace mgc::guidance
