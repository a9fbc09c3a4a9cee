// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/profile.hpp"

namespace mgc::guidance {

void Profile::reset(const JointState& start) noexcept {
  count_ = 0;
  acceleration_scale_ = 0.0;
  brake_phase_count = 0;
  start_state_[0] = start;
  start_time_s_[0] = 0.0;
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
