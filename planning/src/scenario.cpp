// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mgc::planning {

Eigen::Isometry3d DynamicObstacleSpec::pose_at(double t_s) const noexcept {
  const auto pose = [](const Eigen::Vector3d& p, double yaw) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translate(p);
    t.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
    return t;
  };
  if (motion.empty()) return Eigen::Isometry3d::Identity();
  if (t_s <= motion.front().t_s) return pose(motion.front().position_m, motion.front().yaw_rad);
  if (t_s >= motion.back().t_s) return pose(motion.back().position_m, motion.back().yaw_rad);
  const auto next = std::upper_bound(motion.begin(), motion.end(), t_s,
                                     [](double t, const Keyframe& k) { return t < k.t_s; });
  const Keyframe& b = *next;
  const Keyframe& a = *(next - 1);
  const double s = (t_s - a.t_s) / (b.t_s - a.t_s);
  return pose(a.position_m + s * (b.position_m - a.position_m), a.yaw_rad + s * (b.yaw_rad - a.yaw_rad));
}

bool DynamicObstacleSpec::moves_between(double from_s, double to_s) const noexcept {
  // The motion is linear between keys: it holds still on [from_s, to_s] when the keys inside it
  // and its two ends all stand in one place.
  const auto same = [](const Keyframe& a, const Keyframe& b) {
    return a.position_m == b.position_m && a.yaw_rad == b.yaw_rad;
  };
  if (motion.size() < 2 || to_s <= motion.front().t_s || from_s >= motion.back().t_s) return false;
  const auto first = std::upper_bound(motion.begin(), motion.end(), from_s,
                                      [](double t, const Keyframe& k) { return t < k.t_s; });
  // first: the first key after from_s; the keys from first - 1 up to the first at or after to_s
  // shape the motion over the interval.
  auto k = first == motion.begin() ? first : first - 1;
  for (auto next = k + 1; next != motion.end(); ++k, ++next) {
    if (!same(*k, *next)) return true;
    if (next->t_s >= to_s) break;
  }
  return false;
}

double DynamicObstacleSpec::max_travel_m(double from_s, double to_s, double reach_m) const noexcept {
  double travel_m = 0.0;
  for (std::size_t k = 0; k + 1 < motion.size(); ++k) {
    const Keyframe& a = motion[k];
    const Keyframe& b = motion[k + 1];
    // The part of [from_s, to_s] inside this stretch, as fractions of it.
    const double lo_s = std::max(from_s, a.t_s);
    const double hi_s = std::min(to_s, b.t_s);
    if (!(hi_s > lo_s)) continue;
    const double fraction = (hi_s - lo_s) / (b.t_s - a.t_s);
    travel_m += fraction * ((b.position_m - a.position_m).norm() + std::abs(b.yaw_rad - a.yaw_rad) * reach_m);
  }
  return travel_m;
}

std::unique_ptr<MachineModel> build_model(const Scenario& scenario) {
  const MachineDefinition& m = scenario.machine;
  if (scenario.dual_crane) {
    return std::make_unique<DualCraneModel>(m.name + " x2", m.joints, m.mobile_crane, m.load_chart, *scenario.dual_crane);
  }
  switch (m.kind) {
    case MachineKind::MobileCrane: {
      if (!scenario.task) throw std::invalid_argument("a mobile crane scenario needs a task");
      const TaskSpec& t = *scenario.task;
      LiftTask lift;
      lift.load_lb = t.load_lb;
      lift.capacity_reduction_pct = t.capacity_reduction_pct;
      lift.constraint = t.constraint;
      lift.load_size_m = t.load_size_m;
      lift.sling_length_m = t.sling_length_m;
      if (t.constraint == CraneConstraintMode::LoadChart && !m.load_chart) {
        throw std::invalid_argument("constraint load_chart needs a load_chart in the machine file");
      }
      return std::make_unique<MobileCrane>(m.name, m.joints, m.mobile_crane, m.load_chart.value_or(LoadChart{}),
                                           m.luff_table, lift, scenario.world_from_base);
    }
    case MachineKind::TowerCrane: {
      TowerLiftTask lift;
      if (scenario.task) {
        lift.load_size_m = scenario.task->load_size_m;
        lift.sling_length_m = scenario.task->sling_length_m;
      }
      return std::make_unique<TowerCrane>(m.name, m.joints, m.tower_crane, lift, scenario.world_from_base);
    }
    case MachineKind::Excavator:
      return std::make_unique<Excavator>(m.name, m.joints, m.excavator, scenario.world_from_base);
  }
  throw std::invalid_argument("unknown machine kind");
}

std::unique_ptr<CollisionWorld> build_world(const Scenario& scenario, const MachineModel& model, double t_s,
                                            int predicted_poses) {
  auto world = std::make_unique<CollisionWorld>(model, scenario.planner.dilation_m);
  for (const StaticObstacle& o : scenario.obstacles) world->add_static(o);
  for (const DynamicObstacleSpec& d : scenario.dynamic_obstacles) {
    for (int k = 0; k <= predicted_poses; ++k) {
      DynamicObstacle copy = d.obstacle;
      if (k > 0) copy.name += " (predicted " + std::to_string(k) + ")";
      world->add_dynamic(std::move(copy));
    }
  }
  world->finalize();
  for (int i = 0; i < world->num_dynamic(); ++i) {
    world->set_dynamic_pose(i, scenario.dynamic_obstacles[static_cast<std::size_t>(i / (predicted_poses + 1))].pose_at(t_s));
  }
  return world;
}

PlanningProblem planning_problem(const Scenario& scenario, const MachineModel& model, CollisionWorld& world) {
  PlanningProblem problem;
  problem.model = &model;
  problem.world = &world;
  problem.start = scenario.start;
  problem.goal = scenario.goal;
  problem.step = step_sizes(model, scenario.planner.space_resolution);
  problem.error_tolerance = scenario.planner.error_tolerance;
  problem.goal_bias = scenario.planner.goal_bias;
  problem.max_iterations = scenario.planner.max_iterations;
  problem.seed = scenario.planner.seed;
  return problem;
}

JointVector step_sizes(const MachineModel& model, int space_resolution) {
  JointVector steps(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointSpec& j = model.joints()[static_cast<std::size_t>(i)];
    steps[i] = (j.continuous ? std::numbers::pi : j.range()) / space_resolution;
  }
  return steps;
}

}  // namespace mgc::planning
