// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/dual_crane.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <type_traits>
#include <utility>

namespace mgc::planning {
namespace {

constexpr int kDualDof = 6;
constexpr int kJointsPerCrane = 3;

// The last suspension solved on this thread: check_constraints(q) and then forward_kinematics(q)
// -- what CollisionWorld::validate does -- solve once. Trivially destructible, so a thread's
// first use registers no destructor (and allocates nothing).
struct SuspensionCache {
  std::uint64_t model_id = 0;
  std::array<double, kDualDof> q{};
  Suspension suspension;
};
static_assert(std::is_trivially_destructible_v<SuspensionCache>);
thread_local SuspensionCache t_cache;

std::atomic<std::uint64_t> g_next_model_id{1};

// Appended rather than "_" + to_string(): GCC 12 at -O3 misreads the latter's insert at the front
// as an overlapping copy (-Wrestrict).
std::string crane_suffix(int crane) {
  std::string suffix(1, '_');
  suffix += std::to_string(crane + 1);
  return suffix;
}

// Pose of a capsule (axis along body z) between two points.
Eigen::Isometry3d segment_pose(const Eigen::Vector3d& from, const Eigen::Vector3d& to) noexcept {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d axis = to - from;
  const double length = axis.norm();
  if (length > 0.0) pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis / length).toRotationMatrix();
  pose.translation() = 0.5 * (from + to);
  return pose;
}

}  // namespace

std::vector<JointSpec> dual_crane_joints(const std::vector<JointSpec>& crane_joints, const DualCraneSpec& spec) {
  static constexpr const char* kCraneJoints[] = {"swing", "boom_elevation", "boom_length", "cable_length"};
  if (crane_joints.size() != 4) throw std::invalid_argument("a dual-crane lift needs mobile cranes (4 joints: swing, boom_elevation, boom_length, cable_length)");
  for (std::size_t i = 0; i < 4; ++i) {
    if (crane_joints[i].name != kCraneJoints[i]) {
      throw std::invalid_argument(std::string("crane joint ") + std::to_string(i) + " must be '" + kCraneJoints[i] + "'");
    }
  }
  const JointSpec& boom = crane_joints[2];
  std::vector<JointSpec> out;
  for (int crane = 0; crane < 2; ++crane) {
    const double boom_m = spec.cranes[static_cast<std::size_t>(crane)].boom_length_m;
    if (!(boom_m >= boom.position_min - 1e-9 && boom_m <= boom.position_max + 1e-9)) {
      throw std::invalid_argument("crane " + std::to_string(crane + 1) + "'s boom length " + std::to_string(boom_m) +
                                  " m is outside the crane's boom_length range [" + std::to_string(boom.position_min) +
                                  ", " + std::to_string(boom.position_max) + "] m");
    }
    for (const std::size_t j : {std::size_t{0}, std::size_t{1}, std::size_t{3}}) {
      JointSpec joint = crane_joints[j];
      joint.name += crane_suffix(crane);
      out.push_back(std::move(joint));
    }
    JointSpec& cable = out.back();
    cable.position_max = std::min(cable.position_max, boom_m);
    if (!(cable.position_max > cable.position_min)) {
      throw std::invalid_argument("crane " + std::to_string(crane + 1) + "'s boom of " + std::to_string(boom_m) +
                                  " m is no longer than the shortest cable");
    }
  }
  return out;
}

