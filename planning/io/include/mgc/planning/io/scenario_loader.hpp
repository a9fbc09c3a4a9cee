// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::planning::io {

//! Reads a machine file (docs/scenario-format.md). Every field is checked: a missing or unknown
//! field, a wrong type, a non-finite number or an inverted range throws InputError.
[[nodiscard]] MachineDefinition load_machine(const std::filesystem::path& file);

//! Reads a scenario file and the machine file it names (relative to the scenario's folder).
//! Throws InputError as load_machine does, and also when the task does not fit the machine (a
//! load above every chart entry, a rigging the chart does not cover) or start or goal lies outside
//! the joint ranges.
[[nodiscard]] Scenario load_scenario(const std::filesystem::path& file);

//! A scenario with its model and world built, ready for queries.
struct LoadedScenario {
  Scenario scenario;
  std::unique_ptr<MachineModel> model;
  std::unique_ptr<CollisionWorld> world;
};

//! load_scenario() plus build_model() and build_world(), with construction errors reported as
//! InputError at the field responsible.
[[nodiscard]] LoadedScenario load_and_build(const std::filesystem::path& file);

//! Start and goal (and a work cycle's dumped and next-dig poses) against joint ranges, the
//! machine's constraints and collision at t = 0: one InputError per infeasible pose (empty when
//! all are feasible).
[[nodiscard]] std::vector<InputError> check_endpoints(LoadedScenario& loaded);

}  // namespace mgc::planning::io
