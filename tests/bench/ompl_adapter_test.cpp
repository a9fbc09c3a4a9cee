// SPDX-License-Identifier: Apache-2.0
// The OMPL adapter plans with our checks and our metric: its paths pass the same independent
// dense re-check as our planners' paths, its edges are no longer than the range in steps, and a
// seed repeats a run.
#include <catch2/catch.hpp>

#include "../planning/dense_recheck.hpp"
#include "../planning/planner_fixture.hpp"
#include "ompl_adapter.hpp"

namespace {

using namespace mgc::planning;
using mgc::bench::OmplOptions;
using mgc::bench::OmplPlanner;
using mgc::bench::solve_with_ompl;

constexpr const char* kScenario = "thesis-steel-frame.yaml";

}  // namespace

TEST_CASE("OMPL RRTConnect solves the thesis scenario through the adapter, raw and simplified paths pass the dense re-check") {
  mgc::test::Fixture f(kScenario);
  // The straight line swings the load through the frame: a solver that ignored our checks would
  // return it.
  REQUIRE_FALSE(f.loaded.world->validate_edge(f.problem.start, f.problem.goal, f.problem.step).valid());
  OmplOptions options;
  options.time_limit_s = 10.0;
  for (const std::uint64_t seed : {0u, 1u, 2u}) {
    CAPTURE(seed);
    const auto result = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, seed);
    REQUIRE(result.solved);
    CHECK(result.error.empty());
    CHECK(result.path.size() > 2);
    CHECK(result.tree_nodes >= static_cast<int>(result.path.size()));
    mgc::test::dense_recheck(kScenario, result.path);
    mgc::test::dense_recheck(kScenario, result.simplified);
    CHECK(result.simplified.size() <= result.path.size());
  }
}

TEST_CASE("OMPL measures with our step metric: no RRTConnect edge is longer than the range in steps") {
  mgc::test::Fixture f(kScenario);
  OmplOptions options;
  options.time_limit_s = 10.0;
  options.range_steps = 3.0;
  const auto result = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 4);
  REQUIRE(result.solved);
  // In rad and m, 3 would be dozens of swing steps (a step is pi / 50 rad).
  for (std::size_t e = 0; e + 1 < result.path.size(); ++e) {
    CAPTURE(e);
    CHECK(step_metric(*f.loaded.model, f.problem.step, result.path[e], result.path[e + 1]) <= 3.0 + 1e-9);
  }
}

TEST_CASE("OMPL RRT and BIT* solve the thesis scenario through the adapter and pass the dense re-check") {
  mgc::test::Fixture f(kScenario);
  OmplOptions options;
  options.time_limit_s = 10.0;
  for (const OmplPlanner planner : {OmplPlanner::Rrt, OmplPlanner::BitStar}) {
    CAPTURE(mgc::bench::ompl_planner_name(planner));
    const auto result = solve_with_ompl(f.problem, planner, options, 0);
    REQUIRE(result.solved);
    CHECK(result.error.empty());
    mgc::test::dense_recheck(kScenario, result.path);
    mgc::test::dense_recheck(kScenario, result.simplified);
  }
}

TEST_CASE("An OMPL run repeats for a seed and differs for another") {
  mgc::test::Fixture f(kScenario);
  OmplOptions options;
  options.time_limit_s = 10.0;
  const auto a = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 7);
  const auto b = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 7);
  const auto c = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 8);
  REQUIRE(a.solved);
  REQUIRE(b.solved);
  REQUIRE(c.solved);
  CHECK(a.path == b.path);
  CHECK(a.simplified == b.simplified);
  CHECK(a.path != c.path);
}

TEST_CASE("OMPL without simplification returns the same raw path and no simplified one") {
  mgc::test::Fixture f(kScenario);
  OmplOptions options;
  options.time_limit_s = 10.0;
  const auto full = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 6);
  options.simplify = false;
  const auto raw_only = solve_with_ompl(f.problem, OmplPlanner::RrtConnect, options, 6);
  REQUIRE(full.solved);
  REQUIRE(raw_only.solved);
  CHECK(raw_only.path == full.path);
  CHECK_FALSE(full.simplified.empty());
  CHECK(raw_only.simplified.empty());
  CHECK(raw_only.simplify_ms == 0.0);
}
