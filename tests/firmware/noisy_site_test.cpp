// SPDX-License-Identifier: Apache-2.0
// The controller on an excavator site with sensor noise, in stepped time: a truck that stands
// still is no reason to stop however its tags scatter, and one that starts and drives into the
// bucket's path is stopped for.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "../sim/sim_rig.hpp"
#include "mgc/firmware/controller.hpp"

using namespace mgc;
using test::SimRig;

namespace {

//! mgc-sim's default noise: encoders 0.5 counts, UWB 0.15 m with 2 % dropouts.
sim::SimConfig noisy(std::uint64_t seed) {
  sim::SimConfig config = SimRig::quiet_config();
  config.encoder_noise_counts = 0.5;
  config.uwb.noise_sigma_m = 0.15;
  config.uwb.dropout_probability = 0.02;
  config.seed = seed;
  return config;
}

//! A controller on the rig that requests the goal once, and the referee's true clearance of the
//! true machine to the dynamic obstacles every 50 ms.
struct Site {
  SimRig rig;
  firmware::Controller controller;
  std::unique_ptr<planning::MachineModel> truth_model;
  std::unique_ptr<planning::CollisionWorld> truth_world;
  bool goal_sent = false;
  bool done = false;
  double least_true_dynamic_m = std::numeric_limits<double>::infinity();
  std::string log;
  std::function<void(const hal::SensorSnapshot&)> also;

  Site(const char* file, sim::SimConfig config, const std::function<void(planning::Scenario&)>& edit = {},
       const firmware::ControllerConfig& controller_config = firmware::ControllerConfig{})
      : rig(file, std::move(config), "noisy-site", edit), controller(rig.scenario, controller_config) {
    planning::Scenario bare = rig.scenario;
    bare.planner.dilation_m = 0.0;
    truth_model = planning::build_model(bare);
    truth_world = planning::build_world(bare, *truth_model);
    rig.calibrate_valves();
    rig.on_cycle = [this](const hal::SensorSnapshot& s) { cycle(s); };
  }

  void cycle(const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) commands.goal_request = goal_sent = true;
    const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, commands, false);
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    if (out.supervisor.transitioned) {
      char line[240];
      double allowance_m = 0.0;
      for (std::size_t t = 0; t < controller.num_trackers(); ++t) {
        const firmware::ObstacleTracker& tracker = controller.tracker(t);
        if (tracker.still()) allowance_m = std::max(allowance_m, 2.0 * tracker.position_sigma_m());
      }
      const guidance::StopCheckResult& check = controller.stop_check();
      std::snprintf(line, sizeof line, "%.2f s %s (%s): nearest %d/%d at %.3f m (geometric %.3f m), obstacle speed %.2f m/s, allowance %.3f m\n",
                    static_cast<double>(s.t_us - SimRig::kSimZeroUs) * 1e-6, guidance::to_string(out.supervisor.state),
                    guidance::to_string(out.supervisor.reason), static_cast<int>(check.nearest.with), check.nearest.other,
                    check.min_clearance_m, check.min_geometric_m, controller.obstacle_speed_m_s(),
                    allowance_m);
      log += line;
    }
    if (out.supervisor.reason == guidance::TransitionReason::GoalReached) done = true;
    if (also) also(s);
    if (!rig.scenario.dynamic_obstacles.empty() && s.cycle % static_cast<std::uint64_t>(50'000 / rig.cycle_us) == 0) {
      planning::JointVector q(controller.num_joints());
      for (int j = 0; j < controller.num_joints(); ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
      for (std::size_t d = 0; d < rig.scenario.dynamic_obstacles.size(); ++d) {
        truth_world->set_dynamic_pose(static_cast<int>(d), rig.sim->obstacle_pose(d));
      }
      least_true_dynamic_m = std::min(
          least_true_dynamic_m,
          truth_world->clearance(q, planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic).distance_m);
    }
  }

  //! Until the goal, a FAULT or limit_s of simulated time.
  void run(double limit_s) {
    while (!done && controller.supervisor().state() != guidance::SupervisorState::Fault && rig.t_us < SimRig::at_sim_s(limit_s)) {
      rig.run(1'000'000);
    }
  }
};

//! excavator-truck.yaml's truck 2 driving in and standing at x = 12 m, out of the bucket's reach,
//! from 2 s to go_s, then on at 3.5 m/s to x = 5 m, across the bucket's swing.
void stands_then_goes(planning::Scenario& s, double go_s) {
  auto& motion = s.dynamic_obstacles[0].motion;
  const double yaw = motion.front().yaw_rad;
  motion = {{0.0, {20.0, 4.2, 0.0}, yaw}, {2.0, {12.0, 4.2, 0.0}, yaw}, {go_s, {12.0, 4.2, 0.0}, yaw}, {go_s + 2.0, {5.0, 4.2, 0.0}, yaw}};
}

}  // namespace

