// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <vector>

#include "mgc/planning/collision_world.hpp"

namespace mgc::planning {

struct SmoothingOptions {
  //! Keep every edge moving one joint (the thesis's rules of action): shortcuts are axis-aligned
  //! staircases, one move per joint that differs. Off: shortcuts are straight joint-space edges.
  bool single_axis = true;
  int shortcut_attempts = 50;  //!< random (i, k) pairs tried
  std::uint64_t seed = 0;
};

//! Shortens a valid path and returns the new one (same start and goal): merges consecutive moves
//! of the same joint, then tries random shortcuts between nodes i < k, keeping one only when it
//! has fewer edges than the stretch it replaces and every new edge passes validate_edge at `step`.
//! The one-joint-at-a-time execution time never grows (a staircase moves each joint once, by its
//! net change). Deterministic for a seed. Post-processing: allocates.
[[nodiscard]] std::vector<JointVector> smooth_path(CollisionWorld& world, const std::vector<JointVector>& path,
                                                   const JointVector& step, const SmoothingOptions& options);

}  // namespace mgc::planning
