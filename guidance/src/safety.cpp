// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/safety.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
  if (config_.fixed_bodies_once) {
    // Fixed bodies stand where they stand at any configuration; the middle of every range will do.
    planning::JointVector q(static_cast<int>(joints.size()));
    for (std::size_t j = 0; j < joints.size(); ++j) {
      q[static_cast<Eigen::Index>(j)] = joints[j].continuous ? 0.0 : 0.5 * (joints[j].position_min + joints[j].position_max);
    }
    fixed_static_ = world_.clearance(q, planning::CollisionWorld::Bodies::Fixed, planning::CollisionWorld::Obstacles::Static);
  }
}

StopCheck::Sample StopCheck::measure_full(const planning::JointVector& q, double reach_m) noexcept {
  ++full_queries_;
  using Bodies = planning::CollisionWorld::Bodies;
  using Obstacles = planning::CollisionWorld::Obstacles;
  const Bodies bodies = config_.fixed_bodies_once ? Bodies::Moving : Bodies::All;
  // A dynamic obstacle counts less its reach during the stop, so it may matter more than a static
  // one that is nearer: each kind is measured, and the lesser clearance taken.
  Sample s;
  s.contact = world_.clearance(q, bodies, Obstacles::Static);
  s.clearance_m = s.contact.distance_m;
  s.geometric_m = s.contact.distance_m;
  if (s.contact.with == planning::Contact::With::Dynamic) s.clearance_m -= reach_m;
  if (world_.num_dynamic() > 0 && s.clearance_m > 0.0) {
    const planning::Clearance dynamic = world_.clearance(q, bodies, Obstacles::Dynamic);
    s.geometric_m = std::min(s.geometric_m, dynamic.distance_m);
    const double dynamic_m = dynamic.with == planning::Contact::With::Dynamic ? dynamic.distance_m - reach_m : dynamic.distance_m;
    if (dynamic_m < s.clearance_m) {
      s.contact = dynamic;
      s.clearance_m = dynamic_m;
    }
  }
  return s;
}

