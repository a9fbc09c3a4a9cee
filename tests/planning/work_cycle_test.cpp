// SPDX-License-Identifier: Apache-2.0
// Seed 003's excavator work cycle: the scenario's work_cycle section, the subtask holds of the
// nonuniform planner, and the three subtasks planned in order.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "cycle_recheck.hpp"
#include "mgc/planning/excavator.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/work_cycle.hpp"
#include "mgc/planning/smoothing.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;
using mgc::test::TempFile;

namespace {

constexpr const char* kCycleScenario = "excavator-cycle.yaml";
// The planner's tolerance for a held value. [rad]
constexpr double kHeld_rad = 1e-9;

struct Cycle {
  io::LoadedScenario loaded;
  PlanningProblem problem;
  WorkCyclePlanner planner;

  explicit Cycle(std::uint64_t seed)
      : loaded(io::load_and_build(mgc::test::source_path(std::string("scenarios/") + kCycleScenario))),
        problem(planning_problem(loaded.scenario, *loaded.model, *loaded.world)),
        planner(loaded.scenario.work_cycle.value().dumped, loaded.scenario.work_cycle.value().next_dig) {
    problem.seed = seed;
  }

  PlannerStatus run(int budget) {
    PlannerStatus status = planner.reset(problem);
    while (status == PlannerStatus::Running) status = planner.step(budget);
    return status;
  }
};

// The subtask holds, at every configuration of the path sampled at `step`.
void check_holds(const MachineModel& model, ExcavatorSubtask subtask, const std::vector<JointVector>& path,
                 const JointVector& step) {
  const JointVector& start = path.front();
  int samples = 0;
  mgc::test::for_each_dense_sample(model, path, step, [&](const JointVector& q) {
    ++samples;
    switch (subtask) {
      case ExcavatorSubtask::MoveToDump:
        REQUIRE(std::abs(bucket_ground_angle_rad(q) - bucket_ground_angle_rad(start)) <= kHeld_rad);
        break;
      case ExcavatorSubtask::Dump:
        REQUIRE(std::abs(wrap_angle(q[Excavator::kSwing] - start[Excavator::kSwing])) <= kHeld_rad);
        REQUIRE(std::abs(q[Excavator::kBoom] - start[Excavator::kBoom]) <= kHeld_rad);
        break;
      default: break;
    }
  });
  CHECK(samples > static_cast<int>(path.size()));
}

// A shipped scenario's text, its machine file named by absolute path so that a copy loads anywhere.
std::string scenario_text(const std::string& name) {
  std::ifstream in(mgc::test::source_path("scenarios/" + name));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string machine = "machine: machines/";
  text.replace(text.find(machine), machine.size(), "machine: " + mgc::test::source_path("scenarios/machines/").string() + "/");
  return text;
}

std::string cycle_text() { return scenario_text(kCycleScenario); }

// The text without the lines from `from` up to (not including) `to`.
std::string erase_between(std::string text, const std::string& from, const std::string& to) {
  const auto a = text.find(from);
  const auto b = text.find(to, a);
  REQUIRE(a != std::string::npos);
  REQUIRE(b != std::string::npos);
  return text.erase(a, b - a);
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  REQUIRE(pos != std::string::npos);
  return text.replace(pos, from.size(), to);
}

// 1-based line of the first occurrence of `fragment`.
int line_of(const std::string& text, const std::string& fragment) {
  const auto pos = text.find(fragment);
  REQUIRE(pos != std::string::npos);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
}

void expect_error(const std::string& text, int line, const std::string& field, const std::string& message) {
  TempFile file("cycle.yaml", text);
  try {
    auto loaded = io::load_and_build(file.path());
    const auto errors = io::check_endpoints(loaded);
    REQUIRE(errors.size() == 1);
    throw errors.front();
  } catch (const io::InputError& error) {
    const std::string what = error.what();
    CAPTURE(what);
    CHECK(error.file() == file.path().string());
    CHECK(error.line() == line);
    CHECK(error.field() == field);
    CHECK(what.find(message) != std::string::npos);
    CHECK(what.find('\n') == std::string::npos);
  }
}

}  // namespace

