// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "mgc/limits.hpp"
#include "mgc/planning/joint.hpp"

//! The last stage before the Hal: per-joint limiting of the commanded joint velocity (the valve
//! command is velocity / max_velocity, docs/protocol.md §Valve) so that no cycle's command change
//! exceeds the joint's acceleration and, optionally, jerk limit. docs/control-loop.md §Rate limiter.
namespace mgc::firmware {

//! One joint's limits as the rate limiter applies them.
struct RateLimits {
  double max_velocity = 0.0;      //!< [rad/s | m/s], > 0
  double max_acceleration = 0.0;  //!< the slew rate of the velocity command [rad/s^2 | m/s^2], > 0
  double max_jerk = 0.0;          //!< [rad/s^3 | m/s^3]; 0 = no jerk limit
};

//! Whether the rate limiter limits jerk too (the joints' max_jerk) or only acceleration.
enum class JerkLimit : std::uint8_t { Off, On };

//! Limits from the machine model's joints. With JerkLimit::On every joint needs max_jerk > 0.
//! Start-up only: throws std::invalid_argument naming the joint and the field on a bad limit or
//! more than kMaxJoints joints.
[[nodiscard]] std::array<RateLimits, kMaxJoints> rate_limits_from(std::span<const planning::JointSpec> joints,
                                                                 JerkLimit jerk);

enum class RateLimitStatus : std::int8_t {
  Ok = 0,
  InvalidPeriod = -1,  //!< period not finite or <= 0: the command was held unchanged
};

struct RateLimitResult {
  RateLimitStatus status = RateLimitStatus::Ok;
  std::uint8_t limited_mask = 0;  //!< bit j: joint j's output differs from its (clamped) target this cycle
  std::uint8_t clamped_mask = 0;  //!< bit j: joint j's target exceeded max_velocity and was clamped
  std::uint8_t refused_mask = 0;  //!< bit j: joint j's target was NaN or infinite and taken as 0
};

//! Per-joint slew limiter of velocity commands, with the period passed in. Each joint keeps a
//! commanded velocity and acceleration; per cycle the acceleration changes by at most
//! max_jerk * period (when jerk is limited), stays within +-max_acceleration, and the velocity moves
//! toward the target without overshooting it, reaching a constant target exactly (bit for bit),
//! also when the period varies from cycle to cycle. The one exception to the jerk limit besides the
//! stop: the cycle after the target is reached brings the acceleration to zero, which for a cycle
//! under half as long as the one before takes up to max_jerk x (previous period) / (2 x period).
//!
//! A controlled stop (stop()) ramps every joint to zero at max_acceleration: the deceleration limit
//! always holds, the jerk limit is waived because it only lengthens the stop. There is no bypass:
//! the hardware emergency stop acts outside the software, and the loop then calls reset() with what
//! the machine does. RT-safe after construction: no allocation, no throw, no clock.
class RateLimiter {
 public:
  //! num_joints entries of limits are used (1..kMaxJoints). Start-up: throws std::invalid_argument on
  //! a bad count or limit. The state starts at rest.
  explicit RateLimiter(std::span<const RateLimits> limits);

  //! One cycle toward target_velocity (num_joints() entries; more are ignored; fewer are a
  //! programming error that an assert catches in debug builds, and in release builds the missing
  //! joints are taken as 0) over period_s [s]. The limited command is velocity().
  RateLimitResult update(std::span<const double> target_velocity, double period_s) noexcept;
  //! One cycle of the controlled stop: every joint toward zero at max_acceleration.
  RateLimitResult stop(double period_s) noexcept;
  //! Sets the state to the machine's measured one (at start, after a fault, after the hardware
  //! emergency stop): the next command continues from there without a jump. acceleration may be
  //! empty (taken as zero); values are clamped to the acceleration limit, velocity is not clamped so
  //! that a measured overspeed is brought back at the deceleration limit rather than cut.
  void reset(std::span<const double> velocity, std::span<const double> acceleration = {}) noexcept;

  //! The limited command: hand this to Hal::write. [rad/s | m/s]
  [[nodiscard]] std::span<const double> velocity() const noexcept {
    return {velocity_.data(), static_cast<std::size_t>(num_joints_)};
  }
  //! The command's acceleration over the last cycle (the jerk limiter's state); 0 once a stop has
  //! reached rest. [rad/s^2 | m/s^2]
  [[nodiscard]] std::span<const double> acceleration() const noexcept {
    return {acceleration_.data(), static_cast<std::size_t>(num_joints_)};
  }
  //! Every joint's command is exactly zero (SupervisorInputs::progress.command_at_rest).
  [[nodiscard]] bool at_rest() const noexcept;
  [[nodiscard]] int num_joints() const noexcept { return num_joints_; }
  [[nodiscard]] const RateLimits& limits(int joint) const noexcept { return limits_[static_cast<std::size_t>(joint)]; }

 private:
  std::array<RateLimits, kMaxJoints> limits_{};
  std::array<double, kMaxJoints> velocity_{};
  std::array<double, kMaxJoints> acceleration_{};
  std::array<bool, kMaxJoints> on_target_{};  //!< the jerk-limited step landed on the target: hold it
  int num_joints_ = 0;
};

}  // namespace mgc::firmware
