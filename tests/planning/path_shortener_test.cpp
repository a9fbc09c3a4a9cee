// SPDX-License-Identifier: Apache-2.0
// The in-loop path shortener (planning/path_shortener.hpp): raw RRT paths on the thesis site made
// shorter, every shortened path re-checked densely in an independent world, without allocating.
#include <catch2/catch.hpp>

#include "allocation_counter.hpp"
#include "dense_recheck.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/path_shortener.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "test_support.hpp"

using namespace mgc::planning;

namespace {

constexpr const char* kScenario = "thesis-steel-frame.yaml";

struct Shortened {
  std::vector<JointVector> path;
  std::vector<int> source;
  long allocations = 0;
  int slices = 0;
};

Shortened shorten(CollisionWorld& world, const JointVector* prefix, const std::vector<JointVector>& path, const JointVector& step,
                  std::size_t first) {
  PathShortener shortener(world.model().dof(), 1024);
  Shortened out;
  const long before = mgc::test::allocation_count();
  PathShortener::Status s = shortener.begin(world, prefix, path, step, first, true);
  while (s == PathShortener::Status::Running && out.slices < 1'000'000) {
    s = shortener.step(3);
    ++out.slices;
  }
  out.allocations = mgc::test::allocation_count() - before;
  REQUIRE(s == PathShortener::Status::Done);
  REQUIRE_FALSE(shortener.truncated());
  for (std::size_t i = 0; i < shortener.size(); ++i) {
    out.path.push_back(shortener[i]);
    out.source.push_back(shortener.source(i));
  }
  return out;
}

}  // namespace

TEST_CASE("path shortener: raw RRT paths get shorter, stay valid, and are re-checked densely", "[unit]") {
  io::LoadedScenario site = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + kScenario).string());
  PlanningProblem problem = planning_problem(site.scenario, *site.model, *site.world);
  double raw_time_s = 0.0;
  double short_time_s = 0.0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    CAPTURE(seed);
    problem.seed = seed;
    problem.max_iterations = 20000;
    auto planner = make_planner("rrt");
    REQUIRE(planner->reset(problem) == PlannerStatus::Running);
    PlannerStatus status = PlannerStatus::Running;
    while (status == PlannerStatus::Running) status = planner->step(100);
    REQUIRE(status == PlannerStatus::Solved);
    const std::vector<JointVector> raw = planner->path();

    const Shortened out = shorten(*site.world, nullptr, raw, problem.step, 0);
    CHECK(out.allocations == 0);
    CAPTURE(raw.size(), out.path.size(), out.slices);
    CHECK(out.path.size() < raw.size());
    mgc::test::dense_recheck(kScenario, out.path);
    // Every node is one of the input's (named by source()) or a staircase corner (-1); the ends
    // are the input's ends.
    CHECK(out.source.front() == 0);
    CHECK(out.source.back() == static_cast<int>(raw.size()) - 1);
    for (std::size_t i = 0; i < out.path.size(); ++i) {
      if (out.source[i] >= 0) CHECK(out.path[i] == raw[static_cast<std::size_t>(out.source[i])]);
    }
    const PathMetrics before = compute_path_metrics(*site.model, *site.world, raw, problem.step);
    const PathMetrics after = compute_path_metrics(*site.model, *site.world, out.path, problem.step);
    CHECK(after.multi_joint_edges <= before.multi_joint_edges);
    CHECK(after.exec_time_sequential_s <= before.exec_time_sequential_s + 1e-9);
    raw_time_s += before.exec_time_sequential_s;
    short_time_s += after.exec_time_sequential_s;

    // Deterministic.
    const Shortened again = shorten(*site.world, nullptr, raw, problem.step, 0);
    CHECK(again.path == out.path);
  }
  // Raw RRT paths wander: shortening should take a good part of their one-joint-at-a-time time.
  CAPTURE(raw_time_s, short_time_s);
  CHECK(short_time_s < 0.8 * raw_time_s);
}

