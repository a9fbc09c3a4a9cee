// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/truth_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "mgc/sim/simulator.hpp"
#include "mgc/sim/truth_snapshot.hpp"

namespace mgc::sim {

namespace {

//! A load set down on the ground touches it at 0; rounding in the kinematics must not count it as
//! below, as planning's load-above-ground rule allows the same. [m]
constexpr double kGroundToleranceM = 1e-9;

//! A chart utilisation as a percentage with one decimal.
std::string percent1(double utilisation) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * utilisation);
  return buf;
}

//! Two decimals: centimetres and centiseconds, as mgc's summary prints them.
std::string fixed2(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", value);
  return buf;
}

}  // namespace

TruthMonitor::TruthMonitor(const planning::Scenario& scenario, TruthMonitorConfig config)
    : config_(config), num_dynamic_(scenario.dynamic_obstacles.size()) {
  if (!(std::isfinite(config.period_s) && config.period_s >= 0.0)) {
    throw std::invalid_argument("truth monitor: the period must be a finite number >= 0 s");
  }
  grid_ = SampleGrid(config.period_s);
  if (!(std::isfinite(config.clearance_margin_m) && config.clearance_margin_m >= 0.0)) {
    throw std::invalid_argument("truth monitor: the clearance margin must be a finite number >= 0 m");
  }
  // The real machine: its bodies as they are, without the planner's safety margin around them.
  planning::Scenario bare = scenario;
  bare.planner.dilation_m = 0.0;
  try {
    model_ = planning::build_model(bare);
    world_ = planning::build_world(bare, *model_);
    if (num_dynamic_ > 0) {
      bare.obstacles.clear();
      dynamic_world_ = planning::build_world(bare, *model_);
    }
    if (scenario.envelope) {
      envelope_ = std::make_unique<guidance::Envelope>(*model_, guidance::envelope_config(*scenario.envelope, *model_));
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("truth monitor: ") + e.what());
  }
  q_wrapped_ = planning::JointVector::Zero(model_->dof());
  // The single cranes name their hook "hook" and the load's bottom centre "load_bottom". An
  // excavator has neither, and its bucket digs below the ground by design; the dual crane's
  // "hook" is the girder's centre, not its underside, and mgc does not drive that pair.
  if (model_->kind() != planning::MachineKind::Excavator) {
    const int hook = model_->key_point_index("hook");
    const int load_bottom = model_->key_point_index("load_bottom");
    if (hook >= 0 && load_bottom >= 0) {
      hook_point_ = hook;
      load_bottom_point_ = load_bottom;
    }
  }
  // The controller limits a mobile crane's rated capacity when the scenario has a lift task; the
  // dual crane's pair is no MobileCrane, and rates each cable's tension instead.
  if (const auto* crane = dynamic_cast<const planning::MobileCrane*>(model_.get());
      crane != nullptr && scenario.task && !crane->chart().boom_lengths_ft.empty() && !crane->chart().radii_ft.empty()) {
    crane_ = crane;
    chart_load_lb_ = guidance::RatedCapacityLimiter(*crane, guidance::RatedCapacityConfig{}).task_load_lb();
  }
  if (scenario.start.size() != model_->dof()) {
    throw std::invalid_argument("truth monitor: the scenario's start has " + std::to_string(scenario.start.size()) +
                                " joints, its machine " + std::to_string(model_->dof()));
  }
  // Any configuration poses the fixed bodies alike; the start is one whose moving bodies are sane.
  fixed_static_ =
      world_->clearance(scenario.start, planning::CollisionWorld::Bodies::Fixed, planning::CollisionWorld::Obstacles::Static);
}

TruthMonitor::~TruthMonitor() = default;

bool TruthMonitor::sample(const Simulator& sim) noexcept {
  if (!grid_.due(sim.truth().t_s)) return false;
  for (std::size_t i = 0; i < num_dynamic_; ++i) set_obstacle_pose(i, sim.obstacle_pose(i));
  sample_truth(sim.truth());
  return true;
}

bool TruthMonitor::sample(const TruthSnapshot& snapshot) noexcept {
  if (!grid_.due(snapshot.truth.t_s)) return false;
  for (std::size_t i = 0; i < std::min(num_dynamic_, snapshot.obstacle_poses.size()); ++i) set_obstacle_pose(i, snapshot.obstacle_poses[i]);
  sample_truth(snapshot.truth);
  return true;
}

void TruthMonitor::sample_truth(const TrueState& truth) noexcept {
  planning::JointVector q(model_->dof());
  for (int j = 0; j < model_->dof(); ++j) q[j] = truth.position[static_cast<std::size_t>(j)];
  (void)measure(truth.t_s, q);
  grid_.taken(truth.t_s);
}

void TruthMonitor::set_obstacle_pose(std::size_t i, const Eigen::Isometry3d& world_from_obstacle) noexcept {
  if (i >= num_dynamic_) return;
  world_->set_dynamic_pose(static_cast<int>(i), world_from_obstacle);
  dynamic_world_->set_dynamic_pose(static_cast<int>(i), world_from_obstacle);
}

