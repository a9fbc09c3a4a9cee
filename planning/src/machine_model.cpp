// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/machine_model.hpp"

#include <cmath>
#include <numbers>
#include <utility>

namespace mgc::planning {

double wrap_angle(double angle_rad) noexcept {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  double wrapped = angle_rad + std::numbers::pi;
  // Within a turn or two (differences of wrapped angles, one step past +-pi) fmod is the identity
  // or one exact subtraction (Sterbenz), without fmod's cost; the result is bit for bit the same.
  if (wrapped >= kTwoPi && wrapped < 2.0 * kTwoPi) {
    wrapped -= kTwoPi;
  } else if (!(std::abs(wrapped) < kTwoPi)) {
    wrapped = std::fmod(wrapped, kTwoPi);
  }
  if (wrapped < 0.0) wrapped += kTwoPi;
  // A negative wrapped within half an ulp of 0 rounds onto 2 pi when raised, which would give +pi.
  if (wrapped >= kTwoPi) wrapped -= kTwoPi;
  return wrapped - std::numbers::pi;
}

double shorter_turn(double delta_rad) noexcept {
  const double turn = wrap_angle(delta_rad);
  return turn > std::numbers::pi - kHalfTurnTolerance_rad ? turn - 2.0 * std::numbers::pi : turn;
}

JointSpec joint_from_ramps(const char* name, JointType type, bool continuous, double position_min, double position_max,
                           double max_velocity, double accel_ramp_s, double jerk_ramp_s) {
  JointSpec j;
  j.name = name;
  j.type = type;
  j.continuous = continuous;
  j.position_min = position_min;
  j.position_max = position_max;
  j.max_velocity = max_velocity;
  j.max_acceleration = max_velocity / accel_ramp_s;
  j.max_jerk = j.max_acceleration / jerk_ramp_s;
  return j;
}

bool JointSpec::contains(double value) const noexcept {
  if (!std::isfinite(value)) return false;
  if (continuous) return true;
  return value >= position_min && value <= position_max;
}

const char* to_string(MachineKind kind) noexcept {
  switch (kind) {
    case MachineKind::MobileCrane: return "mobile_crane";
    case MachineKind::TowerCrane: return "tower_crane";
    case MachineKind::Excavator: return "excavator";
  }
  return "unknown";
}

const char* to_string(ConstraintStatus status) noexcept {
  switch (status) {
    case ConstraintStatus::Ok: return "ok";
    case ConstraintStatus::BoomLengthOutsideChart: return "boom length outside the chart";
    case ConstraintStatus::LoadAboveChart: return "no capacity of the chart row exceeds the load";
    case ConstraintStatus::BoomBelowChartAngle: return "boom elevation below the chart minimum";
    case ConstraintStatus::BoomAboveChartAngle: return "boom elevation above the allowed maximum";
    case ConstraintStatus::LoadBelowGround: return "load below the ground";
    case ConstraintStatus::CableTooShort: return "cable too short";
    case ConstraintStatus::NoEquilibrium: return "no suspension equilibrium with the cable tilt within its limit";
    case ConstraintStatus::TipDistance: return "boom tips too far apart or too close to hang the load";
    case ConstraintStatus::CableTilt: return "cable tilt above its limit";
    case ConstraintStatus::GirderTilt: return "girder tilt above its limit";
    case ConstraintStatus::CraneOverload: return "cable tension above the crane's rated capacity";
  }
  return "unknown";
}

MachineModel::MachineModel(std::string name, std::vector<JointSpec> joints,
                           const Eigen::Isometry3d& world_from_base)
    : name_(std::move(name)), joints_(std::move(joints)), world_from_base_(world_from_base) {}

namespace {
template <class Range, class Key>
int index_of(const Range& range, std::string_view name, Key key) {
  int i = 0;
  for (const auto& item : range) {
    if (key(item) == name) return i;
    ++i;
  }
  return -1;
}
}  // namespace

int MachineModel::joint_index(std::string_view name) const noexcept {
  return index_of(joints_, name, [](const JointSpec& j) -> const std::string& { return j.name; });
}
int MachineModel::body_index(std::string_view name) const noexcept {
  return index_of(bodies_, name, [](const BodySpec& b) -> const std::string& { return b.name; });
}
int MachineModel::key_point_index(std::string_view name) const noexcept {
  return index_of(key_point_names_, name, [](const std::string& s) -> const std::string& { return s; });
}

ConstraintVerdict MachineModel::check_constraints(const JointVector& /*q*/) const noexcept { return {}; }

ConstraintVerdict MachineModel::check_edge_constraints(const JointVector& /*from*/, const JointVector& /*to*/,
                                                       double& t_first) const noexcept {
  t_first = 1.0;
  return {};
}

double MachineModel::edge_displacement_bound(const JointVector& /*from*/, const JointVector& /*to*/,
                                             int joint) const noexcept {
  return displacement_bound(joint);
}

double MachineModel::box_displacement_bound(const JointVector& /*lo*/, const JointVector& /*hi*/,
                                            int joint) const noexcept {
  return displacement_bound(joint);
}

int MachineModel::edge_min_samples(const JointVector& /*from*/, const JointVector& /*to*/) const noexcept { return 1; }

int MachineModel::joint_out_of_range(const JointVector& q) const noexcept {
  for (int i = 0; i < dof(); ++i) {
    if (!joints_[static_cast<std::size_t>(i)].contains(q[i])) return i;
  }
  return -1;
}

JointVector MachineModel::difference(const JointVector& from, const JointVector& to) const noexcept {
  JointVector d = to - from;
  for (int i = 0; i < dof(); ++i) {
    if (joints_[static_cast<std::size_t>(i)].continuous) d[i] = shorter_turn(d[i]);
  }
  return d;
}

JointVector MachineModel::interpolate(const JointVector& from, const JointVector& to, double t) const noexcept {
  JointVector q = from + t * difference(from, to);
  for (int i = 0; i < dof(); ++i) {
    if (joints_[static_cast<std::size_t>(i)].continuous) q[i] = wrap_angle(q[i]);
  }
  return q;
}

Eigen::Vector3d hang_load(const Eigen::Matrix3d& heading, const Eigen::Vector3d& top, const Eigen::Vector3d& hook,
                          const Eigen::Vector3d& up, double cable_radius_m, double cable_length_m,
                          const Eigen::Vector3d& load_size_m, double sling_length_m, BodyState& cable,
                          BodyState& sling, BodyState& load) noexcept {
  cable.world_from_body.linear() = heading;
  cable.world_from_body.translation() = 0.5 * (top + hook);
  cable.size_m = Eigen::Vector3d(2.0 * cable_radius_m, 2.0 * cable_radius_m, cable_length_m);
  load.world_from_body.linear() = heading;
  load.world_from_body.translation() = hook - (sling_length_m + 0.5 * load_size_m.z()) * up;
  load.size_m = load_size_m;
  // Slings from the hook to the load's top corners (or any lifting points on its top face) lie
  // in the pyramid from the hook to that face, and the pyramid lies in the box over the face up
  // to the hook. Without a sling there is nothing between hook and load: the box is the load's
  // own, not a degenerate flat one.
  sling.world_from_body.linear() = heading;
  if (sling_length_m > 0.0) {
    sling.world_from_body.translation() = hook - 0.5 * sling_length_m * up;
    sling.size_m = Eigen::Vector3d(load_size_m.x(), load_size_m.y(), sling_length_m);
  } else {
    sling.world_from_body.translation() = load.world_from_body.translation();
    sling.size_m = load_size_m;
  }
  return hook - (sling_length_m + load_size_m.z()) * up;
}

Eigen::Isometry3d dh_modified(double alpha_prev_rad, double a_prev_m, double theta_rad, double d_m) noexcept {
  // Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d) multiplied out (Craig's form): forward
  // kinematics runs at every collision query, and composing the four takes several times as long.
  const double ca = std::cos(alpha_prev_rad);
  const double sa = std::sin(alpha_prev_rad);
  const double ct = std::cos(theta_rad);
  const double st = std::sin(theta_rad);
  Eigen::Isometry3d t;
  t.linear() << ct, -st, 0.0,
                st * ca, ct * ca, -sa,
                st * sa, ct * sa, ca;
  t.translation() << a_prev_m, -sa * d_m, ca * d_m;
  t.makeAffine();
  return t;
}

}  // namespace mgc::planning
