// SPDX-License-Identifier: Apache-2.0
// Seed 002's cart-RRT: Cartesian edges tracked by differential IK, shortcutting, and the
// uniformly time-scaled cubic spline.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dense_recheck.hpp"
#include "mgc/planning/excavator.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/cart_rrt.hpp"
#include "mgc/planning/spline_trajectory.hpp"
#include "mgc/planning/tower_crane.hpp"
#include "planner_fixture.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::dense_recheck;
using mgc::test::Fixture;
using mgc::test::kDeg;
using mgc::test::kScenarios;
using mgc::test::run;

namespace {

Eigen::Vector3d tool_point(const MachineModel& model, const JointVector& q) {
  Kinematics k;
  model.forward_kinematics(q, k);
  const int tool = model.key_point_index(model.kind() == MachineKind::Excavator ? "bucket_tip" : "hook");
  return k.points[static_cast<std::size_t>(tool)];
}

// Samples the trajectory every dt_s and checks every joint against its velocity and
// acceleration limits; returns the largest share of a limit used (1 when k_tau is tight).
double check_limits(const MachineModel& model, const SplineTrajectory& trajectory, int samples) {
  double used = 0.0;
  for (int i = 0; i <= samples; ++i) {
    const double t = trajectory.duration_s() * i / samples;
    const JointVector v = trajectory.velocity(t);
    const JointVector a = trajectory.acceleration(t);
    for (int j = 0; j < model.dof(); ++j) {
      const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
      CAPTURE(t, j, v[j], a[j]);
      REQUIRE(std::abs(v[j]) <= spec.max_velocity * (1 + 1e-9));
      REQUIRE(std::abs(a[j]) <= spec.max_acceleration * (1 + 1e-9));
      used = std::max({used, std::abs(v[j]) / spec.max_velocity, std::abs(a[j]) / spec.max_acceleration});
    }
  }
  return used;
}

// The trajectory itself as a list of configurations, exact start and goal at the ends.
std::vector<JointVector> sample_trajectory(const SplineTrajectory& trajectory, const JointVector& start,
                                           const JointVector& goal, int samples) {
  std::vector<JointVector> out{start};
  for (int i = 1; i < samples; ++i) out.push_back(trajectory.position(trajectory.duration_s() * i / samples));
  out.push_back(goal);
  return out;
}

TowerCrane make_tower() {
  return TowerCrane("tower", default_tower_crane_joints(), TowerCraneGeometry{}, TowerLiftTask{}, Eigen::Isometry3d::Identity());
}

JointVector tower_q(double slew_rad, double trolley_m, double hook_m) {
  JointVector q(3);
  q << slew_rad, trolley_m, hook_m;
  return q;
}

}  // namespace

TEST_CASE("spline: a single rest-to-rest move is the cubic 3s^2 - 2s^3, scaled to its binding limit", "[unit]") {
  const TowerCrane model = make_tower();
  const JointSpec& trolley = model.joints()[TowerCrane::kTrolleyRadius];
  SplineTrajectory trajectory;
  trajectory.reserve(8);
  for (const double delta_m : {0.5, 20.0}) {
    CAPTURE(delta_m);
    const std::vector<JointVector> vias{tower_q(0.3, 10.0, 5.0), tower_q(0.3, 10.0 + delta_m, 5.0)};
    REQUIRE(trajectory.fit(model, vias, SplineTrajectory::Shape::Spline));
    // q' peaks at 1.5 delta (s = 1/2), q'' at 6 delta (s = 0, 1), in virtual time.
    const double expected_s = std::max(1.5 * delta_m / trolley.max_velocity, std::sqrt(6 * delta_m / trolley.max_acceleration));
    CHECK(trajectory.duration_s() == Approx(expected_s).epsilon(1e-12));
    CHECK(trajectory.position(0.5 * expected_s)[1] == Approx(10.0 + 0.5 * delta_m).epsilon(1e-12));
    CHECK(trajectory.velocity(0.0).norm() == Approx(0.0).margin(1e-12));
    CHECK(trajectory.velocity(expected_s).norm() == Approx(0.0).margin(1e-12));
    CHECK(check_limits(model, trajectory, 2000) == Approx(1.0).epsilon(1e-6));
  }
  // A short move is bound by acceleration, a long one by velocity.
  CHECK(std::sqrt(6 * 0.5 / trolley.max_acceleration) > 1.5 * 0.5 / trolley.max_velocity);
  CHECK(1.5 * 20.0 / trolley.max_velocity > std::sqrt(6 * 20.0 / trolley.max_acceleration));
}

