// SPDX-License-Identifier: Apache-2.0
// The default one-joint-at-a-time planner (axis-connect) and its re-planner (drrt-axis-connect).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/axis_connect.hpp"
#include "mgc/planning/planners/replanner.hpp"
#include "dense_recheck.hpp"
#include "planner_fixture.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::dense_recheck;
using mgc::test::Fixture;
using mgc::test::run;

namespace {

constexpr int kSwing = 0;
constexpr double kDeg = std::numbers::pi / 180.0;

const char* const kSites[] = {"thesis-steel-frame.yaml", "thesis-steel-frame-tower.yaml", "thesis-steel-frame-road.yaml",
                              "excavator-pipelines.yaml", "excavator-truck.yaml"};

//! Every edge moves exactly one joint, and no two edges in a row move the same one unless
//! together they turn it more than half a turn (one edge would go round the other way).
void check_one_joint_edges(const MachineModel& model, const std::vector<JointVector>& path) {
  int previous = -1;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    CAPTURE(e);
    const int j = moving_joint(model, path[e], path[e + 1]);
    REQUIRE(j >= 0);
    if (j == previous) {
      const double turn = model.difference(path[e - 1], path[e])[j] + model.difference(path[e], path[e + 1])[j];
      CHECK(model.joints()[static_cast<std::size_t>(j)].continuous);
      CHECK(std::abs(turn) >= std::numbers::pi);
    }
    previous = j;
  }
}

}  // namespace

TEST_CASE("axis-connect solves every shipped site, one joint per edge, densely valid", "[planner]") {
  for (const char* site : kSites) {
    for (std::uint64_t seed = 0; seed < 8; ++seed) {
      CAPTURE(site, seed);
      Fixture f(site, seed);
      AxisConnectPlanner planner;
      REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
      const std::vector<JointVector>& path = planner.path();
      dense_recheck(site, path);
      check_one_joint_edges(*f.loaded.model, path);
    }
  }
}

TEST_CASE("axis-connect is the default planner and make_planner knows it", "[planner]") {
  CHECK(kDefaultPlanner == "axis-connect");
  auto planner = make_planner(kDefaultPlanner);
  REQUIRE(planner);
  CHECK(planner->name() == "axis-connect");
  CHECK(make_replanner(kDefaultReplanner)->name() == "drrt-axis-connect");
}

TEST_CASE("axis-connect: the same seed gives the same path, whatever the slices", "[planner]") {
  for (const char* site : {"thesis-steel-frame.yaml", "excavator-pipelines.yaml"}) {
    CAPTURE(site);
    Fixture f(site, 3);
    AxisConnectPlanner whole;
    AxisConnectPlanner sliced;
    REQUIRE(run(whole, f.problem, 100000) == PlannerStatus::Solved);
    REQUIRE(run(sliced, f.problem, 1) == PlannerStatus::Solved);
    CHECK(whole.path() == sliced.path());
    CHECK(whole.stats().iterations == sliced.stats().iterations);
  }
  // Where neither direct staircase is taken the trees are random: the thesis lift from 20 deg
  // further round, where the long way is too slow to take without a search.
  Fixture f("thesis-steel-frame.yaml", 0);
  f.problem.start[kSwing] -= 20.0 * kDeg;
  std::vector<JointVector> first_nodes;
  std::vector<int> parents;
  AxisConnectPlanner first;
  REQUIRE(run(first, f.problem) == PlannerStatus::Solved);
  REQUIRE(first.stats().iterations > 1);
  first.tree(first_nodes, parents);
  int differ = 0;
  for (std::uint64_t seed = 1; seed < 6; ++seed) {
    f.problem.seed = seed;
    AxisConnectPlanner other;
    REQUIRE(run(other, f.problem) == PlannerStatus::Solved);
    std::vector<JointVector> nodes;
    other.tree(nodes, parents);
    differ += nodes != first_nodes ? 1 : 0;
  }
  CHECK(differ >= 1);
}

