// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/rated_capacity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mgc::guidance {
namespace {
//! Keeps the chart's own boom lengths, converted from feet, inside their row (as LoadChartRule). [m]
constexpr double kRowToleranceM = 1e-6;
//! A radius gradient below this is rounding noise of the central difference. [m per rad | m per m]
constexpr double kGradientTolerance = 1e-6;
}  // namespace

const char* to_string(RclStage stage) noexcept {
  switch (stage) {
    case RclStage::Normal: return "normal";
    case RclStage::Warning: return "warning";
    case RclStage::Overload: return "overload";
    case RclStage::OutsideChart: return "outside chart";
  }
  return "unknown";
}

RatedCapacity rated_capacity(const planning::LoadChart& chart, double boom_length_m,
                             double boom_elevation_rad) noexcept {
  RatedCapacity out;
  const std::size_t rows = chart.boom_lengths_ft.size();
  std::size_t row = 0;
  while (row < rows && boom_length_m > chart.boom_lengths_ft[row] * planning::kMetresPerFoot + kRowToleranceM) ++row;
  if (row == rows) return out;
  const double from_vertical_deg = planning::angle_from_vertical_deg(boom_elevation_rad);
  const auto& capacities = chart.capacity_lb[row];
  const auto& angles = chart.max_angle_from_vertical_deg[row];
  for (std::size_t c = 0; c < chart.radii_ft.size(); ++c) {
    if (std::isnan(capacities[c]) || std::isnan(angles[c])) continue;
    if (angles[c] >= from_vertical_deg) {
      out.in_chart = true;
      out.capacity_lb = capacities[c];
      out.chart_row = static_cast<int>(row);
      out.chart_column = static_cast<int>(c);
      return out;
    }
  }
  out.chart_row = static_cast<int>(row);
  return out;
}

RatedCapacity rated_capacity_along(const planning::LoadChart& chart, double from_boom_m, double from_elevation_rad,
                                   double to_boom_m, double to_elevation_rad) noexcept {
  RatedCapacity out;
  out.in_chart = true;
  out.capacity_lb = std::numeric_limits<double>::infinity();
  const std::size_t rows = chart.boom_lengths_ft.size();
  const double length_delta = to_boom_m - from_boom_m;
  const double lo_m = std::min(from_boom_m, to_boom_m);
  const double hi_m = std::max(from_boom_m, to_boom_m);
  const auto outside = [&](int row) {
    out.in_chart = false;
    out.capacity_lb = 0.0;
    out.chart_row = row;
    out.chart_column = -1;
  };
  // Row r covers the boom lengths (row r-1, row r], as rated_capacity() reads it.
  double previous_m = -std::numeric_limits<double>::infinity();
  for (std::size_t row = 0; row < rows; ++row) {
    const double bound_m = chart.boom_lengths_ft[row] * planning::kMetresPerFoot + kRowToleranceM;
    const double span_lo_m = previous_m;
    previous_m = bound_m;
    if (!(hi_m > span_lo_m && lo_m <= bound_m)) continue;
    // The stretch of the motion within the row, and the elevations at its ends.
    double t0 = 0.0;
    double t1 = 1.0;
    if (length_delta != 0.0) {
      const double ta = std::isfinite(span_lo_m) ? std::clamp((span_lo_m - from_boom_m) / length_delta, 0.0, 1.0)
                                                 : (length_delta > 0.0 ? 0.0 : 1.0);
      const double tb = std::clamp((bound_m - from_boom_m) / length_delta, 0.0, 1.0);
      t0 = std::min(ta, tb);
      t1 = std::max(ta, tb);
    }
    const double e0 = from_elevation_rad + t0 * (to_elevation_rad - from_elevation_rad);
    const double e1 = from_elevation_rad + t1 * (to_elevation_rad - from_elevation_rad);
    const double nearest_deg = planning::angle_from_vertical_deg(std::max(e0, e1));
    const double farthest_deg = planning::angle_from_vertical_deg(std::min(e0, e1));
    // Each angle reads the first cell whose angle reaches it: the cells read over the stretch run
    // from the nearest angle's cell to the farthest angle's.
    const auto& capacities = chart.capacity_lb[row];
    const auto& angles = chart.max_angle_from_vertical_deg[row];
    bool reached = false;
    for (std::size_t c = 0; c < chart.radii_ft.size(); ++c) {
      if (std::isnan(capacities[c]) || std::isnan(angles[c])) continue;
      if (angles[c] < nearest_deg) continue;
      if (capacities[c] < out.capacity_lb) {
        out.capacity_lb = capacities[c];
        out.chart_row = static_cast<int>(row);
        out.chart_column = static_cast<int>(c);
      }
      if (angles[c] >= farthest_deg) {
        reached = true;
        break;
      }
    }
    if (!reached) {
      outside(static_cast<int>(row));
      return out;
    }
  }
  if (hi_m > previous_m) outside(static_cast<int>(rows));
  return out;
}

