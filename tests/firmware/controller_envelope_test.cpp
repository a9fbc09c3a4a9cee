// SPDX-License-Identifier: Apache-2.0
// The working envelope in the controller's cycle, against the simulated crane: the thesis lift
// with a road west of the crane that nothing may swing over (scenarios/thesis-steel-frame-road.yaml).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "../sim/sim_rig.hpp"
#include <mgc/alert_t.hpp>
#include <mgc/operator_instruction_t.hpp>

#include "mgc/firmware/controller.hpp"
#include "mgc/guidance/envelope.hpp"
#include "mgc/planning/planners/planner.hpp"

using namespace mgc;
using test::SimRig;

namespace {

constexpr const char* kScenario = "thesis-steel-frame-road.yaml";
//! Simulated time by which the lift is done, the longer way round included. [s]
constexpr double kLiftLimitS = 400.0;
//! Configurations per metre of the fastest body point along a re-checked path: far denser than any
//! planner's edge check. [1/m]
constexpr double kDenseSamplesPerM = 20.0;

//! The least envelope distance of any monitored point along the path, densely interpolated. [m]
double least_envelope_along(const planning::MachineModel& model, guidance::Envelope& envelope,
                            std::span<const planning::JointVector> path) {
  double least_m = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    double travel_m = 0.0;
    const planning::JointVector delta = model.difference(path[i], path[i + 1]);
    for (int j = 0; j < model.dof(); ++j) travel_m += model.edge_displacement_bound(path[i], path[i + 1], j) * std::abs(delta[j]);
    const int samples = std::max(2, static_cast<int>(std::ceil(travel_m * kDenseSamplesPerM)));
    for (int k = 0; k <= samples; ++k) {
      const planning::JointVector q = model.interpolate(path[i], path[i + 1], static_cast<double>(k) / samples);
      least_m = std::min(least_m, envelope.nearest(q).distance_m);
    }
  }
  return least_m;
}

planning::PlannerStatus solve(planning::Planner& planner, const planning::PlanningProblem& problem) {
  planning::PlannerStatus status = planner.reset(problem);
  while (status == planning::PlannerStatus::Running) status = planner.step(1000);
  return status;
}

//! One cycle of the controller on the rig: the scenario's goal requested once in HOLD, the
//! commands written to the bus.
void drive(firmware::Controller& controller, SimRig& rig, bool& goal_sent, const hal::SensorSnapshot& s) {
  firmware::ControllerCommands commands;
  if (!goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) {
    commands.goal_request = true;
    goal_sent = true;
  }
  const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, commands, false);
  if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
  rig.hal->set_pilot_enabled(out.pilot_enable);
  for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
}

}  // namespace

TEST_CASE("the scenario's envelope binds: the plain lift swings over the road", "[firmware][envelope]") {
  // Without the envelope the planner takes the west route, over the road: so the lift below is a
  // real test of the envelope, not of a site the lift never comes near.
  auto loaded = planning::io::load_and_build(test::scenario_path(kScenario));
  REQUIRE(loaded.scenario.envelope.has_value());
  guidance::Envelope envelope(*loaded.model, guidance::envelope_config(*loaded.scenario.envelope, *loaded.model));
  auto planner = planning::make_planner("limcon");
  REQUIRE(planner);
  planning::PlanningProblem problem = planning::planning_problem(loaded.scenario, *loaded.model, *loaded.world);
  REQUIRE(solve(*planner, problem) == planning::PlannerStatus::Solved);
  CHECK(least_envelope_along(*loaded.model, envelope, planner->path()) < -1.0);

  // With the envelope as the world's rule, the same query keeps inside it by the margin.
  guidance::EnvelopeRule rule(*loaded.model, envelope.config(), 1.25);
  loaded.world->set_rule(&rule);
  REQUIRE(solve(*planner, problem) == planning::PlannerStatus::Solved);
  // Edges are checked at samples no body point moves more than the dilation between: half of it
  // is the most a point can lose between two of them.
  CHECK(least_envelope_along(*loaded.model, envelope, planner->path()) >= 1.25 - 0.5 * loaded.world->dilation_m() - 1e-9);
  // The rule speaks in validate()'s verdict.
  planning::JointVector west = loaded.scenario.start;
  west[0] = std::numbers::pi;
  const planning::Validity v = loaded.world->validate(west);
  CHECK(v.status == planning::Validity::Status::Rule);
  CHECK(loaded.world->describe(v).find("virtual wall 0") != std::string::npos);
}