TEST_CASE("spline: through the vias, C2, at rest at both ends, within limits and tight", "[unit]") {
  const TowerCrane model = make_tower();
  // The slew crosses +-pi: the spline must take the short way round.
  const std::vector<JointVector> vias{tower_q(170 * kDeg, 10, 5), tower_q(-175 * kDeg, 14, 9), tower_q(-160 * kDeg, 20, 9),
                                      tower_q(-150 * kDeg, 22, 15), tower_q(-120 * kDeg, 12, 20)};
  SplineTrajectory trajectory;
  trajectory.reserve(vias.size());
  REQUIRE(trajectory.fit(model, vias, SplineTrajectory::Shape::Spline));
  REQUIRE(trajectory.knots() == vias.size());
  const double t_end = trajectory.duration_s();
  for (std::size_t i = 0; i < vias.size(); ++i) {
    CAPTURE(i);
    const double t = trajectory.knot_tau(i) * t_end;
    CHECK(model.difference(trajectory.position(t), vias[i]).norm() == Approx(0.0).margin(1e-9));
    if (i == 0 || i + 1 == vias.size()) continue;
    // Velocity and acceleration agree from both sides of an inner knot.
    constexpr double kEps = 1e-7;
    CHECK((trajectory.velocity(t - kEps) - trajectory.velocity(t + kEps)).norm() == Approx(0.0).margin(1e-6));
    CHECK((trajectory.acceleration(t - kEps) - trajectory.acceleration(t + kEps)).norm() == Approx(0.0).margin(1e-6));
  }
  CHECK(trajectory.velocity(0.0).norm() == Approx(0.0).margin(1e-12));
  CHECK(trajectory.velocity(t_end).norm() == Approx(0.0).margin(1e-12));
  // The slew never goes the long way: it stays within [170, 240] deg, unwrapped.
  for (int i = 0; i <= 1000; ++i) {
    const double slew = trajectory.position(t_end * i / 1000)[0];
    CHECK((slew >= 160 * kDeg || slew <= -110 * kDeg));
  }
  // k_tau is the smallest uniform scaling: some joint reaches a limit.
  CHECK(check_limits(model, trajectory, 20000) == Approx(1.0).epsilon(1e-3));
  // Finite differences of the positions agree with the analytic velocity.
  for (int i = 1; i < 100; ++i) {
    const double t = t_end * i / 100;
    constexpr double kDt = 1e-4;
    const JointVector fd = model.difference(trajectory.position(t - kDt), trajectory.position(t + kDt)) / (2 * kDt);
    CHECK((fd - trajectory.velocity(t)).norm() == Approx(0.0).margin(1e-6));
  }
}

TEST_CASE("spline: stop-at-vias runs along the straight edges and rests at every via", "[unit]") {
  const TowerCrane model = make_tower();
  const std::vector<JointVector> vias{tower_q(0, 10, 5), tower_q(0.5, 14, 9), tower_q(0.5, 20, 9)};
  SplineTrajectory trajectory;
  trajectory.reserve(vias.size());
  REQUIRE(trajectory.fit(model, vias, SplineTrajectory::Shape::StopAtVias));
  const double t1 = trajectory.knot_tau(1) * trajectory.duration_s();
  CHECK(trajectory.velocity(t1).norm() == Approx(0.0).margin(1e-12));
  for (int i = 0; i <= 100; ++i) {
    const JointVector q = trajectory.position(t1 * i / 100);
    const double s = (q[1] - 10.0) / 4.0;  // share of the first edge done
    CHECK(q[0] == Approx(0.5 * s).margin(1e-12));
    CHECK(q[2] == Approx(5.0 + 4.0 * s).margin(1e-12));
  }
  check_limits(model, trajectory, 2000);
  // Too many vias for the reserved room, or a single distinct one, is refused.
  SplineTrajectory small;
  small.reserve(2);
  CHECK_FALSE(small.fit(model, vias, SplineTrajectory::Shape::Spline));
  const std::vector<JointVector> same{vias[0], vias[0]};
  CHECK_FALSE(small.fit(model, same, SplineTrajectory::Shape::Spline));
}

