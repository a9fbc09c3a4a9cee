// SPDX-License-Identifier: Apache-2.0
#pragma once

// A shipped scenario loaded with its planning query, and a planner run to the end: shared by the
// planner suites.

#include <cstdint>
#include <string>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "test_support.hpp"

namespace mgc::test {

inline const char* const kScenarios[] = {"thesis-steel-frame.yaml", "thesis-steel-frame-tower.yaml",
                                         "excavator-pipelines.yaml"};

struct Fixture {
  planning::io::LoadedScenario loaded;
  planning::PlanningProblem problem;

  explicit Fixture(const std::string& name, std::uint64_t seed = 0)
      : loaded(planning::io::load_and_build(source_path("scenarios/" + name))),
        problem(planning::planning_problem(loaded.scenario, *loaded.model, *loaded.world)) {
    problem.seed = seed;
  }
};

inline planning::PlannerStatus run(planning::Planner& planner, const planning::PlanningProblem& problem,
                                   int budget = 1000) {
  planning::PlannerStatus status = planner.reset(problem);
  while (status == planning::PlannerStatus::Running) status = planner.step(budget);
  return status;
}

}  // namespace mgc::test
