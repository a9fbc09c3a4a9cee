// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/tower_crane.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace mgc::planning {

namespace {

// Thesis App. B link matrices, entered as printed.
Eigen::Isometry3d thesis_t01(double theta1_rad) noexcept {
  const double c1 = std::cos(theta1_rad);
  const double s1 = std::sin(theta1_rad);
  Eigen::Matrix4d m;
  m << c1, -s1, 0.0, 0.0,
       s1, c1, 0.0, 0.0,
       0.0, 0.0, 1.0, 0.0,
       0.0, 0.0, 0.0, 1.0;
  Eigen::Isometry3d t;
  t.matrix() = m;
  return t;
}

// t12 and t23 have the same form: a prismatic joint d along the previous frame's y axis.
Eigen::Isometry3d thesis_prismatic(double d_m) noexcept {
  Eigen::Matrix4d m;
  m << -1.0, 0.0, 0.0, 0.0,
       0.0, 0.0, 1.0, d_m,
       0.0, 1.0, 0.0, 0.0,
       0.0, 0.0, 0.0, 1.0;
  Eigen::Isometry3d t;
  t.matrix() = m;
  return t;
}

// A box lying horizontally along the slew frame's +x (sign = +1) or -x (sign = -1): body z runs
// along the box's long axis, body y along the slew frame's y.
Eigen::Isometry3d horizontal_body(const Eigen::Isometry3d& slew_frame, double sign, const Eigen::Vector3d& centre) {
  Eigen::Isometry3d t = slew_frame * Eigen::Translation3d(centre);
  t.rotate(Eigen::AngleAxisd(sign * 0.5 * std::numbers::pi, Eigen::Vector3d::UnitY()));
  return t;
}

void require_positive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("tower crane geometry: ") + field + " must be a positive length, got " +
                                std::to_string(value));
  }
}

}  // namespace

TowerCrane::TowerCrane(std::string name, std::vector<JointSpec> joints, const TowerCraneGeometry& geometry,
                       const TowerLiftTask& task, const Eigen::Isometry3d& world_from_base)
    : MachineModel(std::move(name), std::move(joints), world_from_base), geometry_(geometry), task_(task) {
  static constexpr const char* kJointNames[] = {"slew", "trolley_radius", "hook_height"};
  static constexpr JointType kJointTypes[] = {JointType::Revolute, JointType::Prismatic, JointType::Prismatic};
  if (joints_.size() != 3) {
    throw std::invalid_argument("a tower crane has 3 joints: slew, trolley_radius, hook_height; got " +
                                std::to_string(joints_.size()));
  }
  for (std::size_t i = 0; i < 3; ++i) {
    if (joints_[i].name != kJointNames[i] || joints_[i].type != kJointTypes[i]) {
      throw std::invalid_argument(std::string("tower crane joint ") + std::to_string(i) + " must be '" +
                                  kJointNames[i] + "' (" +
                                  (kJointTypes[i] == JointType::Revolute ? "revolute" : "prismatic") + ")");
    }
  }
  const auto& g = geometry_;
  require_positive(g.jib_height_m, "jib_height_m");
  require_positive(g.jib_length_m, "jib_length_m");
  require_positive(g.counter_jib_length_m, "counter_jib_length_m");
  require_positive(g.mast_width_m, "mast_width_m");
  require_positive(g.jib_width_m, "jib_width_m");
  require_positive(g.jib_depth_m, "jib_depth_m");
  require_positive(g.counterweight_size_m.x(), "counterweight_size_m.x");
  require_positive(g.counterweight_size_m.y(), "counterweight_size_m.y");
  require_positive(g.counterweight_size_m.z(), "counterweight_size_m.z");
  require_positive(g.cable_radius_m, "cable_radius_m");
  require_positive(g.min_hook_drop_m, "min_hook_drop_m");
  if (g.min_hook_drop_m >= g.jib_height_m) {
    throw std::invalid_argument("tower crane geometry: min_hook_drop_m must be below jib_height_m");
  }
  if (g.counterweight_size_m.x() > g.counter_jib_length_m) {
    throw std::invalid_argument("tower crane geometry: the counterweight is longer than the counter-jib");
  }
  for (int k = 0; k < 3; ++k) {
    if (!(task_.load_size_m[k] > 0.0)) throw std::invalid_argument("tower lift task: load_size_m must be positive");
  }
  if (!(task_.sling_length_m >= 0.0)) throw std::invalid_argument("tower lift task: sling_length_m must be >= 0");

  frame_names_ = {"base", "slew", "radius", "hook", "trolley"};
  bodies_ = {{"mast", BodyShape::Box, false},
             {"jib", BodyShape::Box, false},
             {"counter_jib", BodyShape::Box, false},
             {"cable", BodyShape::Capsule, true},
             {"load", BodyShape::Box, false},
             {"sling", BodyShape::Box, false}};
  key_point_names_ = {"trolley", "hook", "load_bottom", "jib_tip"};
  self_pairs_ = {{kLoad, kMast}, {kSling, kMast}};

  // Slewing: the farthest body point from the mast axis is at the jib tip or under the trolley's
  // farthest position (the load's corners; the sling has the load's footprint). Trolley and hoist
  // move points one for one.
  const auto& tg = geometry_;
  const double jib_reach = std::hypot(tg.jib_length_m, 0.5 * tg.jib_width_m);
  const double load_reach = joints_[kTrolleyRadius].position_max + 0.5 * task_.load_size_m.norm() + tg.cable_radius_m;
  const double counter_reach = std::hypot(tg.counter_jib_length_m, 0.5 * tg.counterweight_size_m.y());
  displacement_bound_ = {std::max({jib_reach, load_reach, counter_reach, 0.5 * std::sqrt(2.0) * tg.mast_width_m}), 1.0, 1.0};
}

