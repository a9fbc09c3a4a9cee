// SPDX-License-Identifier: Apache-2.0
// The truth monitor against measurements made here on a world and an envelope of our own: the
// clearance it reports, the envelope distance and the count outside, the minima with their times,
// and the sampling period when it watches the simulator.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "sim_rig.hpp"

#include "mgc/guidance/envelope.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_simulation.hpp"
#include "mgc/sim/truth_monitor.hpp"
#include "mgc/sim/truth_snapshot.hpp"

using namespace mgc;

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

//! The site as the controller tests measure the truth: the scenario's machine and obstacles with
//! the bodies undilated.
struct Reference {
  explicit Reference(const planning::Scenario& scenario) {
    planning::Scenario bare = scenario;
    bare.planner.dilation_m = 0.0;
    model = planning::build_model(bare);
    world = planning::build_world(bare, *model);
  }
  std::unique_ptr<planning::MachineModel> model;
  std::unique_ptr<planning::CollisionWorld> world;
};

planning::Scenario load(const char* name) { return planning::io::load_scenario(test::scenario_path(name)); }

}  // namespace

TEST_CASE("the truth monitor's clearance is the collision world's at set configurations", "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  REQUIRE(scenario.dynamic_obstacles.size() == 1);
  Reference ref(scenario);
  sim::TruthMonitor monitor(scenario);
  REQUIRE(monitor.has_dynamic_obstacles());
  REQUIRE_FALSE(monitor.has_envelope());

  // Crane 2 where its script puts it, and once parked 8 m west of our base, in reach of our boom.
  const Eigen::Isometry3d parked = Eigen::Isometry3d(Eigen::Translation3d(-8.0, 0.0, 0.0));
  const Eigen::Isometry3d poses[] = {scenario.dynamic_obstacles[0].pose_at(0.0), scenario.dynamic_obstacles[0].pose_at(70.0),
                                     parked};
  int dynamic_nearest = 0;
  int static_nearest = 0;
  int cases = 0;
  for (const Eigen::Isometry3d& pose : poses) {
    ref.world->set_dynamic_pose(0, pose);
    monitor.set_obstacle_pose(0, pose);
    for (const double swing : {0.0, 1.0, 2.0, 3.0, 4.0, 5.0}) {
      for (const double elevation : {0.5, 0.9}) {
        planning::JointVector q = scenario.start;
        q[0] = swing;
        q[1] = elevation;
        const planning::Clearance all = ref.world->clearance(q);
        const planning::Clearance moving = ref.world->clearance(q, planning::CollisionWorld::Bodies::Moving);
        // Two turns round: the simulator's swing is unwrapped, the geometry is not.
        planning::JointVector q_turned = q;
        q_turned[0] += 2.0 * kTwoPi;
        const sim::TruthSample& s = monitor.measure(static_cast<double>(cases), q_turned);
        CAPTURE(swing, elevation, pose.translation().transpose(), all.distance_m, s.clearance.distance_m);
        CHECK(s.clearance.distance_m == Approx(all.distance_m).margin(1e-9));
        // Which obstacle is named may differ where two tie (the frame's members repeat), the kind not.
        CHECK(s.clearance.with == all.with);
        CHECK(s.moving_clearance.distance_m == Approx(moving.distance_m).margin(1e-9));
        if (all.distance_m > 0.0) {
          // Free: the world's own dynamic-only query is the reference.
          const planning::Clearance dynamic =
              ref.world->clearance(q, planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic);
          CHECK(s.dynamic_clearance.distance_m == Approx(dynamic.distance_m).margin(1e-9));
          CHECK(s.dynamic_clearance.with == planning::Contact::With::Dynamic);
        }
        dynamic_nearest += all.with == planning::Contact::With::Dynamic ? 1 : 0;
        static_nearest += all.with == planning::Contact::With::Static ? 1 : 0;
        ++cases;
      }
    }
  }
  // The configurations reach both kinds of nearest obstacle, so both paths were compared.
  CHECK(dynamic_nearest >= 1);
  CHECK(static_nearest >= 1);
  CHECK(monitor.summary().samples == static_cast<std::uint64_t>(cases));
}