TEST_CASE("cart-rrt: the central-difference Jacobian matches the tower crane's and excavator's analytic ones", "[oracle]") {
  Fixture f("thesis-steel-frame-tower.yaml");
  CartRrtPlanner planner;
  REQUIRE(planner.reset(f.problem) == PlannerStatus::Running);
  Eigen::Matrix<double, 4, mgc::kMaxJoints> jac;
  for (const JointVector& q : {tower_q(0.3, 15, 10), tower_q(-2.5, 40, 30), tower_q(3.0, 5, 2)}) {
    // Hook = (r cos s, r sin s, h) with the base at the origin.
    const double s = q[0];
    const double r = q[1];
    planner.jacobian(q, jac);
    Eigen::Matrix<double, 4, 3> expected;
    expected << -r * std::sin(s), std::cos(s), 0, r * std::cos(s), std::sin(s), 0, 0, 0, 1, 0, 0, 0;
    CAPTURE(q.transpose(), jac.leftCols(3));
    CHECK((jac.leftCols(3) - expected).norm() < 1e-6);
  }
  // The excavator's fourth task row is the bucket's ground angle, boom + arm + bucket.
  Fixture e("excavator-pipelines.yaml");
  REQUIRE(planner.reset(e.problem) == PlannerStatus::Running);
  planner.jacobian(e.problem.start, jac);
  CHECK(jac(3, Excavator::kSwing) == Approx(0.0).margin(1e-9));
  for (const int j : {Excavator::kBoom, Excavator::kArm, Excavator::kBucket}) CHECK(jac(3, j) == Approx(1.0).epsilon(1e-9));
  // The tip moves tangentially under swing: |d tip / d swing| is its radius from the axis.
  const Eigen::Vector3d tip = tool_point(*e.loaded.model, e.problem.start);
  CHECK(jac.col(Excavator::kSwing).head<3>().norm() == Approx(tip.head<2>().norm()).epsilon(1e-6));
}

TEST_CASE("cart-rrt solves every shipped scenario, path, waypoints and the trajectory itself densely valid", "[planner]") {
  for (const char* scenario : kScenarios) {
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      CAPTURE(scenario, seed);
      Fixture f(scenario, seed);
      CartRrtPlanner planner;
      REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
      dense_recheck(scenario, planner.path());
      dense_recheck(scenario, planner.waypoints());
      const auto& r = planner.report();
      CHECK(r.waypoints == static_cast<int>(planner.waypoints().size()));
      CHECK(r.tool_length_m <= r.raw_tool_length_m + 1e-9);
      CHECK(r.waypoints <= r.raw_nodes);
      CHECK_FALSE(r.stops_at_vias);
      // The trajectory starts and ends on the exact start and goal, at rest, within the limits.
      const SplineTrajectory& trajectory = planner.trajectory();
      const MachineModel& model = *f.loaded.model;
      REQUIRE(trajectory.duration_s() > 0.0);
      CHECK(r.duration_s == trajectory.duration_s());
      CHECK(model.difference(trajectory.position(0.0), f.problem.start).norm() < 1e-9);
      CHECK(model.difference(trajectory.position(trajectory.duration_s()), f.problem.goal).norm() < 1e-9);
      CHECK(check_limits(model, trajectory, 5000) == Approx(1.0).epsilon(1e-2));
      dense_recheck(scenario, sample_trajectory(trajectory, f.problem.start, f.problem.goal, 3000));
      // Every configuration of path() lies on the trajectory's course: it is within the tracked
      // joint step of some dense sample.
      std::vector<JointVector> dense = sample_trajectory(trajectory, f.problem.start, f.problem.goal, 20000);
      std::size_t cursor = 0;
      for (const JointVector& q : planner.path()) {
        const auto close = [&](const JointVector& s) {
          const JointVector d = model.difference(s, q);
          for (int j = 0; j < model.dof(); ++j) {
            if (std::abs(d[j]) > 0.05 * f.problem.step[j]) return false;
          }
          return true;
        };
        while (cursor < dense.size() && !close(dense[cursor])) ++cursor;
        CAPTURE(q.transpose());
        REQUIRE(cursor < dense.size());
      }
    }
  }
}

TEST_CASE("cart-rrt: an open straight move is one tracked Cartesian line", "[planner]") {
  // Tower crane, from the scenario's start up and out by 6.7 m of hook travel: the goal region
  // holds the start, so the first iteration tracks the line to the goal.
  Fixture f("thesis-steel-frame-tower.yaml");
  f.problem.goal = tower_q(80 * kDeg, 20, 8);
  REQUIRE(f.loaded.world->validate(f.problem.goal).valid());
  CartRrtPlanner planner;
  REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
  const MachineModel& model = *f.loaded.model;
  const Eigen::Vector3d a = tool_point(model, f.problem.start);
  const Eigen::Vector3d b = tool_point(model, f.problem.goal);
  REQUIRE((b - a).norm() <= planner.max_length_m());
  CHECK(planner.stats().tree_nodes == static_cast<int>(planner.report().raw_nodes));
  const auto& waypoints = planner.waypoints();
  REQUIRE(waypoints.size() >= 3);
  double progress = -1.0;
  for (const JointVector& q : waypoints) {
    const Eigen::Vector3d p = tool_point(model, q);
    const double s = (p - a).dot(b - a) / (b - a).squaredNorm();
    CAPTURE(q.transpose(), s);
    CHECK((a + s * (b - a) - p).norm() < 2e-3);  // on the line, to the tracking tolerance
    CHECK(s > progress);                         // and moving along it
    progress = s;
  }
  // Straight in task space means curved in joint space: the slew and the trolley do not move in
  // proportion, so this is not the straight joint-space edge.
  CHECK(planner.report().raw_tool_length_m == Approx((b - a).norm()).epsilon(1e-3));
}