TEST_CASE("work cycle: the scenario's section gives the dumped and next-dig poses", "[unit]") {
  const Scenario s = io::load_scenario(mgc::test::source_path(std::string("scenarios/") + kCycleScenario));
  REQUIRE(s.work_cycle);
  const WorkCycleSpec& c = *s.work_cycle;
  // Dumping keeps the goal's swing and boom and moves the arm and bucket.
  CHECK(c.dumped[Excavator::kSwing] == s.goal[Excavator::kSwing]);
  CHECK(c.dumped[Excavator::kBoom] == s.goal[Excavator::kBoom]);
  CHECK(c.dumped[Excavator::kArm] == Approx(-80 * kDeg));
  CHECK(c.dumped[Excavator::kBucket] == Approx(-15 * kDeg));
  CHECK(bucket_ground_angle_rad(c.dumped) == Approx(-45 * kDeg));
  CHECK(bucket_ground_angle_rad(s.goal) == Approx(bucket_ground_angle_rad(s.start)));
  CHECK(c.next_dig[Excavator::kBoom] == Approx(25 * kDeg));
  CHECK(c.next_dig_ref.field == "work_cycle.next_dig");
  // The pipelines scenario has no cycle; without next_dig the cycle returns to the start.
  CHECK_FALSE(io::load_scenario(mgc::test::source_path("scenarios/excavator-pipelines.yaml")).work_cycle);
  TempFile file("cycle-no-next.yaml", erase_between(cycle_text(), "  next_dig:", "planner:"));
  const Scenario back = io::load_scenario(file.path());
  REQUIRE(back.work_cycle);
  CHECK(back.work_cycle->next_dig == back.start);
  CHECK(back.work_cycle->next_dig_ref.field.empty());
}

TEST_CASE("work cycle: the site needs planning for move-to-dump and return, not for the dump", "[unit]") {
  Cycle c(0);
  const Scenario& s = c.loaded.scenario;
  CollisionWorld& world = *c.loaded.world;
  CHECK_FALSE(world.validate_edge(s.start, s.goal, c.problem.step).valid());
  CHECK(world.validate_edge(s.goal, s.work_cycle->dumped, c.problem.step).valid());
  CHECK_FALSE(world.validate_edge(s.work_cycle->dumped, s.work_cycle->next_dig, c.problem.step).valid());
}

TEST_CASE("work cycle: three subtasks in order, each densely valid, holds kept at every dense sample", "[planner]") {
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    CAPTURE(seed);
    Cycle c(seed);
    REQUIRE(c.run(100) == PlannerStatus::Solved);
    const Scenario& s = c.loaded.scenario;
    const JointVector poses[] = {s.start, s.goal, s.work_cycle->dumped, s.work_cycle->next_dig};
    const JointVector fine = step_sizes(*c.loaded.model, 4 * s.planner.space_resolution);
    std::vector<JointVector> joined;
    for (int k = 0; k < WorkCyclePlanner::kSubtasks; ++k) {
      CAPTURE(k);
      const ExcavatorSubtask subtask = WorkCyclePlanner::kOrder[static_cast<std::size_t>(k)];
      const auto& path = c.planner.subtask_path(k);
      CHECK(c.planner.subtask_status(k) == PlannerStatus::Solved);
      mgc::test::dense_recheck_between(kCycleScenario, path, poses[k], poses[k + 1]);
      check_holds(*c.loaded.model, subtask, path, fine);
      // Straight shortcuts between a subtask's nodes keep its holds (mgc-plan smooths so).
      SmoothingOptions straight;
      straight.single_axis = false;
      straight.seed = seed;
      const auto smoothed = smooth_path(*c.loaded.world, path, c.problem.step, straight);
      mgc::test::dense_recheck_between(kCycleScenario, smoothed, poses[k], poses[k + 1]);
      check_holds(*c.loaded.model, subtask, smoothed, fine);
      joined.insert(joined.end(), path.begin() + (joined.empty() ? 0 : 1), path.end());
    }
    CHECK(c.planner.path() == joined);
    // The dump's straight line is free on this site: the paper's parametric dump, one iteration.
    CHECK(c.planner.subtask_path(1).size() == 2);
    CHECK(c.planner.subtask_stats(1).iterations == 1);
    const PlannerStats total = c.planner.stats();
    CHECK(total.iterations == c.planner.subtask_stats(0).iterations + 1 + c.planner.subtask_stats(2).iterations);
    CHECK(total.collision_checks > 0);
  }
}