TEST_CASE("a configuration outside the scenario's envelope is counted outside with a negative distance", "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame-road.yaml");
  REQUIRE(scenario.envelope.has_value());
  Reference ref(scenario);
  guidance::Envelope envelope(*ref.model, guidance::envelope_config(*scenario.envelope, *ref.model));
  sim::TruthMonitor monitor(scenario);
  REQUIRE(monitor.has_envelope());

  // The road's wall is x = -8 m: swung east the boom tip is well inside, swung west past it.
  planning::JointVector east = scenario.start;
  east[0] = 0.0;
  planning::JointVector west = scenario.start;
  west[0] = std::numbers::pi;

  const sim::TruthSample& inside = monitor.measure(1.0, east);
  CHECK(inside.envelope.distance_m > 0.0);
  CHECK(inside.envelope.distance_m == Approx(envelope.nearest(east).distance_m).margin(1e-9));
  CHECK(monitor.summary().samples_outside_envelope == 0);

  // Unwrapped one turn back, as the simulator may report it after swinging round.
  planning::JointVector west_unwrapped = west;
  west_unwrapped[0] -= kTwoPi;
  const sim::TruthSample& outside = monitor.measure(2.0, west_unwrapped);
  const guidance::EnvelopeDistance expected = envelope.nearest(west);
  REQUIRE(expected.distance_m < 0.0);
  CHECK(outside.envelope.distance_m == Approx(expected.distance_m).margin(1e-9));
  CHECK(outside.envelope.limit == guidance::EnvelopeLimit::Wall);
  CHECK(outside.envelope.point == expected.point);

  (void)monitor.measure(3.0, east);
  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples == 3);
  CHECK(m.samples_outside_envelope == 1);
  CHECK(m.least_envelope.distance_m == Approx(expected.distance_m).margin(1e-9));
  CHECK(m.least_envelope_t_s == 2.0);
  CHECK_THAT(monitor.summary_line(), Catch::Contains("1 samples outside") && Catch::Contains("virtual wall 0"));
}

TEST_CASE("the truth monitor keeps the least clearance with its time and counts samples below the margin", "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  Reference ref(scenario);
  // Crane 2 parked 20 m west, its boom pointing away: swinging our load from the start (north) to
  // the west brings it to about a metre of crane 2's carrier, nearer than our own carrier is to the
  // frame (1.30 m).
  const Eigen::Isometry3d parked =
      Eigen::Translation3d(-20.0, 0.0, 0.0) * Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitZ());
  ref.world->set_dynamic_pose(0, parked);
  const planning::JointVector far = scenario.start;
  planning::JointVector near = scenario.start;
  near[0] = std::numbers::pi;
  const double far_m = ref.world->clearance(far).distance_m;
  const double near_m = ref.world->clearance(near).distance_m;
  CAPTURE(near_m, far_m);
  REQUIRE(near_m > 0.0);
  REQUIRE(near_m < far_m);

  sim::TruthMonitorConfig config;
  config.clearance_margin_m = 0.5 * (near_m + far_m);
  sim::TruthMonitor monitor(scenario, config);
  monitor.set_obstacle_pose(0, parked);
  (void)monitor.measure(10.0, far);
  CHECK(monitor.summary().least_clearance.distance_m == Approx(far_m).margin(1e-9));
  CHECK(monitor.summary().least_clearance_t_s == 10.0);
  (void)monitor.measure(10.5, near);
  (void)monitor.measure(11.0, far);
  // A tie later does not move the time of the minimum.
  (void)monitor.measure(11.5, near);
  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples == 4);
  CHECK(m.samples_below_margin == 2);
  CHECK(m.least_clearance.distance_m == Approx(near_m).margin(1e-9));
  CHECK(m.least_clearance_t_s == 10.5);
  CHECK(m.least_dynamic.distance_m <= m.least_clearance.distance_m + 1e-9);
  CHECK(std::isnan(m.least_envelope_t_s));
  CHECK(monitor.last().t_s == 11.5);
  CHECK_THAT(monitor.summary_line(), Catch::Contains("2 of 4 samples below") && !Catch::Contains("envelope"));
}

