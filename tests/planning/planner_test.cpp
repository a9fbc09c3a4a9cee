// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/anytime.hpp"
#include "mgc/planning/planners/bidirectional.hpp"
#include "mgc/planning/planners/nonuniform.hpp"
#include "mgc/planning/excavator.hpp"
#include "mgc/planning/smoothing.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "dense_recheck.hpp"
#include "planner_fixture.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::dense_recheck;
using mgc::test::Fixture;
using mgc::test::kDeg;
using mgc::test::kScenarios;
using mgc::test::run;


TEST_CASE("limcon solves every shipped scenario, one joint per edge, densely valid", "[planner]") {
  for (const char* scenario : kScenarios) {
    for (std::uint64_t seed = 0; seed < 5; ++seed) {
      CAPTURE(scenario, seed);
      Fixture f(scenario, seed);
      auto planner = make_planner("limcon");
      REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
      const auto& path = planner->path();
      dense_recheck(scenario, path);
      for (std::size_t e = 0; e + 1 < path.size(); ++e) {
        CAPTURE(e);
        CHECK(moving_joint(*f.loaded.model, path[e], path[e + 1]) >= 0);
      }
      CHECK(planner->stats().tree_nodes <= planner->stats().iterations + 1);
    }
  }
}

TEST_CASE("rrt (goal-biased, single step) solves every shipped scenario, densely valid", "[planner]") {
  for (const char* scenario : kScenarios) {
    CAPTURE(scenario);
    Fixture f(scenario, 1);
    f.problem.max_iterations = 20000;
    auto planner = make_planner("rrt");
    REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
    dense_recheck(scenario, planner->path());
    // Single steps: every edge but the final gap-closing moves is one step of one joint.
    const auto& path = planner->path();
    for (std::size_t e = 0; e + 1 < path.size(); ++e) CHECK(moving_joint(*f.loaded.model, path[e], path[e + 1]) >= 0);
  }
}

TEST_CASE("bidirectional planners solve every shipped scenario, densely valid", "[planner]") {
  for (const char* name : {"rrt-connect", "rrt-ext-con", "rrt-ext-ext", "con-con-mod"}) {
    for (const char* scenario : kScenarios) {
      for (std::uint64_t seed = 0; seed < 3; ++seed) {
        CAPTURE(name, scenario, seed);
        Fixture f(scenario, seed);
        f.problem.max_iterations = 5000;
        auto planner = make_planner(name);
        REQUIRE(planner->name() == name);
        REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
        dense_recheck(scenario, planner->path());
      }
    }
  }
}

TEST_CASE("con-con-mod with a threshold nothing fails is rrt-connect, path for path", "[planner]") {
  // Seed 000 §3.4: for a large gamma the first candidate always passes Eq. 6, the random stream
  // is RRT-Con-Con's, and so are the paths.
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    CAPTURE(seed);
    Fixture f("excavator-pipelines.yaml", seed);
    f.problem.max_iterations = 5000;
    BidirectionalPlanner concon(BidirectionalPlanner::Variant::ConCon);
    BidirectionalPlanner mod(BidirectionalPlanner::Variant::ConConMod, 1e9);
    REQUIRE(run(concon, f.problem) == PlannerStatus::Solved);
    REQUIRE(run(mod, f.problem) == PlannerStatus::Solved);
    CHECK(concon.path() == mod.path());
    // A tight threshold changes the samples, and with them the tree.
    BidirectionalPlanner tight(BidirectionalPlanner::Variant::ConConMod, 1.05);
    REQUIRE(run(tight, f.problem) == PlannerStatus::Solved);
    std::vector<JointVector> nodes_a, nodes_b;
    std::vector<int> parents_a, parents_b;
    concon.tree(nodes_a, parents_a);
    tight.tree(nodes_b, parents_b);
    CHECK(nodes_a != nodes_b);
  }
}

