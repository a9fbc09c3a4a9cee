// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! Quality of a joint-space path (consecutive configurations joined by straight edges).
struct PathMetrics {
  int path_nodes = 0;
  int dof_switches = 0;                   //!< consecutive edges that move different joints
  int multi_joint_edges = 0;              //!< edges that move more than one joint
  double length_normalized = 0.0;         //!< seed 000: Euclidean length with every joint scaled to [0, 1] by its range [-]
  double roughness = 0.0;                 //!< seed 000 Eq. 3: as length_normalized, without the hoist (cranes) [-]
  double exec_time_sequential_s = 0.0;    //!< one joint at a time at full speed: sum over edges of sum_j |d_j| / v_j [s]
  double exec_time_simultaneous_s = 0.0;  //!< all joints together: sum over edges of max_j |d_j| / v_j [s]
  double cost = 0.0;                      //!< seed 000 Eq. 4 as used there: 0.5 t [min] + 0.5 roughness [-]
  //! Lower bound of clearance() (the dilated machine) along the whole continuous path, not only at
  //! its samples: see compute_path_metrics() [m]
  double min_clearance_m = 0.0;
  //! Smallest clearance() at any configuration measured (the samples at the check resolution and
  //! any refinement): the true least clearance lies in [min_clearance_m, this] [m]
  double min_clearance_sampled_m = 0.0;
};

//! Default for compute_path_metrics()'s clearance_tolerance_m. [m]
inline constexpr double kClearanceTolerance_m = 0.01;

//! Seed 000's Eq. 2 between two configurations: Euclidean with each joint scaled to [0, 1] by
//! its range (a continuous joint's range is a full turn, taken the short way round), with or
//! without the hoist joint (seed 000 leaves it out of roughness). [-]
[[nodiscard]] double normalized_distance(const MachineModel& model, const JointVector& a, const JointVector& b,
                                         bool include_hoist) noexcept;

//! The joint an edge moves: its index, -1 when none moves, -2 when several do.
[[nodiscard]] int moving_joint(const MachineModel& model, const JointVector& from, const JointVector& to) noexcept;

//! Metrics of `path`. Clearance is measured along every edge at `step` resolution; between two
//! measured configurations a and b, where no body point moves more than delta (the edge's
//! MachineModel::edge_displacement_bound times each joint's motion, summed over the joints, as
//! CollisionWorld::validate_edge bounds it), clearance changes no faster than the body points move,
//! so it is at least max(0, (d_a + d_b - delta) / 2) all the way. min_clearance_m is the least of
//! these bounds and the measured values. Stretches whose bound lies more than
//! clearance_tolerance_m below the least measured clearance are bisected (one more measurement
//! each time) until it does not, so min_clearance_m ends within clearance_tolerance_m of
//! min_clearance_sampled_m and of the true minimum; 0 or less keeps the first bound. The bound is
//! certified only for models whose displacement bound is strict (displacement_bound_is_strict()).
//! The metrics of `path` that need no world: every field but the two clearances, which stay 0.
[[nodiscard]] PathMetrics compute_motion_metrics(const MachineModel& model, const std::vector<JointVector>& path);

[[nodiscard]] PathMetrics compute_path_metrics(const MachineModel& model, CollisionWorld& world,
                                               const std::vector<JointVector>& path, const JointVector& step,
                                               double clearance_tolerance_m = kClearanceTolerance_m);

}  // namespace mgc::planning