TEST_CASE("the truth monitor samples the simulator once a period at the true state", "[unit][sim][truth]") {
  sim::SimConfig config = test::SimRig::quiet_config();
  config.scenario_time_offset_s = 70.0;  // crane 2 mid-swing: its pose is not the file's start
  test::SimRig rig("thesis-steel-frame.yaml", config, "truth-monitor");
  Reference ref(rig.scenario);
  sim::TruthMonitor monitor(rig.scenario);  // 50 ms
  int taken = 0;
  for (std::int64_t t = test::SimRig::kSimZeroUs; t <= test::SimRig::at_sim_s(1.0); t += test::SimRig::kPhysicsUs) {
    rig.clock.set_us(t);
    rig.sim->step(t);
    const bool sampled = monitor.sample(*rig.sim);
    taken += sampled ? 1 : 0;
    if (sampled) CHECK(std::abs(std::remainder(rig.sim->time_s(), 0.05)) < 1e-6);
  }
  CHECK(taken == 21);  // 0, 0.05, ..., 1.00 s
  CHECK(monitor.summary().samples == 21);
  CHECK(monitor.last().t_s == Approx(1.0).margin(1e-9));

  ref.world->set_dynamic_pose(0, rig.scenario.dynamic_obstacles[0].pose_at(71.0));
  planning::JointVector q(static_cast<int>(rig.sim->truth().num_joints));
  for (int j = 0; j < q.size(); ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
  CHECK(monitor.last().clearance.distance_m == Approx(ref.world->clearance(q).distance_m).margin(1e-9));
  const planning::Clearance dynamic =
      ref.world->clearance(q, planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic);
  CHECK(monitor.last().dynamic_clearance.distance_m == Approx(dynamic.distance_m).margin(1e-9));
}

TEST_CASE("a copy of the simulator's state is measured as the simulator itself is", "[unit][sim][truth]") {
  sim::SimConfig config = test::SimRig::quiet_config();
  config.scenario_time_offset_s = 60.0;  // crane 2 swinging: its pose changes from sample to sample
  test::SimRig rig("thesis-steel-frame.yaml", config, "truth-snapshot");
  sim::TruthMonitor live(rig.scenario);
  sim::TruthMonitor copied(rig.scenario);
  sim::TruthSnapshot snapshot;
  snapshot.resize_for(*rig.sim);
  REQUIRE(snapshot.obstacle_poses.size() == rig.scenario.dynamic_obstacles.size());
  rig.start();
  rig.command[0] = 0.4;  // swinging, so that the joints change too
  int taken = 0;
  for (int i = 0; i < 200; ++i) {
    rig.run(10'000);
    snapshot.capture(*rig.sim);
    const bool a = live.sample(*rig.sim);
    const bool b = copied.sample(snapshot);
    CHECK(a == b);
    taken += a ? 1 : 0;
    CHECK(copied.last().clearance.distance_m == live.last().clearance.distance_m);
    CHECK(copied.last().dynamic_clearance.distance_m == live.last().dynamic_clearance.distance_m);
  }
  CHECK(taken == 40);  // 2 s at one sample per 50 ms
  CHECK(copied.summary_line() == live.summary_line());
}

TEST_CASE("a site's monitors and pair referee measure a captured frame as they measure the simulators", "[unit][sim][truth]") {
  const planning::Site site = planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml");
  hal::ManualClock clock(1'000'000);
  auto a1 = hal::open_can_bus("loop:truth-frame-a1", &clock);
  auto a2 = hal::open_can_bus("loop:truth-frame-a2", &clock);
  auto b1 = hal::open_can_bus("loop:truth-frame-b1", &clock);
  auto b2 = hal::open_can_bus("loop:truth-frame-b2", &clock);
  REQUIRE((a1 && a2 && b1 && b2));
  const std::array<hal::CanBus*, 2> a_buses{a1.bus.get(), a2.bus.get()};
  const std::array<hal::CanBus*, 2> b_buses{b1.bus.get(), b2.bus.get()};
  const sim::TruthMonitorConfig monitor{.period_s = 0.05, .clearance_margin_m = 0.5};
  sim::SiteSimulation live(site, a_buses, sim::SimConfig{}, monitor);
  sim::SiteSimulation copied(site, b_buses, sim::SimConfig{}, monitor);
  sim::TruthFrame frame = copied.make_frame();
  REQUIRE(frame.machines.size() == 2);
  CHECK(copied.monitor_period_s() == 0.05);
  int taken = 0;
  for (std::int64_t t = 1'000'000; t <= 2'000'000; t += 1'000) {
    clock.set_us(t);
    live.step(t);
    copied.step(t);
    copied.capture(frame);
    const bool a = live.sample();
    const bool b = copied.sample(frame);
    CHECK(a == b);
    taken += a ? 1 : 0;
  }
  CHECK(taken == 21);  // 0, 0.05, ..., 1.00 s
  for (std::size_t i = 0; i < 2; ++i) CHECK(copied.monitor(i)->summary_line() == live.monitor(i)->summary_line());
  CHECK(copied.referee()->summary_line() == live.referee()->summary_line());
}

TEST_CASE("the truth monitor refuses a negative period", "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  sim::TruthMonitorConfig config;
  config.period_s = -0.05;
  CHECK_THROWS_WITH(sim::TruthMonitor(scenario, config), Catch::Contains("truth monitor: the period"));
}

namespace {

//! The thesis crane's load and hook above its ground by hand: the boom tip stands
//! boom_foot_height + boom x sin(elevation) above the base plane (the boom pin is on the swing
//! axis), the cable hangs straight down from it, and the load hangs sling_length under the hook.
struct HandCrane {
  explicit HandCrane(const planning::Scenario& scenario) {
    const auto model = planning::build_model(scenario);
    boom_foot_height_m = dynamic_cast<const planning::MobileCrane&>(*model).geometry().boom_foot_height_m;
    sling_m = scenario.task->sling_length_m;
    load_height_m = scenario.task->load_size_m.z();
  }
  [[nodiscard]] double hook_m(const planning::JointVector& q) const {
    return boom_foot_height_m + q[2] * std::sin(q[1]) - q[3];
  }
  [[nodiscard]] double load_bottom_m(const planning::JointVector& q) const { return hook_m(q) - sling_m - load_height_m; }
  //! The cable length that puts the load's bottom at height_m. [m]
  [[nodiscard]] double cable_for_load_at(const planning::JointVector& q, double height_m) const {
    return boom_foot_height_m + q[2] * std::sin(q[1]) - sling_m - load_height_m - height_m;
  }
  double boom_foot_height_m = 0.0;
  double sling_m = 0.0;
  double load_height_m = 0.0;
};

constexpr double kDegToRad = std::numbers::pi / 180.0;

}  // namespace

TEST_CASE("a normal pose has positive ground clearance by hand and a chart utilisation read by hand below 1",
          "[unit][sim][truth]") {
  planning::Scenario scenario = load("thesis-steel-frame.yaml");
  REQUIRE(scenario.task.has_value());
  // The ground is the base's plane wherever the base stands: raised 1.5 m and turned, the load's
  // height is still measured from it.
  scenario.world_from_base = Eigen::Translation3d(5.0, -3.0, 1.5) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ());
  const HandCrane hand(scenario);
  sim::TruthMonitor monitor(scenario);
  REQUIRE(monitor.has_ground_clearance());
  REQUIRE(monitor.has_load_chart());
  CHECK(monitor.chart_load_lb() == 20000.0);

  // The start: boom 20 m at 50 deg, cable 14.82 m: the load 0.50 m above the ground.
  const planning::JointVector q = scenario.start;
  REQUIRE(q[1] == Approx(50.0 * kDegToRad));
  REQUIRE(q[2] == Approx(20.0));
  const sim::TruthSample& s = monitor.measure(4.0, q);
  CHECK(s.hook_ground_clearance_m == Approx(hand.hook_m(q)).margin(1e-9));
  CHECK(s.load_ground_clearance_m == Approx(hand.load_bottom_m(q)).margin(1e-9));
  CHECK(s.load_ground_clearance_m == Approx(0.50).margin(0.01));
  // The chart by hand (grove-tms870.yaml): 20 m = 65.6 ft reads the 70-ft row; 50 deg elevation is
  // 40 deg from vertical, and the row's first angle at or beyond it is 43.5 deg (45-ft radius),
  // rated 24,650 lb.
  CHECK(s.chart.in_chart);
  CHECK(s.chart.chart_row == 3);
  CHECK(s.chart.chart_column == 8);
  CHECK(s.chart.capacity_lb == 24650.0);
  CHECK(s.chart_utilisation == Approx(20000.0 / 24650.0).epsilon(1e-12));
  CHECK(s.chart_utilisation < 1.0);

  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples_below_ground == 0);
  CHECK(m.least_ground_clearance_m == Approx(hand.load_bottom_m(q)).margin(1e-9));
  CHECK(m.least_ground_clearance_t_s == 4.0);
  CHECK(m.least_hook_ground_clearance_m == Approx(hand.hook_m(q)).margin(1e-9));
  CHECK(m.samples_chart_exceeded == 0);
  CHECK(m.samples_outside_chart == 0);
  CHECK(m.peak_chart_utilisation == Approx(20000.0 / 24650.0).epsilon(1e-12));
  CHECK(m.peak_chart_utilisation_t_s == 4.0);
  CHECK_THAT(monitor.summary_line(),
             Catch::Contains("ground: least clearance 0.50 m at 4.00 s (load bottom), of the hook 3.50 m at 4.00 s, 0 samples below") &&
                 Catch::Contains("load chart: peak utilisation 81.1 % at 4.00 s (boom 20.00 m at 50.0 deg), 0 samples above "
                                 "100 %, 0 outside the chart"));
}