TEST_CASE("path shortener: a prefix stays as given and a multi-joint edge becomes valid stairs", "[unit]") {
  io::LoadedScenario site = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + kScenario).string());
  const PlanningProblem problem = planning_problem(site.scenario, *site.model, *site.world);
  const JointVector& start = site.scenario.start;
  // A two-node path whose one edge luffs up 5 deg and hoists up 3 m at once; the prefix is a
  // configuration just beside the start.
  JointVector mid = start;
  mid[1] += 5.0 * mgc::test::kDeg;
  mid[3] -= 3.0;
  REQUIRE(site.world->validate_edge(start, mid, problem.step).valid());
  const std::vector<JointVector> path = {start, mid};
  JointVector prefix = start;
  prefix[0] -= 0.01;
  REQUIRE(site.world->validate_edge(prefix, start, problem.step).valid());
  const Shortened out = shorten(*site.world, &prefix, path, problem.step, 1);
  CHECK(out.allocations == 0);
  REQUIRE(out.path.size() == 4);
  CHECK(out.path[0] == prefix);
  CHECK(out.source[0] == -1);
  CHECK(out.path[1] == start);
  CHECK(out.source[1] == 0);
  CHECK(out.source[2] == -1);
  CHECK(out.path[3] == mid);
  CHECK(out.source[3] == 1);
  for (std::size_t e = 1; e + 1 < out.path.size(); ++e) {
    CAPTURE(e);
    CHECK(moving_joint(*site.model, out.path[e], out.path[e + 1]) >= 0);
    CHECK(site.world->validate_edge(out.path[e], out.path[e + 1], problem.step).valid());
  }
  // The larger move first, as the follower takes it (in the joints' own units): the 3 m hoist.
  CHECK(moving_joint(*site.model, out.path[1], out.path[2]) == 3);
}

TEST_CASE("path shortener: where the stretch's own order is blocked, another order of the same joints shortens it", "[unit]") {
  io::LoadedScenario site = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + kScenario).string());
  const PlanningProblem problem = planning_problem(site.scenario, *site.model, *site.world);
  // The thesis lift's way round the east: at the start's boom angle the slew to the east is
  // blocked by the frame, with the boom luffed up 24 deg it is free. The path slews a little,
  // luffs up, then slews on; its own order (slew first, then luff) cannot shorten it.
  const JointVector& a = site.scenario.start;
  const auto n = a.size();
  const JointVector b = a - 5.0 * mgc::test::kDeg * JointVector::Unit(n, 0);
  const JointVector c = b + 24.0 * mgc::test::kDeg * JointVector::Unit(n, 1);
  const JointVector d = c - 155.0 * mgc::test::kDeg * JointVector::Unit(n, 0);
  const std::vector<JointVector> path = {a, b, c, d};
  for (std::size_t e = 0; e + 1 < path.size(); ++e) REQUIRE(site.world->validate_edge(path[e], path[e + 1], problem.step).valid());
  const JointVector slew_first = a + (d[0] - a[0]) * JointVector::Unit(n, 0);
  REQUIRE_FALSE(site.world->validate_edge(a, slew_first, problem.step).valid());
  const JointVector luff_first = a + (d[1] - a[1]) * JointVector::Unit(n, 1);
  REQUIRE(site.world->validate_edge(a, luff_first, problem.step).valid());
  REQUIRE(site.world->validate_edge(luff_first, d, problem.step).valid());

  const Shortened out = shorten(*site.world, nullptr, path, problem.step, 0);
  CHECK(out.allocations == 0);
  REQUIRE(out.path.size() == 3);
  CHECK(out.path[0] == a);
  CHECK(out.path[1] == luff_first);
  CHECK(out.path[2] == d);
  CHECK(out.source[1] == -1);
  CHECK(out.source[2] == 3);
  mgc::test::dense_recheck(kScenario, out.path, false);
}
