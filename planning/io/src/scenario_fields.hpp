// SPDX-License-Identifier: Apache-2.0
#pragma once

// The sections a scenario file shares with a site file (docs/scenario-format.md), read the same
// way by both loaders. Each throws InputError naming the file, line and field.

#include <filesystem>
#include <vector>

#include "mgc/planning/scenario.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {

//! A `machine` field: a machine file relative to `folder`, which must exist and be readable; `owner`
//! ("scenario", "site") names the file whose folder that is in the message.
[[nodiscard]] MachineDefinition read_machine_field(const Value& value, const std::filesystem::path& folder, const char* owner);
//! An `obstacles` list; names unique within it.
void read_static_obstacles(const Value& value, std::vector<StaticObstacle>& out);
//! A `start` or `goal`: one field per joint, within the joint ranges.
[[nodiscard]] JointVector read_configuration_field(const Value& value, const MachineDefinition& machine);
//! A crane's `task`.
[[nodiscard]] TaskSpec read_task_field(const Value& value, const MachineDefinition& machine);
//! A `planner` section.
[[nodiscard]] PlannerParams read_planner_field(const Value& value);

}  // namespace mgc::planning::io