TEST_CASE("a load below the ground has a negative ground clearance and is counted, one set down on it is not",
          "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  const HandCrane hand(scenario);
  sim::TruthMonitor monitor(scenario);

  planning::JointVector on_ground = scenario.start;
  on_ground[3] = hand.cable_for_load_at(scenario.start, 0.0);
  planning::JointVector below = scenario.start;
  below[3] = hand.cable_for_load_at(scenario.start, -1.2);

  const sim::TruthSample& set_down = monitor.measure(1.0, on_ground);
  CHECK(set_down.load_ground_clearance_m == Approx(0.0).margin(1e-9));
  CHECK(monitor.summary().samples_below_ground == 0);

  const sim::TruthSample& sunk = monitor.measure(2.0, below);
  CHECK(sunk.load_ground_clearance_m == Approx(-1.2).margin(1e-9));
  CHECK(sunk.hook_ground_clearance_m == Approx(hand.hook_m(below)).margin(1e-9));
  (void)monitor.measure(3.0, scenario.start);
  (void)monitor.measure(4.0, below);  // a tie later keeps the first time

  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples == 4);
  CHECK(m.samples_below_ground == 2);
  CHECK(m.least_ground_clearance_m == Approx(-1.2).margin(1e-9));
  CHECK(m.least_ground_clearance_t_s == 2.0);
  CHECK(m.least_hook_ground_clearance_m == Approx(hand.hook_m(below)).margin(1e-9));
  CHECK(m.least_hook_ground_clearance_t_s == 2.0);
  CHECK_THAT(monitor.summary_line(), Catch::Contains("ground: least clearance -1.20 m at 2.00 s (load bottom)") &&
                                         Catch::Contains("2 samples below"));
}

