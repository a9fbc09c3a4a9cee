// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/rate_limiter.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mgc::firmware {
namespace {

[[noreturn]] void fail(const std::string& where, const char* field, double value, const char* expected) {
  std::string message = where;
  message += '.';
  message += field;
  message += ": expected ";
  message += expected;
  message += ", got ";
  message += std::to_string(value);
  throw std::invalid_argument(message);
}

void validate(const RateLimits& l, const std::string& where) {
  if (!(std::isfinite(l.max_velocity) && l.max_velocity > 0.0)) fail(where, "max_velocity", l.max_velocity, "> 0");
  if (!(std::isfinite(l.max_acceleration) && l.max_acceleration > 0.0)) {
    fail(where, "max_acceleration", l.max_acceleration, "> 0");
  }
  if (!(std::isfinite(l.max_jerk) && l.max_jerk >= 0.0)) fail(where, "max_jerk", l.max_jerk, ">= 0 (0: not limited)");
}

//! Velocity step toward `target` at most max_acceleration * period_s; lands on target exactly.
double slew_step(double velocity, double target, double max_acceleration, double period_s) noexcept {
  const double max_step = max_acceleration * period_s;
  const double error = target - velocity;
  if (std::abs(error) <= max_step) return target;
  return velocity + std::copysign(max_step, error);
}

//! One jerk-limited step of (velocity, acceleration) toward target. The command's acceleration over
//! a cycle is a_new = (v_new - v) / period, with |a_new - a| <= jerk * period and |a_new| <= max
//! acceleration. Of those, the one taken is the largest toward the target from which ramping the
//! acceleration back to zero at the jerk limit still ends at or before the target. That ramp adds
//! a^2 / (2 jerk) of velocity in continuous time, and less in whole cycles of any length, so the
//! guarantee survives a period that varies from cycle to cycle. Once the rest of the error fits in
//! one cycle at an acceleration from which zero is one jerk step away, the step lands on the target
//! exactly. A target changed under a running ramp may be passed: then it brakes as hard as allowed.
//! on_target: the last step landed on target (cleared by any other step).
void jerk_step(double& velocity, double& acceleration, bool& on_target, double target, const RateLimits& limits,
               double period_s) noexcept {
  if (on_target && velocity == target) {
    // Steady state: hold exactly. The landing cycle left at most half a jerk step of acceleration
    // for this one; only a cycle under half the landing cycle's length ends it faster than jerk.
    acceleration = 0.0;
    return;
  }
  on_target = false;
  const double dir = target >= velocity ? 1.0 : -1.0;
  // Mirrored so that the target lies ahead.
  const double error = dir * (target - velocity);  // [rad/s | m/s], >= 0
  const double a = dir * acceleration;
  const double q = limits.max_jerk * period_s;  // largest acceleration change per cycle
  const double lo = std::max(-limits.max_acceleration, a - q);
  const double hi = std::min(limits.max_acceleration, a + q);
  const double a_land = error / period_s;
  // Half a jerk step, so that a next cycle down to half this one's length still returns the
  // acceleration to zero within the jerk limit.
  const bool can_land = a_land <= 0.5 * q && a_land >= lo && a_land <= hi;
  if (can_land) {
    velocity = target;
    acceleration = dir * a_land;
    on_target = true;
    return;
  }
  // Largest a with a T + a^2 / (2 J) <= error, in the form that does not cancel for small errors.
  const double a_best =
      2.0 * error / (period_s + std::sqrt(period_s * period_s + 2.0 * error / limits.max_jerk));
  const double a_new = std::clamp(a_best, lo, hi);
  velocity += dir * a_new * period_s;
  acceleration = dir * a_new;
}

}  // namespace

std::array<RateLimits, kMaxJoints> rate_limits_from(std::span<const planning::JointSpec> joints, JerkLimit jerk) {
  if (joints.empty() || joints.size() > static_cast<std::size_t>(kMaxJoints)) {
    throw std::invalid_argument("rate_limits_from: expected 1.." + std::to_string(kMaxJoints) + " joints, got " +
                                std::to_string(joints.size()));
  }
  std::array<RateLimits, kMaxJoints> limits{};
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const planning::JointSpec& spec = joints[j];
    const std::string where = "joint " + std::to_string(j) + " (" + spec.name + ")";
    limits[j] = {spec.max_velocity, spec.max_acceleration, jerk == JerkLimit::On ? spec.max_jerk : 0.0};
    validate(limits[j], where);
    if (jerk == JerkLimit::On && !(spec.max_jerk > 0.0)) {
      fail(where, "max_jerk", spec.max_jerk, "> 0 with the jerk limit on");
    }
  }
  return limits;
}