const TruthSample& TruthMonitor::measure(double t_s, const planning::JointVector& q) noexcept {
  TruthSample& s = last_;
  s.t_s = t_s;
  // The whole machine's clearance is the least of three parts, so that the fixed bodies' distance
  // to the static site, which no joint changes, is not measured again at every sample: the moving
  // bodies to everything (0 on any contact of the machine, as clearance() of all bodies gives), the
  // fixed bodies to the static site (measured once), and every body to the dynamic obstacles.
  s.moving_clearance = world_->clearance(q, planning::CollisionWorld::Bodies::Moving);
  s.clearance = s.moving_clearance;
  if (fixed_static_.distance_m < s.clearance.distance_m) s.clearance = fixed_static_;
  if (num_dynamic_ > 0) {
    s.dynamic_clearance = dynamic_world_->clearance(q);
    if (s.dynamic_clearance.distance_m < s.clearance.distance_m) s.clearance = s.dynamic_clearance;
  } else {
    s.dynamic_clearance = planning::Clearance{std::numeric_limits<double>::infinity()};
  }
  s.envelope = guidance::EnvelopeDistance{};
  if (envelope_) {
    // The limiter's azimuths are taken on wrapped angles, as the controller feeds it.
    for (int j = 0; j < model_->dof(); ++j) {
      const bool continuous = model_->joints()[static_cast<std::size_t>(j)].continuous;
      q_wrapped_[j] = continuous ? std::remainder(q[j], 2.0 * std::numbers::pi) : q[j];
    }
    s.envelope = envelope_->nearest(q_wrapped_);
  }
  measure_ground_and_chart(s, q);

  TruthSummary& m = summary_;
  ++m.samples;
  if (s.clearance.distance_m < config_.clearance_margin_m) ++m.samples_below_margin;
  if (s.clearance.distance_m < m.least_clearance.distance_m) {
    m.least_clearance = s.clearance;
    m.least_clearance_t_s = t_s;
  }
  if (s.moving_clearance.distance_m < m.least_moving.distance_m) {
    m.least_moving = s.moving_clearance;
    m.least_moving_t_s = t_s;
  }
  if (num_dynamic_ > 0 && s.dynamic_clearance.distance_m < m.least_dynamic.distance_m) {
    m.least_dynamic = s.dynamic_clearance;
    m.least_dynamic_t_s = t_s;
  }
  if (s.envelope.limit != guidance::EnvelopeLimit::None) {
    if (s.envelope.distance_m < 0.0) ++m.samples_outside_envelope;
    if (s.envelope.distance_m < m.least_envelope.distance_m) {
      m.least_envelope = s.envelope;
      m.least_envelope_t_s = t_s;
    }
  }
  if (hook_point_ >= 0) {
    // The load's bottom is the lowest of what hangs from the hook.
    const double ground_m = s.load_ground_clearance_m;
    if (ground_m < -kGroundToleranceM) ++m.samples_below_ground;
    if (ground_m < m.least_ground_clearance_m) {
      m.least_ground_clearance_m = ground_m;
      m.least_ground_clearance_t_s = t_s;
    }
    if (s.hook_ground_clearance_m < m.least_hook_ground_clearance_m) {
      m.least_hook_ground_clearance_m = s.hook_ground_clearance_m;
      m.least_hook_ground_clearance_t_s = t_s;
    }
  }
  if (crane_ != nullptr) {
    if (s.chart_utilisation > 1.0) ++m.samples_chart_exceeded;
    if (!s.chart.in_chart) ++m.samples_outside_chart;
    // The first sample sets the peak even at 0 utilisation, so that its time is never NaN.
    if (s.chart_utilisation > m.peak_chart_utilisation || std::isnan(m.peak_chart_utilisation_t_s)) {
      m.peak_chart_utilisation = s.chart_utilisation;
      m.peak_chart_utilisation_t_s = t_s;
      m.peak_chart_boom_length_m = q[planning::MobileCrane::kBoomLength];
      m.peak_chart_elevation_rad = q[planning::MobileCrane::kBoomElevation];
    }
  }
  return s;
}

