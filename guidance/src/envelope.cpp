// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/envelope.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mgc::guidance {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

//! Angle in [0, 2 pi). [rad]
double wrap_positive(double angle_rad) noexcept {
  const double a = std::fmod(angle_rad, kTwoPi);
  return a < 0.0 ? a + kTwoPi : a;
}

//! A gradient entry below this is rounding noise of the central difference (values of tens of
//! metres, step 1e-5: ~1e-10), not an effect of the joint; counting it would cut joints that do
//! not move the point toward the limit. [m per rad | m per m]
constexpr double kGradientTolerance = 1e-6;

}  // namespace

const char* to_string(EnvelopeLimit limit) noexcept {
  switch (limit) {
    case EnvelopeLimit::None: return "none";
    case EnvelopeLimit::HeightCeiling: return "height ceiling";
    case EnvelopeLimit::DepthFloor: return "depth floor";
    case EnvelopeLimit::SlewLeft: return "slew left";
    case EnvelopeLimit::SlewRight: return "slew right";
    case EnvelopeLimit::RadiusMin: return "minimum radius";
    case EnvelopeLimit::RadiusMax: return "maximum radius";
    case EnvelopeLimit::Wall: return "virtual wall";
  }
  return "unknown";
}

Envelope::Envelope(const planning::MachineModel& model, const EnvelopeConfig& config) noexcept
    : model_(model), config_(config) {
  config_.point_count = std::clamp(config_.point_count, 0, EnvelopeConfig::kMaxPoints);
  config_.wall_count = std::clamp(config_.wall_count, 0, EnvelopeConfig::kMaxWalls);
}

template <typename Visit>
void Envelope::for_each_limit(const Eigen::Vector3d& p_world, const std::array<Eigen::Vector3d, kMaxJoints>* dp,
                              int point, Visit&& visit) const noexcept {
  const int n = model_.dof();
  std::array<double, kMaxJoints> grad{};
  const auto emit = [&](EnvelopeLimit limit, int wall, double distance_m) {
    visit(EnvelopeDistance{limit, point, wall, distance_m}, grad);
  };
  const Eigen::Isometry3d& world_from_base = model_.world_from_base();
  const Eigen::Matrix3d base_from_world_rot = world_from_base.linear().transpose();
  const Eigen::Vector3d p_base = world_from_base.inverse() * p_world;
  const auto dp_base = [&](int j) -> Eigen::Vector3d { return base_from_world_rot * (*dp)[static_cast<std::size_t>(j)]; };
  const auto dpw = [&](int j) -> const Eigen::Vector3d& { return (*dp)[static_cast<std::size_t>(j)]; };

  if (config_.height_ceiling_enabled) {
    for (int j = 0; dp && j < n; ++j) grad[static_cast<std::size_t>(j)] = -dpw(j).z();
    emit(EnvelopeLimit::HeightCeiling, -1, config_.height_ceiling_m - p_world.z());
  }
  if (config_.depth_floor_enabled) {
    for (int j = 0; dp && j < n; ++j) grad[static_cast<std::size_t>(j)] = dpw(j).z();
    emit(EnvelopeLimit::DepthFloor, -1, p_world.z() - config_.depth_floor_m);
  }
  const double radius_m = std::hypot(p_base.x(), p_base.y());
  if (config_.radius_min_enabled || config_.radius_max_enabled) {
    // d r / dq = (x dx + y dy) / r; at the axis itself the radius has no direction: zero.
    std::array<double, kMaxJoints> dr{};
    for (int j = 0; dp && j < n && radius_m > 1e-9; ++j) {
      const Eigen::Vector3d d = dp_base(j);
      dr[static_cast<std::size_t>(j)] = (p_base.x() * d.x() + p_base.y() * d.y()) / radius_m;
    }
    if (config_.radius_min_enabled) {
      grad = dr;
      emit(EnvelopeLimit::RadiusMin, -1, radius_m - config_.radius_min_m);
    }
    if (config_.radius_max_enabled) {
      for (int j = 0; j < n; ++j) grad[static_cast<std::size_t>(j)] = -dr[static_cast<std::size_t>(j)];
      emit(EnvelopeLimit::RadiusMax, -1, config_.radius_max_m - radius_m);
    }
  }
  if (config_.slew_enabled && radius_m >= config_.min_slew_radius_m) {
    const double azimuth_rad = std::atan2(p_base.y(), p_base.x());
    double span_rad = wrap_positive(config_.slew_left_rad - config_.slew_right_rad);
    if (span_rad == 0.0) span_rad = kTwoPi;
    const double off_rad = wrap_positive(azimuth_rad - config_.slew_right_rad);
    double to_left_rad = span_rad - off_rad;
    double to_right_rad = off_rad;
    if (off_rad > span_rad) {
      // Outside the sector: beyond whichever limit is nearer; the other is the long way round.
      const double past_left_rad = off_rad - span_rad;
      const double past_right_rad = kTwoPi - off_rad;
      if (past_left_rad < past_right_rad) {
        to_left_rad = -past_left_rad;
        to_right_rad = span_rad + past_left_rad;
      } else {
        to_right_rad = -past_right_rad;
        to_left_rad = span_rad + past_right_rad;
      }
    }
    // d azimuth / dq = (x dy - y dx) / r^2; as arc length at the point's radius: times r.
    std::array<double, kMaxJoints> daz_m{};
    for (int j = 0; dp && j < n; ++j) {
      const Eigen::Vector3d d = dp_base(j);
      daz_m[static_cast<std::size_t>(j)] = (p_base.x() * d.y() - p_base.y() * d.x()) / radius_m;
    }
    for (int j = 0; j < n; ++j) grad[static_cast<std::size_t>(j)] = -daz_m[static_cast<std::size_t>(j)];
    emit(EnvelopeLimit::SlewLeft, -1, to_left_rad * radius_m);
    grad = daz_m;
    emit(EnvelopeLimit::SlewRight, -1, to_right_rad * radius_m);
  }
  for (int w = 0; w < config_.wall_count; ++w) {
    const EnvelopeWall& wall = config_.walls[static_cast<std::size_t>(w)];
    for (int j = 0; dp && j < n; ++j) grad[static_cast<std::size_t>(j)] = wall.normal.dot(dpw(j));
    emit(EnvelopeLimit::Wall, w, wall.normal.dot(p_world) - wall.offset_m);
  }
}