DualCraneModel::DualCraneModel(std::string name, std::vector<JointSpec> joints, const MobileCraneGeometry& geometry,
                               std::optional<LoadChart> chart, const DualCraneSpec& spec)
    : MachineModel(std::move(name), std::move(joints), Eigen::Isometry3d::Identity()),
      geometry_(geometry),
      chart_(std::move(chart)),
      spec_(spec),
      cache_id_(g_next_model_id.fetch_add(1)) {
  static constexpr const char* kNames[] = {"swing", "boom_elevation", "cable_length"};
  static constexpr JointType kTypes[] = {JointType::Revolute, JointType::Revolute, JointType::Prismatic};
  if (joints_.size() != kDualDof) throw std::invalid_argument("a dual-crane lift has 6 joints (dual_crane_joints)");
  for (int crane = 0; crane < 2; ++crane) {
    for (int j = 0; j < kJointsPerCrane; ++j) {
      const JointSpec& joint = joints_[static_cast<std::size_t>(crane * kJointsPerCrane + j)];
      if (joint.name != kNames[j] + crane_suffix(crane) || joint.type != kTypes[j]) {
        throw std::invalid_argument("dual-crane joint " + std::to_string(crane * kJointsPerCrane + j) + " must be '" +
                                    kNames[j] + crane_suffix(crane) + "'");
      }
    }
  }
  const GirderSpec& g = spec_.girder;
  if (!(g.length_m > 0.0) || !(g.mass_kg > 0.0) || !(g.radius_m > 0.0)) {
    throw std::invalid_argument("girder length, mass and radius must be positive");
  }
  const auto angle_ok = [](double a) { return a > 0.0 && a < 0.5 * std::numbers::pi; };
  if (!angle_ok(spec_.max_cable_tilt_rad) || !angle_ok(spec_.max_girder_tilt_rad)) {
    throw std::invalid_argument("tilt limits must lie in (0, 90) deg");
  }
  if (!(spec_.anchor_step_m > 0.0)) throw std::invalid_argument("anchor step must be positive");
  if (chart_) {
    for (int crane = 0; crane < 2; ++crane) {
      const double boom_m = spec_.cranes[static_cast<std::size_t>(crane)].boom_length_m;
      const auto& lengths = chart_->boom_lengths_ft;
      // The thesis's rule: the first chart boom length at or above the actual one.
      const auto it = std::find_if(lengths.begin(), lengths.end(),
                                   [&](double ft) { return boom_m <= ft * kMetresPerFoot + 1e-6; });
      if (it == lengths.end()) {
        throw std::invalid_argument("crane " + std::to_string(crane + 1) + "'s boom is longer than every row of the load chart");
      }
      chart_row_[static_cast<std::size_t>(crane)] = static_cast<int>(it - lengths.begin());
    }
  }

  frame_names_ = {"base_1", "boom_tip_1", "base_2", "boom_tip_2", "girder"};
  for (int crane = 0; crane < 2; ++crane) {
    const std::string s = crane_suffix(crane);
    bodies_.push_back({"carrier" + s, BodyShape::Box, false});
    bodies_.push_back({"superstructure" + s, BodyShape::Box, false});
    bodies_.push_back({"boom" + s, BodyShape::Box, false});
    bodies_.push_back({"cable" + s, BodyShape::Capsule, true});
  }
  bodies_.push_back({"girder", BodyShape::Capsule, false});
  key_point_names_ = {"boom_tip_1", "anchor_1", "boom_tip_2", "anchor_2", "hook"};
  // Every pair that can meet, i.e. all but the attached ones and the two fixed carriers.
  const auto attached = [](int a, int b) {
    const auto crane_of = [](int body) { return body == kGirder ? -1 : body / 4; };
    const auto role_of = [](int body) { return body == kGirder ? -1 : body % 4; };  // carrier, superstructure, boom, cable
    if (crane_of(a) < 0 || crane_of(b) < 0) {
      const int other = crane_of(a) < 0 ? b : a;
      return role_of(other) == 3;  // cables hold the girder
    }
    if (crane_of(a) != crane_of(b)) return role_of(a) == 0 && role_of(b) == 0;
    const int lo = std::min(role_of(a), role_of(b));
    const int hi = std::max(role_of(a), role_of(b));
    // Carrier, superstructure and boom foot form the crane; the cable hangs from its boom tip.
    return hi <= 2 || (lo == 2 && hi == 3);
  };
  for (int a = 0; a <= kGirder; ++a) {
    for (int b = a + 1; b <= kGirder; ++b) {
      if (!attached(a, b)) self_pairs_.push_back({a, b});
    }
  }

  // Farthest body point from each joint's axis, the equilibrium's own shift left out: the boom
  // tip plus its section, and the anchor swung out by the largest cable tilt.
  displacement_bound_.assign(kDualDof, 1.0);
  for (int crane = 0; crane < 2; ++crane) {
    const double boom_m = spec_.cranes[static_cast<std::size_t>(crane)].boom_length_m;
    const double cable_max = joints_[static_cast<std::size_t>(crane * kJointsPerCrane + 2)].position_max;
    const double reach = std::abs(geometry_.boom_foot_forward_m) + boom_m +
                         0.5 * std::hypot(geometry_.boom_width_m, geometry_.boom_depth_m) +
                         cable_max * std::sin(spec_.max_cable_tilt_rad) + g.radius_m;
    displacement_bound_[static_cast<std::size_t>(crane * kJointsPerCrane)] = reach;
    displacement_bound_[static_cast<std::size_t>(crane * kJointsPerCrane + 1)] = reach;
  }
}

