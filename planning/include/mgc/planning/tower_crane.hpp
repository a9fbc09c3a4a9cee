// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>
#include <vector>

#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! Fixed dimensions of a top-slewing tower crane with a horizontal trolley jib. The defaults are a
//! Pecco SK 180 class crane (59.7 m jib, 1.8 m tower) in a 45 m free-standing hook-height set-up;
//! docs/machines.md gives the source or the reasoning for every number. [m]
struct TowerCraneGeometry {
  double jib_height_m = 47.0;            //!< jib bottom chord (trolley track) above the base [m]
  double jib_length_m = 59.7;            //!< slew axis to the jib tip = maximum trolley radius [m]
  double counter_jib_length_m = 20.0;    //!< slew axis to the end of the counter-jib [m]
  double mast_width_m = 1.8;             //!< square tower cross-section [m]
  double jib_width_m = 1.2;              //!< jib cross-section, horizontal [m]
  double jib_depth_m = 1.5;              //!< jib cross-section, vertical (counter-jib the same) [m]
  Eigen::Vector3d counterweight_size_m{2.0, 2.4, 2.0};  //!< along the counter-jib, across, vertical [m]
  double cable_radius_m = 0.15;          //!< hoist rope falls and hook block, as one capsule [m]
  double min_hook_drop_m = 2.0;          //!< closest approach of the hook to the jib bottom chord [m]

  //! Highest hook position: the hook block drawn up to its limit under the trolley. [m]
  [[nodiscard]] double max_hook_height_m() const noexcept { return jib_height_m - min_hook_drop_m; }
};

//! What hangs on the hook. The thesis applies no load chart to the tower crane, so there is none.
struct TowerLiftTask {
  Eigen::Vector3d load_size_m{2.0, 2.0, 1.0};  //!< box hung under the hook [m]
  double sling_length_m = 2.0;                 //!< hook to top of the load [m]
};

//! Tower crane as in the ICE-Planner thesis, App. B:
//! q = (slew [rad], trolley_radius [m from the slew axis], hook_height [m above the base]).
//!
//! Forward kinematics multiply the thesis's three link matrices literally,
//!   t01 = RotZ(theta1),
//!   t12 = [-1 0 0 0; 0 0 1 d2; 0 1 0 0; 0 0 0 1],
//!   t23 = [-1 0 0 0; 0 0 1 d3; 0 1 0 0; 0 0 0 1],
//! which puts the hook at (-d2 sin theta1, d2 cos theta1, d3) in the thesis's frame {0}. Frame {0}
//! is our base frame (z up, origin on the ground at the slew axis); d2 = trolley_radius,
//! d3 = hook_height and theta1 = slew - pi/2, so that slew = 0 points the jib along base +x and the
//! hook sits at (d2 cos slew, d2 sin slew, d3).
class TowerCrane final : public MachineModel {
 public:
  enum Joint : int { kSlew = 0, kTrolleyRadius = 1, kHookHeight = 2 };
  //! kFrameSlew, kFrameRadius and kFrameHook are the thesis frames {1}, {2}, {3}; {2} lies on the
  //! base plane under the trolley. kFrameTrolley is the trolley on the jib, with {3}'s axes.
  enum Frame : int { kFrameBase = 0, kFrameSlew, kFrameRadius, kFrameHook, kFrameTrolley };
  enum Body : int { kMast = 0, kJib, kCounterJib, kCable, kLoad, kSling };
  enum Point : int { kPointTrolley = 0, kPointHook, kPointLoadBottom, kPointJibTip };

  //! Throws std::invalid_argument for joints that are not the three above in that order, for
  //! non-positive dimensions, or for a load of non-positive size or a negative sling length.
  TowerCrane(std::string name, std::vector<JointSpec> joints, const TowerCraneGeometry& geometry,
             const TowerLiftTask& task, const Eigen::Isometry3d& world_from_base);

  [[nodiscard]] MachineKind kind() const noexcept override { return MachineKind::TowerCrane; }
  //! RT-safe: no alloc, no lock, no throw.
  void forward_kinematics(const JointVector& q, Kinematics& out) const noexcept override;
  //! CableTooShort when the hook is above max_hook_height_m(); LoadBelowGround when the bottom of
  //! the load is below the base plane. RT-safe.
  [[nodiscard]] ConstraintVerdict check_constraints(const JointVector& q) const noexcept override;

  [[nodiscard]] const TowerCraneGeometry& geometry() const noexcept { return geometry_; }
  [[nodiscard]] const TowerLiftTask& task() const noexcept { return task_; }

 private:
  TowerCraneGeometry geometry_;
  TowerLiftTask task_;
};

//! The documented default joints for TowerCraneGeometry{} (docs/machines.md): slew continuous over
//! [-pi, pi) at 0.8 rpm, trolley 3.0-59.7 m at 38 m/min, hook 0-45 m at 65 m/min (4-part line).
//! SI units.
[[nodiscard]] std::vector<JointSpec> default_tower_crane_joints();

}  // namespace mgc::planning