TEST_CASE("same seed, same path, bit for bit, slicing does not change it", "[planner]") {
  for (const char* name : {"limcon", "rrt", "rrt-connect", "rrt-ext-ext", "con-con-mod"}) {
    CAPTURE(name);
    Fixture a("thesis-steel-frame.yaml", 7);
    Fixture b("thesis-steel-frame.yaml", 7);
    auto pa = make_planner(name);
    auto pb = make_planner(name);
    a.problem.max_iterations = b.problem.max_iterations = 20000;
    REQUIRE(run(*pa, a.problem, 1000) == PlannerStatus::Solved);
    REQUIRE(run(*pb, b.problem, 1) == PlannerStatus::Solved);  // one iteration per slice
    REQUIRE(pa->path().size() == pb->path().size());
    for (std::size_t i = 0; i < pa->path().size(); ++i) CHECK(pa->path()[i] == pb->path()[i]);
    CHECK(pa->stats().iterations == pb->stats().iterations);
    // A different seed gives a different tree.
    Fixture c("thesis-steel-frame.yaml", 8);
    c.problem.max_iterations = 20000;
    auto pc = make_planner(name);
    REQUIRE(run(*pc, c.problem) == PlannerStatus::Solved);
    std::vector<JointVector> nodes_a, nodes_c;
    std::vector<int> parents_a, parents_c;
    pa->tree(nodes_a, parents_a);
    pc->tree(nodes_c, parents_c);
    CHECK((nodes_a.size() != nodes_c.size() || nodes_a != nodes_c));
  }
}

TEST_CASE("limcon builds far smaller trees and paths than single-step rrt", "[planner]") {
  Fixture f("thesis-steel-frame.yaml", 3);
  f.problem.max_iterations = 20000;
  auto limcon = make_planner("limcon");
  auto rrt = make_planner("rrt");
  REQUIRE(run(*limcon, f.problem) == PlannerStatus::Solved);
  REQUIRE(run(*rrt, f.problem) == PlannerStatus::Solved);
  CHECK(limcon->path().size() * 5 <= rrt->path().size());
  CHECK(limcon->stats().tree_nodes * 5 <= rrt->stats().tree_nodes);
}

TEST_CASE("planner errors: invalid start or goal, exhausted pool, iteration limit, unknown name", "[planner]") {
  Fixture f("thesis-steel-frame.yaml");
  auto planner = make_planner("limcon");
  SECTION("goal in collision") {
    f.problem.goal[0] = 10 * kDeg;  // load swung into the frame
    CHECK(planner->reset(f.problem) == PlannerStatus::InvalidGoal);
    CHECK(planner->step(10) == PlannerStatus::InvalidGoal);
  }
  SECTION("start outside the joint range") {
    f.problem.start[2] = 40.0;
    CHECK(planner->reset(f.problem) == PlannerStatus::InvalidStart);
  }
  SECTION("the pool is sized at reset and never grows") {
    f.problem.node_capacity = 3;
    CHECK(run(*planner, f.problem) == PlannerStatus::PoolExhausted);
    CHECK(planner->stats().tree_nodes == 3);
  }
  SECTION("iteration limit") {
    f.problem.max_iterations = 2;
    CHECK(run(*planner, f.problem) == PlannerStatus::IterationLimit);
    CHECK(planner->stats().iterations == 2);
  }
  SECTION("step before reset") { CHECK(planner->step(10) == PlannerStatus::NotReset); }
  SECTION("bidirectional pool") {
    auto connect = make_planner("rrt-connect");
    f.problem.node_capacity = 4;
    CHECK(run(*connect, f.problem) == PlannerStatus::PoolExhausted);
    CHECK(connect->stats().tree_nodes <= 8);
  }
  SECTION("bidirectional invalid goal") {
    auto connect = make_planner("con-con-mod");
    f.problem.goal[0] = 10 * kDeg;
    CHECK(connect->reset(f.problem) == PlannerStatus::InvalidGoal);
  }
  CHECK(make_planner("rrt-star-please") == nullptr);
}