RateLimiter::RateLimiter(std::span<const RateLimits> limits) {
  if (limits.empty() || limits.size() > static_cast<std::size_t>(kMaxJoints)) {
    throw std::invalid_argument("RateLimiter: expected 1.." + std::to_string(kMaxJoints) + " joints, got " +
                                std::to_string(limits.size()));
  }
  num_joints_ = static_cast<int>(limits.size());
  for (std::size_t j = 0; j < limits.size(); ++j) {
    validate(limits[j], "RateLimiter joint " + std::to_string(j));
    limits_[j] = limits[j];
  }
}

RateLimitResult RateLimiter::update(std::span<const double> target_velocity, double period_s) noexcept {
  assert(target_velocity.size() >= static_cast<std::size_t>(num_joints_));
  RateLimitResult result;
  if (!(std::isfinite(period_s) && period_s > 0.0)) {
    // No sound step exists without a period: hold the command, which changes nothing.
    result.status = RateLimitStatus::InvalidPeriod;
    acceleration_.fill(0.0);
    return result;
  }
  for (std::size_t j = 0; j < static_cast<std::size_t>(num_joints_); ++j) {
    const RateLimits& l = limits_[j];
    const auto bit = static_cast<std::uint8_t>(1U << j);
    double target = j < target_velocity.size() ? target_velocity[j] : 0.0;
    if (!std::isfinite(target)) {
      // A broken upstream value: slow that joint down rather than pass it on or freeze it.
      target = 0.0;
      result.refused_mask |= bit;
    } else if (std::abs(target) > l.max_velocity) {
      target = std::copysign(l.max_velocity, target);
      result.clamped_mask |= bit;
    }
    if (l.max_jerk > 0.0) {
      jerk_step(velocity_[j], acceleration_[j], on_target_[j], target, l, period_s);
    } else {
      const double v = slew_step(velocity_[j], target, l.max_acceleration, period_s);
      acceleration_[j] = (v - velocity_[j]) / period_s;
      velocity_[j] = v;
    }
    if (velocity_[j] != target) result.limited_mask |= bit;
  }
  return result;
}

RateLimitResult RateLimiter::stop(double period_s) noexcept {
  RateLimitResult result;
  if (!(std::isfinite(period_s) && period_s > 0.0)) {
    result.status = RateLimitStatus::InvalidPeriod;
    acceleration_.fill(0.0);
    return result;
  }
  for (std::size_t j = 0; j < static_cast<std::size_t>(num_joints_); ++j) {
    // Jerk waived: a jerk-limited stop only takes longer, and the stop check's predicted stop
    // (jerk-limited) stays an upper bound on the distance this one covers.
    on_target_[j] = false;
    const double v = slew_step(velocity_[j], 0.0, limits_[j].max_acceleration, period_s);
    // At rest the stop is over: the next command starts from rest, not from the braking.
    acceleration_[j] = v == 0.0 ? 0.0 : (v - velocity_[j]) / period_s;
    velocity_[j] = v;
    if (v != 0.0) result.limited_mask |= static_cast<std::uint8_t>(1U << j);
  }
  return result;
}

void RateLimiter::reset(std::span<const double> velocity, std::span<const double> acceleration) noexcept {
  for (std::size_t j = 0; j < static_cast<std::size_t>(num_joints_); ++j) {
    const double v = j < velocity.size() ? velocity[j] : 0.0;
    const double a = j < acceleration.size() ? acceleration[j] : 0.0;
    on_target_[j] = false;
    velocity_[j] = std::isfinite(v) ? v : 0.0;
    const double a_max = limits_[j].max_acceleration;
    acceleration_[j] = std::isfinite(a) ? std::clamp(a, -a_max, a_max) : 0.0;
  }
}

bool RateLimiter::at_rest() const noexcept {
  for (std::size_t j = 0; j < static_cast<std::size_t>(num_joints_); ++j) {
    if (velocity_[j] != 0.0) return false;
  }
  return true;
}

}  // namespace mgc::firmware
