// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/obstacle_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mgc::firmware {

ObstacleTracker::ObstacleTracker(const planning::DynamicObstacleSpec& spec, const TrackerConfig& config)
    : config_(config) {
  if (spec.tags.empty()) throw std::invalid_argument("obstacle '" + spec.obstacle.name + "' has no UWB tags to track it by");
  if (spec.tags.size() > kMaxTagsPerObstacle) {
    throw std::invalid_argument("obstacle '" + spec.obstacle.name + "' has more than " +
                                std::to_string(kMaxTagsPerObstacle) + " tags");
  }
  for (const planning::UwbTagSpec& t : spec.tags) {
    tag_ids_[num_tags_] = static_cast<std::uint8_t>(t.id);
    local_m_[num_tags_] = t.position_m;
    ++num_tags_;
  }
  for (std::size_t i = 0; i < num_tags_; ++i) {
    for (std::size_t j = i + 1; j < num_tags_; ++j) {
      if ((local_m_[i] - local_m_[j]).head<2>().norm() > 0.5) yaw_observable_ = true;
    }
  }
  if (!spec.motion.empty()) yaw_rad_ = spec.motion.front().yaw_rad;
}

Eigen::Isometry3d ObstacleTracker::pose() const noexcept {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(position_m_);
  t.rotate(Eigen::AngleAxisd(yaw_rad_, Eigen::Vector3d::UnitZ()));
  return t;
}

bool ObstacleTracker::fit(std::size_t count, double& yaw_rad, Eigen::Vector3d& position_m) const noexcept {
  double w_sum = 0.0;
  Eigen::Vector3d local_mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d world_mean = Eigen::Vector3d::Zero();
  std::size_t used = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (!fixes_[i].used) continue;
    const double w = 1.0 / (fixes_[i].sigma_m * fixes_[i].sigma_m);
    w_sum += w;
    local_mean += w * fixes_[i].local_m;
    world_mean += w * fixes_[i].world_m;
    ++used;
  }
  if (used == 0) return false;
  local_mean /= w_sum;
  world_mean /= w_sum;
  double yaw = yaw_rad;
  if (used >= 2) {
    // 2-D Procrustes about z: the yaw that best turns the centred layout onto the centred fixes.
    double s_cross = 0.0;
    double s_dot = 0.0;
    for (std::size_t i = 0; i < count; ++i) {
      if (!fixes_[i].used) continue;
      const double w = 1.0 / (fixes_[i].sigma_m * fixes_[i].sigma_m);
      const Eigen::Vector3d l = fixes_[i].local_m - local_mean;
      const Eigen::Vector3d m = fixes_[i].world_m - world_mean;
      s_dot += w * (l.x() * m.x() + l.y() * m.y());
      s_cross += w * (l.x() * m.y() - l.y() * m.x());
    }
    // Tags stacked on one vertical line say nothing about yaw: keep the last one.
    if (std::hypot(s_cross, s_dot) > 1e-9) yaw = std::atan2(s_cross, s_dot);
  }
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  yaw_rad = yaw;
  position_m = world_mean - r * local_mean;
  return true;
}

bool ObstacleTracker::update(const hal::SensorSnapshot& snapshot, std::int64_t now_us) noexcept {
  const auto gate = [&](double sigma_m, double allowance_m) {
    return std::max(config_.gate_sigmas * sigma_m, config_.min_gate_m) + allowance_m;
  };
  // Gate 1: each fresh fix against where its tag should be, given the last pose and how far the
  // obstacle can have moved since.
  const bool tracking = valid(now_us);
  const Eigen::Isometry3d predicted = pose();
  const double allowance = config_.max_speed_m_s * static_cast<double>(now_us - last_update_us_) * 1e-6;
  bool fresh = false;
  for (std::size_t k = 0; k < num_tags_; ++k) {
    const hal::TagReading* r = snapshot.find_tag(tag_ids_[k]);
    if (r == nullptr || !r->updated || !r->valid) continue;
    const double sigma = std::isfinite(r->sigma_m) && r->sigma_m > 0.0 ? r->sigma_m : config_.unknown_sigma_m;
    const Eigen::Vector3d world(r->position_m[0], r->position_m[1], r->position_m[2]);
    if (tracking && (world - predicted * local_m_[k]).norm() > gate(sigma, allowance)) {
      ++counters_.outliers;
      continue;
    }
    latest_[k] = {world, sigma, r->t_us, true};
    fresh = true;
  }
  if (!fresh) return false;

  std::size_t count = 0;
  bool spread = false;
  for (std::size_t k = 0; k < num_tags_; ++k) {
    if (!latest_[k].have || now_us - latest_[k].t_us > config_.fusion_window_us) continue;
    for (std::size_t i = 0; i < count; ++i) {
      if ((fixes_[i].local_m - local_m_[k]).head<2>().norm() > 0.5) spread = true;
    }
    fixes_[count++] = {local_m_[k], latest_[k].world_m, latest_[k].sigma_m, true};
  }
  if (count == 0) return false;
  if (!tracking && yaw_observable_ && !spread) return false;  // (re)acquire only with the yaw observable

  double yaw = yaw_rad_;
  Eigen::Vector3d position = position_m_;
  if (!fit(count, yaw, position)) return false;

  // Gate 2: with three or more fixes the fit itself shows an outlier; drop the worst and refit
  // while one stands out (two fixes always agree with their own fit).
  while (true) {
    std::size_t used = 0;
    std::size_t worst = count;
    double worst_ratio = 1.0;
    const Eigen::Isometry3d fitted = Eigen::Translation3d(position) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    for (std::size_t i = 0; i < count; ++i) {
      if (!fixes_[i].used) continue;
      ++used;
      const double ratio = (fixes_[i].world_m - fitted * fixes_[i].local_m).norm() / gate(fixes_[i].sigma_m, 0.0);
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = i;
      }
    }
    if (used < 3 || worst == count) break;
    fixes_[worst].used = false;
    ++counters_.outliers;
    if (!fit(count, yaw, position)) return false;
  }

  double inv_var = 0.0;
  std::size_t used = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (!fixes_[i].used) continue;
    inv_var += 1.0 / (fixes_[i].sigma_m * fixes_[i].sigma_m);
    ++used;
  }
  yaw_rad_ = yaw;
  position_m_ = position;
  sigma_m_ = std::sqrt(1.0 / inv_var);
  have_pose_ = true;
  last_update_us_ = now_us;
  ++counters_.updates;
  counters_.fixes_used += used;
  return true;
}

}  // namespace mgc::firmware