TEST_CASE("a pose above the chart's capacity or outside the chart is counted, the peak kept with its time",
          "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  sim::TruthMonitor monitor(scenario);

  // 35 deg elevation is 55 deg from vertical: on the 70-ft row the first angle at or beyond it is
  // 58 deg (55-ft radius), rated 17,500 lb, under the 20,000 lb load.
  planning::JointVector heavy = scenario.start;
  heavy[1] = 35.0 * kDegToRad;
  // The boom lowered past horizontal: every row's last cell is 90 deg from vertical, so no cell
  // rates it.
  planning::JointVector below_horizontal = scenario.start;
  below_horizontal[1] = -2.0 * kDegToRad;
  // A boom longer than the chart's longest row (110 ft = 33.53 m).
  planning::JointVector too_long = scenario.start;
  too_long[2] = 34.0;

  const sim::TruthSample& over = monitor.measure(1.0, heavy);
  CHECK(over.chart.in_chart);
  CHECK(over.chart.capacity_lb == 17500.0);
  CHECK(over.chart_utilisation == Approx(20000.0 / 17500.0).epsilon(1e-12));
  CHECK(monitor.summary().samples_chart_exceeded == 1);
  CHECK(monitor.summary().samples_outside_chart == 0);
  CHECK(monitor.summary().peak_chart_utilisation == Approx(20000.0 / 17500.0).epsilon(1e-12));
  CHECK_THAT(monitor.summary_line(), Catch::Contains("peak utilisation 114.3 % at 1.00 s (boom 20.00 m at 35.0 deg)"));

  (void)monitor.measure(2.0, scenario.start);
  const sim::TruthSample& outside = monitor.measure(3.0, below_horizontal);
  CHECK_FALSE(outside.chart.in_chart);
  CHECK(std::isinf(outside.chart_utilisation));
  CHECK(outside.chart_utilisation > 0.0);
  const sim::TruthSample& long_boom = monitor.measure(4.0, too_long);
  CHECK_FALSE(long_boom.chart.in_chart);
  CHECK(std::isinf(long_boom.chart_utilisation));

  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples == 4);
  CHECK(m.samples_chart_exceeded == 3);  // outside the chart counts as exceeded too
  CHECK(m.samples_outside_chart == 2);
  CHECK(std::isinf(m.peak_chart_utilisation));
  CHECK(m.peak_chart_utilisation_t_s == 3.0);
  CHECK(m.peak_chart_elevation_rad == Approx(-2.0 * kDegToRad));
  CHECK_THAT(monitor.summary_line(), Catch::Contains("load chart: peak utilisation outside the chart at 3.00 s (boom 20.00 m "
                                                     "at -2.0 deg), 3 samples above 100 %, 2 outside the chart"));
}

