// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! One planning query and the thesis's parameters (ICE-Planner Table 4.1), in our units.
struct PlanningProblem {
  const MachineModel* model = nullptr;
  CollisionWorld* world = nullptr;  //!< validity: joint ranges, constraints, collision
  JointVector start;
  JointVector goal;
  //! Per-joint step: the extension step of one input and the resolution at which every edge is
  //! checked. [rad | m]
  JointVector step;
  //! Goal reached when every joint is within error_tolerance * step of the goal.
  double error_tolerance = 1.0;
  double goal_bias = 0.1;          //!< probability of sampling the goal
  int max_iterations = 1000;       //!< iteration cap (the thesis's Max_Nodes)
  int node_capacity = 0;           //!< node pool size per tree; 0: the planner's default
  double extend_steps = 5.0;       //!< straight-line planners: the Extend step epsilon, in steps
  std::uint64_t seed = 0;
};

//! The thesis's metric (App. D): Euclidean in steps, sqrt(sum((delta_i / step_i)^2)), with the
//! shorter way round for continuous joints. One step along any joint has length 1.
[[nodiscard]] double step_metric(const MachineModel& model, const JointVector& step, const JointVector& a,
                                 const JointVector& b) noexcept;

}  // namespace mgc::planning
