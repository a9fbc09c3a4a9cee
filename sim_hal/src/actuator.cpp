// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/actuator.hpp"

#include <algorithm>
#include <cmath>

namespace mgc::sim {

double HydraulicActuator::target_velocity(double spool_fraction) const noexcept {
  const double s = std::clamp(spool_fraction, -1.0, 1.0);
  const double magnitude = std::abs(s);
  if (magnitude <= params_.deadband) return 0.0;
  const double open = (magnitude - params_.deadband) / (1.0 - params_.deadband);
  return std::copysign(open * params_.max_velocity, s);
}

void HydraulicActuator::step(double spool_fraction, double dt_s) noexcept {
  const double target = target_velocity(spool_fraction);
  // Exact discretisation of the first-order lag, so the response does not depend on dt.
  const double alpha = params_.lag_s > 0.0 ? 1.0 - std::exp(-dt_s / params_.lag_s) : 1.0;
  double dv = (target - velocity_) * alpha;
  const double dv_max = params_.max_acceleration * dt_s;
  dv = std::clamp(dv, -dv_max, dv_max);
  const double v0 = velocity_;
  double v1 = std::clamp(v0 + dv, -params_.max_velocity, params_.max_velocity);
  // A closed valve holds the load: the lag's exponential tail is cut once it is below a
  // millionth of full speed, so the joint comes to rest instead of creeping for ever.
  if (target == 0.0 && std::abs(v1) < 1e-6 * params_.max_velocity) v1 = 0.0;
  double p1 = position_ + 0.5 * (v0 + v1) * dt_s;
  if (!params_.continuous) {
    // An end stop halts the cylinder at once: the oil has nowhere to go.
    if (p1 <= params_.position_min && v1 <= 0.0) {
      p1 = params_.position_min;
      v1 = 0.0;
    } else if (p1 >= params_.position_max && v1 >= 0.0) {
      p1 = params_.position_max;
      v1 = 0.0;
    }
  }
  acceleration_ = dt_s > 0.0 ? (v1 - v0) / dt_s : 0.0;
  velocity_ = v1;
  position_ = p1;
}

void HydraulicActuator::displace(double delta) noexcept {
  position_ += delta;
  if (!params_.continuous) position_ = std::clamp(position_, params_.position_min, params_.position_max);
}

}  // namespace mgc::sim
