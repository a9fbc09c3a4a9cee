// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <numbers>
#include <string>
#include <vector>

#include "mgc/planning/constraint.hpp"

namespace mgc::planning {

inline constexpr double kMetresPerFoot = 0.3048;
inline constexpr double kKilogramsPerPound = 0.45359237;

//! A mobile crane's rated-capacity chart as published (feet, pounds, degrees), for one rigging:
//! outrigger state and counterweight. Rows are boom lengths, columns are load radii; a cell
//! holds the rated capacity and the chart's boom angle, or NaN where the chart has no entry.
struct LoadChart {
  std::string rating;                     //!< e.g. "85% domestic"
  std::string outriggers;                 //!< rigging the chart is valid for, e.g. "fully_extended"
  double counterweight_lb = 0.0;          //!< [lb]
  std::vector<double> boom_lengths_ft;    //!< strictly ascending [ft]
  std::vector<double> radii_ft;           //!< strictly ascending [ft]
  std::vector<std::vector<double>> capacity_lb;                  //!< [row][column] [lb] [n/a: NaN]
  std::vector<std::vector<double>> max_angle_from_vertical_deg;  //!< [row][column] [deg] [n/a: NaN]
};

//! A boom's angle from vertical [deg] at boom_elevation_rad [rad], as the chart's columns state it.
//! The planner's rule and the rated capacity limiter both read the chart through it, so that at a
//! cell's boundary they agree to the last bit.
[[nodiscard]] inline double angle_from_vertical_deg(double boom_elevation_rad) noexcept {
  return 90.0 - boom_elevation_rad * (180.0 / std::numbers::pi);
}

//! The thesis's load-chart rule (ICE-Planner App. G, "LVA") for one load: the boom-length row is
//! the first chart boom length at or above the actual one; in that row the largest radius up to
//! which every cell's capacity exceeds the load sets the maximum boom angle from vertical, i.e. the
//! minimum boom elevation. So the rule accepts a configuration only where the rated capacity
//! limiter, which reads the cell at the boom's angle, stands below 100 % and holds no motion. App.
//! G differs twice: it takes a capacity equal to the load (the limiter cuts the moment-increasing
//! motions and hoist raising at 100 %, so a path through such a cell could not be driven), and it
//! takes the largest radius whose own capacity covers the load (the same where capacities fall
//! with the radius, which App. G's 36-ft row does not). Computed once per load so a check is a
//! search over a handful of rows.
class LoadChartRule {
 public:
  //! load_lb already includes any capacity reduction. Throws std::invalid_argument when no row
  //! of the chart rates the load at all.
  LoadChartRule(const LoadChart& chart, double load_lb);

  //! Checks a boom length [m] and boom elevation above horizontal [rad]. RT-safe.
  [[nodiscard]] ConstraintVerdict check(double boom_length_m, double boom_elevation_rad) const noexcept;

  //! Checks every configuration of the straight motion from (from_boom_m, from_elevation_rad) to
  //! (to_boom_m, to_elevation_rad), both linear in t in [0, 1]: ok only if check() holds all
  //! along. Otherwise t_first receives the first fraction at which it fails (on the boundary of the
  //! failing stretch: a row's span entered, or the elevation crossing its limit) and the verdict
  //! says which rule, row and limit. Exact: the rule is constant over each row's span of boom
  //! lengths, and a linear elevation meets a constant range at the ends of each span's stretch, so
  //! those ends are the only configurations to check. RT-safe.
  [[nodiscard]] ConstraintVerdict check_edge(double from_boom_m, double from_elevation_rad, double to_boom_m,
                                             double to_elevation_rad, double& t_first) const noexcept;

  //! Minimum boom elevation [rad] for the row that covers boom_length_m, with the cell used;
  //! status says when the boom length or load is outside the chart.
  [[nodiscard]] ConstraintVerdict min_elevation(double boom_length_m) const noexcept;

  [[nodiscard]] double load_lb() const noexcept { return load_lb_; }

 private:
  struct Row {
    double boom_length_m = 0.0;
    int column = -1;                 //!< -1: no radius of this row rates the load
    double min_elevation_rad = 0.0;
  };
  std::vector<Row> rows_;
  double load_lb_ = 0.0;
};

//! Seed 000's Table 1: the luffing-angle range per boom length for one lift task, an
//! alternative to the load-chart rule. Between two rows the range is the conservative
//! intersection of both rows (the larger minimum and the smaller maximum), because the paper
//! gives no interpolation and the feasible region is not convex.
struct LuffRangeTable {
  std::vector<double> boom_lengths_ft;  //!< strictly ascending [ft]
  std::vector<double> luff_min_deg;     //!< [deg] above horizontal
  std::vector<double> luff_max_deg;     //!< [deg] above horizontal

  //! Elevation [rad] against the range at boom_length_m. RT-safe.
  [[nodiscard]] ConstraintVerdict check(double boom_length_m, double boom_elevation_rad) const noexcept;

  //! The same along a straight motion, as LoadChartRule::check_edge: the range is constant at
  //! each row and between two rows, so the ends of each stretch are the configurations to check.
  //! RT-safe.
  [[nodiscard]] ConstraintVerdict check_edge(double from_boom_m, double from_elevation_rad, double to_boom_m,
                                             double to_elevation_rad, double& t_first) const noexcept;
};

}  // namespace mgc::planning
