// SPDX-License-Identifier: Apache-2.0
// compute_path_metrics' min_clearance_m against an oracle: the clearance measured densely along
// every edge of planned paths.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "planner_fixture.hpp"

using namespace mgc::planning;
using mgc::test::Fixture;
using mgc::test::kDeg;
using mgc::test::kScenarios;
using mgc::test::run;

namespace {

constexpr int kDenseSamples = 1000;  // per edge

struct Dense {
  double min_m = std::numeric_limits<double>::infinity();
  // How far the dense minimum may lie above the true one: half the body-point travel between two
  // dense samples, at the edge where the minimum is.
  double slack_m = 0.0;
};

Dense dense_minimum(const MachineModel& model, CollisionWorld& world, const std::vector<JointVector>& path) {
  Dense out;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const JointVector d = model.difference(path[e], path[e + 1]);
    double travel_m = 0.0;
    for (int i = 0; i < model.dof(); ++i) travel_m += model.edge_displacement_bound(path[e], path[e + 1], i) * std::abs(d[i]);
    for (int k = 0; k <= kDenseSamples; ++k) {
      const double c = world.clearance(model.interpolate(path[e], path[e + 1], static_cast<double>(k) / kDenseSamples)).distance_m;
      if (c < out.min_m) {
        out.min_m = c;
        out.slack_m = 0.5 * travel_m / kDenseSamples;
      }
    }
  }
  return out;
}

// GJK's distance tolerance: two queries on nearly the same pose may differ by this much.
constexpr double kDistanceTolerance_m = 1e-6;

// Checks compute_path_metrics on `path` at `step` against the dense minimum; returns the least
// clearance at the samples alone (no refinement).
double check_against_dense(const MachineModel& model, CollisionWorld& world, const std::vector<JointVector>& path,
                           const JointVector& step, const Dense& dense) {
  const PathMetrics plain = compute_path_metrics(model, world, path, step, 0.0);
  const PathMetrics refined = compute_path_metrics(model, world, path, step);
  CAPTURE(dense.min_m, dense.slack_m, plain.min_clearance_m, plain.min_clearance_sampled_m, refined.min_clearance_m,
          refined.min_clearance_sampled_m);
  CHECK(plain.min_clearance_m <= dense.min_m + kDistanceTolerance_m);
  CHECK(refined.min_clearance_m <= dense.min_m + kDistanceTolerance_m);
  CHECK(refined.min_clearance_m >= 0.0);
  CHECK(refined.min_clearance_m <= refined.min_clearance_sampled_m);
  CHECK(refined.min_clearance_sampled_m - refined.min_clearance_m <= kClearanceTolerance_m + 1e-12);
  CHECK(refined.min_clearance_m >= dense.min_m - dense.slack_m - kClearanceTolerance_m - kDistanceTolerance_m);
  return plain.min_clearance_sampled_m;
}

}  // namespace

TEST_CASE("min_clearance_m bounds the dense minimum along planned paths from below, within the tolerance", "[oracle]") {
  for (const char* scenario : kScenarios) {
    for (std::uint64_t seed = 0; seed < 2; ++seed) {
      CAPTURE(scenario, seed);
      Fixture f(scenario, seed);
      auto planner = make_planner("rrt-connect");
      REQUIRE(run(*planner, f.problem) == PlannerStatus::Solved);
      const std::vector<JointVector> path = planner->path();
      const MachineModel& model = *f.loaded.model;
      CollisionWorld& world = *f.loaded.world;
      const Dense dense = dense_minimum(model, world, path);
      // The planner's step, and so coarse that only the path's nodes are measured.
      for (const double coarse : {1.0, 1e3}) {
        CAPTURE(coarse);
        check_against_dense(model, world, path, coarse * f.problem.step, dense);
      }
    }
  }
}

TEST_CASE("min_clearance_m catches a load passing low over the frame between two samples", "[oracle]") {
  Fixture f("thesis-steel-frame.yaml");
  const MachineModel& model = *f.loaded.model;
  CollisionWorld& world = *f.loaded.world;
  // Luff up and hoist, swing over the steel frame from the north laydown area to the south one, come
  // back down: the boom just high enough (2 deg steps) and the load as low as clears the frame (0.25 m
  // steps), so the load passes just over it mid-swing, while at both ends the nearest obstacle is the
  // carrier's, 1.15 m off.
  constexpr int kElevation = 1;
  constexpr int kCable = 3;
  const JointVector step = f.problem.step;
  JointVector up = f.problem.start;
  JointVector across = f.problem.goal;
  const auto set = [&](int joint, double value) {
    up[joint] = value;
    across[joint] = value;
  };
  const auto clear = [&] { return world.validate_edge(up, across, step).valid(); };
  set(kCable, model.joints()[kCable].position_min);
  while (!clear()) {
    set(kElevation, up[kElevation] + 2.0 * kDeg);
    REQUIRE(up[kElevation] < model.joints()[kElevation].position_max);
  }
  while (up[kCable] + 0.25 < f.problem.start[kCable]) {
    set(kCable, up[kCable] + 0.25);
    if (!clear()) {
      set(kCable, up[kCable] - 0.25);
      break;
    }
  }
  const std::vector<JointVector> path{f.problem.start, up, across, f.problem.goal};
  for (std::size_t e = 0; e + 1 < path.size(); ++e) REQUIRE(world.validate_edge(path[e], path[e + 1], step).valid());
  const Dense dense = dense_minimum(model, world, path);
  REQUIRE(dense.min_m < 1.0);
  check_against_dense(model, world, path, step, dense);
  // Measured only at the nodes, the samples overstate the minimum: the bound does not.
  CHECK(check_against_dense(model, world, path, 1e3 * step, dense) > dense.min_m + 0.1);
}