void TowerCrane::forward_kinematics(const JointVector& q, Kinematics& out) const noexcept {
  const double slew = q[kSlew];
  const double d2 = q[kTrolleyRadius];
  const double d3 = q[kHookHeight];
  const auto& g = geometry_;

  // The thesis chain; its frame {0} is our base frame.
  const double theta1 = slew - 0.5 * std::numbers::pi;
  const Eigen::Isometry3d f1 = world_from_base_ * thesis_t01(theta1);
  const Eigen::Isometry3d f2 = f1 * thesis_prismatic(d2);
  const Eigen::Isometry3d f3 = f2 * thesis_prismatic(d3);
  const Eigen::Vector3d up = world_from_base_.linear().col(2);
  const Eigen::Vector3d hook = f3.translation();
  // The trolley runs on the jib's bottom chord, straight above the hook (the cable is vertical).
  const Eigen::Vector3d trolley = hook + (g.jib_height_m - d3) * up;

  out.frames[kFrameBase] = world_from_base_;
  out.frames[kFrameSlew] = f1;
  out.frames[kFrameRadius] = f2;
  out.frames[kFrameHook] = f3;
  out.frames[kFrameTrolley] = f3;
  out.frames[kFrameTrolley].translation() = trolley;

  // Bodies that turn with the slew use a z-up frame with x pointing along the jib.
  const Eigen::Isometry3d slew_frame = world_from_base_ * Eigen::AngleAxisd(slew, Eigen::Vector3d::UnitZ());

  auto& mast = out.bodies[kMast];
  mast.world_from_body = world_from_base_ * Eigen::Translation3d(0.0, 0.0, 0.5 * g.jib_height_m);
  mast.size_m = Eigen::Vector3d(g.mast_width_m, g.mast_width_m, g.jib_height_m);

  // Jib: from the slew axis to the tip, its bottom chord at jib height. Body x is vertical.
  auto& jib = out.bodies[kJib];
  const Eigen::Vector3d jib_centre(0.5 * g.jib_length_m, 0.0, g.jib_height_m + 0.5 * g.jib_depth_m);
  jib.world_from_body = horizontal_body(slew_frame, 1.0, jib_centre);
  jib.size_m = Eigen::Vector3d(g.jib_depth_m, g.jib_width_m, g.jib_length_m);

  // Counter-jib and counterweight as one box: the counterweight hangs from the counter-jib's top
  // chord at its end, so the box spans the deeper and the wider of the two over the whole length.
  const double top_m = g.jib_height_m + g.jib_depth_m;
  const double height_m = std::max(g.jib_depth_m, g.counterweight_size_m.z());
  auto& counter_jib = out.bodies[kCounterJib];
  counter_jib.world_from_body = horizontal_body(
      slew_frame, -1.0, Eigen::Vector3d(-0.5 * g.counter_jib_length_m, 0.0, top_m - 0.5 * height_m));
  const double width_m = std::max(g.jib_width_m, g.counterweight_size_m.y());
  counter_jib.size_m = Eigen::Vector3d(height_m, width_m, g.counter_jib_length_m);

  // A hook above its upper limit is reported by check_constraints(); the shape must still not get
  // a negative length.
  const double cable_length_m = std::max(0.0, g.jib_height_m - d3);
  out.points[kPointLoadBottom] = hang_load(slew_frame.linear(), trolley, hook, up, g.cable_radius_m, cable_length_m,
                                           task_.load_size_m, task_.sling_length_m, out.bodies[kCable], out.bodies[kSling],
                                           out.bodies[kLoad]);
  out.points[kPointTrolley] = trolley;
  out.points[kPointHook] = hook;
  out.points[kPointJibTip] = slew_frame * Eigen::Vector3d(g.jib_length_m, 0.0, g.jib_height_m);
}

