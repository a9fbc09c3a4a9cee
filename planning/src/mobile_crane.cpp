// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/mobile_crane.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace mgc::planning {

MobileCrane::MobileCrane(std::string name, std::vector<JointSpec> joints, const MobileCraneGeometry& geometry,
                         const LoadChart& chart, std::optional<LuffRangeTable> luff_table, const LiftTask& task,
                         const Eigen::Isometry3d& world_from_base)
    : MachineModel(std::move(name), std::move(joints), world_from_base),
      geometry_(geometry),
      chart_(chart),
      luff_table_(std::move(luff_table)),
      task_(task) {
  static constexpr const char* kJointNames[] = {"swing", "boom_elevation", "boom_length", "cable_length"};
  static constexpr JointType kJointTypes[] = {JointType::Revolute, JointType::Revolute, JointType::Prismatic,
                                              JointType::Prismatic};
  if (joints_.size() != 4) throw std::invalid_argument("a mobile crane has 4 joints: swing, boom_elevation, boom_length, cable_length");
  for (std::size_t i = 0; i < 4; ++i) {
    if (joints_[i].name != kJointNames[i] || joints_[i].type != kJointTypes[i]) {
      throw std::invalid_argument(std::string("mobile crane joint ") + std::to_string(i) + " must be '" +
                                  kJointNames[i] + "' (" + (kJointTypes[i] == JointType::Revolute ? "revolute" : "prismatic") + ")");
    }
  }
  if (task_.constraint == CraneConstraintMode::LoadChart) {
    rule_.emplace(chart_, task_.load_lb * (100.0 + task_.capacity_reduction_pct) / 100.0);
  }
  if (task_.constraint == CraneConstraintMode::LuffTable && !luff_table_) {
    throw std::invalid_argument("the luff-table constraint needs a luff range table in the machine");
  }
  frame_names_ = {"base", "swing", "boom_foot", "boom_tip", "hook"};
  bodies_ = {{"carrier", BodyShape::Box, false},
             {"superstructure", BodyShape::Box, false},
             {"boom", BodyShape::Box, true},
             {"cable", BodyShape::Capsule, true},
             {"load", BodyShape::Box, false},
             {"sling", BodyShape::Box, false}};
  key_point_names_ = {"boom_foot", "boom_tip", "hook", "load_bottom"};
  self_pairs_ = {{kLoad, kCarrier}, {kLoad, kSuperstructure}, {kSling, kCarrier}, {kSling, kSuperstructure}};

  // Farthest body points from each joint's axis. The cable, the sling and the load translate with
  // the boom tip (the cable stays vertical), so luffing moves them no more than the tip; the
  // sling's footprint is the load's, so the load's corners bound its reach too.
  const auto& g = geometry_;
  const double boom_max = joints_[kBoomLength].position_max;
  const double boom_half_section = 0.5 * std::hypot(g.boom_width_m, g.boom_depth_m);
  const double load_half_diagonal = 0.5 * task_.load_size_m.norm();
  const double superstructure_reach =
      g.superstructure_centre_m.head<2>().norm() + 0.5 * g.superstructure_size_m.head<2>().norm();
  superstructure_reach_m_ = superstructure_reach;
  boom_margin_m_ = std::max(boom_half_section, load_half_diagonal + g.cable_radius_m);
  const double swing_reach = std::max(superstructure_reach, std::abs(g.boom_foot_forward_m) + boom_max + boom_margin_m_);
  displacement_bound_ = {swing_reach, boom_max + boom_half_section, 1.0, 1.0};
}

double MobileCrane::edge_displacement_bound(const JointVector& from, const JointVector& to, int joint) const noexcept {
  return reach_bound(std::max(from[kBoomLength], to[kBoomLength]),
                     std::min(from[kBoomElevation], to[kBoomElevation]), joint);
}

double MobileCrane::box_displacement_bound(const JointVector& lo, const JointVector& hi, int joint) const noexcept {
  return reach_bound(hi[kBoomLength], lo[kBoomElevation], joint);
}

double MobileCrane::reach_bound(double boom_m, double lowest_elevation, int joint) const noexcept {
  switch (joint) {
    case kSwing: {
      // cos falls over [0, 90 deg], so the lowest elevation reaches furthest out.
      const double elevation = std::clamp(lowest_elevation, 0.0, 0.5 * std::numbers::pi);
      return std::max(superstructure_reach_m_,
                      std::abs(geometry_.boom_foot_forward_m) + boom_m * std::cos(elevation) + boom_margin_m_);
    }
    case kBoomElevation: return boom_m + 0.5 * std::hypot(geometry_.boom_width_m, geometry_.boom_depth_m);
    default: return 1.0;
  }
}