TEST_CASE("a standing truck that starts and drives into the bucket's swing is stopped for", "[firmware][sim][e2e]") {
  // The truck stands long enough (2 s) to be posed by the average of its fixes, then drives into
  // the path while the bucket swings toward it. The stillness test must see the start within its
  // documented 0.5 s (docs/control-loop.md), and the stop check then stop the machine clear of it.
  constexpr double kGoS = 4.0;
  for (const std::uint64_t seed : {31, 32, 33}) {
    CAPTURE(seed);
    Site site("excavator-truck.yaml", noisy(seed), [](planning::Scenario& s) { stands_then_goes(s, kGoS); });
    bool still_at_go = false;
    std::int64_t seen_us = -1;
    std::int64_t stop_us = -1;
    site.also = [&](const hal::SensorSnapshot& s) {
      const firmware::ObstacleTracker& truck = site.controller.tracker(0);
      if (s.t_us < SimRig::at_sim_s(kGoS)) still_at_go = truck.still();
      if (s.t_us >= SimRig::at_sim_s(kGoS) && seen_us < 0 && !truck.still()) seen_us = s.t_us;
      if (s.t_us >= SimRig::at_sim_s(kGoS) && stop_us < 0 && site.controller.supervisor().state() == guidance::SupervisorState::Stopping &&
          site.controller.supervisor().reason() == guidance::TransitionReason::SafetyStopZone) {
        stop_us = s.t_us;
      }
    };
    site.run(120.0);
    INFO(site.log);
    const firmware::ControllerStats& st = site.controller.stats();
    const double seen_s = static_cast<double>(seen_us - SimRig::at_sim_s(kGoS)) * 1e-6;
    const double stop_s = static_cast<double>(stop_us - SimRig::at_sim_s(kGoS)) * 1e-6;
    CAPTURE(seen_s, stop_s, site.least_true_dynamic_m, st.safety_stops);
    REQUIRE(site.rig.scenario.guidance.has_value());
    CHECK(still_at_go);
    REQUIRE(seen_us > 0);
    CHECK(seen_s <= 0.5);
    REQUIRE(stop_us > 0);
    // Stopped before the truck, 2 s on its way, has parked across the swing.
    CHECK(stop_s < 2.0);
    CHECK(site.least_true_dynamic_m > *site.rig.scenario.guidance->stop_margin_m);
    CHECK(st.plausibility_fault == guidance::PlausibilityFault::None);
    CHECK(st.goals_reached == 1);
    WARN("truck starting at " << kGoS << " s, seed " << seed << ": seen " << seen_s << " s after, stopped " << stop_s
                              << " s after; least true clearance " << site.least_true_dynamic_m << " m");
  }
}

TEST_CASE("measure: false stops and faults over noise seeds on four sites", "[.measure]") {
  // Not run by default: the rate of runs with more safety stops than the noise-free run, with a
  // plausibility finding, or short of the goal, over 30 noise seeds per site (MGC_MEASURE_SEEDS,
  // MGC_MEASURE_SITE to change them).
  const int seeds = std::getenv("MGC_MEASURE_SEEDS") != nullptr ? std::atoi(std::getenv("MGC_MEASURE_SEEDS")) : 30;
  const char* only = std::getenv("MGC_MEASURE_SITE");
  for (const char* file : {"excavator-truck.yaml", "excavator-cycle.yaml", "excavator-pipelines.yaml", "thesis-steel-frame.yaml"}) {
    if (only != nullptr && std::string(only) != file) continue;
    Site quiet(file, SimRig::quiet_config());
    quiet.run(400.0);
    const int quiet_stops = quiet.controller.stats().safety_stops;
    if (quiet.controller.stats().goals_reached != 1) std::printf("%s without noise:\n%s", file, quiet.log.c_str());
    int extra_stops = 0;
    int findings = 0;
    int short_of_goal = 0;
    int most_stops = 0;
    for (int seed = 1; seed <= seeds; ++seed) {
      Site site(file, noisy(static_cast<std::uint64_t>(1000 + seed)));
      site.run(400.0);
      const firmware::ControllerStats& st = site.controller.stats();
      extra_stops += st.safety_stops > quiet_stops ? 1 : 0;
      most_stops = std::max(most_stops, st.safety_stops);
      findings += st.plausibility_fault != guidance::PlausibilityFault::None ? 1 : 0;
      short_of_goal += st.goals_reached == 1 ? 0 : 1;
      if (st.safety_stops > quiet_stops || st.plausibility_fault != guidance::PlausibilityFault::None) {
        std::printf("%s seed %d: %d stops, %s\n%s", file, 1000 + seed, static_cast<int>(st.safety_stops),
                    guidance::to_string(st.plausibility_fault), site.log.c_str());
      }
    }
    std::printf("%s: quiet run %d safety stops, %d goals; over %d noise seeds: %d with more stops (most %d), %d with a plausibility finding, %d short of the goal\n",
                file, quiet_stops, static_cast<int>(quiet.controller.stats().goals_reached), seeds, extra_stops, most_stops, findings, short_of_goal);
  }
}
