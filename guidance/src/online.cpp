// SPDX-License-Identifier: Apache-2.0
// Online trajectories (docs/trajectory.md, "Online"): a stored time-optimal profile sampled cycle by
// cycle, recalculated when the input changes; and the one-joint-at-a-time wrapper.
#include "mgc/guidance/online.hpp"

#include <cmath>

namespace mgc::guidance {
namespace {

bool same_state(const JointState& a, const JointState& b) noexcept {
  return a.position == b.position && a.velocity == b.velocity && a.acceleration == b.acceleration;
}

bool same_limits(const JointLimits& a, const JointLimits& b) noexcept {
  return a.max_velocity == b.max_velocity && a.max_acceleration == b.max_acceleration && a.max_jerk == b.max_jerk;
}

}  // namespace

TrajectoryStatus JointTrajectory::update(const JointState& current, double target_position, const JointLimits& limits,
                                         double dt_s, JointState& next) noexcept {
  if (!(std::isfinite(dt_s) && dt_s > 0.0)) {
    invalid_field_ = InvalidField::CycleTime;
    return TrajectoryStatus::ErrorInvalidInput;
  }
  // Exact comparisons: a caller feeding `next` back gets the stored profile; any other state
  // (measured, or from another planner) is a new start and is planned from.
  const bool unchanged = planned_ && target_position == target_position_ && same_limits(limits, limits_) &&
                         same_state(current, last_next_);
  if (!unchanged) {
    ++calculation_count_;
    const CalculationResult r = calculate_time_optimal(current, target_position, limits, profile_);
    invalid_field_ = r.field;
    if (!r.ok()) {
      planned_ = false;
      return r.status;
    }
    planned_ = true;
    target_position_ = target_position;
    limits_ = limits;
    time_s_ = 0.0;
  }
  time_s_ += dt_s;
  const JointSample s = profile_.at_time(time_s_);
  next = {s.position, s.velocity, s.acceleration};
  last_next_ = next;
  return time_s_ >= profile_.duration() ? TrajectoryStatus::Finished : TrajectoryStatus::Working;
}

TrajectoryStatus OneJointAtATime::update(const JointState* current, const JointLimits* limits, std::size_t joint_count,
                                         std::size_t moving_joint, double target_position, double dt_s,
                                         JointState* next) noexcept {
  invalid_joint_ = joint_count;
  invalid_field_ = InvalidField::None;
  if (joint_count == 0 || joint_count > kMaxJoints) {
    invalid_field_ = InvalidField::JointCount;
    return TrajectoryStatus::ErrorInvalidInput;
  }
  if (moving_joint >= joint_count) {
    invalid_field_ = InvalidField::MovingJoint;
    return TrajectoryStatus::ErrorInvalidInput;
  }
  bool finished = true;
  for (std::size_t i = 0; i < joint_count; ++i) {
    double target = target_position;
    if (i == moving_joint) {
      holding_[i] = false;
    } else {
      if (!holding_[i]) {
        // Latched once: planning the hold from each new state would let the stop point creep.
        Profile stop;
        const CalculationResult r = calculate_stop(current[i], limits[i], stop);
        if (!r.ok()) {
          invalid_joint_ = i;
          invalid_field_ = r.field;
          return r.status;
        }
        hold_position_[i] = stop.end_state().position;
        holding_[i] = true;
      }
      target = hold_position_[i];
    }
    const TrajectoryStatus st = joints_[i].update(current[i], target, limits[i], dt_s, next[i]);
    if (st != TrajectoryStatus::Working && st != TrajectoryStatus::Finished) {
      invalid_joint_ = i;
      invalid_field_ = joints_[i].invalid_field();
      return st;
    }
    finished = finished && st == TrajectoryStatus::Finished;
  }
  return finished ? TrajectoryStatus::Finished : TrajectoryStatus::Working;
}

}  // namespace mgc::guidance