void MobileCrane::forward_kinematics(const JointVector& q, Kinematics& out) const noexcept {
  const double swing = q[kSwing];
  const double elevation = q[kBoomElevation];
  const double boom_length = q[kBoomLength];
  const double cable_length = q[kCableLength];
  const auto& g = geometry_;

  // The thesis chain, in its z-down frame {0}.
  const Eigen::Isometry3d world_from_thesis0 =
      world_from_base_ * Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX());
  const double theta1 = -swing;
  const double theta2 = 0.5 * std::numbers::pi - elevation;
  const Eigen::Isometry3d f1 = world_from_thesis0 * dh_modified(0.0, 0.0, theta1, -g.boom_foot_height_m);
  const Eigen::Isometry3d f2 = f1 * dh_modified(0.5 * std::numbers::pi, g.boom_foot_forward_m, theta2, 0.0);
  const Eigen::Isometry3d f3 = f2 * dh_modified(0.5 * std::numbers::pi, 0.0, 0.0, boom_length);
  // Zero-length link {Z}: 3R_Z = (1R2 2R3)^T cancels the boom's pitch, so {Z} keeps the swing
  // frame's axes at the boom tip and the cable runs along the thesis's z, straight down.
  Eigen::Isometry3d fz = f1;
  fz.translation() = f3.translation();
  const Eigen::Isometry3d f4 = fz * Eigen::Translation3d(0.0, 0.0, cable_length);

  out.frames[kFrameBase] = world_from_base_;
  out.frames[kFrameSwing] = f1;
  out.frames[kFrameBoomFoot] = f2;
  out.frames[kFrameBoomTip] = f3;
  out.frames[kFrameHook] = f4;

  const Eigen::Vector3d foot = f2.translation();
  const Eigen::Vector3d tip = f3.translation();
  const Eigen::Vector3d hook = f4.translation();
  const Eigen::Vector3d up = world_from_base_.linear().col(2);
  // Bodies that turn with the swing use a z-up swing frame with x pointing along the boom.
  Eigen::Isometry3d swing_frame = world_from_base_ * Eigen::AngleAxisd(swing, Eigen::Vector3d::UnitZ());

  auto& carrier = out.bodies[kCarrier];
  carrier.world_from_body = world_from_base_ * Eigen::Translation3d(g.carrier_centre_m);
  carrier.size_m = g.carrier_size_m;

  auto& superstructure = out.bodies[kSuperstructure];
  superstructure.world_from_body = swing_frame * Eigen::Translation3d(g.superstructure_centre_m);
  superstructure.size_m = g.superstructure_size_m;

  // Frame 3's z axis runs along the boom and its y axis along the luffing pin.
  auto& boom = out.bodies[kBoom];
  boom.world_from_body.linear() = f3.linear();
  boom.world_from_body.translation() = 0.5 * (foot + tip);
  boom.size_m = Eigen::Vector3d(g.boom_depth_m, g.boom_width_m, boom_length);

  out.points[kPointLoadBottom] = hang_load(swing_frame.linear(), tip, hook, up, g.cable_radius_m, cable_length, task_.load_size_m,
                                           task_.sling_length_m, out.bodies[kCable], out.bodies[kSling],
                                           out.bodies[kLoad]);
  out.points[kPointBoomFoot] = foot;
  out.points[kPointBoomTip] = tip;
  out.points[kPointHook] = hook;
}

ConstraintVerdict MobileCrane::check_constraints(const JointVector& q) const noexcept {
  ConstraintVerdict v;
  switch (task_.constraint) {
    case CraneConstraintMode::LoadChart: v = rule_->check(q[kBoomLength], q[kBoomElevation]); break;
    case CraneConstraintMode::LuffTable: v = luff_table_->check(q[kBoomLength], q[kBoomElevation]); break;
    case CraneConstraintMode::None: break;
  }
  if (!v.ok()) return v;
  // The load hangs straight below the boom tip; its bottom must stay above the ground plane of
  // the base. Touching (a load resting on the ground at the pick) is allowed.
  const double tip_height_m = geometry_.boom_foot_height_m + q[kBoomLength] * std::sin(q[kBoomElevation]);
  const double load_bottom_m = tip_height_m - q[kCableLength] - task_.sling_length_m - task_.load_size_m.z();
  if (load_bottom_m < -1e-9) {
    ConstraintVerdict g;
    g.status = ConstraintStatus::LoadBelowGround;
    g.value = load_bottom_m;
    g.limit = 0.0;
    return g;
  }
  return v;
}

ConstraintVerdict MobileCrane::check_edge_constraints(const JointVector& from, const JointVector& to,
                                                      double& t_first) const noexcept {
  t_first = 1.0;
  // interpolate() moves both linearly: neither is a continuous joint.
  const double to_boom_m = from[kBoomLength] + (to[kBoomLength] - from[kBoomLength]);
  const double to_elevation = from[kBoomElevation] + (to[kBoomElevation] - from[kBoomElevation]);
  switch (task_.constraint) {
    case CraneConstraintMode::LoadChart:
      return rule_->check_edge(from[kBoomLength], from[kBoomElevation], to_boom_m, to_elevation, t_first);
    case CraneConstraintMode::LuffTable:
      return luff_table_->check_edge(from[kBoomLength], from[kBoomElevation], to_boom_m, to_elevation, t_first);
    case CraneConstraintMode::None: break;
  }
  return {};
}

double MobileCrane::load_radius_m(const JointVector& q) const noexcept {
  return geometry_.boom_foot_forward_m + q[kBoomLength] * std::cos(q[kBoomElevation]);
}

}  // namespace mgc::planning