ConstraintVerdict TowerCrane::check_constraints(const JointVector& q) const noexcept {
  ConstraintVerdict v;
  const double hook_m = q[kHookHeight];
  const double max_hook_m = geometry_.max_hook_height_m();
  if (hook_m > max_hook_m + 1e-9) {
    v.status = ConstraintStatus::CableTooShort;
    v.value = hook_m;
    v.limit = max_hook_m;
    return v;
  }
  // Touching the ground (a load set down at the pick) is allowed.
  const double load_bottom_m = hook_m - task_.sling_length_m - task_.load_size_m.z();
  if (load_bottom_m < -1e-9) {
    v.status = ConstraintStatus::LoadBelowGround;
    v.value = load_bottom_m;
    v.limit = 0.0;
  }
  return v;
}

std::vector<JointSpec> default_tower_crane_joints() {
  const TowerCraneGeometry g;
  // Speeds: Pecco SK 180 data, 4-part line (docs/machines.md). Accelerations: full speed in 3 s
  // (slew) and 2 s (trolley, hoist); jerk: full acceleration in 0.5 s. Both are assumptions.
  constexpr double kSlewRpm = 0.8;
  constexpr double kTrolleyMPerMin = 38.0;
  constexpr double kHoistMPerMin = 65.0;
  constexpr double kSlewRampS = 3.0;
  constexpr double kTrolleyRampS = 2.0;
  constexpr double kHoistRampS = 2.0;
  constexpr double kJerkRampS = 0.5;
  constexpr double kTrolleyMinRadiusM = 3.0;

  const auto joint = [&](const char* name, JointType type, bool continuous, double lo, double hi, double v,
                         double ramp_s) { return joint_from_ramps(name, type, continuous, lo, hi, v, ramp_s, kJerkRampS); };
  return {
      joint("slew", JointType::Revolute, true, -std::numbers::pi, std::numbers::pi,
            kSlewRpm * 2.0 * std::numbers::pi / 60.0, kSlewRampS),
      joint("trolley_radius", JointType::Prismatic, false, kTrolleyMinRadiusM, g.jib_length_m, kTrolleyMPerMin / 60.0,
            kTrolleyRampS),
      joint("hook_height", JointType::Prismatic, false, 0.0, g.max_hook_height_m(), kHoistMPerMin / 60.0, kHoistRampS),
  };
}

}  // namespace mgc::planning
