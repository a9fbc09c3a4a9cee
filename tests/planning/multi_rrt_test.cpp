// SPDX-License-Identifier: Apache-2.0
// Seed 004's multiple-RRT on the paper's three scenarios, and the framework's rrt-connect on the same
// six-joint problem; every returned path re-checked densely in a fresh world.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "mgc/planning/dual_crane.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/multi_rrt.hpp"
#include "planner_fixture.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::Fixture;
using mgc::test::run;

namespace {

constexpr const char* kKimScenarios[] = {"kim-s1.yaml", "kim-s2.yaml", "kim-s3.yaml"};

// A fresh model and world (not the planner's) whose anchors may move an eighth of the planner's
// anchor step between samples, every joint at a quarter of its step; exact start and goal.
void dense_recheck_dual(const std::string& scenario, const std::vector<JointVector>& path) {
  Scenario s = io::load_scenario(mgc::test::source_path("scenarios/" + scenario));
  REQUIRE(s.dual_crane);
  s.dual_crane->anchor_step_m /= 8.0;
  const auto model = build_model(s);
  const auto world = build_world(s, *model);
  const JointVector fine = step_sizes(*model, 4 * s.planner.space_resolution);
  REQUIRE(path.size() >= 2);
  CHECK(path.front() == s.start);
  CHECK(path.back() == s.goal);
  CHECK(world->validate(path.front()).valid());
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const Validity v = world->validate_edge(path[e], path[e + 1], fine);
    CAPTURE(scenario, e, world->describe(v));
    REQUIRE(v.valid());
  }
}

double length(const MachineModel& model, const JointVector& step, const std::vector<JointVector>& path) {
  double sum = 0.0;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) sum += step_metric(model, step, path[e], path[e + 1]);
  return sum;
}

}  // namespace

TEST_CASE("multi-rrt solves the three Kim scenarios, every path densely valid, smoothing never lengthens", "[planner]") {
  int merged_runs = 0;
  for (const char* scenario : kKimScenarios) {
    for (std::uint64_t seed = 0; seed < 4; ++seed) {
      CAPTURE(scenario, seed);
      Fixture f(scenario, seed);
      MultiRrtPlanner planner;
      REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
      CHECK(planner.phase() == MultiRrtPlanner::Phase::Done);
      dense_recheck_dual(scenario, planner.path());
      CHECK(length(*f.loaded.model, f.problem.step, planner.path()) <=
            length(*f.loaded.model, f.problem.step, planner.raw_path()) + 1e-9);
      // Start and goal share a tree; trees that joined it are gone.
      CHECK(planner.trees_alive() <= planner.trees_created() - 1);
      if (planner.trees_created() > 2 && planner.trees_alive() < planner.trees_created() - 1) ++merged_runs;
    }
  }
  // The runs above grow and merge extra trees (the new-tree and merge paths are exercised).
  CHECK(merged_runs > 0);
}

TEST_CASE("multi-rrt: the same seed gives the same path, another seed another", "[planner]") {
  Fixture a("kim-s2.yaml", 3);
  Fixture b("kim-s2.yaml", 3);
  Fixture c("kim-s2.yaml", 4);
  MultiRrtPlanner pa;
  MultiRrtPlanner pb;
  MultiRrtPlanner pc;
  REQUIRE(run(pa, a.problem, 1) == PlannerStatus::Solved);
  REQUIRE(run(pb, b.problem, 1000) == PlannerStatus::Solved);
  REQUIRE(run(pc, c.problem) == PlannerStatus::Solved);
  CHECK(pa.path() == pb.path());
  CHECK(pa.stats().iterations == pb.stats().iterations);
  CHECK(pa.path() != pc.path());
}

TEST_CASE("multi-rrt: growth and smoothing come in separate slices, no smoothing keeps the raw path", "[planner]") {
  Fixture f("kim-s1.yaml", 1);
  MultiRrtPlanner planner;
  PlannerStatus status = planner.reset(f.problem);
  while (status == PlannerStatus::Running && planner.phase() == MultiRrtPlanner::Phase::Growing) status = planner.step(1000);
  CHECK(status == PlannerStatus::Running);
  CHECK(planner.phase() == MultiRrtPlanner::Phase::Smoothing);
  const int iterations = planner.stats().iterations;
  CHECK(planner.step(5) == PlannerStatus::Running);
  CHECK(planner.step(1000) == PlannerStatus::Solved);
  CHECK(planner.stats().iterations == iterations);

  MultiRrtPlanner::Options options;
  options.smoothing_passes = 0;
  MultiRrtPlanner raw(options);
  REQUIRE(run(raw, f.problem) == PlannerStatus::Solved);
  CHECK(raw.path() == raw.raw_path());
  CHECK(raw.path() == planner.raw_path());
}

TEST_CASE("multi-rrt reports an infeasible goal and a spent budget", "[planner]") {
  Fixture f("kim-s3.yaml");
  f.problem.goal[DualCraneModel::kSwing2] = 130.0 * mgc::test::kDeg;  // Table 1 as printed
  MultiRrtPlanner planner;
  CHECK(planner.reset(f.problem) == PlannerStatus::InvalidGoal);

  Fixture g("kim-s3.yaml");
  g.problem.max_iterations = 1;
  MultiRrtPlanner once;
  const PlannerStatus status = run(once, g.problem);
  CHECK(status == PlannerStatus::IterationLimit);
  CHECK(once.stats().iterations == 1);
}

TEST_CASE("rrt-connect runs unchanged on the six-joint problem, its paths are densely valid", "[planner]") {
  for (const char* scenario : {"kim-s1.yaml", "kim-s2.yaml"}) {
    CAPTURE(scenario);
    Fixture f(scenario, 2);
    auto planner = make_planner("rrt-connect");
    REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
    dense_recheck_dual(scenario, planner->path());
  }
  auto multi = make_planner("multi-rrt");
  REQUIRE(multi != nullptr);
  CHECK(multi->name() == "multi-rrt");
}
