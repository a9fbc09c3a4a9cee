// SPDX-License-Identifier: Apache-2.0
// The work cycle's step() runs in the controller's loop like every planner's: no allocation.
#include <catch2/catch.hpp>

#include "allocation_counter.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/work_cycle.hpp"
#include "test_support.hpp"

using namespace mgc::planning;

TEST_CASE("work cycle step() does not allocate after reset", "[unit]") {
  auto loaded = io::load_and_build(mgc::test::source_path("scenarios/excavator-cycle.yaml"));
  PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
  WorkCyclePlanner planner(loaded.scenario.work_cycle.value().dumped, loaded.scenario.work_cycle.value().next_dig);
  // Warm up FCL's one-time buffers with a full query, then count a second one.
  problem.seed = 5;
  PlannerStatus status = planner.reset(problem);
  while (status == PlannerStatus::Running) status = planner.step(100);
  problem.seed = 6;
  status = planner.reset(problem);
  const long before = mgc::test::allocation_count();
  while (status == PlannerStatus::Running) status = planner.step(7);
  const long allocations = mgc::test::allocation_count() - before;
  CHECK(status == PlannerStatus::Solved);
  CHECK(planner.stats().iterations > 3);
  CHECK(allocations == 0);
}
