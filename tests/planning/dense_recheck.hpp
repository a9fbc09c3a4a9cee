// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <catch2/catch.hpp>

#include <string>
#include <utility>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

namespace mgc::test {

// An independent check of a returned path: a fresh world (not the planner's) whose machine keeps
// half the planner's dilation -- the clearance validate_edge guarantees along the continuous
// motion -- every edge at a quarter of the planner's step, exact start and goal (unless the path
// is a piece of a lift: scenario_ends false).
inline void dense_recheck(const std::string& scenario, const std::vector<planning::JointVector>& path, bool scenario_ends = true) {
  using namespace mgc::planning;
  Scenario s = io::load_scenario(source_path("scenarios/" + scenario));
  s.planner.dilation_m *= 0.5;
  io::LoadedScenario fresh;
  fresh.model = build_model(s);
  fresh.world = build_world(s, *fresh.model);
  fresh.scenario = std::move(s);
  // Every sample by a collision query: the re-check shares nothing with the planner's shortcuts.
  fresh.world->certify_edges(false);
  const JointVector fine = step_sizes(*fresh.model, 4 * fresh.scenario.planner.space_resolution);
  REQUIRE(path.size() >= 2);
  if (scenario_ends) {
    CHECK(path.front() == fresh.scenario.start);
    CHECK(path.back() == fresh.scenario.goal);
  }
  CHECK(fresh.world->validate(path.front()).valid());
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    JointVector at;
    const Validity v = fresh.world->validate_edge(path[e], path[e + 1], fine, &at);
    CAPTURE(e, fresh.world->describe(v));
    REQUIRE(v.valid());
  }
}

}  // namespace mgc::test
