// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
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

//! One view of render_svg: world axis axis_x to the right and axis_y up, in pixels.
struct SvgPanel {
  int axis_x = 0;  //!< world axis drawn to the right (0 x, 1 y, 2 z)
  int axis_y = 1;  //!< world axis drawn up
  double min_x = 0.0;  //!< world coordinate at the panel's left edge [m]
  double min_y = 0.0;  //!< world coordinate at the panel's bottom edge [m]
  double scale = 1.0;  //!< [px/m]
  double offset_x = 0.0;  //!< the panel's left edge in the document [px]
  double height_px = 0.0;  //!< the panel is a square of this side [px]
  //! A world point's place in the document [px].
  [[nodiscard]] std::array<double, 2> map(const Eigen::Vector3d& p) const {
    return {offset_x + (p[axis_x] - min_x) * scale, height_px - (p[axis_y] - min_y) * scale};
  }
};

//! Where render_svg draws: one scale for both panels, fitted to everything drawn (the working
//! envelope's ceiling, floor and radius circles included when the scenario has an `envelope`).
struct SvgLayout {
  SvgPanel top;   //!< top view (x, y)
  SvgPanel side;  //!< side view (x, z)
  double span_m = 1.0;  //!< world length across a panel, margins aside [m]
};

//! The layout render_svg uses for this input.
[[nodiscard]] SvgLayout svg_layout(const SvgInput& input);

//! Top view (x right, y up) and side view (x right, z up), side by side, as one SVG document. The
//! scenario's working envelope, if it has one, is drawn dashed red-orange as the limiter
//! (guidance::Envelope) reads it: walls as lines in each view in which they stand edge-on, the
//! radius limits as circles and the slew limits as rays about the slew axis in the top view, the
//! height ceiling and depth floor as horizontal lines in the side view.
[[nodiscard]] std::string render_svg(const SvgInput& input);

}  // namespace mgc::tools
