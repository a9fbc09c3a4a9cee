// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/path_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

PathMetrics compute_path_metrics(const MachineModel& model, CollisionWorld& world, const std::vector<JointVector>& path,
                                 const JointVector& step) {
  PathMetrics m;
  m.path_nodes = static_cast<int>(path.size());
  m.min_clearance_m = std::numeric_limits<double>::infinity();
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

    int steps = 1;
    for (int i = 0; i < model.dof(); ++i) steps = std::max(steps, static_cast<int>(std::ceil(std::abs(d[i]) / step[i])));
    for (int k = (e == 0 ? 0 : 1); k <= steps; ++k) {
      const JointVector q = model.interpolate(path[e], path[e + 1], static_cast<double>(k) / steps);
      m.min_clearance_m = std::min(m.min_clearance_m, world.clearance(q).distance_m);
    }
  }
  if (path.size() == 1) m.min_clearance_m = world.clearance(path.front()).distance_m;
  if (path.empty()) m.min_clearance_m = 0.0;
  m.cost = 0.5 * (m.exec_time_sequential_s / 60.0) + 0.5 * m.roughness;
  return m;
}

}  // namespace mgc::planning
