// SPDX-License-Identifier: Apache-2.0
// The truth monitor against measurements made here on a world and an envelope of our own: the
// clearance it reports, the envelope distance and the count outside, the minima with their times,
// and the sampling period when it watches the simulator.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include "sim_rig.hpp"

#include "mgc/guidance/envelope.hpp"
#include "mgc/sim/truth_monitor.hpp"

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

TEST_CASE("the truth monitor refuses a negative period", "[unit][sim][truth]") {
  const planning::Scenario scenario = load("thesis-steel-frame.yaml");
  sim::TruthMonitorConfig config;
  config.period_s = -0.05;
  CHECK_THROWS_WITH(sim::TruthMonitor(scenario, config), Catch::Contains("truth monitor: the period"));
}