StopCheck::Sample StopCheck::measure(const planning::JointVector& q, bool bounded, double bound_m, double reach_m) noexcept {
  if (!bounded) return measure_full(q, reach_m);
  using planning::Contact;
  using Bodies = planning::CollisionWorld::Bodies;
  // Within this of contact the bounded query's GJK distance and the full query's collision pass may
  // disagree; the full query decides (and names the contact as it does).
  constexpr double kContactM = 1e-3;
  // clearance() takes the nearest obstacle and only then lessens a dynamic one by its reach; so a
  // dynamic obstacle matters out to the bound plus its reach.
  const planning::CollisionWorld::NearestBelow near =
      world_.nearest_below(q, Bodies::Moving, bound_m, world_.num_dynamic() > 0 ? bound_m + reach_m : 0.0, &hint_);
  const planning::Clearance& st = near.static_obstacle;
  const planning::Clearance& dy = near.dynamic_obstacle;
  if (st.with == Contact::With::Self || st.distance_m < kContactM ||
      (dy.with == Contact::With::Dynamic && dy.distance_m < kContactM)) {
    return measure_full(q, reach_m);
  }
  if (st.with == Contact::With::Static) hint_.static_obstacle = st;
  if (dy.with == Contact::With::Dynamic) hint_.dynamic_obstacle = dy;
  // A dynamic obstacle counts less its reach during the stop: the lesser of the two clearances.
  Sample s;
  s.contact = st;  // a static obstacle within the bound, or none: then at least the bound
  s.clearance_m = st.with == Contact::With::Static ? st.distance_m : bound_m;
  s.bounded = st.with != Contact::With::Static;
  // Without a dynamic obstacle its bound is 0: no distance.
  s.geometric_m = world_.num_dynamic() > 0 ? std::min(st.distance_m, dy.distance_m) : st.distance_m;
  if (dy.with == Contact::With::Dynamic && dy.distance_m - reach_m < s.clearance_m) {
    s.contact = dy;
    s.clearance_m = dy.distance_m - reach_m;
    s.bounded = false;
  }
  return s;
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
  // The finest step keeps body points within sample_step_m of each other between samples; where the
  // clearance is large the check advances further (conservative advancement): a body point moves
  // at most rate_m_s, so clearance d at one sample stays above the warning margin for
  // (d - warning) / rate_m_s. Steps never fall below the finest, so at most max_samples + 1 samples.
  const double min_dt_s = intervals > 0 ? r.stop_duration_s / intervals : 0.0;
  const double dynamic_reach_m = config_.dynamic_obstacle_speed_m_s * r.stop_duration_s + dynamic_allowance_m_;
  constexpr double kFar = 1e9;  //!< stands for "no envelope limit" [m]

  planning::JointVector q(n);
  using Bodies = planning::CollisionWorld::Bodies;
  // The fixed bodies' clearance, once per check: to the static obstacles it was measured at
  // construction; only a dynamic obstacle's approach can change it.
  double fixed_m = kFar;
  double fixed_geometric_m = kFar;
  planning::Clearance fixed;
  if (config_.fixed_bodies_once) {
    for (int j = 0; j < n; ++j) q[j] = state.joints[static_cast<std::size_t>(j)].position;
    // Only a dynamic obstacle nearer, less its reach, than the static site matters; bounded, the
    // rest go unmeasured.
    const planning::Clearance dynamic =
        config_.bounded_queries
            ? world_.nearest_below(q, Bodies::Fixed, 0.0, fixed_static_.distance_m + dynamic_reach_m).dynamic_obstacle
            : world_.clearance(q, Bodies::Fixed, planning::CollisionWorld::Obstacles::Dynamic);
    fixed = fixed_static_;
    fixed_m = fixed_static_.distance_m;
    if (dynamic.with == planning::Contact::With::Dynamic) fixed_geometric_m = std::min(fixed_m, dynamic.distance_m);
    else fixed_geometric_m = fixed_m;
    if (dynamic.with == planning::Contact::With::Dynamic && dynamic.distance_m - dynamic_reach_m < fixed_m) {
      fixed = dynamic;
      fixed_m = dynamic.distance_m - dynamic_reach_m;
    }
  }
  // Bounded queries (StopCheckConfig::bounded_queries): a sample at time t is measured exactly only
  // below bound = headroom + rate (T - t); at or above it the sample counts as the bound. Then
  //  - the steps are the full sweep's: from a value v >= bound the step (v - warning) / rate reaches
  //    the end of the stop whatever v is, as headroom >= warning;
  //  - an interval bound is the full sweep's wherever either is under exact_m, because headroom
  //    >= 2 exact_m - warning and >= exact_m + the finest step's travel: next to a bounded end the
  //    interval bound is either at least exact_m or the other, exact, end's value (see
  //    docs/safety.md). Should rounding ever break that, the bounded end is measured in full.
  // A contact of the fixed bodies makes every full query 0, so then every sample is measured in full.
  const double exact_m = std::max(config_.warning_margin_m, config_.exact_clearance_m);
  const double headroom_m = std::max(2.0 * exact_m - config_.warning_margin_m, exact_m + rate_m_s * min_dt_s);
  const bool bounded = config_.bounded_queries && config_.fixed_bodies_once && fixed.distance_m >= 1e-3;
  full_queries_ = 0;
  const auto at_time = [&](double time_s, planning::JointVector& out) {
    for (int j = 0; j < n; ++j) out[j] = profiles_[static_cast<std::size_t>(j)].at_time(time_s).position;
  };
  double t_s = 0.0;
  Sample prev;
  double prev_envelope_m = 0.0;
  EnvelopeDistance prev_limit;
  double prev_t_s = 0.0;
  r.min_clearance_m = kFar;
  r.min_geometric_m = kFar;
  double min_envelope_m = kFar;
  for (;;) {
    at_time(t_s, q);
    // A hair over the threshold, so that a bounded value steps to the end despite rounding.
    const double bound_m = headroom_m + rate_m_s * (r.stop_duration_s - t_s) + 1e-6;
    Sample cur = measure(q, bounded, bound_m, dynamic_reach_m);
    EnvelopeDistance limit;
    double envelope_m = kFar;
    if (envelope_ != nullptr) {
      limit = envelope_->nearest(q);
      if (limit.limit != EnvelopeLimit::None) envelope_m = limit.distance_m;
    }
    ++r.samples;

    // Least clearance over the interval since the previous sample: both ends can only fall at
    // rate_m_s, so the two falling lines meet at (d0 + d1 - rate h) / 2.
    double lowest_m = cur.clearance_m;
    double envelope_bound_m = envelope_m;
    const bool interval = r.samples > 1;
    if (interval) {
      const double travel_m = rate_m_s * (t_s - prev_t_s);
      const auto interval_bound = [&] {
        return std::min({prev.clearance_m, cur.clearance_m, 0.5 * (prev.clearance_m + cur.clearance_m - travel_m)});
      };
      lowest_m = interval_bound();
      const double exact_end_m = std::min(prev.bounded ? kFar : prev.clearance_m, cur.bounded ? kFar : cur.clearance_m);
      if ((prev.bounded || cur.bounded) && lowest_m < exact_m && lowest_m < exact_end_m) {
        // The bound matters and rests on a bounded end: measure it in full. The steps stay as they
        // were (a full value is at least the bounded one, and that already reached the end).
        if (cur.bounded) cur = measure_full(q, dynamic_reach_m);
        if (prev.bounded) {
          at_time(prev_t_s, q);
          prev = measure_full(q, dynamic_reach_m);
          at_time(t_s, q);
        }
        lowest_m = interval_bound();
      }
      envelope_bound_m = std::min({prev_envelope_m, envelope_m, 0.5 * (prev_envelope_m + envelope_m - travel_m)});
    }
    if (lowest_m < r.min_clearance_m) {
      r.min_clearance_m = lowest_m;
      const bool earlier = interval && prev.clearance_m < cur.clearance_m;
      r.nearest = earlier ? prev.contact : cur.contact;
      r.nearest_time_s = earlier ? prev_t_s : t_s;
    }
    const double geometric_m =
        interval ? std::min({prev.geometric_m, cur.geometric_m, 0.5 * (prev.geometric_m + cur.geometric_m - rate_m_s * (t_s - prev_t_s))})
                 : std::min(cur.geometric_m, fixed_geometric_m);
    r.min_geometric_m = std::min(r.min_geometric_m, geometric_m);
    if (!interval && fixed_m < r.min_clearance_m) {
      r.min_clearance_m = fixed_m;
      r.nearest = fixed;
      r.nearest_time_s = 0.0;
    }
    if (limit.limit != EnvelopeLimit::None && envelope_bound_m < min_envelope_m) {
      min_envelope_m = envelope_bound_m;
      r.envelope = interval && prev_envelope_m < envelope_m ? prev_limit : limit;
      r.envelope.distance_m = envelope_bound_m;
    }
    // Once the stop is certain the rest of the sweep changes nothing.
    if ((r.min_clearance_m < config_.stop_margin_m && r.min_geometric_m < retreat_floor_m_) ||
        min_envelope_m < -config_.envelope_stop_margin_m) {
      break;
    }
    if (t_s >= r.stop_duration_s) break;

    const double clearance_m = cur.clearance_m;
    prev = cur;
    prev_envelope_m = envelope_m;
    prev_limit = limit;
    prev_t_s = t_s;
    double dt_s = min_dt_s;
    if (rate_m_s > 0.0) {
      const double free_m = std::min(clearance_m - config_.warning_margin_m, envelope_m + config_.envelope_stop_margin_m);
      dt_s = std::max(dt_s, free_m / rate_m_s);
    } else {
      dt_s = r.stop_duration_s;
    }
    t_s = std::min(t_s + dt_s, r.stop_duration_s);
  }

  const bool envelope_crossed =
      r.envelope.limit != EnvelopeLimit::None && r.envelope.distance_m < -config_.envelope_stop_margin_m;
  const bool undercut = r.min_clearance_m < config_.stop_margin_m;
  const bool retreating = std::isfinite(retreat_floor_m_);
  if ((undercut && r.min_geometric_m < retreat_floor_m_) || envelope_crossed) {
    r.status = StopCheckStatus::Stop;
    r.speed_scale = 0.0;
    r.replan = true;
  } else if (undercut) {
    r.status = StopCheckStatus::Warning;
    r.speed_scale = std::clamp(config_.retreat_speed_scale, 0.0, 1.0);
    r.retreat = true;
  } else if (r.min_clearance_m < config_.warning_margin_m) {
    r.status = StopCheckStatus::Warning;
    const double band_m = std::max(config_.warning_margin_m - config_.stop_margin_m, 1e-9);
    r.speed_scale = std::clamp((r.min_clearance_m - config_.stop_margin_m) / band_m, 0.0, 1.0);
    if (retreating) r.speed_scale = std::max(r.speed_scale, std::clamp(config_.retreat_speed_scale, 0.0, 1.0));
  }
  return r;
}

}  // namespace mgc::guidance