TEST_CASE("the controller completes the lift inside the working envelope", "[firmware][sim][e2e][envelope]") {
  SimRig rig(kScenario, SimRig::quiet_config(), "ctl-envelope");
  rig.calibrate_valves();
  firmware::Controller controller(rig.scenario, firmware::ControllerConfig{});
  REQUIRE(controller.has_envelope());

  // The truth: the simulated crane's monitored points against the envelope itself.
  planning::Scenario bare = rig.scenario;
  bare.planner.dilation_m = 0.0;
  const auto truth_model = planning::build_model(bare);
  guidance::Envelope truth(*truth_model, guidance::envelope_config(*bare.envelope, *truth_model));

  bool goal_sent = false;
  double least_true_m = std::numeric_limits<double>::infinity();
  double least_planned_m = std::numeric_limits<double>::infinity();
  std::uint64_t plan_checked = 0;
  int wall_reports = 0;
  int envelope_alerts = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    drive(controller, rig, goal_sent, s);
    // Every plan the machine follows, re-checked densely once.
    const firmware::GuidanceSnapshot& snap = controller.snapshot();
    if (snap.plan.plan_id != plan_checked && controller.planner().path().size() > 1) {
      plan_checked = snap.plan.plan_id;
      least_planned_m = std::min(least_planned_m, least_envelope_along(*truth_model, truth, controller.planner().path()));
    }
    planning::JointVector q(controller.num_joints());
    for (int j = 0; j < controller.num_joints(); ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
    least_true_m = std::min(least_true_m, truth.nearest(q).distance_m);
    if (snap.envelope_limit == mgc::operator_instruction_t::ENVELOPE_WALL && std::isfinite(snap.envelope_distance_m)) ++wall_reports;
    for (int a = 0; a < snap.num_alerts; ++a) {
      if (snap.alerts[static_cast<std::size_t>(a)].source == mgc::alert_t::SOURCE_ENVELOPE) ++envelope_alerts;
    }
  };
  rig.run(SimRig::at_sim_s(kLiftLimitS) - rig.t_us);

  const firmware::ControllerStats& st = controller.stats();
  CAPTURE(st.plans, st.replans, st.escapes, st.safety_stops, st.min_envelope_m, least_true_m, least_planned_m,
          st.envelope_cut_cycles, wall_reports, envelope_alerts);
  CHECK(st.goals_reached == 1);
  CHECK(st.trajectory_errors == 0);
  CHECK(plan_checked > 0);
  // Every plan keeps the planning margin less half the planning world's dilation; the machine
  // itself never reaches the wall.
  const firmware::ControllerConfig config;
  CHECK(least_planned_m >= config.envelope_planning_margin_m - 0.5 * (rig.scenario.planner.dilation_m + config.planning_margin_m));
  CHECK(least_true_m > 0.0);
  CHECK(st.min_envelope_m > 0.0);
  CHECK(st.min_envelope_m < 1e9);
  // The feed reports the wall as the nearest limit for part of the lift.
  CHECK(wall_reports > 0);
  // The true crane stands at the goal.
  for (int j = 0; j < controller.num_joints(); ++j) {
    CAPTURE(j);
    const planning::JointSpec& spec = controller.model().joints()[static_cast<std::size_t>(j)];
    double error = rig.sim->truth().position[static_cast<std::size_t>(j)] - rig.scenario.goal[j];
    if (spec.continuous) error = std::remainder(error, 2.0 * std::numbers::pi);
    CHECK(std::abs(error) < (spec.type == planning::JointType::Revolute ? 0.5 * std::numbers::pi / 180.0 : 0.05));
  }
}