TEST_CASE("a tower crane's load is measured against the ground without a chart, an excavator's bucket neither",
          "[unit][sim][truth]") {
  const planning::Scenario tower = load("thesis-steel-frame-tower.yaml");
  sim::TruthMonitor tower_monitor(tower);
  CHECK(tower_monitor.has_ground_clearance());
  CHECK_FALSE(tower_monitor.has_load_chart());
  // q = (slew, trolley radius, hook height above the base): the load hangs sling + height under it.
  planning::JointVector q = tower.start;
  q[2] = 1.0;
  const sim::TruthSample& s = tower_monitor.measure(1.0, q);
  CHECK(s.hook_ground_clearance_m == Approx(1.0).margin(1e-9));
  CHECK(s.load_ground_clearance_m == Approx(1.0 - tower.task->sling_length_m - tower.task->load_size_m.z()).margin(1e-9));
  CHECK(std::isnan(s.chart_utilisation));
  CHECK(tower_monitor.summary().samples_below_ground == 1);
  CHECK(tower_monitor.summary().samples_chart_exceeded == 0);
  CHECK_THAT(tower_monitor.summary_line(), Catch::Contains("1 samples below; load chart: n/a"));

  const planning::Scenario excavator = load("excavator-cycle.yaml");
  sim::TruthMonitor excavator_monitor(excavator);
  CHECK_FALSE(excavator_monitor.has_ground_clearance());
  CHECK_FALSE(excavator_monitor.has_load_chart());
  const sim::TruthSample& e = excavator_monitor.measure(1.0, excavator.start);
  CHECK(std::isnan(e.load_ground_clearance_m));
  CHECK(std::isnan(e.hook_ground_clearance_m));
  CHECK(std::isnan(e.chart_utilisation));
  CHECK(excavator_monitor.summary().samples_below_ground == 0);
  CHECK(std::isinf(excavator_monitor.summary().least_ground_clearance_m));
  CHECK_THAT(excavator_monitor.summary_line(), Catch::EndsWith("; ground: n/a; load chart: n/a"));
}

