// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/obstacle_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mgc::firmware {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

}  // namespace

ObstacleTracker::ObstacleTracker(const planning::DynamicObstacleSpec& spec, const TrackerConfig& config)
    : config_(config) {
  if (config.still_window_us <= 0 || !(config.still_gate_sigmas > 0.0)) {
    throw std::invalid_argument("tracker: still_window_us and still_gate_sigmas must be > 0");
  }
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
  fit_yaw_rad_ = yaw_rad_;
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
  // The newest fit, not the still average: a motion that has just begun is in the fixes before the
  // stillness test sees it, and must not be gated out for it.
  const Eigen::Isometry3d predicted = Eigen::Translation3d(fit_position_m_) * Eigen::AngleAxisd(fit_yaw_rad_, Eigen::Vector3d::UnitZ());
  // Each tag's allowance runs from its own last accepted fix, not from the last update: a fit that
  // other tags keep alive can drift from a tag it keeps rejecting (a crane's yaw held by the one
  // tag near its slewing axis while the jib-tip tag is gated out), and the growing allowance takes
  // that tag back in and with it the true pose.
  const auto allowance = [&](std::size_t k) {
    const std::int64_t since_us = latest_[k].have ? std::min(latest_[k].t_us, last_update_us_) : last_update_us_;
    return config_.max_speed_m_s * static_cast<double>(now_us - since_us) * 1e-6;
  };
  if (!tracking) restart_still();
  bool fresh = false;
  double fresh_inv_var = 0.0;
  for (std::size_t k = 0; k < num_tags_; ++k) {
    const hal::TagReading* r = snapshot.find_tag(tag_ids_[k]);
    if (r == nullptr || !r->updated || !r->valid) continue;
    const double sigma = std::isfinite(r->sigma_m) && r->sigma_m > 0.0 ? r->sigma_m : config_.unknown_sigma_m;
    const Eigen::Vector3d world(r->position_m[0], r->position_m[1], r->position_m[2]);
    if (tracking && (world - predicted * local_m_[k]).norm() > gate(sigma, allowance(k))) {
      ++counters_.outliers;
      continue;
    }
    latest_[k] = {world, sigma, r->t_us, true};
    fresh = true;
    fresh_inv_var += 1.0 / (sigma * sigma);
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

  double yaw = fit_yaw_rad_;
  Eigen::Vector3d position = fit_position_m_;
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
  fit_yaw_rad_ = yaw;
  fit_position_m_ = position;
  double sigma = std::sqrt(1.0 / inv_var);
  average(now_us, yaw, position, sigma, fresh_inv_var);
  yaw_rad_ = yaw;
  position_m_ = position;
  sigma_m_ = sigma;
  have_pose_ = true;
  last_update_us_ = now_us;
  ++counters_.updates;
  counters_.fixes_used += used;
  return true;
}

void ObstacleTracker::retire_oldest() noexcept {
  const StillFit& f = ring_[ring_head_];
  add(older_, f);
  recent_.position_m -= f.position_m;
  recent_.yaw_rad -= f.yaw_rad;
  recent_.inv_var -= f.inv_var;
  --recent_.count;
  ring_head_ = (ring_head_ + 1) % kStillRing;
  --ring_count_;
}

void ObstacleTracker::restart_still() noexcept {
  ring_head_ = 0;
  ring_count_ = 0;
  recent_ = FitSum{};
  older_ = FitSum{};
  still_ = false;
}

void ObstacleTracker::average(std::int64_t now_us, double& yaw_rad, Eigen::Vector3d& position_m, double& sigma_m,
                              double fresh_inv_var) noexcept {
  if (ring_count_ == 0 && older_.count == 0) {
    yaw_ref_rad_ = yaw_rad;
    still_since_us_ = now_us;
  }
  if (ring_count_ == kStillRing) retire_oldest();
  const StillFit fit{now_us, position_m, std::remainder(yaw_rad - yaw_ref_rad_, kTwoPi), fresh_inv_var};
  ring_[(ring_head_ + ring_count_) % kStillRing] = fit;
  ++ring_count_;
  add(recent_, fit);
  while (ring_count_ > 1 && now_us - ring_[ring_head_].t_us > config_.still_window_us) retire_oldest();
  still_ = false;
  // The window test needs fits before the window to compare with.
  if (older_.count == 0 || !(older_.inv_var > 0.0) || !(recent_.inv_var > 0.0)) return;
  const auto mean = [this](const FitSum& sum) {
    const double n = static_cast<double>(sum.count);
    return Eigen::Isometry3d(Eigen::Translation3d(sum.position_m / n) *
                             Eigen::AngleAxisd(yaw_ref_rad_ + sum.yaw_rad / n, Eigen::Vector3d::UnitZ()));
  };
  FitSum all = older_;
  all.position_m += recent_.position_m;
  all.yaw_rad += recent_.yaw_rad;
  all.inv_var += recent_.inv_var;
  all.count += recent_.count;
  const Eigen::Isometry3d recent = mean(recent_);
  const Eigen::Isometry3d older = mean(older_);
  const Eigen::Isometry3d averaged = mean(all);
  const Eigen::Isometry3d newest = Eigen::Translation3d(position_m) * Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ());
  // 1-sigma at one tag's place of a mean (its fixes are shared among the tags) and of the newest
  // fit (one fix of each tag).
  const double tags = static_cast<double>(num_tags_);
  const double window_gate_m = config_.still_gate_sigmas * std::sqrt(tags / recent_.inv_var + tags / older_.inv_var);
  const double fit_gate_m = config_.still_gate_sigmas * std::sqrt(sigma_m * sigma_m * tags + tags / all.inv_var);
  double window_moved_m = 0.0;
  double fit_moved_m = 0.0;
  for (std::size_t k = 0; k < num_tags_; ++k) {
    window_moved_m = std::max(window_moved_m, (recent * local_m_[k] - older * local_m_[k]).head<2>().norm());
    fit_moved_m = std::max(fit_moved_m, (newest * local_m_[k] - averaged * local_m_[k]).head<2>().norm());
  }
  if (window_moved_m > window_gate_m || fit_moved_m > fit_gate_m) {
    // Motion: a new still period starts from the newest fit, which is published.
    ++counters_.motion_starts;
    restart_still();
    yaw_ref_rad_ = yaw_rad;
    still_since_us_ = now_us;
    const StillFit first{now_us, position_m, 0.0, fresh_inv_var};
    ring_[0] = first;
    ring_count_ = 1;
    add(recent_, first);
    return;
  }
  // Published once the window has as long a stretch before it to be compared with: a motion
  // slower than the window test sees in one window cannot pass for standing by a short start.
  if (now_us - still_since_us_ < 2 * config_.still_window_us) return;
  position_m = averaged.translation();
  yaw_rad = std::remainder(yaw_ref_rad_ + all.yaw_rad / static_cast<double>(all.count), kTwoPi);
  sigma_m = std::sqrt(1.0 / all.inv_var);
  still_ = true;
}

}  // namespace mgc::firmware