TEST_CASE("cart-rrt: the excavator keeps the bucket's ground angle when start and goal share it", "[planner]") {
  for (std::uint64_t seed = 0; seed < 3; ++seed) {
    CAPTURE(seed);
    Fixture f("excavator-pipelines.yaml", seed);
    CartRrtPlanner planner;
    REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
    // Tracked to 0.1 mrad at every node; the spline through them stays as close.
    for (const JointVector& q : planner.waypoints()) CHECK(bucket_ground_angle_rad(q) == Approx(-180 * kDeg).margin(2e-4));
    for (const JointVector& q : planner.path()) CHECK(bucket_ground_angle_rad(q) == Approx(-180 * kDeg).margin(1e-3));
  }
}

TEST_CASE("cart-rrt: the mobile crane's redundant joints reach the goal's along the way", "[planner]") {
  // Same hook height and nearly the same radius, but 4 m more boom: a goal the hook reaches with
  // the start's boom too. The null-space pull telescopes on the way, so no edge -- the closing
  // one at the goal included -- moves a joint more than a tracked edge may (3 steps).
  Fixture f("thesis-steel-frame.yaml");
  JointVector goal = f.problem.start;
  goal[0] = 60 * kDeg;
  goal[1] = 55 * kDeg;
  goal[2] = 24.0;
  goal[3] = 3.0 + 24.0 * std::sin(55 * kDeg) - 3.5;
  f.problem.goal = goal;
  REQUIRE(f.loaded.world->validate(goal).valid());
  for (std::uint64_t seed = 0; seed < 3; ++seed) {
    CAPTURE(seed);
    f.problem.seed = seed;
    CartRrtPlanner planner;
    REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
    const auto& waypoints = planner.waypoints();
    for (std::size_t e = 0; e + 1 < waypoints.size(); ++e) {
      const JointVector d = f.loaded.model->difference(waypoints[e], waypoints[e + 1]);
      for (int j = 0; j < 4; ++j) {
        CAPTURE(e, j, d[j]);
        CHECK(std::abs(d[j]) <= 3.0 * f.problem.step[j] + 1e-12);
      }
    }
    CHECK(waypoints.back() == goal);
  }
}

TEST_CASE("cart-rrt: same seed, same path bit for bit, slicing does not change it", "[planner]") {
  for (const char* scenario : kScenarios) {
    CAPTURE(scenario);
    Fixture a(scenario, 7);
    Fixture b(scenario, 7);
    CartRrtPlanner pa;
    CartRrtPlanner pb;
    REQUIRE(run(pa, a.problem, 1000) == PlannerStatus::Solved);
    REQUIRE(run(pb, b.problem, 1) == PlannerStatus::Solved);
    CHECK(pa.path() == pb.path());
    CHECK(pa.waypoints() == pb.waypoints());
    CHECK(pa.stats().iterations == pb.stats().iterations);
    CHECK(pa.trajectory().duration_s() == pb.trajectory().duration_s());
    Fixture c(scenario, 8);
    CartRrtPlanner pc;
    REQUIRE(run(pc, c.problem) == PlannerStatus::Solved);
    CHECK(pa.path() != pc.path());
  }
}

TEST_CASE("cart-rrt errors: invalid start or goal, exhausted pool, iteration limit, not reset", "[planner]") {
  Fixture f("thesis-steel-frame.yaml");
  CartRrtPlanner planner;
  SECTION("step before reset") { CHECK(planner.step(10) == PlannerStatus::NotReset); }
  SECTION("goal in collision") {
    f.problem.goal[0] = 10 * kDeg;  // load swung into the frame
    CHECK(planner.reset(f.problem) == PlannerStatus::InvalidGoal);
    CHECK(planner.step(10) == PlannerStatus::InvalidGoal);
  }
  SECTION("start outside the joint range") {
    f.problem.start[2] = 40.0;
    CHECK(planner.reset(f.problem) == PlannerStatus::InvalidStart);
  }
  SECTION("the pool is sized at reset and never grows") {
    f.problem.node_capacity = 30;
    CHECK(run(planner, f.problem) == PlannerStatus::PoolExhausted);
    CHECK(planner.stats().tree_nodes <= 30);
    CHECK(planner.path().empty());
  }
  SECTION("iteration limit") {
    f.problem.max_iterations = 2;
    CHECK(run(planner, f.problem) == PlannerStatus::IterationLimit);
    CHECK(planner.stats().iterations == 2);
  }
  CHECK(make_planner("cart-rrt") != nullptr);
  CHECK(make_planner("cart-rrt")->name() == "cart-rrt");
}