EnvelopeDistance Envelope::nearest(const planning::JointVector& q) noexcept {
  model_.forward_kinematics(q, kinematics_);
  return nearest_posed();
}

EnvelopeDistance Envelope::nearest_posed() const noexcept {
  EnvelopeDistance best;
  for (int i = 0; i < config_.point_count; ++i) {
    const int point = config_.points[static_cast<std::size_t>(i)];
    for_each_limit(kinematics_.points[static_cast<std::size_t>(point)], nullptr, point,
                   [&](const EnvelopeDistance& d, const std::array<double, kMaxJoints>&) {
                     if (best.limit == EnvelopeLimit::None || d.distance_m < best.distance_m) best = d;
                   });
  }
  return best;
}

EnvelopeResult Envelope::limit_velocity(const planning::JointVector& q,
                                        const planning::JointVector& commanded_velocity) noexcept {
  const int n = model_.dof();
  EnvelopeResult result;
  result.allowed_velocity = commanded_velocity;
  result.joint_scale.fill(1.0);
  model_.forward_kinematics(q, kinematics_);

  // Every limit beyond the slowdown band cuts nothing: the distances alone settle it, without the
  // 2 dof forward kinematics of the gradients.
  const double band_m = std::max(config_.slowdown_band_m, 1e-9);
  result.nearest = nearest_posed();
  if (result.nearest.limit == EnvelopeLimit::None || result.nearest.distance_m >= band_m) return result;
  result.nearest = EnvelopeDistance{};

  // d(point)/dq_j for every monitored point by central differences: 2 dof forward kinematics.
  std::array<std::array<Eigen::Vector3d, kMaxJoints>, EnvelopeConfig::kMaxPoints> dp{};
  const double h = config_.gradient_step;
  planning::JointVector q_step = q;
  for (int j = 0; j < n; ++j) {
    q_step[j] = q[j] + h;
    model_.forward_kinematics(q_step, kinematics_step_);
    for (int i = 0; i < config_.point_count; ++i) {
      const auto p = static_cast<std::size_t>(config_.points[static_cast<std::size_t>(i)]);
      dp[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = kinematics_step_.points[p];
    }
    q_step[j] = q[j] - h;
    model_.forward_kinematics(q_step, kinematics_step_);
    for (int i = 0; i < config_.point_count; ++i) {
      const auto p = static_cast<std::size_t>(config_.points[static_cast<std::size_t>(i)]);
      auto& d = dp[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      d = (d - kinematics_step_.points[p]) / (2.0 * h);
    }
    q_step[j] = q[j];
  }

  for (int i = 0; i < config_.point_count; ++i) {
    const int point = config_.points[static_cast<std::size_t>(i)];
    for_each_limit(kinematics_.points[static_cast<std::size_t>(point)], &dp[static_cast<std::size_t>(i)], point,
                   [&](const EnvelopeDistance& d, const std::array<double, kMaxJoints>& grad) {
                     if (result.nearest.limit == EnvelopeLimit::None || d.distance_m < result.nearest.distance_m) {
                       result.nearest = d;
                     }
                     if (d.distance_m < 0.0) result.violated = true;
                     if (d.distance_m >= band_m) return;
                     const double scale = std::clamp(d.distance_m / band_m, 0.0, 1.0);
                     bool cuts = false;
                     for (int j = 0; j < n; ++j) {
                       const double g = grad[static_cast<std::size_t>(j)];
                       // Only the component that approaches the limit is cut.
                       if (std::abs(g) < kGradientTolerance || g * commanded_velocity[j] >= 0.0) continue;
                       double& s = result.joint_scale[static_cast<std::size_t>(j)];
                       s = std::min(s, scale);
                       cuts = true;
                     }
                     if (cuts && (result.acting.limit == EnvelopeLimit::None || d.distance_m < result.acting.distance_m)) {
                       result.acting = d;
                     }
                   });
  }
  for (int j = 0; j < n; ++j) result.allowed_velocity[j] = commanded_velocity[j] * result.joint_scale[static_cast<std::size_t>(j)];
  return result;
}

EnvelopeConfig envelope_config(const planning::EnvelopeSpec& spec, const planning::MachineModel& model) {
  const std::string where = spec.points_ref.file + ":" + std::to_string(spec.points_ref.line) + ": " + spec.points_ref.field + ": ";
  EnvelopeConfig c;
  if (spec.points.size() > static_cast<std::size_t>(EnvelopeConfig::kMaxPoints)) {
    throw std::invalid_argument(where + "at most " + std::to_string(EnvelopeConfig::kMaxPoints) + " key points");
  }
  const auto names = model.key_point_names();
  for (const std::string& name : spec.points) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::string known;
      for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
      throw std::invalid_argument(where + "expected a key point of the " + std::string(planning::to_string(model.kind())) + " machine (" + known +
                                  "), got '" + name + "'");
    }
    c.points[static_cast<std::size_t>(c.point_count++)] = static_cast<int>(it - names.begin());
  }
  if (spec.height_ceiling_m) {
    c.height_ceiling_enabled = true;
    c.height_ceiling_m = *spec.height_ceiling_m;
  }
  if (spec.depth_floor_m) {
    c.depth_floor_enabled = true;
    c.depth_floor_m = *spec.depth_floor_m;
  }
  if (spec.slew_left_rad && spec.slew_right_rad) {
    c.slew_enabled = true;
    c.slew_left_rad = *spec.slew_left_rad;
    c.slew_right_rad = *spec.slew_right_rad;
  }
  if (spec.radius_min_m) {
    c.radius_min_enabled = true;
    c.radius_min_m = *spec.radius_min_m;
  }
  if (spec.radius_max_m) {
    c.radius_max_enabled = true;
    c.radius_max_m = *spec.radius_max_m;
  }
  if (spec.walls.size() > static_cast<std::size_t>(EnvelopeConfig::kMaxWalls)) {
    throw std::invalid_argument(where + "at most " + std::to_string(EnvelopeConfig::kMaxWalls) + " walls");
  }
  for (const planning::EnvelopeWallSpec& w : spec.walls) c.walls[static_cast<std::size_t>(c.wall_count++)] = {w.normal, w.offset_m};
  if (spec.slowdown_band_m) c.slowdown_band_m = *spec.slowdown_band_m;
  return c;
}

