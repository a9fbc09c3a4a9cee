// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/excavator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace mgc::planning {

namespace {

// Frame at `origin` (swing-frame coordinates) whose z axis points along the direction
// (cos angle, 0, sin angle) of the swing plane and whose y axis is the swing frame's y (the pin
// axis): R_y(pi/2 - angle) carries z onto that direction.
Eigen::Isometry3d link_frame(const Eigen::Isometry3d& swing_frame, const Eigen::Vector3d& origin, double angle_rad) {
  Eigen::Isometry3d t = swing_frame * Eigen::Translation3d(origin);
  t.rotate(Eigen::AngleAxisd(0.5 * std::numbers::pi - angle_rad, Eigen::Vector3d::UnitY()));
  return t;
}

void require_positive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("excavator geometry: ") + field + " must be a positive length, got " +
                                std::to_string(value));
  }
}

void require_positive(const Eigen::Vector3d& size, const char* field) {
  for (int k = 0; k < 3; ++k) {
    if (!(size[k] > 0.0) || !std::isfinite(size[k])) {
      throw std::invalid_argument(std::string("excavator geometry: every entry of ") + field + " must be positive");
    }
  }
}

}  // namespace

Excavator::Excavator(std::string name, std::vector<JointSpec> joints, const ExcavatorGeometry& geometry,
                     const Eigen::Isometry3d& world_from_base)
    : MachineModel(std::move(name), std::move(joints), world_from_base), geometry_(geometry) {
  static constexpr const char* kJointNames[] = {"swing", "boom", "arm", "bucket"};
  if (joints_.size() != 4) {
    throw std::invalid_argument("an excavator has 4 joints: swing, boom, arm, bucket; got " +
                                std::to_string(joints_.size()));
  }
  for (std::size_t i = 0; i < 4; ++i) {
    if (joints_[i].name != kJointNames[i] || joints_[i].type != JointType::Revolute) {
      throw std::invalid_argument(std::string("excavator joint ") + std::to_string(i) + " must be '" + kJointNames[i] +
                                  "' (revolute)");
    }
  }
  const auto& g = geometry_;
  require_positive(g.boom_length_m, "boom_length_m");
  require_positive(g.arm_length_m, "arm_length_m");
  require_positive(g.bucket_length_m, "bucket_length_m");
  require_positive(g.boom_foot_height_m, "boom_foot_height_m");
  require_positive(g.undercarriage_size_m, "undercarriage_size_m");
  require_positive(g.house_size_m, "house_size_m");
  require_positive(g.cab_size_m, "cab_size_m");
  require_positive(g.boom_width_m, "boom_width_m");
  require_positive(g.boom_depth_m, "boom_depth_m");
  require_positive(g.arm_width_m, "arm_width_m");
  require_positive(g.arm_depth_m, "arm_depth_m");
  require_positive(g.bucket_width_m, "bucket_width_m");
  require_positive(g.bucket_depth_m, "bucket_depth_m");

  frame_names_ = {"base", "swing", "boom_foot", "arm_pin", "bucket_pin", "bucket_tip"};
  bodies_ = {{"undercarriage", BodyShape::Box, false}, {"house", BodyShape::Box, false},
             {"cab", BodyShape::Box, false},           {"boom", BodyShape::Box, false},
             {"arm", BodyShape::Box, false},           {"bucket", BodyShape::Box, false}};
  key_point_names_ = {"boom_foot", "arm_pin", "bucket_pin", "bucket_tip"};
  self_pairs_ = {{kBucketBody, kUndercarriage}, {kBucketBody, kCab}, {kBucketBody, kHouse}};

  // Farthest body point from each joint's axis: the links beyond it laid out straight, plus the
  // largest half cross-section; the house and cab corners for the swing.
  const auto& eg = geometry_;
  const double half_section = 0.5 * std::max({std::hypot(eg.boom_width_m, eg.boom_depth_m),
                                              std::hypot(eg.arm_width_m, eg.arm_depth_m),
                                              std::hypot(eg.bucket_width_m, eg.bucket_depth_m)});
  const double from_bucket_pin = eg.bucket_length_m + half_section;
  const double from_arm_pin = eg.arm_length_m + from_bucket_pin;
  const double from_foot = eg.boom_length_m + from_arm_pin;
  const auto corner_reach = [](const Eigen::Vector3d& centre, const Eigen::Vector3d& size) {
    return centre.head<2>().norm() + 0.5 * size.head<2>().norm();
  };
  const double swing_reach = std::max({std::abs(eg.boom_foot_forward_m) + from_foot, corner_reach(eg.house_centre_m, eg.house_size_m),
                                       corner_reach(eg.cab_centre_m, eg.cab_size_m)});
  displacement_bound_ = {swing_reach, from_foot, from_arm_pin, from_bucket_pin};
}