double DualCraneModel::heading_rad(const JointVector& q, int crane) const noexcept {
  // Note 004 §1.1: psi = theta + 90 deg fits the paper's Table 1.
  return spec_.cranes[static_cast<std::size_t>(crane)].base_yaw_rad + q[crane * kJointsPerCrane] + 0.5 * std::numbers::pi;
}

Eigen::Vector3d DualCraneModel::boom_tip(const JointVector& q, int crane) const noexcept {
  const CraneMount& mount = spec_.cranes[static_cast<std::size_t>(crane)];
  const double psi = heading_rad(q, crane);
  const double elevation = q[crane * kJointsPerCrane + 1];
  const double reach = geometry_.boom_foot_forward_m + mount.boom_length_m * std::cos(elevation);
  return mount.base_position_m + Eigen::Vector3d(reach * std::cos(psi), reach * std::sin(psi),
                                                 geometry_.boom_foot_height_m + mount.boom_length_m * std::sin(elevation));
}

double DualCraneModel::radius_m(const JointVector& q, int crane) const noexcept {
  return geometry_.boom_foot_forward_m +
         spec_.cranes[static_cast<std::size_t>(crane)].boom_length_m * std::cos(q[crane * kJointsPerCrane + 1]);
}

SuspensionInput DualCraneModel::suspension_input(const JointVector& q) const noexcept {
  SuspensionInput in;
  in.tip_1_m = boom_tip(q, 0);
  in.tip_2_m = boom_tip(q, 1);
  in.cable_1_m = q[kCable1];
  in.cable_2_m = q[kCable2];
  in.girder_length_m = spec_.girder.length_m;
  in.max_cable_tilt_rad = spec_.max_cable_tilt_rad;
  return in;
}

Suspension DualCraneModel::suspension(const JointVector& q) const noexcept {
  SuspensionCache& cache = t_cache;
  bool hit = cache.model_id == cache_id_;
  for (int i = 0; hit && i < kDualDof; ++i) hit = cache.q[static_cast<std::size_t>(i)] == q[i];
  if (hit) return cache.suspension;
  cache.suspension = solve_suspension(suspension_input(q));
  cache.model_id = cache_id_;
  for (int i = 0; i < kDualDof; ++i) cache.q[static_cast<std::size_t>(i)] = q[i];
  return cache.suspension;
}

double DualCraneModel::rated_capacity_lb(int crane, double radius_m, int* row, int* column) const noexcept {
  if (row) *row = -1;
  if (column) *column = -1;
  if (!chart_) return std::numeric_limits<double>::infinity();
  const int r = chart_row_[static_cast<std::size_t>(crane)];
  if (row) *row = r;
  const auto& capacities = chart_->capacity_lb[static_cast<std::size_t>(r)];
  for (std::size_t c = 0; c < chart_->radii_ft.size(); ++c) {
    if (std::isnan(capacities[c]) || chart_->radii_ft[c] * kMetresPerFoot < radius_m - 1e-9) continue;
    if (column) *column = static_cast<int>(c);
    return capacities[c];
  }
  return 0.0;
}