namespace {

// A refusing limit packed into one int for Validity::rule_limit: key point, limit kind, wall.
constexpr int kLimitKinds = 8;
constexpr int kWallSlots = EnvelopeConfig::kMaxWalls;

int pack_limit(const EnvelopeDistance& d) noexcept {
  return (d.point * kLimitKinds + static_cast<int>(d.limit)) * kWallSlots + std::max(d.wall, 0);
}

}  // namespace

EnvelopeRule::EnvelopeRule(const planning::MachineModel& model, const EnvelopeConfig& config, double margin_m) noexcept
    : model_(model), envelope_(model, config), margin_m_(margin_m) {}

bool EnvelopeRule::allows(const planning::JointVector& q, int* limit) noexcept {
  const EnvelopeDistance d = envelope_.nearest(q);
  if (d.limit == EnvelopeLimit::None || d.distance_m >= margin_m_) return true;
  if (limit != nullptr) *limit = pack_limit(d);
  return false;
}

std::string EnvelopeRule::describe(int limit) const {
  if (limit < 0) return "outside the working envelope";
  const int wall = limit % kWallSlots;
  const auto kind = static_cast<EnvelopeLimit>((limit / kWallSlots) % kLimitKinds);
  const auto point = static_cast<std::size_t>(limit / (kWallSlots * kLimitKinds));
  const auto names = model_.key_point_names();
  const std::string name = point < names.size() ? names[point] : "key point " + std::to_string(point);
  char margin[32];
  std::snprintf(margin, sizeof margin, "%.2f", margin_m_);
  std::string text = "working envelope: " + name + " within " + margin + " m of the " + to_string(kind);
  // Appended piece by piece: GCC 12 at -O3 misreads " " + to_string()'s insert at the front as an
  // overlapping copy (-Wrestrict).
  if (kind == EnvelopeLimit::Wall) {
    text += ' ';
    text += std::to_string(wall);
  }
  return text;
}

}  // namespace mgc::guidance
