// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/load_chart.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mgc::planning {
namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;
}

LoadChartRule::LoadChartRule(const LoadChart& chart, double load_lb) : load_lb_(load_lb) {
  bool any = false;
  rows_.reserve(chart.boom_lengths_ft.size());
  for (std::size_t r = 0; r < chart.boom_lengths_ft.size(); ++r) {
    Row row;
    row.boom_length_m = chart.boom_lengths_ft[r] * kMetresPerFoot;
    // App. G scans from the largest radius inward and stops at the first capacity that covers
    // the load: the longest reach at which the load is rated.
    for (std::size_t c = chart.radii_ft.size(); c-- > 0;) {
      const double capacity = chart.capacity_lb[r][c];
      if (std::isnan(capacity)) continue;
      if (load_lb <= capacity) {
        row.column = static_cast<int>(c);
        row.min_elevation_rad = (90.0 - chart.max_angle_from_vertical_deg[r][c]) * kDegToRad;
        any = true;
        break;
      }
    }
    rows_.push_back(row);
  }
  if (!any) throw std::invalid_argument("load is above every capacity of the load chart");
}

ConstraintVerdict LoadChartRule::min_elevation(double boom_length_m) const noexcept {
  ConstraintVerdict v;
  v.value = boom_length_m;
  // First chart boom length at or above the actual one (App. G: distance <= Distances[i]).
  // A tolerance of a micrometre keeps the chart's own boom lengths, converted from feet, inside
  // their row.
  const auto it = std::find_if(rows_.begin(), rows_.end(),
                               [&](const Row& r) { return boom_length_m <= r.boom_length_m + 1e-6; });
  if (it == rows_.end()) {
    v.status = ConstraintStatus::BoomLengthOutsideChart;
    v.limit = rows_.empty() ? 0.0 : rows_.back().boom_length_m;
    return v;
  }
  v.chart_row = static_cast<int>(it - rows_.begin());
  if (it->column < 0) {
    v.status = ConstraintStatus::LoadAboveChart;
    v.value = load_lb_;
    return v;
  }
  v.chart_column = it->column;
  v.limit = it->min_elevation_rad;
  return v;
}

ConstraintVerdict LoadChartRule::check(double boom_length_m, double boom_elevation_rad) const noexcept {
  ConstraintVerdict v = min_elevation(boom_length_m);
  if (!v.ok()) return v;
  v.value = boom_elevation_rad;
  // App. G accepts 0 <= angle from vertical <= MaxAngle.
  if (boom_elevation_rad < v.limit) {
    v.status = ConstraintStatus::BoomBelowChartAngle;
  } else if (boom_elevation_rad > 0.5 * std::numbers::pi) {
    v.status = ConstraintStatus::BoomAboveChartAngle;
    v.limit = 0.5 * std::numbers::pi;
  }
  return v;
}

ConstraintVerdict LuffRangeTable::check(double boom_length_m, double boom_elevation_rad) const noexcept {
  ConstraintVerdict v;
  v.value = boom_length_m;
  const double length_ft = boom_length_m / kMetresPerFoot;
  const std::size_t n = boom_lengths_ft.size();
  constexpr double kTolFt = 1e-6;
  if (n == 0 || length_ft < boom_lengths_ft.front() - kTolFt || length_ft > boom_lengths_ft.back() + kTolFt) {
    v.status = ConstraintStatus::BoomLengthOutsideChart;
    return v;
  }
  std::size_t hi = 0;
  while (hi < n && boom_lengths_ft[hi] < length_ft - kTolFt) ++hi;
  hi = std::min(hi, n - 1);
  std::size_t lo = hi;
  if (std::abs(boom_lengths_ft[hi] - length_ft) > kTolFt && hi > 0) lo = hi - 1;
  const double min_deg = std::max(luff_min_deg[lo], luff_min_deg[hi]);
  const double max_deg = std::min(luff_max_deg[lo], luff_max_deg[hi]);
  v.chart_row = static_cast<int>(hi);
  v.value = boom_elevation_rad;
  if (boom_elevation_rad < min_deg * kDegToRad) {
    v.status = ConstraintStatus::BoomBelowChartAngle;
    v.limit = min_deg * kDegToRad;
  } else if (boom_elevation_rad > max_deg * kDegToRad) {
    v.status = ConstraintStatus::BoomAboveChartAngle;
    v.limit = max_deg * kDegToRad;
  } else {
    v.limit = min_deg * kDegToRad;
  }
  return v;
}

}  // namespace mgc::planning