RatedCapacityLimiter::RatedCapacityLimiter(const planning::MobileCrane& crane, const RatedCapacityConfig& config) noexcept
    : crane_(crane), config_(config) {}

double RatedCapacityLimiter::task_load_lb() const noexcept {
  const planning::LiftTask& task = crane_.task();
  return task.load_lb * (100.0 + task.capacity_reduction_pct) / 100.0;
}

RatedCapacityResult RatedCapacityLimiter::limit_velocity(const planning::JointVector& q, double hook_load_lb,
                                                         const planning::JointVector& commanded_velocity) noexcept {
  return limit_velocity(q, hook_load_lb, commanded_velocity, 0.0);
}

RatedCapacityResult RatedCapacityLimiter::limit_velocity(const planning::JointVector& q, double hook_load_lb,
                                                         const planning::JointVector& commanded_velocity,
                                                         double horizon_s) noexcept {
  using planning::MobileCrane;
  RatedCapacityResult r;
  r.load_lb = hook_load_lb;
  r.allowed_velocity = commanded_velocity;
  r.load_radius_m = crane_.load_radius_m(q);
  const double boom_m = q[MobileCrane::kBoomLength];
  const double elevation = q[MobileCrane::kBoomElevation];
  r.rated = horizon_s > 0.0
                ? rated_capacity_along(crane_.chart(), boom_m, elevation,
                                       boom_m + horizon_s * commanded_velocity[MobileCrane::kBoomLength],
                                       elevation + horizon_s * commanded_velocity[MobileCrane::kBoomElevation])
                : rated_capacity(crane_.chart(), boom_m, elevation);
  if (r.rated.in_chart && r.rated.capacity_lb > 0.0) {
    r.utilisation = hook_load_lb / r.rated.capacity_lb;
  } else {
    r.utilisation = std::numeric_limits<double>::infinity();
  }

  if (!r.rated.in_chart) {
    r.stage = RclStage::OutsideChart;
  } else if (r.utilisation >= config_.cutoff_utilisation) {
    r.stage = RclStage::Overload;
    latched_ = true;
  } else if (latched_ && r.utilisation >= config_.warning_utilisation) {
    r.stage = RclStage::Overload;
  } else if (r.utilisation >= config_.warning_utilisation) {
    r.stage = RclStage::Warning;
    latched_ = false;
  } else {
    r.stage = RclStage::Normal;
    latched_ = false;
  }

  const int n = crane_.dof();
  const double h = config_.gradient_step;
  planning::JointVector q_step = q;
  for (int j = 0; j < n; ++j) {
    q_step[j] = q[j] + h;
    const double up_m = crane_.load_radius_m(q_step);
    q_step[j] = q[j] - h;
    const double down_m = crane_.load_radius_m(q_step);
    q_step[j] = q[j];
    r.radius_gradient[static_cast<std::size_t>(j)] = (up_m - down_m) / (2.0 * h);
  }

  if (r.stage != RclStage::Overload && r.stage != RclStage::OutsideChart) return r;
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double v = commanded_velocity[j];
    const double g = r.radius_gradient[k];
    bool increases = std::abs(g) >= kGradientTolerance && g * v > 0.0;
    // Hoist raising is a shorter cable.
    if (j == MobileCrane::kCableLength && config_.cut_hoist_raise && v < 0.0) increases = true;
    if (increases) {
      r.cut[k] = true;
      r.allowed_velocity[j] = 0.0;
    }
  }
  return r;
}

}  // namespace mgc::guidance
