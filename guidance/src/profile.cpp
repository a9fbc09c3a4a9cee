// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/profile.hpp"

namespace mgc::guidance {

JointState advance(const JointState& s, double jerk, double t_s) noexcept {
  const double t = t_s;
  return {s.position + t * (s.velocity + t * (s.acceleration / 2.0 + t * jerk / 6.0)),
          s.velocity + t * (s.acceleration + t * jerk / 2.0), s.acceleration + t * jerk};
}

void Profile::reset(const JointState& start) noexcept {
  count_ = 0;
  brake_phase_count = 0;
  start_state_[0] = start;
  start_time_s_[0] = 0.0;
}

bool Profile::append(double duration_s, double jerk) noexcept {
  // A phase too short to move the clock could never be sampled; its effect on the state is below
  // the rounding of the time itself.
  if (!(start_time_s_[count_] + duration_s > start_time_s_[count_])) return true;
  if (count_ >= kMaxPhases) return false;
  duration_s_[count_] = duration_s;
  jerk_[count_] = jerk;
  start_state_[count_ + 1] = advance(start_state_[count_], jerk, duration_s);
  start_time_s_[count_ + 1] = start_time_s_[count_] + duration_s;
  ++count_;
  return true;
}

JointSample Profile::at_time(double t_s) const noexcept {
  if (!(t_s > 0.0)) {
    const JointState& s = start_state_[0];
    return {s.position, s.velocity, s.acceleration, count_ > 0 ? jerk_[0] : 0.0};
  }
  // Linear search: at most kMaxPhases, cheaper than bisection at this size.
  std::size_t i = 0;
  while (i < count_ && t_s >= start_time_s_[i + 1]) ++i;
  const double jerk = i < count_ ? jerk_[i] : 0.0;
  const JointState s = advance(start_state_[i], jerk, t_s - start_time_s_[i]);
  return {s.position, s.velocity, s.acceleration, jerk};
}

}  // namespace mgc::guidance