TEST_CASE("path metrics of a hand-made path", "[unit]") {
  Fixture f("thesis-steel-frame.yaml");
  const MachineModel& model = *f.loaded.model;
  // Start -> boom up 10 deg -> swing -20 deg -> boom up 5 deg.
  std::vector<JointVector> path{f.problem.start};
  JointVector q = f.problem.start;
  q[1] += 10 * kDeg;
  path.push_back(q);
  q[0] -= 20 * kDeg;
  path.push_back(q);
  q[1] += 5 * kDeg;
  path.push_back(q);
  const PathMetrics m = compute_path_metrics(model, *f.loaded.world, path, f.problem.step);
  CHECK(m.path_nodes == 4);
  CHECK(m.dof_switches == 2);
  CHECK(m.multi_joint_edges == 0);
  // Luff 15 deg at 1.04 deg/s, swing 20 deg at 3.75 deg/s; one joint moves per edge, so both
  // execution times agree.
  CHECK(m.exec_time_sequential_s == Approx(15 / 1.04 + 20 / 3.75));
  CHECK(m.exec_time_simultaneous_s == Approx(m.exec_time_sequential_s));
  // Normalized: luff range 80 deg, swing a full turn.
  CHECK(m.length_normalized == Approx(10.0 / 80 + 20.0 / 360 + 5.0 / 80));
  CHECK(m.roughness == Approx(m.length_normalized));
  CHECK(m.cost == Approx(0.5 * m.exec_time_sequential_s / 60 + 0.5 * m.roughness));
  CHECK(m.min_clearance_m > 0.0);
  CHECK(moving_joint(model, path[0], path[1]) == 1);
  JointVector both = path[0];
  both[0] += 0.1;
  both[3] += 0.1;
  CHECK(moving_joint(model, path[0], both) == -2);
}

TEST_CASE("smoothing shortens paths, keeps them valid, and keeps one joint per edge when asked", "[planner]") {
  for (const char* name : {"limcon", "rrt", "rrt-connect", "con-con-mod"}) {
    for (const char* scenario : kScenarios) {
      CAPTURE(name, scenario);
      Fixture f(scenario, 2);
      f.problem.max_iterations = 20000;
      auto planner = make_planner(name);
      REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
      const auto& raw = planner->path();
      const MachineModel& model = *f.loaded.model;
      const PathMetrics before = compute_path_metrics(model, *f.loaded.world, raw, f.problem.step);
      SmoothingOptions options;
      options.single_axis = before.multi_joint_edges == 0;
      options.seed = 2;
      const auto smoothed = smooth_path(*f.loaded.world, raw, f.problem.step, options);
      const PathMetrics after = compute_path_metrics(model, *f.loaded.world, smoothed, f.problem.step);
      dense_recheck(scenario, smoothed);
      CHECK(after.path_nodes <= before.path_nodes);
      if (options.single_axis) {
        CHECK(after.multi_joint_edges == 0);
        CHECK(after.exec_time_sequential_s <= before.exec_time_sequential_s + 1e-9);
      }
      // Deterministic for a seed.
      CHECK(smooth_path(*f.loaded.world, raw, f.problem.step, options) == smoothed);
    }
  }
  // The single-step rrt's long staircase of tiny moves collapses.
  Fixture f("thesis-steel-frame.yaml", 0);
  f.problem.max_iterations = 20000;
  auto rrt = make_planner("rrt");
  REQUIRE(run(*rrt, f.problem) == PlannerStatus::Solved);
  const auto smoothed = smooth_path(*f.loaded.world, rrt->path(), f.problem.step, SmoothingOptions{});
  CHECK(smoothed.size() * 4 <= rrt->path().size());
}

TEST_CASE("nonuniform: Beta samples have their mean on the goal (note 003's corrected rule)", "[unit]") {
  Random random(1);
  for (const double mean : {0.05, 0.2, 0.5, 0.7, 0.95}) {
    CAPTURE(mean);
    double sum = 0.0;
    constexpr int kDraws = 200000;
    for (int i = 0; i < kDraws; ++i) {
      const double x = NonUniformRrtPlanner::beta_sample(mean, random.uniform());
      REQUIRE(x >= 0.0);
      REQUIRE(x <= 1.0);
      sum += x;
    }
    CHECK(sum / kDraws == Approx(mean).margin(0.005));
  }
}

TEST_CASE("nonuniform: solves the pipelines scenario holding the bucket's ground angle", "[planner]") {
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    CAPTURE(seed);
    Fixture f("excavator-pipelines.yaml", seed);
    NonUniformRrtPlanner planner;
    REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
    CHECK(planner.holds_bucket());
    dense_recheck("excavator-pipelines.yaml", planner.path());
    // Every node keeps psi = -180 deg; psi is linear in the joints, so every edge does too.
    for (const JointVector& q : planner.path()) CHECK(bucket_ground_angle_rad(q) == Approx(-180 * kDeg).margin(1e-9));
  }
  // Without the hold (different ground angles at start and goal) all four joints are sampled.
  Fixture f("excavator-pipelines.yaml", 0);
  f.problem.goal[Excavator::kBucket] += 10 * kDeg;
  NonUniformRrtPlanner planner;
  REQUIRE(run(planner, f.problem) == PlannerStatus::Solved);
  CHECK_FALSE(planner.holds_bucket());
}

