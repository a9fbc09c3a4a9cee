// SPDX-License-Identifier: Apache-2.0
// The default one-joint-at-a-time planner (axis-connect) and its re-planner (drrt-axis-connect).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

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
  // Where the direct staircase is blocked the trees are random, and so are their paths.
  Fixture f("thesis-steel-frame.yaml", 0);
  AxisConnectPlanner first;
  REQUIRE(run(first, f.problem) == PlannerStatus::Solved);
  int differ = 0;
  for (std::uint64_t seed = 1; seed < 6; ++seed) {
    f.problem.seed = seed;
    AxisConnectPlanner other;
    REQUIRE(run(other, f.problem) == PlannerStatus::Solved);
    differ += other.path() != first.path() ? 1 : 0;
  }
  CHECK(differ >= 1);
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
  // One iteration is the direct staircase, which the frame blocks.
  p = f.problem;
  p.max_iterations = 1;
  CHECK(run(planner, p) == PlannerStatus::IterationLimit);
}
