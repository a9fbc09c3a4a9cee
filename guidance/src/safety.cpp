// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/safety.hpp"

#include <algorithm>
#include <cmath>

namespace mgc::guidance {
namespace {

//! Largest |velocity| a profile reaches: velocity is quadratic in each phase, so its extremes lie at
//! the phase ends or where the acceleration crosses zero inside a phase. [/s]
double peak_speed(const Profile& profile) noexcept {
  double peak = std::abs(profile.end_state().velocity);
  for (std::size_t i = 0; i < profile.phase_count(); ++i) {
    const JointState& s = profile.state_at_phase(i);
    peak = std::max(peak, std::abs(s.velocity));
    const double jerk = profile.phase_jerk(i);
    if (jerk == 0.0) continue;
    const double t_s = -s.acceleration / jerk;
    if (t_s > 0.0 && t_s < profile.phase_duration(i)) {
      peak = std::max(peak, std::abs(s.velocity + s.acceleration * t_s + 0.5 * jerk * t_s * t_s));
    }
  }
  return peak;
}

}  // namespace

const char* to_string(StopCheckStatus status) noexcept {
  switch (status) {
    case StopCheckStatus::Clear: return "clear";
    case StopCheckStatus::Warning: return "warning";
    case StopCheckStatus::Stop: return "stop";
    case StopCheckStatus::ErrorInput: return "invalid input";
  }
  return "unknown";
}

StopCheck::StopCheck(planning::CollisionWorld& world, Envelope* envelope, const StopCheckConfig& config) noexcept
    : world_(world), envelope_(envelope), config_(config) {
  const auto joints = world_.model().joints();
  for (std::size_t j = 0; j < joints.size() && j < limits_.size(); ++j) {
    limits_[j] = JointLimits{joints[j].max_velocity, joints[j].max_acceleration, joints[j].max_jerk};
  }
  config_.max_samples = std::max(config_.max_samples, 1);
  config_.sample_step_m = std::max(config_.sample_step_m, 1e-3);
}

StopCheckResult StopCheck::check(const MachineState& state) noexcept {
  const planning::MachineModel& model = world_.model();
  const int n = model.dof();
  StopCheckResult r;
  r.stop_position.resize(n);

  // The braking motion of every joint, and how fast any body point can move during it.
  double rate_m_s = 0.0;
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const CalculationResult calc = calculate_stop(state.joints[k], limits_[k], profiles_[k]);
    if (!calc.ok()) {
      r.status = StopCheckStatus::ErrorInput;
      r.calculation = calc.status;
      r.invalid_joint = j;
      r.speed_scale = 0.0;
      r.replan = true;
      return r;
    }
    r.stop_duration_s = std::max(r.stop_duration_s, profiles_[k].duration());
    r.stop_position[j] = profiles_[k].end_state().position;
    rate_m_s += model.displacement_bound(j) * peak_speed(profiles_[k]);
  }

  int intervals = 0;
  if (r.stop_duration_s > 0.0) {
    const double needed = std::ceil(r.stop_duration_s * rate_m_s / config_.sample_step_m);
    intervals = static_cast<int>(std::clamp(needed, 1.0, static_cast<double>(config_.max_samples)));
  }
  const double dt_s = intervals > 0 ? r.stop_duration_s / intervals : 0.0;
  // Most a body point moves between samples: half of it may lie between a sample and the worst point.
  const double half_step_m = 0.5 * rate_m_s * dt_s;
  const double dynamic_reach_m = config_.dynamic_obstacle_speed_m_s * r.stop_duration_s;

  planning::JointVector q(n);
  bool first = true;
  for (int s = 0; s <= intervals; ++s) {
    const double t_s = s * dt_s;
    for (int j = 0; j < n; ++j) q[j] = profiles_[static_cast<std::size_t>(j)].at_time(t_s).position;
    const planning::Clearance c = world_.clearance(q);
    double conservative_m = c.distance_m - half_step_m;
    if (c.with == planning::Contact::With::Dynamic) conservative_m -= dynamic_reach_m;
    if (first || conservative_m < r.min_clearance_m) {
      r.min_clearance_m = conservative_m;
      r.nearest = c;
      r.nearest_time_s = t_s;
    }
    if (envelope_ != nullptr) {
      const EnvelopeDistance e = envelope_->nearest(q);
      if (e.limit != EnvelopeLimit::None &&
          (r.envelope.limit == EnvelopeLimit::None || e.distance_m - half_step_m < r.envelope.distance_m)) {
        r.envelope = e;
        r.envelope.distance_m -= half_step_m;
      }
    }
    first = false;
    ++r.samples;
  }

  const bool envelope_crossed =
      r.envelope.limit != EnvelopeLimit::None && r.envelope.distance_m < -config_.envelope_stop_margin_m;
  if (r.min_clearance_m < config_.stop_margin_m || envelope_crossed) {
    r.status = StopCheckStatus::Stop;
    r.speed_scale = 0.0;
    r.replan = true;
  } else if (r.min_clearance_m < config_.warning_margin_m) {
    r.status = StopCheckStatus::Warning;
    const double band_m = std::max(config_.warning_margin_m - config_.stop_margin_m, 1e-9);
    r.speed_scale = std::clamp((r.min_clearance_m - config_.stop_margin_m) / band_m, 0.0, 1.0);
  }
  return r;
}

}  // namespace mgc::guidance
