// SPDX-License-Identifier: Apache-2.0
// Closed loop over the bus (end to end): the thesis crane planned with limcon,
// the path followed one joint at a time by the online jerk-limited generator, velocity commands
// with position feedback written through the Hal to the simulated crane, whose true state must
// reach the goal without touching the site.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include "../sim/sim_rig.hpp"
#include "mgc/firmware/rate_limiter.hpp"
#include "mgc/firmware/sensing.hpp"
#include "mgc/guidance/online.hpp"
#include "mgc/guidance/supervisor.hpp"
#include "mgc/planning/planners/single_axis_tree.hpp"

using namespace mgc;
using test::SimRig;

namespace {

constexpr std::size_t kJoints = guidance::OneJointAtATime::kMaxJoints;

//! The lift planned with limcon on the static site (crane 2 is the re-planning tests' business),
//! and a follower that turns it into velocity commands: one joint at a time along the plan by the
//! online jerk-limited generator, plus position feedback on the measured joints.
struct Follower {
  std::unique_ptr<planning::MachineModel> model;
  std::unique_ptr<planning::CollisionWorld> world;
  std::vector<planning::JointVector> waypoints;  //!< unwrapped from the start
  int n = 0;
  std::array<guidance::JointLimits, kJoints> limits{};
  std::array<guidance::JointState, kJoints> setpoint{};
  std::array<guidance::JointState, kJoints> next{};
  guidance::OneJointAtATime generator;
  std::size_t target = 1;
  bool generator_error = false;

  explicit Follower(planning::Scenario site) {
    site.dynamic_obstacles.clear();
    model = planning::build_model(site);
    world = planning::build_world(site, *model);
    planning::PlanningProblem problem = planning::planning_problem(site, *model, *world);
    planning::LimConPlanner planner;
    planning::PlannerStatus status = planner.reset(problem);
    while (status == planning::PlannerStatus::Running) status = planner.step(100);
    REQUIRE(status == planning::PlannerStatus::Solved);
    n = model->dof();
    // Unwrapped, so a continuous swing never takes the long way round.
    waypoints.push_back(planner.path().front());
    for (std::size_t k = 1; k < planner.path().size(); ++k) {
      waypoints.push_back(waypoints.back() + model->difference(planner.path()[k - 1], planner.path()[k]));
    }
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& spec = model->joints()[static_cast<std::size_t>(j)];
      // 80 % of the machine's speed: the rest is the feedback's authority.
      limits[static_cast<std::size_t>(j)] = {0.8 * spec.max_velocity, spec.max_acceleration, spec.max_jerk};
      setpoint[static_cast<std::size_t>(j)] = {waypoints.front()[j], 0.0, 0.0};
    }
  }

  [[nodiscard]] bool done() const { return target >= waypoints.size(); }

  //! One cycle: the next setpoint along the plan and, per joint, its velocity plus 1/s times the
  //! position error, scaled by speed_scale, clamped to the joint's speed.
  void command(const hal::SensorSnapshot& s, double dt_s, double speed_scale, std::vector<double>& out) {
    if (!done()) {
      const planning::JointVector& from = waypoints[target - 1];
      const planning::JointVector& to = waypoints[target];
      std::size_t moving = 0;
      for (int j = 1; j < n; ++j) {
        if (std::abs(to[j] - from[j]) > std::abs(to[static_cast<Eigen::Index>(moving)] - from[static_cast<Eigen::Index>(moving)])) {
          moving = static_cast<std::size_t>(j);
        }
      }
      const guidance::TrajectoryStatus st = generator.update(setpoint.data(), limits.data(), static_cast<std::size_t>(n),
                                                             moving, to[static_cast<Eigen::Index>(moving)], dt_s, next.data());
      if (st != guidance::TrajectoryStatus::Working && st != guidance::TrajectoryStatus::Finished) generator_error = true;
      setpoint = next;
      if (st == guidance::TrajectoryStatus::Finished) ++target;
    }
    for (int j = 0; j < n; ++j) {
      const auto k = static_cast<std::size_t>(j);
      double error = setpoint[k].position - s.joints[k].position;
      if (model->joints()[k].continuous) error = std::remainder(error, 2.0 * std::numbers::pi);
      const double v_max = model->joints()[k].max_velocity;
      out[k] = std::clamp(speed_scale * (setpoint[k].velocity + 1.0 * error), -v_max, v_max);
    }
  }
};

}  // namespace

TEST_CASE("closed loop over the bus: the crane follows a limcon plan one joint at a time to the goal", "[firmware][sim]") {
  SimRig rig("thesis-steel-frame.yaml", SimRig::quiet_config());
  rig.start();
  Follower f(rig.scenario);
  const int n = f.n;
  // The real machine, undilated, for the true clearance.
  planning::Scenario bare = rig.scenario;
  bare.dynamic_obstacles.clear();
  bare.planner.dilation_m = 0.0;
  const auto true_world = planning::build_world(bare, *f.model);

  const double dt_s = SimRig::kCycleUs * 1e-6;
  double min_true_clearance_m = std::numeric_limits<double>::infinity();
  int cycles = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    ++cycles;
    f.command(s, dt_s, 1.0, rig.command);
    if (cycles % 5 == 0) {
      planning::JointVector q(n);
      for (int j = 0; j < n; ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
      min_true_clearance_m = std::min(min_true_clearance_m, true_world->clearance(q).distance_m);
    }
  };
  for (int block = 0; block < 40 && !f.done(); ++block) rig.run(5'000'000);
  rig.run(5'000'000);  // settle on the goal

  CHECK_FALSE(f.generator_error);
  REQUIRE(f.done());
  const planning::JointVector& goal = f.waypoints.back();
  for (int j = 0; j < n; ++j) {
    CAPTURE(j);
    const planning::JointSpec& spec = f.model->joints()[static_cast<std::size_t>(j)];
    double error = rig.sim->truth().position[static_cast<std::size_t>(j)] - goal[j];
    if (spec.continuous) error = std::remainder(error, 2.0 * std::numbers::pi);
    CHECK(std::abs(error) < (spec.type == planning::JointType::Revolute ? 0.5 * std::numbers::pi / 180.0 : 0.05));
  }
  CAPTURE(min_true_clearance_m, cycles);
  CHECK(min_true_clearance_m > 0.0);
  WARN("closed loop: lift of " << f.waypoints.size() << " waypoints in " << cycles * dt_s << " s, least true clearance "
                               << min_true_clearance_m << " m");
}

