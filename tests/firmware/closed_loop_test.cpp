// SPDX-License-Identifier: Apache-2.0
// Closed loop over the bus (issue 7, first end-to-end piece): the thesis crane planned with limcon,
// the path followed one joint at a time by the online jerk-limited generator, velocity commands
// with position feedback written through the Hal to the simulated crane, whose true state must
// reach the goal without touching the site.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "../sim/sim_rig.hpp"
#include "mgc/guidance/online.hpp"
#include "mgc/planning/planners/single_axis_tree.hpp"

using namespace mgc;
using test::SimRig;

TEST_CASE("closed loop over the bus: the crane follows a limcon plan one joint at a time to the goal", "[firmware][sim]") {
  sim::SimConfig config = SimRig::quiet_config();
  SimRig rig("thesis-steel-frame.yaml", config);
  rig.start();

  // The plan, on the static site (crane 2 is the re-planning tests' business).
  planning::Scenario site = rig.scenario;
  site.dynamic_obstacles.clear();
  const auto model = planning::build_model(site);
  const auto world = planning::build_world(site, *model);
  planning::PlanningProblem problem = planning::planning_problem(site, *model, *world);
  planning::LimConPlanner planner;
  planning::PlannerStatus status = planner.reset(problem);
  while (status == planning::PlannerStatus::Running) status = planner.step(100);
  REQUIRE(status == planning::PlannerStatus::Solved);
  const int n = model->dof();
  // Waypoints unwrapped from the start, so a continuous swing never takes the long way round.
  std::vector<planning::JointVector> waypoints{planner.path().front()};
  for (std::size_t k = 1; k < planner.path().size(); ++k) {
    waypoints.push_back(waypoints.back() + model->difference(planner.path()[k - 1], planner.path()[k]));
  }

  // The real machine, undilated, for the true clearance.
  planning::Scenario bare = site;
  bare.planner.dilation_m = 0.0;
  const auto true_world = planning::build_world(bare, *model);

  std::array<guidance::JointLimits, guidance::OneJointAtATime::kMaxJoints> limits{};
  std::array<guidance::JointState, guidance::OneJointAtATime::kMaxJoints> setpoint{};
  std::array<guidance::JointState, guidance::OneJointAtATime::kMaxJoints> next{};
  for (int j = 0; j < n; ++j) {
    const planning::JointSpec& spec = model->joints()[static_cast<std::size_t>(j)];
    // 80 % of the machine's speed: the rest is the feedback's authority.
    limits[static_cast<std::size_t>(j)] = {0.8 * spec.max_velocity, spec.max_acceleration, spec.max_jerk};
    setpoint[static_cast<std::size_t>(j)] = {waypoints.front()[j], 0.0, 0.0};
  }
  constexpr double kFeedbackPerS = 1.0;  // velocity per position error [1/s]
  const double dt_s = SimRig::kCycleUs * 1e-6;
  guidance::OneJointAtATime generator;
  std::size_t target = 1;
  double min_true_clearance_m = std::numeric_limits<double>::infinity();
  int cycles = 0;
  bool generator_error = false;

  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    ++cycles;
    if (target < waypoints.size()) {
      const planning::JointVector& from = waypoints[target - 1];
      const planning::JointVector& to = waypoints[target];
      std::size_t moving = 0;
      for (int j = 1; j < n; ++j) {
        if (std::abs(to[j] - from[j]) > std::abs(to[static_cast<Eigen::Index>(moving)] - from[static_cast<Eigen::Index>(moving)])) {
          moving = static_cast<std::size_t>(j);
        }
      }
      const guidance::TrajectoryStatus st =
          generator.update(setpoint.data(), limits.data(), static_cast<std::size_t>(n), moving,
                           to[static_cast<Eigen::Index>(moving)], dt_s, next.data());
      if (st != guidance::TrajectoryStatus::Working && st != guidance::TrajectoryStatus::Finished) generator_error = true;
      setpoint = next;
      if (st == guidance::TrajectoryStatus::Finished) ++target;
    }
    for (int j = 0; j < n; ++j) {
      const auto k = static_cast<std::size_t>(j);
      double error = setpoint[k].position - s.joints[k].position;
      if (model->joints()[k].continuous) error = std::remainder(error, 2.0 * std::numbers::pi);
      const double v = setpoint[k].velocity + kFeedbackPerS * error;
      const double v_max = model->joints()[k].max_velocity;
      rig.command[k] = std::clamp(v, -v_max, v_max);
    }
    if (cycles % 5 == 0) {
      planning::JointVector q(n);
      for (int j = 0; j < n; ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
      min_true_clearance_m = std::min(min_true_clearance_m, true_world->clearance(q).distance_m);
    }
  };
  for (int block = 0; block < 40 && target < waypoints.size(); ++block) rig.run(5'000'000);
  rig.run(5'000'000);  // settle on the goal

  CHECK_FALSE(generator_error);
  REQUIRE(target == waypoints.size());
  const planning::JointVector& goal = waypoints.back();
  for (int j = 0; j < n; ++j) {
    CAPTURE(j);
    double error = rig.sim->truth().position[static_cast<std::size_t>(j)] - goal[j];
    if (model->joints()[static_cast<std::size_t>(j)].continuous) error = std::remainder(error, 2.0 * std::numbers::pi);
    CHECK(std::abs(error) < (model->joints()[static_cast<std::size_t>(j)].type == planning::JointType::Revolute ? 0.5 * std::numbers::pi / 180.0 : 0.05));
  }
  CAPTURE(min_true_clearance_m, cycles);
  CHECK(min_true_clearance_m > 0.0);
  WARN("closed loop: lift of " << waypoints.size() << " waypoints in " << cycles * dt_s << " s, least true clearance "
                               << min_true_clearance_m << " m");
}
