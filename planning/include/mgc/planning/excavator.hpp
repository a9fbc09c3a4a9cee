// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>
#include <vector>

#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! Fixed dimensions of a hydraulic backhoe excavator. Link lengths are pin to pin (pin to tip for
//! the bucket). Boxes that turn with the swing are given in the swing frame: x forward along the
//! boom, y to the left, z up, origin on the ground at the swing axis. The defaults are a Cat 320
//! with the 5.7 m reach boom, R2.9 stick and a 1.19 m3 bucket; docs/machines.md gives the source
//! or the reasoning for every number. [m]
struct ExcavatorGeometry {
  double boom_length_m = 5.7;              //!< boom foot pin to arm (stick) pin [m]
  double arm_length_m = 2.9;               //!< arm pin to bucket pin [m]
  double bucket_length_m = 1.47;           //!< bucket pin to tooth tip ("tip radius") [m]
  double boom_foot_forward_m = 0.25;       //!< boom foot pin ahead of the swing axis (a0) [m]
  double boom_foot_height_m = 2.0;         //!< boom foot pin above the ground (h0) [m]
  Eigen::Vector3d undercarriage_size_m{4.45, 3.17, 1.0};       //!< tracks and carbody, base frame [m]
  Eigen::Vector3d undercarriage_centre_m{0.0, 0.0, 0.5};       //!< in the base frame [m]
  Eigen::Vector3d house_size_m{4.03, 2.78, 1.45};              //!< upper frame incl. counterweight [m]
  Eigen::Vector3d house_centre_m{-0.815, 0.0, 1.775};          //!< in the swing frame [m]
  Eigen::Vector3d cab_size_m{1.8, 1.0, 1.91};                  //!< operator cab [m]
  Eigen::Vector3d cab_centre_m{0.15, 0.89, 2.005};             //!< in the swing frame (left front) [m]
  double boom_width_m = 0.6;               //!< boom cross-section along the pin axis [m]
  double boom_depth_m = 0.8;               //!< boom cross-section in the digging plane [m]
  double arm_width_m = 0.45;               //!< [m]
  double arm_depth_m = 0.6;                //!< [m]
  double bucket_width_m = 1.2;             //!< along the pin axis [m]
  double bucket_depth_m = 1.0;             //!< across the pin-to-tip line, in the digging plane [m]
};

//! Hydraulic excavator upper structure after seed 003 (Langari & Hammad), §1.1:
//! q = (swing [rad], boom [rad above horizontal of the foot-pin-to-arm-pin line],
//!      arm [rad, relative to the boom line], bucket [rad, relative to the arm line]).
//!
//! Planar chain in the swing plane, (horizontal distance from the swing axis, height):
//!   boom foot  = (a0, h0)
//!   arm pin    = foot       + L_boom   (cos b2, sin b2)
//!   bucket pin = arm pin    + L_arm    (cos(b2+b3), sin(b2+b3))
//!   tip        = bucket pin + L_bucket (cos(b2+b3+b4), sin(b2+b3+b4))
//! rotated by swing about the base z axis (swing = 0: the boom points along base +x). Angles grow
//! upwards, so curling the arm or the bucket in is negative.
class Excavator final : public MachineModel {
 public:
  enum Joint : int { kSwing = 0, kBoom = 1, kArm = 2, kBucket = 3 };
  //! Link frames: z along the link (boom, arm, bucket), y along the pin axis (the swing frame's y).
  //! kFrameBucketTip has the bucket's axes.
  enum Frame : int { kFrameBase = 0, kFrameSwing, kFrameBoomFoot, kFrameArmPin, kFrameBucketPin, kFrameBucketTip };
  enum Body : int { kUndercarriage = 0, kHouse, kCab, kBoomBody, kArmBody, kBucketBody };
  enum Point : int { kPointBoomFoot = 0, kPointArmPin, kPointBucketPin, kPointBucketTip };

  //! Throws std::invalid_argument for joints that are not the four above in that order (all
  //! revolute) or for non-positive dimensions.
  Excavator(std::string name, std::vector<JointSpec> joints, const ExcavatorGeometry& geometry,
            const Eigen::Isometry3d& world_from_base);

  [[nodiscard]] MachineKind kind() const noexcept override { return MachineKind::Excavator; }
  //! RT-safe: no alloc, no lock, no throw.
  void forward_kinematics(const JointVector& q, Kinematics& out) const noexcept override;
  // check_constraints() is inherited and returns Ok: there is no rule beyond the joint ranges,
  // because digging below the ground is the machine's job.

  [[nodiscard]] const ExcavatorGeometry& geometry() const noexcept { return geometry_; }

 private:
  ExcavatorGeometry geometry_;
};

//! Bucket tilt against the ground, psi = boom + arm + bucket (seed 003 §1.1): the angle of the
//! pin-to-tip line above horizontal. Holding it keeps the soil in while the boom and arm move. [rad]
[[nodiscard]] double bucket_ground_angle_rad(const JointVector& q) noexcept;

//! The documented default joints for ExcavatorGeometry{} (docs/machines.md): swing continuous
//! over [-pi, pi) at 11.3 rpm; boom [-50, 60] deg, arm [-155, -30] deg, bucket [-170, 10] deg at
//! 24, 34 and 45 deg/s. SI units.
[[nodiscard]] std::vector<JointSpec> default_excavator_joints();

}  // namespace mgc::planning