void Excavator::forward_kinematics(const JointVector& q, Kinematics& out) const noexcept {
  const auto& g = geometry_;
  const double a2 = q[kBoom];
  const double a3 = a2 + q[kArm];
  const double a4 = a3 + q[kBucket];

  // Seed 003 §1.1 in the swing plane: x = horizontal distance from the swing axis, z = height.
  const Eigen::Vector3d foot(g.boom_foot_forward_m, 0.0, g.boom_foot_height_m);
  const Eigen::Vector3d arm_pin = foot + g.boom_length_m * Eigen::Vector3d(std::cos(a2), 0.0, std::sin(a2));
  const Eigen::Vector3d bucket_pin = arm_pin + g.arm_length_m * Eigen::Vector3d(std::cos(a3), 0.0, std::sin(a3));
  const Eigen::Vector3d tip = bucket_pin + g.bucket_length_m * Eigen::Vector3d(std::cos(a4), 0.0, std::sin(a4));

  const Eigen::Isometry3d swing_frame = world_from_base_ * Eigen::AngleAxisd(q[kSwing], Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d boom_frame = link_frame(swing_frame, foot, a2);
  const Eigen::Isometry3d arm_frame = link_frame(swing_frame, arm_pin, a3);
  const Eigen::Isometry3d bucket_frame = link_frame(swing_frame, bucket_pin, a4);
  Eigen::Isometry3d tip_frame = bucket_frame;
  tip_frame.translation() = swing_frame * tip;

  out.frames[kFrameBase] = world_from_base_;
  out.frames[kFrameSwing] = swing_frame;
  out.frames[kFrameBoomFoot] = boom_frame;
  out.frames[kFrameArmPin] = arm_frame;
  out.frames[kFrameBucketPin] = bucket_frame;
  out.frames[kFrameBucketTip] = tip_frame;

  auto& undercarriage = out.bodies[kUndercarriage];
  undercarriage.world_from_body = world_from_base_ * Eigen::Translation3d(g.undercarriage_centre_m);
  undercarriage.size_m = g.undercarriage_size_m;

  auto& house = out.bodies[kHouse];
  house.world_from_body = swing_frame * Eigen::Translation3d(g.house_centre_m);
  house.size_m = g.house_size_m;

  auto& cab = out.bodies[kCab];
  cab.world_from_body = swing_frame * Eigen::Translation3d(g.cab_centre_m);
  cab.size_m = g.cab_size_m;

  // Link boxes are centred between their pins, body z along the link, size (depth, width, length).
  const auto link_body = [&](BodyState& body, const Eigen::Isometry3d& frame, const Eigen::Vector3d& from,
                             const Eigen::Vector3d& to, double depth_m, double width_m, double length_m) {
    body.world_from_body.linear() = frame.linear();
    body.world_from_body.translation() = swing_frame * (0.5 * (from + to));
    body.size_m = Eigen::Vector3d(depth_m, width_m, length_m);
  };
  link_body(out.bodies[kBoomBody], boom_frame, foot, arm_pin, g.boom_depth_m, g.boom_width_m, g.boom_length_m);
  link_body(out.bodies[kArmBody], arm_frame, arm_pin, bucket_pin, g.arm_depth_m, g.arm_width_m, g.arm_length_m);
  link_body(out.bodies[kBucketBody], bucket_frame, bucket_pin, tip, g.bucket_depth_m, g.bucket_width_m,
            g.bucket_length_m);

  out.points[kPointBoomFoot] = boom_frame.translation();
  out.points[kPointArmPin] = arm_frame.translation();
  out.points[kPointBucketPin] = bucket_frame.translation();
  out.points[kPointBucketTip] = tip_frame.translation();
}

double bucket_ground_angle_rad(const JointVector& q) noexcept {
  return q[Excavator::kBoom] + q[Excavator::kArm] + q[Excavator::kBucket];
}

std::vector<JointSpec> default_excavator_joints() {
  // Ranges: chosen so that the model's envelope reproduces the Cat 320 spec sheet's maximum
  // digging depth, reach at ground level and cutting height (docs/machines.md, envelope test).
  // Speeds: DOMAIN-FACTS §5.2 (Cat 320 swing 11.3 rpm; boom/stick/bucket means from the Cat 323F
  // cylinder times). Full speed in 1.0 s (swing) and 0.5 s (cylinders), full acceleration in
  // 0.25 s: assumptions, reasoning in docs/machines.md.
  constexpr double kDeg = std::numbers::pi / 180.0;
  constexpr double kSwingRpm = 11.3;
  constexpr double kSwingRampS = 1.0;
  constexpr double kCylinderRampS = 0.5;
  constexpr double kJerkRampS = 0.25;

  const auto joint = [&](const char* name, bool continuous, double lo, double hi, double v, double ramp_s) {
    return joint_from_ramps(name, JointType::Revolute, continuous, lo, hi, v, ramp_s, kJerkRampS);
  };
  return {
      joint("swing", true, -std::numbers::pi, std::numbers::pi, kSwingRpm * 2.0 * std::numbers::pi / 60.0, kSwingRampS),
      joint("boom", false, -50.0 * kDeg, 60.0 * kDeg, 24.0 * kDeg, kCylinderRampS),
      joint("arm", false, -155.0 * kDeg, -30.0 * kDeg, 34.0 * kDeg, kCylinderRampS),
      joint("bucket", false, -170.0 * kDeg, 10.0 * kDeg, 45.0 * kDeg, kCylinderRampS),
  };
}

}  // namespace mgc::planning
