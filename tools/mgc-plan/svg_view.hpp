// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>
#include <vector>

#include "mgc/planning/scenario.hpp"

namespace mgc::tools {

//! What to draw: the scenario's obstacles (dynamic ones at t = 0), the machine at start and goal,
//! the path of its tool point (hook or bucket tip), and optionally the planner's tree.
struct SvgInput {
  const planning::Scenario* scenario = nullptr;
  const planning::MachineModel* model = nullptr;
  std::vector<planning::JointVector> path;
  std::vector<planning::JointVector> tree_nodes;  //!< empty: no tree
  std::vector<int> tree_parents;
  planning::JointVector step;  //!< path sampling resolution [rad | m]
  //! Where to draw the dynamic obstacles, in scenario order; empty: where the scenario has them at t = 0.
  std::vector<Eigen::Isometry3d> dynamic_poses;
  std::string dynamic_poses_label = "as tracked at the end";  //!< the caption's words for dynamic_poses
};

//! Top view (x right, y up) and side view (x right, z up), side by side, as one SVG document.
[[nodiscard]] std::string render_svg(const SvgInput& input);

}  // namespace mgc::tools