void TruthMonitor::measure_ground_and_chart(TruthSample& s, const planning::JointVector& q) noexcept {
  s.hook_ground_clearance_m = std::numeric_limits<double>::quiet_NaN();
  s.load_ground_clearance_m = std::numeric_limits<double>::quiet_NaN();
  if (hook_point_ >= 0) {
    model_->forward_kinematics(q, kinematics_);
    // The ground is the plane of the base (docs/scenario-format.md: z = 0 at the base), the
    // plane planning's load-above-ground rule keeps the load on.
    const Eigen::Isometry3d& base = model_->world_from_base();
    const Eigen::Vector3d up = base.linear().col(2);
    const auto height = [&](int point) {
      return up.dot(kinematics_.points[static_cast<std::size_t>(point)] - base.translation());
    };
    s.hook_ground_clearance_m = height(hook_point_);
    s.load_ground_clearance_m = height(load_bottom_point_);
  }
  s.chart = guidance::RatedCapacity{};
  s.chart_utilisation = std::numeric_limits<double>::quiet_NaN();
  if (crane_ != nullptr) {
    s.chart = guidance::rated_capacity(crane_->chart(), q[planning::MobileCrane::kBoomLength],
                                       q[planning::MobileCrane::kBoomElevation]);
    // As the controller's limiter: a cell rated 0 or none at all is no capacity.
    s.chart_utilisation = s.chart.in_chart && s.chart.capacity_lb > 0.0 ? chart_load_lb_ / s.chart.capacity_lb
                                                                        : std::numeric_limits<double>::infinity();
  }
}

std::string TruthMonitor::summary_line() const {
  const TruthSummary& m = summary_;
  if (m.samples == 0) return "no samples";
  const auto body = [this](int b) {
    return b >= 0 && b < static_cast<int>(model_->bodies().size()) ? model_->bodies()[static_cast<std::size_t>(b)].name
                                                                    : std::string("?");
  };
  const auto what = [&](const planning::Clearance& c) -> std::string {
    switch (c.with) {
      case planning::Contact::With::Static: return body(c.body) + " to " + world_->static_name(c.other);
      case planning::Contact::With::Dynamic: return body(c.body) + " to " + world_->dynamic_name(c.other);
      case planning::Contact::With::Self: return body(c.body) + " to " + body(c.other);
      case planning::Contact::With::Nothing: break;
    }
    return "nothing near";
  };
  // With nothing within the monitor's reach there is no distance to print, only that.
  const auto least = [&](const planning::Clearance& c, double t_s) -> std::string {
    if (c.with == planning::Contact::With::Nothing) return "nothing near";
    return fixed2(c.distance_m) + " m at " + fixed2(t_s) + " s (" + what(c) + ")";
  };
  std::string line = "least clearance " + least(m.least_clearance, m.least_clearance_t_s) + ", of the moving bodies " +
                     least(m.least_moving, m.least_moving_t_s);
  if (num_dynamic_ > 0) line += "; to the dynamic obstacles " + least(m.least_dynamic, m.least_dynamic_t_s);
  line += "; " + std::to_string(m.samples_below_margin) + " of " + std::to_string(m.samples) +
          " samples below " + fixed2(config_.clearance_margin_m) + " m";
  if (envelope_) {
    if (m.least_envelope.limit == guidance::EnvelopeLimit::None) {
      line += "; envelope: no limit measured";
    } else {
      const auto& names = model_->key_point_names();
      const int p = m.least_envelope.point;
      std::string limit = guidance::to_string(m.least_envelope.limit);
      // Appended piece by piece: GCC 12 at -O3 misreads " " + to_string()'s insert at the front as
      // an overlapping copy (-Wrestrict).
      if (m.least_envelope.limit == guidance::EnvelopeLimit::Wall) {
        limit += ' ';
        limit += std::to_string(m.least_envelope.wall);
      }
      line += "; envelope: least distance " + fixed2(m.least_envelope.distance_m) + " m at " +
              fixed2(m.least_envelope_t_s) + " s (" +
              (p >= 0 && p < static_cast<int>(names.size()) ? names[static_cast<std::size_t>(p)] : std::string("?")) + " to " +
              limit + "), " + std::to_string(m.samples_outside_envelope) + " samples outside";
    }
  }
  // Appended piece by piece, as above: no literal + temporary string.
  if (hook_point_ < 0) {
    line += "; ground: n/a";
  } else {
    line += "; ground: least clearance ";
    line += fixed2(m.least_ground_clearance_m);
    line += " m at ";
    line += fixed2(m.least_ground_clearance_t_s);
    line += " s (load bottom), of the hook ";
    line += fixed2(m.least_hook_ground_clearance_m);
    line += " m at ";
    line += fixed2(m.least_hook_ground_clearance_t_s);
    line += " s, ";
    line += std::to_string(m.samples_below_ground);
    line += " samples below";
  }
  if (crane_ == nullptr) {
    line += "; load chart: n/a";
  } else {
    line += "; load chart: peak utilisation ";
    line += std::isinf(m.peak_chart_utilisation) ? std::string("outside the chart") : percent1(m.peak_chart_utilisation);
    line += " at ";
    line += fixed2(m.peak_chart_utilisation_t_s);
    char where[64];
    std::snprintf(where, sizeof where, " s (boom %.2f m at %.1f deg), ", m.peak_chart_boom_length_m,
                  m.peak_chart_elevation_rad * 180.0 / std::numbers::pi);
    line += where;
    line += std::to_string(m.samples_chart_exceeded);
    line += " samples above 100 %, ";
    line += std::to_string(m.samples_outside_chart);
    line += " outside the chart";
  }
  return line;
}

}  // namespace mgc::sim
