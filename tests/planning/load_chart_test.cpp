// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/load_chart.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {
const LoadChart& chart() {
  static const MachineDefinition m =
      io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  return *m.load_chart;
}
const LuffRangeTable& luff_table() {
  static const MachineDefinition m =
      io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  return *m.luff_table;
}
}  // namespace

TEST_CASE("load chart holds the thesis's App. G arrays", "[unit]") {
  const LoadChart& c = chart();
  REQUIRE(c.boom_lengths_ft.size() == 8);
  REQUIRE(c.radii_ft.size() == 21);
  CHECK(c.capacity_lb[0][0] == 140000);
  CHECK(c.capacity_lb[3][9] == 20700);
  CHECK(c.max_angle_from_vertical_deg[3][9] == 50.5);
  CHECK(c.capacity_lb[7][20] == 4060);
  CHECK(std::isnan(c.capacity_lb[3][3]));
  CHECK(c.max_angle_from_vertical_deg[3][3] == 18.5);  // an angle-only "(*)" cell
}

TEST_CASE("thesis worked example: 20,000 lb on a 20 m boom needs at least 39.5 deg", "[unit]") {
  const LoadChartRule rule(chart(), 20000.0);
  // 20 m = 65.6 ft -> the 70-ft row; the largest radius rated for 20,000 lb is 50 ft
  // (20,700 lb), whose angle is 50.5 deg from vertical: elevation >= 39.5 deg.
  const ConstraintVerdict v = rule.min_elevation(20.0);
  REQUIRE(v.ok());
  CHECK(v.chart_row == 3);
  CHECK(chart().radii_ft[static_cast<std::size_t>(v.chart_column)] == 50);
  CHECK(v.limit == Approx(39.5 * kDeg).epsilon(1e-12));
  CHECK(rule.check(20.0, 39.6 * kDeg).ok());
  CHECK(rule.check(20.0, 39.5 * kDeg).ok());
  const ConstraintVerdict low = rule.check(20.0, 39.4 * kDeg);
  CHECK(low.status == ConstraintStatus::BoomBelowChartAngle);
  CHECK(low.value == Approx(39.4 * kDeg));
}

TEST_CASE("load chart row is the first chart boom length at or above the actual one", "[unit]") {
  const LoadChartRule rule(chart(), 20000.0);
  CHECK(rule.min_elevation(36 * kMetresPerFoot).chart_row == 0);
  CHECK(rule.min_elevation(36.01 * kMetresPerFoot).chart_row == 1);
  CHECK(rule.min_elevation(110 * kMetresPerFoot).chart_row == 7);
  const ConstraintVerdict beyond = rule.min_elevation(110.5 * kMetresPerFoot);
  CHECK(beyond.status == ConstraintStatus::BoomLengthOutsideChart);
}

TEST_CASE("a heavy load is rated only on short booms", "[unit]") {
  const LoadChartRule rule(chart(), 100000.0);
  // 36-ft row scanned from the largest radius: 27,600, 59,800, 78,750, 69,800 < 100,000;
  // 110,500 at 12 ft covers it: 26 deg from vertical -> elevation >= 64 deg.
  const ConstraintVerdict shortest = rule.min_elevation(10.9728);
  REQUIRE(shortest.ok());
  CHECK(shortest.chart_column == 1);
  CHECK(shortest.limit == Approx(64 * kDeg));
  const ConstraintVerdict v = rule.check(20.0, 70 * kDeg);
  CHECK(v.status == ConstraintStatus::LoadAboveChart);
  CHECK(v.chart_row == 3);
}

TEST_CASE("capacity reduction raises the load the chart must cover", "[unit]") {
  // 19,000 lb + 10 % = 20,900 lb: the 70-ft row's 20,700 lb at 50 ft no longer covers it;
  // 24,650 lb at 45 ft does: 43.5 deg from vertical -> elevation >= 46.5 deg.
  const LoadChartRule rule(chart(), 19000.0 * 1.10);
  CHECK(rule.min_elevation(20.0).limit == Approx(46.5 * kDeg));
}

TEST_CASE("a load at or above every capacity cannot make a rule", "[unit]") {
  CHECK_THROWS_AS(LoadChartRule(chart(), 140001.0), std::invalid_argument);
  CHECK_THROWS_AS(LoadChartRule(chart(), 140000.0), std::invalid_argument);
  CHECK_NOTHROW(LoadChartRule(chart(), 139999.0));
}

TEST_CASE("a cell rated at exactly the load does not rate it: the limiter holds motions from 100 % on", "[unit]") {
  // 70-ft row: 24,650 lb at 43.5 deg from vertical, 20,700 lb at 50.5 deg. 20,700 lb exactly is
  // rated by the 24,650 lb cell only: elevation >= 46.5 deg, not 39.5.
  const LoadChartRule at(chart(), 20700.0);
  CHECK(at.min_elevation(20.0).limit == Approx(46.5 * kDeg));
  const LoadChartRule below(chart(), 20699.0);
  CHECK(below.min_elevation(20.0).limit == Approx(39.5 * kDeg));
}

TEST_CASE("seed 000 luff table: rows exact, conservative between rows", "[unit]") {
  const LuffRangeTable& t = luff_table();
  CHECK(t.check(36 * kMetresPerFoot, 32.5 * kDeg).ok());
  CHECK(t.check(36 * kMetresPerFoot, 32.4 * kDeg).status == ConstraintStatus::BoomBelowChartAngle);
  CHECK(t.check(36 * kMetresPerFoot, 68.1 * kDeg).status == ConstraintStatus::BoomAboveChartAngle);
  // Between 50 ft [24.5, 75] and 60 ft [23, 78]: [24.5, 75].
  const double l55 = 55 * kMetresPerFoot;
  CHECK(t.check(l55, 24.4 * kDeg).status == ConstraintStatus::BoomBelowChartAngle);
  CHECK(t.check(l55, 24.6 * kDeg).ok());
  CHECK(t.check(l55, 75.1 * kDeg).status == ConstraintStatus::BoomAboveChartAngle);
  // Between 60 ft [23, 78] and 70 ft [32, 80]: [32, 78] -- the non-convex rise in the minimum.
  const double l65 = 65 * kMetresPerFoot;
  CHECK(t.check(l65, 31.9 * kDeg).status == ConstraintStatus::BoomBelowChartAngle);
  CHECK(t.check(l65, 78.1 * kDeg).status == ConstraintStatus::BoomAboveChartAngle);
  CHECK(t.check(l65, 50 * kDeg).ok());
  CHECK(t.check(35 * kMetresPerFoot, 50 * kDeg).status == ConstraintStatus::BoomLengthOutsideChart);
  CHECK(t.check(111 * kMetresPerFoot, 60 * kDeg).status == ConstraintStatus::BoomLengthOutsideChart);
}