TEST_CASE("axis-connect turns the long way round at once when it is at most 1.3 times the short way's time", "[planner]") {
  // The thesis lift: 160 deg the short way through the frame, 200 deg the long way round the
  // west side at the same boom angle, 1.25 times as long.
  Fixture f("thesis-steel-frame.yaml", 0);
  const MachineModel& model = *f.loaded.model;
  AxisConnectPlanner planner;
  REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
  CHECK(planner.stats().iterations == 1);
  const std::vector<JointVector>& path = planner.path();
  dense_recheck("thesis-steel-frame.yaml", path);
  check_one_joint_edges(model, path);
  double swing_rad = 0.0;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) swing_rad += model.difference(path[e], path[e + 1])[kSwing];
  CHECK(std::abs(swing_rad) == Approx(200.0 * kDeg).margin(1e-9));
  const double short_way_s = compute_motion_metrics(model, {f.problem.start, f.problem.goal}).exec_time_sequential_s;
  CHECK(compute_motion_metrics(model, path).exec_time_sequential_s <= AxisConnectPlanner::kLongWayFactor * short_way_s);
}

TEST_CASE("axis-connect keeps a slower long way round and returns it when the search does worse or stops at its cap", "[planner]") {
  // From 20 deg further round the long way takes 220 / 140 = 1.57 times the short way's time:
  // not taken at once, but the searches' paths of the first seeds over the frame are slower.
  Fixture f("thesis-steel-frame.yaml", 0);
  const MachineModel& model = *f.loaded.model;
  f.problem.start[kSwing] -= 20.0 * kDeg;
  const double long_way_s = (220.0 * kDeg) / model.joints()[kSwing].max_velocity;
  for (std::uint64_t seed = 0; seed < 6; ++seed) {
    CAPTURE(seed);
    f.problem.seed = seed;
    AxisConnectPlanner planner;
    REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
    CHECK(planner.stats().iterations > 1);
    CHECK(compute_motion_metrics(model, planner.path()).exec_time_sequential_s <= long_way_s + 1e-9);
  }
  PlanningProblem capped = f.problem;
  capped.max_iterations = 1;
  AxisConnectPlanner planner;
  REQUIRE(run(planner, capped) == PlannerStatus::Solved);
  CHECK(compute_motion_metrics(model, planner.path()).exec_time_sequential_s == Approx(long_way_s).epsilon(1e-9));
  CHECK(planner.path().front() == capped.start);
  CHECK(planner.path().back() == capped.goal);
  dense_recheck("thesis-steel-frame.yaml", planner.path(), false);
}

TEST_CASE("axis-connect's shortening never lengthens one-joint-at-a-time execution", "[planner]") {
  for (const char* site : kSites) {
    for (std::uint64_t seed = 0; seed < 4; ++seed) {
      CAPTURE(site, seed);
      Fixture f(site, seed);
      AxisConnectPlanner raw(24, false);
      AxisConnectPlanner shortened(24, true);
      REQUIRE(run(raw, f.problem) == PlannerStatus::Solved);
      REQUIRE(run(shortened, f.problem) == PlannerStatus::Solved);
      check_one_joint_edges(*f.loaded.model, raw.path());
      const PathMetrics r = compute_path_metrics(*f.loaded.model, *f.loaded.world, raw.path(), f.problem.step);
      const PathMetrics s = compute_path_metrics(*f.loaded.model, *f.loaded.world, shortened.path(), f.problem.step);
      CHECK(s.exec_time_sequential_s <= r.exec_time_sequential_s + 1e-9);
      CHECK(s.path_nodes <= r.path_nodes);
    }
  }
}

TEST_CASE("axis-connect refuses an invalid start or goal and stops at its cap", "[planner]") {
  Fixture f("thesis-steel-frame.yaml");
  AxisConnectPlanner planner;
  PlanningProblem p = f.problem;
  p.start[1] = 2.0;  // boom elevation beyond its range
  CHECK(planner.reset(p) == PlannerStatus::InvalidStart);
  p = f.problem;
  p.goal[1] = 2.0;
  CHECK(planner.reset(p) == PlannerStatus::InvalidGoal);
  // One iteration is the direct staircase both ways round: the frame blocks the short way, and a
  // wall west of the crane, from the ground to 100 m, the long way.
  Scenario walled = io::load_scenario(mgc::test::source_path("scenarios/thesis-steel-frame.yaml"));
  StaticObstacle wall;
  wall.name = "west-wall";
  wall.shape.size_m = Eigen::Vector3d(62.0, 0.5, 100.0);
  wall.shape.pose.translation() = Eigen::Vector3d(-39.0, 0.0, 50.0);
  walled.obstacles.push_back(wall);
  const auto model = build_model(walled);
  const auto world = build_world(walled, *model);
  p = planning_problem(walled, *model, *world);
  p.max_iterations = 1;
  CHECK(run(planner, p) == PlannerStatus::IterationLimit);
}
