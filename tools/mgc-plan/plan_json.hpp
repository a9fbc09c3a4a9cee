// SPDX-License-Identifier: Apache-2.0
#pragma once

// The pieces of mgc-plan's output files shared by a single query and a work cycle
// (docs/plan-json.md): configurations in file units, paths with their moving joints, metrics,
// and the SVG file.

#include <string>
#include <vector>

#include "json_writer.hpp"
#include "svg_view.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/path_metrics.hpp"

namespace mgc::tools {

//! One configuration in file units: degrees for revolute joints, metres for prismatic ones.
void write_configuration(JsonWriter& j, const planning::MachineModel& model, const planning::JointVector& q);
//! `joint_names` and `joint_units`.
void write_joints(JsonWriter& j, const planning::MachineModel& model);
//! `path` and `moving_joint` (per edge: the joint it moves, -1 for several).
void write_path(JsonWriter& j, const planning::MachineModel& model, const std::vector<planning::JointVector>& path);
//! The path metrics every plan reports.
void write_metrics(JsonWriter& j, const planning::PathMetrics& m);
//! Writes the SVG views to file; false (and one line on stderr) when the file cannot be written.
[[nodiscard]] bool write_svg_file(const std::string& file, const SvgInput& view);

}  // namespace mgc::tools