TEST_CASE("closed loop: a loss of sensing while the crane moves ends in a controlled stop and FAULT", "[firmware][sim]") {
  struct Case {
    const char* fault;
    guidance::TransitionReason reason;
  };
  // At 20 s of simulated time the crane is on its way (checked below).
  const Case cases[] = {
      {"heartbeat-lost:swing@20", guidance::TransitionReason::EncoderMissing},
      {"encoder-dropout:boom_elevation@20", guidance::TransitionReason::EncoderStale},
      {"heartbeat-lost:uwb@20", guidance::TransitionReason::UwbGatewayLost},
      {"bus-off@20", guidance::TransitionReason::BusOff},
  };
  for (const Case& c : cases) {
    CAPTURE(c.fault);
    sim::SimConfig config = SimRig::quiet_config();
    std::vector<std::string> names;
    {
      const planning::Scenario s = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
      for (const auto& j : s.machine.joints) names.push_back(j.name);
    }
    config.faults.push_back(sim::parse_fault(c.fault, names));
    SimRig rig("thesis-steel-frame.yaml", config);

    Follower f(rig.scenario);
    const int n = f.n;
    std::vector<firmware::RateLimits> rate_limits;
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& spec = f.model->joints()[static_cast<std::size_t>(j)];
      rate_limits.push_back({spec.max_velocity, spec.max_acceleration, 0.0});
    }
    firmware::RateLimiter limiter(rate_limits);
    guidance::SupervisorConfig supervisor_config;
    supervisor_config.num_joints = n;
    guidance::Supervisor supervisor(supervisor_config);
    guidance::SupervisorOutput out{};
    const double dt_s = SimRig::kCycleUs * 1e-6;
    bool goal_sent = false;
    std::array<double, hal::kMaxBusJoints> previous{};
    bool have_previous = false;
    std::int64_t fault_state_us = -1;
    double speed_at_fault = 0.0;
    std::vector<double> v_target(static_cast<std::size_t>(n), 0.0);

    rig.on_cycle = [&](const hal::SensorSnapshot& s) {
      guidance::SupervisorInputs in;
      in.now_us = s.t_us;
      in.sensing = firmware::sensing_inputs(s);
      // At rest: measured positions unchanged within a hundredth of a degree (or mm) per cycle.
      bool at_rest = have_previous;
      for (int j = 0; j < n && at_rest; ++j) {
        at_rest = std::abs(s.joints[static_cast<std::size_t>(j)].position - previous[static_cast<std::size_t>(j)]) < 1.7e-4;
      }
      for (int j = 0; j < n; ++j) previous[static_cast<std::size_t>(j)] = s.joints[static_cast<std::size_t>(j)].position;
      have_previous = true;
      in.progress.at_rest = at_rest;
      in.progress.command_at_rest = limiter.at_rest();
      in.progress.path_complete = f.done();
      if (supervisor.state() == guidance::SupervisorState::Hold && !goal_sent) {
        in.commands.goal_request = true;
        goal_sent = true;
      }
      in.planner.status = planning::PlannerStatus::Solved;  // planned before the loop started
      out = supervisor.update(in);
      if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
      if (out.state == guidance::SupervisorState::Fault && fault_state_us < 0) fault_state_us = s.t_us;

      if (out.motion_permitted) {
        f.command(s, dt_s, out.speed_scale, v_target);
        (void)limiter.update(v_target, dt_s);
      } else if (out.controlled_stop) {
        (void)limiter.stop(dt_s);
      } else {
        std::fill(v_target.begin(), v_target.end(), 0.0);
        (void)limiter.update(v_target, dt_s);
      }
      for (int j = 0; j < n; ++j) rig.command[static_cast<std::size_t>(j)] = limiter.velocity()[static_cast<std::size_t>(j)];
    };

    rig.run(SimRig::at_sim_s(20.0) - rig.t_us);
    REQUIRE(out.state == guidance::SupervisorState::Executing);
    for (int j = 0; j < n; ++j) speed_at_fault = std::max(speed_at_fault, std::abs(rig.sim->truth().velocity[static_cast<std::size_t>(j)]));
    REQUIRE(speed_at_fault > 0.01);  // moving when the fault hits
    rig.run(10'000'000);
    CHECK(out.state == guidance::SupervisorState::Fault);
    CHECK(out.reason == c.reason);
    REQUIRE(fault_state_us > 0);
    // FAULT comes once the command is at rest: detection, then the deceleration ramp of at most
    // max_velocity / max_acceleration (2 s on the slew), and a few cycles.
    CHECK(fault_state_us - SimRig::at_sim_s(20.0) < 3'000'000);
    // And the true crane stands still, held there by the valve at neutral.
    for (int j = 0; j < n; ++j) {
      CAPTURE(j);
      CHECK(std::abs(rig.sim->truth().velocity[static_cast<std::size_t>(j)]) < 1e-6);
    }
  }
}