TEST_CASE("the truth monitor sees the simulated crane lower its load below the ground", "[unit][sim][truth]") {
  test::SimRig rig("thesis-steel-frame.yaml", test::SimRig::quiet_config(), "truth-ground");
  const HandCrane hand(rig.scenario);
  sim::TruthMonitor monitor(rig.scenario);
  rig.start();
  REQUIRE(rig.last->valve_active());
  // The load starts 0.5 m above the ground; paying the cable out at full speed for 4 s (2 s of
  // them accelerating) sinks it.
  rig.command[3] = rig.scenario.machine.joints[3].max_velocity;
  const std::int64_t end_us = rig.t_us + 4'000'000;
  planning::JointVector q(4);
  double least_by_hand_m = std::numeric_limits<double>::infinity();
  int below_by_hand = 0;
  int sampled = 0;
  while (rig.t_us < end_us) {
    rig.run(test::SimRig::kPhysicsUs);
    if (!monitor.sample(*rig.sim)) continue;
    for (int j = 0; j < 4; ++j) q[j] = rig.sim->truth().position[static_cast<std::size_t>(j)];
    CAPTURE(q.transpose());
    CHECK(monitor.last().load_ground_clearance_m == Approx(hand.load_bottom_m(q)).margin(1e-9));
    CHECK(monitor.last().hook_ground_clearance_m == Approx(hand.hook_m(q)).margin(1e-9));
    least_by_hand_m = std::min(least_by_hand_m, hand.load_bottom_m(q));
    below_by_hand += hand.load_bottom_m(q) < 0.0 ? 1 : 0;
    ++sampled;
  }
  REQUIRE(least_by_hand_m < -0.3);
  const sim::TruthSummary& m = monitor.summary();
  CHECK(m.samples == static_cast<std::uint64_t>(sampled));
  CHECK(m.samples_below_ground == static_cast<std::uint64_t>(below_by_hand));
  CHECK(below_by_hand > 0);
  CHECK(below_by_hand < sampled);
  CHECK(m.least_ground_clearance_m == Approx(least_by_hand_m).margin(1e-9));
  // Still sinking at the end: the least is the last sample's.
  CHECK(m.least_ground_clearance_t_s == monitor.last().t_s);
  // The chart does not change with the cable: the start's cell all along.
  CHECK(m.samples_chart_exceeded == 0);
  CHECK(m.peak_chart_utilisation == Approx(20000.0 / 24650.0).epsilon(1e-12));
}