TEST_CASE("under a low ceiling the controller slows only the motions toward it", "[firmware][sim][e2e][envelope]") {
  // The lift of the plain site under a ceiling 1.5 m above the boom tip's start: inside the 2 m
  // slowdown band, outside the planner's margin. Boom up and telescope out raise the tip; they are
  // slowed when they do, and nothing else ever is.
  SimRig rig("thesis-steel-frame.yaml", SimRig::quiet_config(), "ctl-ceiling");
  rig.calibrate_valves();
  planning::Scenario scenario = rig.scenario;
  const auto model = planning::build_model(scenario);
  planning::Kinematics k;
  model->forward_kinematics(scenario.start, k);
  const auto names = model->key_point_names();
  const auto tip = static_cast<std::size_t>(std::find(names.begin(), names.end(), "boom_tip") - names.begin());
  const double ceiling_m = k.points[tip].z() + 1.5;
  planning::EnvelopeSpec spec;
  spec.points = {"boom_tip"};
  spec.height_ceiling_m = ceiling_m;
  scenario.envelope = spec;
  // The thesis's DRRT: its path raises the tip toward the ceiling, which is what is tested here.
  firmware::ControllerConfig config;
  config.replanner = "drrt";
  firmware::Controller controller(scenario, config);

  constexpr int kSwing = 0;
  constexpr int kBoom = 1;
  constexpr int kTelescope = 2;
  constexpr int kHoist = 3;
  bool goal_sent = false;
  double highest_true_m = -std::numeric_limits<double>::infinity();
  int wrong_cuts = 0;
  int boom_up_cuts = 0;
  int slow_down_alerts = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    drive(controller, rig, goal_sent, s);
    if (controller.supervisor().state() == guidance::SupervisorState::Executing) {
      // The limiter's verdict on this cycle's command: a cut joint must be one raising the tip.
      const guidance::EnvelopeResult& e = controller.envelope();
      const auto cut = [&](int j) { return e.joint_scale[static_cast<std::size_t>(j)] < 1.0; };
      if (cut(kSwing) || cut(kHoist)) ++wrong_cuts;
      if (cut(kBoom) && !(e.allowed_velocity[kBoom] > 0.0)) ++wrong_cuts;
      if (cut(kTelescope) && !(e.allowed_velocity[kTelescope] > 0.0)) ++wrong_cuts;
      if (cut(kBoom)) ++boom_up_cuts;
    }
    const firmware::GuidanceSnapshot& snap = controller.snapshot();
    for (int a = 0; a < snap.num_alerts; ++a) {
      const firmware::SnapshotAlert& alert = snap.alerts[static_cast<std::size_t>(a)];
      if (alert.source == mgc::alert_t::SOURCE_ENVELOPE && alert.severity == mgc::alert_t::SEVERITY_SLOW_DOWN) {
        ++slow_down_alerts;
        CHECK(alert.index == mgc::operator_instruction_t::ENVELOPE_HEIGHT_CEILING);
      }
    }
    planning::JointVector q(controller.num_joints());
    for (int j = 0; j < controller.num_joints(); ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
    planning::Kinematics truth;
    model->forward_kinematics(q, truth);
    highest_true_m = std::max(highest_true_m, truth.points[tip].z());
  };
  rig.run(SimRig::at_sim_s(kLiftLimitS) - rig.t_us);

  const firmware::ControllerStats& st = controller.stats();
  CAPTURE(st.plans, st.replans, st.safety_stops, st.min_envelope_m, st.envelope_cut_cycles, boom_up_cuts, wrong_cuts,
          slow_down_alerts, highest_true_m, ceiling_m);
  CHECK(st.goals_reached == 1);
  CHECK(st.envelope_cut_cycles > 0);
  CHECK(boom_up_cuts > 0);
  CHECK(wrong_cuts == 0);
  CHECK(slow_down_alerts > 0);
  CHECK(highest_true_m < ceiling_m);
}
