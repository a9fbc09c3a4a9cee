// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/load_chart.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace mgc::planning {
namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;
//! Keeps the chart's own boom lengths, converted from feet, inside their row. [m]
constexpr double kRowTolerance_m = 1e-6;
//! The luff table's tolerance on its boom lengths. [ft]
constexpr double kLuffRowTolerance_ft = 1e-6;

//! A straight motion of boom length and elevation, both linear in t in [0, 1], and the first
//! failure found on it so far.
struct EdgeScan {
  EdgeScan(double length_at_0, double length_change, double elevation_at_0, double elevation_change) noexcept
      : length_0(length_at_0), length_delta(length_change), elevation_0(elevation_at_0), elevation_delta(elevation_change) {}

  double length_0 = 0.0;     //!< boom length at t = 0, in the unit of the spans [m | ft]
  double length_delta = 0.0;
  double elevation_0 = 0.0;  //!< [rad]
  double elevation_delta = 0.0;
  double t_first = std::numeric_limits<double>::infinity();
  ConstraintVerdict verdict;

  void fail(double t, const ConstraintVerdict& v) noexcept {
    if (t < t_first) {
      t_first = t;
      verdict = v;
    }
  }

  //! The stretch [t0, t1] of the motion whose boom length lies in the span from lo to hi (each end
  //! open or closed; +-inf for none); false when the motion never enters it.
  bool stretch(double lo, bool lo_open, double hi, bool hi_open, double& t0, double& t1) const noexcept {
    const double a = std::min(length_0, length_0 + length_delta);
    const double b = std::max(length_0, length_0 + length_delta);
    if (lo_open ? !(b > lo) : !(b >= lo)) return false;
    if (hi_open ? !(a < hi) : !(a <= hi)) return false;
    if (length_delta == 0.0) {
      t0 = 0.0;
      t1 = 1.0;
      return true;
    }
    const auto t_at = [&](double length) {
      if (!std::isfinite(length)) return (length > 0.0) == (length_delta > 0.0) ? 1.0 : 0.0;
      return std::clamp((length - length_0) / length_delta, 0.0, 1.0);
    };
    t0 = std::min(t_at(lo), t_at(hi));
    t1 = std::max(t_at(lo), t_at(hi));
    return true;
  }

  //! Over the stretch [t0, t1] the elevation must stay within [lowest, highest]. Linear, so it
  //! leaves the range, if at all, at t0 or where it crosses the limit its far end is past; a
  //! strict failure at a stretch's open end goes on just inside it, so checking the closure is
  //! exact. `v` carries the row and column.
  void require_elevation(double t0, double t1, double lowest, double highest, ConstraintVerdict v) noexcept {
    const double e0 = elevation_0 + t0 * elevation_delta;
    const double e1 = elevation_0 + t1 * elevation_delta;
    const auto status_of = [&](double e) {
      return e < lowest ? ConstraintStatus::BoomBelowChartAngle : ConstraintStatus::BoomAboveChartAngle;
    };
    if (e0 < lowest || e0 > highest) {
      v.status = status_of(e0);
      v.value = e0;
      v.limit = e0 < lowest ? lowest : highest;
      fail(t0, v);
    } else if (e1 < lowest || e1 > highest) {
      v.status = status_of(e1);
      v.value = e1;
      v.limit = e1 < lowest ? lowest : highest;
      fail(t0 + (t1 - t0) * (v.limit - e0) / (e1 - e0), v);
    }
  }

  [[nodiscard]] ConstraintVerdict result(double& t) const noexcept {
    t = std::isfinite(t_first) ? t_first : 1.0;
    return verdict;
  }
};
}  // namespace