TEST_CASE("work cycle: same seed, same paths, bit for bit, however the steps are sliced", "[planner]") {
  Cycle a(7);
  Cycle b(7);
  REQUIRE(a.run(1) == PlannerStatus::Solved);
  REQUIRE(b.run(1000) == PlannerStatus::Solved);
  for (int k = 0; k < WorkCyclePlanner::kSubtasks; ++k) CHECK(a.planner.subtask_path(k) == b.planner.subtask_path(k));
  CHECK(a.planner.path() == b.planner.path());
  // And a reset planner repeats itself.
  REQUIRE(a.run(50) == PlannerStatus::Solved);
  CHECK(a.planner.path() == b.planner.path());
  Cycle other(8);
  REQUIRE(other.run(100) == PlannerStatus::Solved);
  CHECK(other.planner.path() != a.planner.path());
}

TEST_CASE("work cycle: step() stops at every subtask's end", "[planner]") {
  Cycle c(0);
  PlannerStatus status = c.planner.reset(c.problem);
  int last = 0;
  while (status == PlannerStatus::Running) {
    status = c.planner.step(100000);
    // A huge budget still ends the slice when a subtask is done.
    CHECK(c.planner.current_subtask() <= last + 1);
    last = c.planner.current_subtask();
  }
  CHECK(status == PlannerStatus::Solved);
  CHECK(c.planner.current_subtask() == WorkCyclePlanner::kSubtasks);
  std::vector<JointVector> nodes;
  std::vector<int> parents;
  c.planner.tree(nodes, parents);
  CHECK(static_cast<int>(nodes.size()) == c.planner.stats().tree_nodes);
  CHECK(std::count(parents.begin(), parents.end(), -1) == WorkCyclePlanner::kSubtasks);
}

TEST_CASE("nonuniform subtasks refuse a query that breaks their hold", "[planner]") {
  Cycle c(0);
  const Scenario& s = c.loaded.scenario;
  PlanningProblem p = c.problem;
  SECTION("move-to-dump: the goal's bucket at another ground angle") {
    p.goal[Excavator::kBucket] += 5 * kDeg;
    NonUniformRrtPlanner planner(ExcavatorSubtask::MoveToDump);
    CHECK(planner.reset(p) == PlannerStatus::InvalidGoal);
    CHECK(planner.step(10) == PlannerStatus::InvalidGoal);
  }
  SECTION("dump: the goal swung or the boom moved") {
    p.start = s.goal;
    p.goal = s.work_cycle->dumped;
    NonUniformRrtPlanner planner(ExcavatorSubtask::Dump);
    CHECK(planner.reset(p) == PlannerStatus::Running);
    p.goal[Excavator::kSwing] += 1 * kDeg;
    CHECK(planner.reset(p) == PlannerStatus::InvalidGoal);
    p.goal = s.work_cycle->dumped;
    p.goal[Excavator::kBoom] -= 1 * kDeg;
    CHECK(planner.reset(p) == PlannerStatus::InvalidGoal);
  }
  SECTION("the cycle says which subtask") {
    WorkCyclePlanner planner(s.work_cycle->dumped, s.goal);  // "next dig" = the dump pose: fine
    CHECK(planner.reset(p) == PlannerStatus::Running);
    JointVector swung = s.work_cycle->dumped;
    swung[Excavator::kSwing] += 10 * kDeg;
    WorkCyclePlanner broken(swung, s.start);
    CHECK(broken.reset(p) == PlannerStatus::InvalidGoal);
    CHECK(broken.failed_subtask() == 1);
  }
  SECTION("a subtask is an excavator's") {
    auto crane = io::load_and_build(mgc::test::source_path("scenarios/thesis-steel-frame.yaml"));
    const PlanningProblem q = planning_problem(crane.scenario, *crane.model, *crane.world);
    NonUniformRrtPlanner planner(ExcavatorSubtask::Return);
    CHECK(planner.reset(q) == PlannerStatus::InvalidGoal);
  }
}