void DualCraneModel::forward_kinematics(const JointVector& q, Kinematics& out) const noexcept {
  const auto& g = geometry_;
  std::array<Eigen::Vector3d, 2> tips;
  for (int crane = 0; crane < 2; ++crane) {
    const CraneMount& mount = spec_.cranes[static_cast<std::size_t>(crane)];
    const int body0 = crane * 4;
    const double psi = heading_rad(q, crane);
    const double elevation = q[crane * kJointsPerCrane + 1];
    Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
    base.translate(mount.base_position_m);
    base.rotate(Eigen::AngleAxisd(mount.base_yaw_rad, Eigen::Vector3d::UnitZ()));
    // Swing frame: x along the boom's heading, z up.
    Eigen::Isometry3d swing = Eigen::Isometry3d::Identity();
    swing.translate(mount.base_position_m);
    swing.rotate(Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()));
    const Eigen::Vector3d foot = swing * Eigen::Vector3d(g.boom_foot_forward_m, 0.0, g.boom_foot_height_m);
    const Eigen::Vector3d along(std::cos(elevation) * std::cos(psi), std::cos(elevation) * std::sin(psi), std::sin(elevation));
    tips[static_cast<std::size_t>(crane)] = foot + mount.boom_length_m * along;

    BodyState& carrier = out.bodies[static_cast<std::size_t>(body0 + 0)];
    carrier.world_from_body = base * Eigen::Translation3d(g.carrier_centre_m);
    carrier.size_m = g.carrier_size_m;
    BodyState& superstructure = out.bodies[static_cast<std::size_t>(body0 + 1)];
    superstructure.world_from_body = swing * Eigen::Translation3d(g.superstructure_centre_m);
    superstructure.size_m = g.superstructure_size_m;
    // Boom box: z along the boom, y along the luffing pin.
    BodyState& boom = out.bodies[static_cast<std::size_t>(body0 + 2)];
    const Eigen::Vector3d pin(-std::sin(psi), std::cos(psi), 0.0);
    boom.world_from_body.linear().col(0) = pin.cross(along);
    boom.world_from_body.linear().col(1) = pin;
    boom.world_from_body.linear().col(2) = along;
    boom.world_from_body.translation() = 0.5 * (foot + tips[static_cast<std::size_t>(crane)]);
    boom.size_m = Eigen::Vector3d(g.boom_depth_m, g.boom_width_m, mount.boom_length_m);

    out.frames[static_cast<std::size_t>(crane == 0 ? kFrameBase1 : kFrameBase2)] = base;
    Eigen::Isometry3d tip_frame = swing;
    tip_frame.translation() = tips[static_cast<std::size_t>(crane)];
    out.frames[static_cast<std::size_t>(crane == 0 ? kFrameBoomTip1 : kFrameBoomTip2)] = tip_frame;
  }

  const Suspension s = suspension(q);
  Eigen::Vector3d anchor_1 = tips[0] - q[kCable1] * Eigen::Vector3d::UnitZ();
  Eigen::Vector3d anchor_2 = tips[1] - q[kCable2] * Eigen::Vector3d::UnitZ();
  if (s.ok()) {
    anchor_1 = s.anchor_1_m;
    anchor_2 = s.anchor_2_m;
  }
  const Eigen::Vector3d toward = anchor_2 - anchor_1;
  const double span = toward.norm();
  const Eigen::Vector3d girder_end =
      anchor_1 + spec_.girder.length_m * (span > 0.0 ? Eigen::Vector3d(toward / span) : Eigen::Vector3d::UnitX());

  const std::array<Eigen::Vector3d, 2> anchors{anchor_1, s.ok() ? anchor_2 : girder_end};
  for (int crane = 0; crane < 2; ++crane) {
    const auto c = static_cast<std::size_t>(crane);
    BodyState& cable = out.bodies[static_cast<std::size_t>(crane * 4 + 3)];
    cable.world_from_body = segment_pose(anchors[c], tips[c]);
    cable.size_m = Eigen::Vector3d(2.0 * g.cable_radius_m, 2.0 * g.cable_radius_m, (tips[c] - anchors[c]).norm());
  }
  BodyState& girder = out.bodies[kGirder];
  girder.world_from_body = segment_pose(anchor_1, girder_end);
  girder.size_m = Eigen::Vector3d(2.0 * spec_.girder.radius_m, 2.0 * spec_.girder.radius_m, spec_.girder.length_m);
  out.frames[kFrameGirder] = girder.world_from_body;

  out.points[kPointBoomTip1] = tips[0];
  out.points[kPointAnchor1] = anchors[0];
  out.points[kPointBoomTip2] = tips[1];
  out.points[kPointAnchor2] = anchors[1];
  out.points[kPointGirderCentre] = girder.world_from_body.translation();
}