TEST_CASE("anytime keeps the least rough path and only ever improves it", "[planner]") {
  Fixture f("thesis-steel-frame.yaml", 0);
  AnytimePlanner planner(6);
  REQUIRE(run(planner, f.problem, 7) == PlannerStatus::Solved);
  dense_recheck("thesis-steel-frame.yaml", planner.path());
  const auto& history = planner.history();
  REQUIRE(!history.empty());
  for (std::size_t i = 1; i < history.size(); ++i) {
    CHECK(history[i].roughness < history[i - 1].roughness);
    CHECK(history[i].iterations >= history[i - 1].iterations);
  }
  double roughness = 0.0;
  for (std::size_t e = 0; e + 1 < planner.path().size(); ++e) {
    roughness += normalized_distance(*f.loaded.model, planner.path()[e], planner.path()[e + 1], false);
  }
  CHECK(roughness == Approx(history.back().roughness));
  // Each seed's RRT-Con-Con run is a candidate: the best is no rougher than seed 0's.
  BidirectionalPlanner connect(BidirectionalPlanner::Variant::ConCon);
  REQUIRE(run(connect, f.problem) == PlannerStatus::Solved);
  double connect_roughness = 0.0;
  for (std::size_t e = 0; e + 1 < connect.path().size(); ++e) {
    connect_roughness += normalized_distance(*f.loaded.model, connect.path()[e], connect.path()[e + 1], false);
  }
  CHECK(history.back().roughness <= connect_roughness + 1e-12);
}

TEST_CASE("no planner returns an edge that moves a joint by a rounding error", "[planner]") {
  // limcon's steps summed in floating point used to end 1e-13 rad short of the goal on the
  // excavator's swing, and the closing move was an edge of that length (80 in 40 seeds).
  for (const char* name : {"limcon", "axis-connect", "rrt-connect", "con-con-mod"}) {
    for (const char* scenario : kScenarios) {
      for (std::uint64_t seed = 0; seed < 20; ++seed) {
        CAPTURE(name, scenario, seed);
        Fixture f(scenario, seed);
        auto planner = make_planner(name);
        REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
        const auto& path = planner->path();
        for (std::size_t e = 0; e + 1 < path.size(); ++e) {
          const JointVector d = f.loaded.model->difference(path[e], path[e + 1]);
          CAPTURE(e, d.transpose());
          CHECK(d.cwiseAbs().maxCoeff() > 0.0);
          for (int j = 0; j < d.size(); ++j) CHECK((d[j] == 0.0 || std::abs(d[j]) >= 1e-9));
        }
        CHECK(path.back() == f.problem.goal);
      }
    }
  }
}

TEST_CASE("limcon's runs on the swing stay short of half a turn, so each edge turns the way its steps were checked", "[planner]") {
  // Start and goal half a turn apart: a goal-biased run heads for the opposite side, validated step
  // by step; stored as one edge, a run of half a turn or more would turn the other way round.
  int checked = 0;
  for (std::uint64_t seed = 0; seed < 12; ++seed) {
    CAPTURE(seed);
    Fixture f("thesis-steel-frame.yaml", seed);
    f.problem.goal = f.problem.start;
    f.problem.goal[0] = wrap_angle(f.problem.start[0] - std::numbers::pi);
    f.problem.goal_bias = 0.5;
    auto planner = make_planner("limcon");
    if (run(*planner, f.problem) != PlannerStatus::Solved) continue;
    ++checked;
    const auto& path = planner->path();
    for (std::size_t e = 0; e + 1 < path.size(); ++e) {
      CAPTURE(e);
      CHECK(std::abs(f.loaded.model->difference(path[e], path[e + 1])[0]) < std::numbers::pi - 1e-7);
    }
    dense_recheck("thesis-steel-frame.yaml", path, false);
  }
  CHECK(checked >= 6);
}
