// SPDX-License-Identifier: Apache-2.0
#pragma once

// Independent checks of a path between any two configurations: dense_recheck() fixes them to the
// scenario's start and goal, and a work cycle has four poses.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

namespace mgc::test {

//! Calls visit(q) at every configuration of every edge of `path` sampled at `step` resolution,
//! both ends included.
template <class Visit>
void for_each_dense_sample(const planning::MachineModel& model, const std::vector<planning::JointVector>& path,
                           const planning::JointVector& step, Visit&& visit) {
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const planning::JointVector d = model.difference(path[e], path[e + 1]);
    int n = 1;
    for (int i = 0; i < model.dof(); ++i) n = std::max(n, static_cast<int>(std::ceil(std::abs(d[i]) / step[i])));
    for (int k = 0; k <= n; ++k) visit(k == n ? path[e + 1] : model.interpolate(path[e], path[e + 1], static_cast<double>(k) / n));
  }
}

//! As dense_recheck(): a fresh world (not the planner's) whose machine keeps half the planner's
//! dilation -- the clearance validate_edge guarantees along the continuous motion -- checks every
//! edge at a quarter of the planner's step; the path must run exactly from `start` to `goal`.
inline void dense_recheck_between(const std::string& scenario, const std::vector<planning::JointVector>& path,
                                  const planning::JointVector& start, const planning::JointVector& goal) {
  using namespace mgc::planning;
  Scenario s = io::load_scenario(source_path("scenarios/" + scenario));
  s.planner.dilation_m *= 0.5;
  const auto model = build_model(s);
  const auto world = build_world(s, *model);
  world->certify_edges(false);  // every sample by a collision query
  const JointVector fine = step_sizes(*model, 4 * s.planner.space_resolution);
  REQUIRE(path.size() >= 2);
  CHECK(path.front() == start);
  CHECK(path.back() == goal);
  CHECK(world->validate(path.front()).valid());
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const Validity v = world->validate_edge(path[e], path[e + 1], fine);
    CAPTURE(e, world->describe(v));
    REQUIRE(v.valid());
  }
}

}  // namespace mgc::test