LoadChartRule::LoadChartRule(const LoadChart& chart, double load_lb) : load_lb_(load_lb) {
  bool any = false;
  rows_.reserve(chart.boom_lengths_ft.size());
  for (std::size_t r = 0; r < chart.boom_lengths_ft.size(); ++r) {
    Row row;
    row.boom_length_m = chart.boom_lengths_ft[r] * kMetresPerFoot;
    // The limiter reads the cell at the boom's angle (the next larger radius), so the rule takes
    // the largest radius up to which every cell of the row rates the load: App. G scans from the
    // largest radius inward for the first capacity that covers it, which is the same where the
    // capacities fall with the radius, but not in the 36-ft row App. G keeps (69,800 lb at 15 ft
    // between 110,500 and 78,750). Rated means strictly above the load: the limiter holds the
    // moment-increasing motions from 100 % on, so a path through a cell rated at exactly the
    // load could not be driven.
    int last_rated = -1;
    for (std::size_t c = 0; c < chart.radii_ft.size(); ++c) {
      const double capacity = chart.capacity_lb[r][c];
      if (std::isnan(capacity) || std::isnan(chart.max_angle_from_vertical_deg[r][c])) continue;
      if (!(load_lb < capacity)) break;
      last_rated = static_cast<int>(c);
    }
    if (last_rated >= 0) {
      row.column = last_rated;
      // The lowest elevation whose angle from vertical, read back, is within the cell's: a
      // conversion to radians and back may land a hair beyond it, in the next cell.
      const double max_angle_deg = chart.max_angle_from_vertical_deg[r][static_cast<std::size_t>(last_rated)];
      double e = (90.0 - max_angle_deg) * kDegToRad;
      while (angle_from_vertical_deg(e) > max_angle_deg) e = std::nextafter(e, std::numeric_limits<double>::infinity());
      row.min_elevation_rad = e;
      any = true;
    }
    rows_.push_back(row);
  }
  if (!any) throw std::invalid_argument("no capacity of the load chart exceeds the load");
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

ConstraintVerdict LoadChartRule::check_edge(double from_boom_m, double from_elevation_rad, double to_boom_m,
                                            double to_elevation_rad, double& t_first) const noexcept {
  EdgeScan scan(from_boom_m, to_boom_m - from_boom_m, from_elevation_rad, to_elevation_rad - from_elevation_rad);
  // Row r covers the boom lengths (row r-1, row r] (App. G: the first row at or above).
  double previous_m = -std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < rows_.size(); ++r) {
    const double bound_m = rows_[r].boom_length_m + kRowTolerance_m;
    double t0 = 0.0;
    double t1 = 0.0;
    const bool enters = scan.stretch(previous_m, true, bound_m, false, t0, t1);
    previous_m = bound_m;
    if (!enters) continue;
    ConstraintVerdict v;
    v.chart_row = static_cast<int>(r);
    if (rows_[r].column < 0) {
      v.status = ConstraintStatus::LoadAboveChart;
      v.value = load_lb_;
      scan.fail(t0, v);
      continue;
    }
    v.chart_column = rows_[r].column;
    scan.require_elevation(t0, t1, rows_[r].min_elevation_rad, 0.5 * std::numbers::pi, v);
  }
  double t0 = 0.0;
  double t1 = 0.0;
  if (scan.stretch(previous_m, true, std::numeric_limits<double>::infinity(), true, t0, t1)) {
    ConstraintVerdict v;
    v.status = ConstraintStatus::BoomLengthOutsideChart;
    v.value = std::max(from_boom_m, to_boom_m);
    v.limit = rows_.empty() ? 0.0 : rows_.back().boom_length_m;
    scan.fail(t0, v);
  }
  return scan.result(t_first);
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

ConstraintVerdict LuffRangeTable::check_edge(double from_boom_m, double from_elevation_rad, double to_boom_m,
                                             double to_elevation_rad, double& t_first) const noexcept {
  // In feet, as the table and check() have it; the length stays linear in t.
  EdgeScan scan(from_boom_m / kMetresPerFoot, (to_boom_m - from_boom_m) / kMetresPerFoot, from_elevation_rad,
                to_elevation_rad - from_elevation_rad);
  const std::size_t n = boom_lengths_ft.size();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto outside = [&](double lo, bool lo_open, double hi, bool hi_open) {
    double t0 = 0.0;
    double t1 = 0.0;
    if (!scan.stretch(lo, lo_open, hi, hi_open, t0, t1)) return;
    ConstraintVerdict v;
    v.status = ConstraintStatus::BoomLengthOutsideChart;
    v.value = scan.length_0 < lo ? std::max(from_boom_m, to_boom_m) : std::min(from_boom_m, to_boom_m);
    scan.fail(t0, v);
  };
  if (n == 0) {
    outside(-kInf, true, kInf, true);
    return scan.result(t_first);
  }
  outside(-kInf, true, boom_lengths_ft.front() - kLuffRowTolerance_ft, true);
  outside(boom_lengths_ft.back() + kLuffRowTolerance_ft, true, kInf, true);
  for (std::size_t i = 0; i < n; ++i) {
    double t0 = 0.0;
    double t1 = 0.0;
    ConstraintVerdict v;
    v.chart_row = static_cast<int>(i);
    // At row i (within the tolerance): its own range.
    if (scan.stretch(boom_lengths_ft[i] - kLuffRowTolerance_ft, false, boom_lengths_ft[i] + kLuffRowTolerance_ft,
                     false, t0, t1)) {
      scan.require_elevation(t0, t1, luff_min_deg[i] * kDegToRad, luff_max_deg[i] * kDegToRad, v);
    }
    // Strictly between rows i and i + 1: both ranges at once.
    if (i + 1 < n && scan.stretch(boom_lengths_ft[i] + kLuffRowTolerance_ft, true,
                                  boom_lengths_ft[i + 1] - kLuffRowTolerance_ft, true, t0, t1)) {
      v.chart_row = static_cast<int>(i + 1);
      scan.require_elevation(t0, t1, std::max(luff_min_deg[i], luff_min_deg[i + 1]) * kDegToRad,
                             std::min(luff_max_deg[i], luff_max_deg[i + 1]) * kDegToRad, v);
    }
  }
  return scan.result(t_first);
}

}  // namespace mgc::planning