TEST_CASE("bad input: work cycle", "[unit]") {
  const std::string base = cycle_text();
  SECTION("the base text is valid") {
    TempFile file("cycle.yaml", base);
    auto loaded = io::load_and_build(file.path());
    CHECK(io::check_endpoints(loaded).empty());
  }
  SECTION("move-to-dump must hold the bucket: the goal's bucket names the angle that would") {
    const std::string text = replace(base, "  bucket_deg: -155", "  bucket_deg: -150");
    expect_error(text, line_of(text, "  bucket_deg: -150"), "goal.bucket_deg",
                 "expected -155, which keeps the start's bucket ground angle (boom + arm + bucket = -180 deg) for the "
                 "work cycle's move-to-dump, got '-150'");
  }
  SECTION("dumping must curl the bucket out") {
    const std::string text = replace(base, "bucket_deg: -15 ", "bucket_deg: -150 ");
    expect_error(text, line_of(text, "bucket_deg: -150 "), "work_cycle.dump.bucket_deg",
                 "expected a bucket curled out from the carry: boom + arm + bucket above the carry's -180 deg (here "
                 "-180 deg), got '-150'");
  }
  SECTION("dump joints within their ranges") {
    const std::string text = replace(base, "arm_deg: -80 ", "arm_deg: -20 ");
    expect_error(text, line_of(text, "arm_deg: -20 "), "work_cycle.dump.arm_deg",
                 "expected a value within the joint range [-155, -30] deg");
  }
  SECTION("dumping holds swing and boom: the dump names only the arm and bucket") {
    const std::string text = replace(base, "    arm_deg: -80 ", "    swing_deg: 80\n    arm_deg: -80 ");
    expect_error(text, line_of(text, "    swing_deg: 80"), "work_cycle.dump.swing_deg", "unknown field");
  }
  SECTION("a missing dump") {
    const std::string text = erase_between(base, "  dump:", "  next_dig:");
    expect_error(text, line_of(text, "work_cycle:"), "work_cycle.dump", "missing field");
  }
  SECTION("a next dig in collision") {
    // Boom down, arm out: the bucket swept through the left pipeline's place.
    std::string text = base;
    const auto at = text.find("  next_dig:");
    text = text.substr(0, at) + replace(text.substr(at), "    swing_deg: 0", "    swing_deg: 15");
    text = text.substr(0, at) + replace(text.substr(at), "    boom_deg: 25", "    boom_deg: -10");
    expect_error(text, line_of(text, "  next_dig:"), "work_cycle.next_dig", "infeasible: collision: ");
  }
  SECTION("a dumped pose in collision") {
    // The arm curled 35 deg further in: the opened bucket reaches down into the truck bed.
    const std::string text = replace(replace(base, "arm_deg: -80 ", "arm_deg: -110 "), "bucket_deg: -15 ", "bucket_deg: 10 ");
    expect_error(text, line_of(text, "  dump:"), "work_cycle.dump", "infeasible: collision: bucket hits obstacle 'truck-bed'");
  }
  SECTION("a crane has no work cycle") {
    const std::string text = scenario_text("thesis-steel-frame.yaml") + "work_cycle:\n  dump:\n    arm_deg: -80\n";
    expect_error(text, line_of(text, "work_cycle:"), "work_cycle",
                 "a work cycle (dig, dump, return) is an excavator's; ");
  }
}
