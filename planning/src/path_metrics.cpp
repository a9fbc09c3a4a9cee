// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/path_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mgc::planning {
namespace {

// Seed 000 leaves the hoist out of its roughness: it "does not contribute to the smoothness".
bool is_hoist(const MachineModel& model, int joint) {
  const std::string& name = model.joints()[static_cast<std::size_t>(joint)].name;
  return (model.kind() == MachineKind::MobileCrane && name == "cable_length") ||
         (model.kind() == MachineKind::TowerCrane && name == "hook_height");
}

double normalized_component(const JointSpec& j, double delta) {
  return delta / (j.continuous ? 2.0 * std::numbers::pi : j.range());
}

}  // namespace

double normalized_distance(const MachineModel& model, const JointVector& a, const JointVector& b,
                           bool include_hoist) noexcept {
  const JointVector d = model.difference(a, b);
  double sum = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    if (!include_hoist && is_hoist(model, i)) continue;
    const double n = normalized_component(model.joints()[static_cast<std::size_t>(i)], d[i]);
    sum += n * n;
  }
  return std::sqrt(sum);
}

int moving_joint(const MachineModel& model, const JointVector& from, const JointVector& to) noexcept {
  const JointVector d = model.difference(from, to);
  int joint = -1;
  for (int i = 0; i < model.dof(); ++i) {
    if (d[i] == 0.0) continue;
    if (joint >= 0) return -2;
    joint = i;
  }
  return joint;
}

PathMetrics compute_motion_metrics(const MachineModel& model, const std::vector<JointVector>& path) {
  PathMetrics m;
  m.path_nodes = static_cast<int>(path.size());
  int previous_joint = -1;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const JointVector d = model.difference(path[e], path[e + 1]);
    double sequential = 0.0;
    double simultaneous = 0.0;
    for (int i = 0; i < model.dof(); ++i) {
      const double t = std::abs(d[i]) / model.joints()[static_cast<std::size_t>(i)].max_velocity;
      sequential += t;
      simultaneous = std::max(simultaneous, t);
    }
    m.length_normalized += normalized_distance(model, path[e], path[e + 1], true);
    m.roughness += normalized_distance(model, path[e], path[e + 1], false);
    m.exec_time_sequential_s += sequential;
    m.exec_time_simultaneous_s += simultaneous;
    const int joint = moving_joint(model, path[e], path[e + 1]);
    if (joint == -2) ++m.multi_joint_edges;
    if (joint >= 0 && previous_joint >= 0 && joint != previous_joint) ++m.dof_switches;
    if (joint != -1) previous_joint = joint;
  }
  m.cost = 0.5 * (m.exec_time_sequential_s / 60.0) + 0.5 * m.roughness;
  return m;
}

PathMetrics compute_path_metrics(const MachineModel& model, CollisionWorld& world, const std::vector<JointVector>& path,
                                 const JointVector& step, double clearance_tolerance_m) {
  PathMetrics m = compute_motion_metrics(model, path);
  if (path.empty()) return m;
  // Every measured stretch of every edge, found first so that refinement compares each stretch's
  // bound with the least clearance measured anywhere on the path.
  struct Stretch {
    std::size_t edge;
    double t0, t1;  // edge fractions
    double d0_m, d1_m;
  };
  std::vector<Stretch> stretches;
  std::vector<double> travel_m(path.size() - 1, 0.0);  // bound on any body point's motion along each edge
  double sampled_m = world.clearance(path.front()).distance_m;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const JointVector d = model.difference(path[e], path[e + 1]);
    for (int i = 0; i < model.dof(); ++i) travel_m[e] += model.edge_displacement_bound(path[e], path[e + 1], i) * std::abs(d[i]);
    int steps = 1;
    for (int i = 0; i < model.dof(); ++i) steps = std::max(steps, static_cast<int>(std::ceil(std::abs(d[i]) / step[i])));
    double before_m = stretches.empty() ? sampled_m : stretches.back().d1_m;
    for (int k = 1; k <= steps; ++k) {
      const double t = static_cast<double>(k) / steps;
      const double at_m = world.clearance(model.interpolate(path[e], path[e + 1], t)).distance_m;
      stretches.push_back({e, static_cast<double>(k - 1) / steps, t, before_m, at_m});
      sampled_m = std::min(sampled_m, at_m);
      before_m = at_m;
    }
  }

  double bound_m = sampled_m;
  const auto stretch_bound = [&](const Stretch& s) {
    const double delta_m = travel_m[s.edge] * (s.t1 - s.t0);
    return std::clamp(0.5 * (s.d0_m + s.d1_m - delta_m), 0.0, std::min(s.d0_m, s.d1_m));
  };
  // Bisection stops where the stretch no longer moves the machine measurably: there the bound is
  // the measured value.
  constexpr double kShortestStretch_m = 1e-9;
  std::vector<Stretch> pending;
  for (const Stretch& first : stretches) {
    pending.push_back(first);
    while (!pending.empty()) {
      const Stretch s = pending.back();
      pending.pop_back();
      const double b = stretch_bound(s);
      const double delta_m = travel_m[s.edge] * (s.t1 - s.t0);
      if (clearance_tolerance_m <= 0.0 || b >= sampled_m - clearance_tolerance_m || delta_m < kShortestStretch_m) {
        bound_m = std::min(bound_m, b);
        continue;
      }
      const double tm = 0.5 * (s.t0 + s.t1);
      const double mid_m = world.clearance(model.interpolate(path[s.edge], path[s.edge + 1], tm)).distance_m;
      sampled_m = std::min(sampled_m, mid_m);
      pending.push_back({s.edge, s.t0, tm, s.d0_m, mid_m});
      pending.push_back({s.edge, tm, s.t1, mid_m, s.d1_m});
    }
  }
  m.min_clearance_sampled_m = sampled_m;
  m.min_clearance_m = std::min(bound_m, sampled_m);
  return m;
}

}  // namespace mgc::planning