ConstraintVerdict DualCraneModel::check_constraints(const JointVector& q) const noexcept {
  ConstraintVerdict v;
  const double l1 = q[kCable1];
  const double l2 = q[kCable2];
  const double girder = spec_.girder.length_m;
  const Eigen::Vector3d tip_1 = boom_tip(q, 0);
  const Eigen::Vector3d tip_2 = boom_tip(q, 1);
  // Seed 004 Fig. 4: the chain cannot reach.
  const double distance = (tip_2 - tip_1).norm();
  if (distance > l1 + l2 + girder) {
    v.status = ConstraintStatus::TipDistance;
    v.value = distance;
    v.limit = l1 + l2 + girder;
    return v;
  }
  // Horizontal closure (3) with every tilt within its limit bounds the tips' horizontal
  // distance; outside it no feasible chain exists, and the solver need not run.
  const double span = (tip_2 - tip_1).head<2>().norm();
  const double swing_out = (l1 + l2) * std::sin(spec_.max_cable_tilt_rad);
  const double span_max = girder + swing_out;
  const double span_min = girder * std::cos(spec_.max_girder_tilt_rad) - swing_out;
  if (span > span_max || span < span_min) {
    v.status = ConstraintStatus::TipDistance;
    v.value = span;
    v.limit = span > span_max ? span_max : span_min;
    return v;
  }
  const Suspension s = suspension(q);
  if (!s.ok()) {
    v.status = ConstraintStatus::NoEquilibrium;
    v.value = s.boundary_tilt_rad;
    v.limit = spec_.max_cable_tilt_rad;
    return v;
  }
  const double cable_tilt = std::max(std::abs(s.cable_tilt_1_rad), std::abs(s.cable_tilt_2_rad));
  if (cable_tilt > spec_.max_cable_tilt_rad) {
    v.status = ConstraintStatus::CableTilt;
    v.value = cable_tilt;
    v.limit = spec_.max_cable_tilt_rad;
    return v;
  }
  if (std::abs(s.girder_tilt_rad) > spec_.max_girder_tilt_rad) {
    v.status = ConstraintStatus::GirderTilt;
    v.value = std::abs(s.girder_tilt_rad);
    v.limit = spec_.max_girder_tilt_rad;
    return v;
  }
  const double lowest = std::min(s.anchor_1_m.z(), s.anchor_2_m.z()) - spec_.girder.radius_m;
  if (lowest < 0.0) {
    v.status = ConstraintStatus::LoadBelowGround;
    v.value = lowest;
    v.limit = 0.0;
    return v;
  }
  // The paper has no capacity limit (note 004 §2); each crane's share of the girder must be
  // rated at its radius.
  const double weight_lb = spec_.girder.mass_kg * (100.0 + spec_.capacity_reduction_pct) / 100.0 / kKilogramsPerPound;
  for (int crane = 0; crane < 2; ++crane) {
    const double tension_lb = (crane == 0 ? s.tension_share_1 : s.tension_share_2) * weight_lb;
    int row = -1;
    int column = -1;
    const double capacity_lb = rated_capacity_lb(crane, radius_m(q, crane), &row, &column);
    if (tension_lb > capacity_lb) {
      v.status = ConstraintStatus::CraneOverload;
      v.value = tension_lb;
      v.limit = capacity_lb;
      v.chart_row = row;
      v.chart_column = column;
      return v;
    }
  }
  return v;
}

int DualCraneModel::edge_min_samples(const JointVector& from, const JointVector& to) const noexcept {
  const JointVector delta = difference(from, to);
  double travel_m = 0.0;
  for (int crane = 0; crane < 2; ++crane) {
    const int j = crane * kJointsPerCrane;
    const double boom_m = spec_.cranes[static_cast<std::size_t>(crane)].boom_length_m;
    // Elevation moves linearly along the edge and cos falls over [0, 90 deg]: the lower end's
    // elevation gives the largest swing radius.
    const double lowest = std::clamp(std::min(from[j + 1], to[j + 1]), 0.0, 0.5 * std::numbers::pi);
    const double radius = std::abs(geometry_.boom_foot_forward_m) + boom_m * std::cos(lowest);
    const double arc = radius * std::abs(delta[j]) + boom_m * std::abs(delta[j + 1]) + std::abs(delta[j + 2]);
    travel_m = std::max(travel_m, arc);
  }
  const Suspension a = solve_suspension(suspension_input(from));
  const Suspension b = solve_suspension(suspension_input(to));
  if (a.ok() && b.ok()) {
    travel_m = std::max({travel_m, (b.anchor_1_m - a.anchor_1_m).norm(), (b.anchor_2_m - a.anchor_2_m).norm()});
  }
  const double samples = std::ceil(travel_m / spec_.anchor_step_m - 1e-12);
  return static_cast<int>(std::clamp(samples, 1.0, 1e6));
}

}  // namespace mgc::planning
