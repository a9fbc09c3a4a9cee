// SPDX-License-Identifier: Apache-2.0
// Rated capacity limiting on the TMS870's chart (scenarios/machines/grove-tms870.yaml) with the
// thesis's 20,000 lb load on a 20 m boom: row 70 ft, whose cells run 43.5 deg from vertical:
// 24,650 lb, 50.5 deg: 20,700 lb, 58 deg: 17,500 lb.
#include <catch2/catch.hpp>

#include <cmath>
#include <optional>
#include <stdexcept>
#include <vector>

#include "fixture.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/planning/random.hpp"

using namespace mgc;
using namespace mgc::guidance;
using mgc::planning::MobileCrane;
using mgc::test::kDeg;
using mgc::test::ThesisCrane;

TEST_CASE("rated capacity is read from the next longer boom row and the next larger radius", "[unit]") {
  ThesisCrane t;
  const RatedCapacity at50 = rated_capacity(t.crane.chart(), 20.0, 50.0 * kDeg);
  CHECK(at50.in_chart);
  CHECK(at50.chart_row == 3);  // 70 ft
  CHECK(at50.chart_column == 8);
  CHECK(at50.capacity_lb == 24650.0);
  CHECK(rated_capacity(t.crane.chart(), 20.0, 40.0 * kDeg).capacity_lb == 20700.0);
  CHECK(rated_capacity(t.crane.chart(), 20.0, 39.0 * kDeg).capacity_lb == 17500.0);
  // A chart boom length is its own row: 60 ft = 18.288 m, 50 deg from vertical -> 55.5 deg: 23,400 lb.
  CHECK(rated_capacity(t.crane.chart(), 60 * planning::kMetresPerFoot, 40.0 * kDeg).capacity_lb == 23400.0);
  CHECK_FALSE(rated_capacity(t.crane.chart(), 40.0, 50.0 * kDeg).in_chart);  // longer than 110 ft
  CHECK_FALSE(rated_capacity(t.crane.chart(), 20.0, -5.0 * kDeg).in_chart);  // below horizontal
}

TEST_CASE("utilisation stages at 90 % and 100 % agree with the load-chart rule", "[unit]") {
  ThesisCrane t;
  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  CHECK(rcl.task_load_lb() == 20000.0);
  const planning::JointVector still = planning::JointVector::Zero(4);

  const RatedCapacityResult normal = rcl.limit_velocity(ThesisCrane::q(80, 50, 20, 14.82), 20000.0, still);
  CHECK(normal.stage == RclStage::Normal);
  CHECK(normal.utilisation == Approx(20000.0 / 24650.0));
  CHECK(normal.load_radius_m == Approx(20.0 * std::cos(50.0 * kDeg)));

  const planning::JointVector q40 = ThesisCrane::q(80, 40, 20, 14.82);
  CHECK(rcl.limit_velocity(q40, 18600.0, still).stage == RclStage::Normal);    // 89.9 %
  CHECK(rcl.limit_velocity(q40, 18650.0, still).stage == RclStage::Warning);   // 90.1 %
  CHECK(rcl.limit_velocity(q40, 20000.0, still).stage == RclStage::Warning);   // 96.6 %
  CHECK(rcl.limit_velocity(q40, 20690.0, still).stage == RclStage::Warning);   // 99.95 %
  const RatedCapacityResult full = rcl.limit_velocity(q40, 20700.0, still);    // 100 %
  CHECK(full.stage == RclStage::Overload);
  CHECK(full.utilisation == 1.0);
  rcl.reset();

  // The load-chart rule's minimum elevation for 20,000 lb on this row is 90 - 50.5 = 39.5 deg: the
  // limiter's 100 % falls on the same boundary.
  const planning::LoadChartRule& rule = *t.crane.chart_rule();
  CHECK(rule.check(20.0, 39.6 * kDeg).ok());
  CHECK(rcl.limit_velocity(ThesisCrane::q(80, 39.6, 20, 14.82), 20000.0, still).stage == RclStage::Warning);
  CHECK_FALSE(rule.check(20.0, 39.4 * kDeg).ok());
  const RatedCapacityResult over = rcl.limit_velocity(ThesisCrane::q(80, 39.4, 20, 14.82), 20000.0, still);
  CHECK(over.stage == RclStage::Overload);
  CHECK(over.utilisation == Approx(20000.0 / 17500.0));
}

TEST_CASE("wherever the load-chart rule accepts a configuration the limiter holds no motion", "[property]") {
  // Every load the chart's own capacities name (the case where App. G's "covers" and the limiter's
  // 100 % meet), one pound either side, and a 500-lb grid; every row's boom length and one between
  // rows; elevations every 0.25 deg and at the rule's limit itself.
  ThesisCrane t;
  const planning::LoadChart& chart = t.crane.chart();
  std::vector<double> loads;
  for (double lb = 500.0; lb <= 150000.0; lb += 500.0) loads.push_back(lb);
  for (const auto& row : chart.capacity_lb) {
    for (const double c : row) {
      if (std::isnan(c)) continue;
      loads.insert(loads.end(), {c - 1.0, c, c + 1.0});
    }
  }
  std::vector<double> booms_m;
  for (std::size_t r = 0; r < chart.boom_lengths_ft.size(); ++r) {
    booms_m.push_back(chart.boom_lengths_ft[r] * planning::kMetresPerFoot);
    if (r + 1 < chart.boom_lengths_ft.size()) {
      booms_m.push_back(0.5 * (chart.boom_lengths_ft[r] + chart.boom_lengths_ft[r + 1]) * planning::kMetresPerFoot);
    }
  }
  const planning::JointVector still = planning::JointVector::Zero(4);
  std::size_t accepted = 0;
  for (const double load_lb : loads) {
    std::optional<planning::LoadChartRule> rule;
    try {
      rule.emplace(chart, load_lb);
    } catch (const std::invalid_argument&) {
      continue;
    }
    for (const double boom_m : booms_m) {
      std::vector<double> elevations_deg;
      for (double e = 0.0; e <= 85.0; e += 0.25) elevations_deg.push_back(e);
      const planning::ConstraintVerdict limit = rule->min_elevation(boom_m);
      if (limit.ok()) elevations_deg.push_back(limit.limit / kDeg);
      for (const double e_deg : elevations_deg) {
        if (!rule->check(boom_m, e_deg * kDeg).ok()) continue;
        RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
        const RatedCapacityResult r = rcl.limit_velocity(ThesisCrane::q(0, e_deg, boom_m, 5.0), load_lb, still);
        ++accepted;
        INFO("load " << load_lb << " lb, boom " << boom_m << " m, elevation " << e_deg << " deg: utilisation " << r.utilisation);
        REQUIRE(r.stage != RclStage::Overload);
        REQUIRE(r.stage != RclStage::OutsideChart);
        REQUIRE(r.utilisation < 1.0);
      }
    }
  }
  CHECK(accepted > 100000);
}

TEST_CASE("in overload the moment-increasing motions are cut and the rest allowed", "[unit]") {
  ThesisCrane t;
  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  const planning::JointVector q = ThesisCrane::q(80, 39, 20, 14.82);  // 114 %

  // Boom down, telescope out, hoist raise, slew: only slew survives.
  const RatedCapacityResult worse = rcl.limit_velocity(q, 20000.0, ThesisCrane::v(0.05, -0.01, 0.1, -0.3));
  CHECK(worse.stage == RclStage::Overload);
  CHECK(worse.allowed_velocity == ThesisCrane::v(0.05, 0.0, 0.0, 0.0));
  CHECK_FALSE(worse.cut[MobileCrane::kSwing]);
  CHECK(worse.cut[MobileCrane::kBoomElevation]);
  CHECK(worse.cut[MobileCrane::kBoomLength]);
  CHECK(worse.cut[MobileCrane::kCableLength]);
  // The signs come from d(radius)/dq: -L sin(elevation) for luffing, cos(elevation) for telescoping.
  CHECK(worse.radius_gradient[1] == Approx(-20.0 * std::sin(39.0 * kDeg)).epsilon(1e-6));
  CHECK(worse.radius_gradient[2] == Approx(std::cos(39.0 * kDeg)).epsilon(1e-6));
  CHECK(worse.radius_gradient[0] == Approx(0.0).margin(1e-9));

  // Boom up, telescope in, hoist lowering: all reduce or keep the moment, all allowed.
  const RatedCapacityResult better = rcl.limit_velocity(q, 20000.0, ThesisCrane::v(-0.05, 0.01, -0.1, 0.3));
  CHECK(better.allowed_velocity == ThesisCrane::v(-0.05, 0.01, -0.1, 0.3));

  // Below 100 % (the warning stage) nothing is cut.
  RatedCapacityLimiter fresh(t.crane, RatedCapacityConfig{});
  const RatedCapacityResult warn = fresh.limit_velocity(ThesisCrane::q(80, 40, 20, 14.82), 20000.0,
                                                        ThesisCrane::v(0.05, -0.01, 0.1, -0.3));
  CHECK(warn.stage == RclStage::Warning);
  CHECK(warn.allowed_velocity == ThesisCrane::v(0.05, -0.01, 0.1, -0.3));

  // Hoist raising may be released by configuration.
  RatedCapacityConfig c;
  c.cut_hoist_raise = false;
  RatedCapacityLimiter hoist(t.crane, c);
  CHECK(hoist.limit_velocity(q, 20000.0, ThesisCrane::v(0, 0, 0, -0.3)).allowed_velocity[3] == -0.3);
}

TEST_CASE("after an overload the cut holds until utilisation falls below 90 %", "[unit]") {
  ThesisCrane t;
  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  const planning::JointVector down = ThesisCrane::v(0.0, -0.01, 0.0, 0.0);
  CHECK(rcl.limit_velocity(ThesisCrane::q(80, 39, 20, 14.82), 20000.0, down).stage == RclStage::Overload);
  CHECK(rcl.overload_latched());
  // Boomed up to 96.6 %: still latched, boom down still cut.
  const RatedCapacityResult latched = rcl.limit_velocity(ThesisCrane::q(80, 40, 20, 14.82), 20000.0, down);
  CHECK(latched.stage == RclStage::Overload);
  CHECK(latched.allowed_velocity[1] == 0.0);
  // At 81 % the latch clears.
  CHECK(rcl.limit_velocity(ThesisCrane::q(80, 50, 20, 14.82), 20000.0, down).stage == RclStage::Normal);
  CHECK_FALSE(rcl.overload_latched());
  CHECK(rcl.limit_velocity(ThesisCrane::q(80, 40, 20, 14.82), 20000.0, down).stage == RclStage::Warning);
}

TEST_CASE("outside the chart every moment-increasing motion is cut", "[unit]") {
  ThesisCrane t;
  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  const RatedCapacityResult r =
      rcl.limit_velocity(ThesisCrane::q(80, -2, 20, 14.82), 20000.0, ThesisCrane::v(0.0, 0.0, 0.1, 0.0));
  CHECK(r.stage == RclStage::OutsideChart);
  CHECK(std::isinf(r.utilisation));
  CHECK(r.allowed_velocity[2] == 0.0);
}

TEST_CASE("the limiter reads the chart along the motion of the next period, not only where it stands", "[unit]") {
  ThesisCrane t;
  const planning::LoadChart& chart = t.crane.chart();
  // 12,000 lb telescoping 24.0 -> 24.6 m while luffing up 35.3 -> 35.6 deg within one period:
  // at 24.0 m the 80-ft row's 60-deg cell rates 13,650 lb (88 %), at the end the 90-ft row's
  // 54.5-deg cell 12,500 lb (96 %); between, just past 80 ft below 35.5 deg, the 90-ft row's
  // 61-deg cell rates only 10,900 lb.
  const planning::JointVector q = ThesisCrane::q(80, 35.3, 24.0, 5.0);
  planning::JointVector v = planning::JointVector::Zero(4);
  v[MobileCrane::kBoomElevation] = 0.3 * kDeg;
  v[MobileCrane::kBoomLength] = 0.6;
  CHECK(rated_capacity(chart, 24.0, 35.3 * kDeg).capacity_lb == 13650.0);
  CHECK(rated_capacity(chart, 24.6, 35.6 * kDeg).capacity_lb == 12500.0);
  const RatedCapacity along = rated_capacity_along(chart, 24.0, 35.3 * kDeg, 24.6, 35.6 * kDeg);
  CHECK(along.in_chart);
  CHECK(along.capacity_lb == 10900.0);
  CHECK(along.chart_row == 5);

  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  CHECK(rcl.limit_velocity(q, 12000.0, v).stage == RclStage::Normal);
  rcl.reset();
  const RatedCapacityResult ahead = rcl.limit_velocity(q, 12000.0, v, 1.0);
  CHECK(ahead.stage == RclStage::Overload);
  CHECK(ahead.utilisation == Approx(12000.0 / 10900.0));
  // Telescoping out is cut; luffing up (it shortens the radius) is not.
  CHECK(ahead.cut[MobileCrane::kBoomLength]);
  CHECK_FALSE(ahead.cut[MobileCrane::kBoomElevation]);
  CHECK(ahead.allowed_velocity[MobileCrane::kBoomLength] == 0.0);
}

TEST_CASE("the chart along a motion is never above any point of it, and is the point's when still", "[oracle][property]") {
  ThesisCrane t;
  const planning::LoadChart& chart = t.crane.chart();
  planning::Random random(5);
  constexpr int kDense = 10000;
  for (int e = 0; e < 400; ++e) {
    const auto row = 1 + static_cast<std::size_t>(random.uniform() * static_cast<double>(chart.boom_lengths_ft.size() - 2));
    const double boundary_m = chart.boom_lengths_ft[row] * planning::kMetresPerFoot;
    const double l0 = boundary_m + random.uniform(-1.0, 1.0);
    const double l1 = boundary_m + random.uniform(-1.0, 1.0);
    const double e0 = random.uniform(5.0, 80.0) * kDeg;
    const double e1 = e0 + random.uniform(-5.0, 5.0) * kDeg;
    CAPTURE(e, l0, l1, e0, e1);
    const RatedCapacity still = rated_capacity_along(chart, l0, e0, l0, e0);
    const RatedCapacity point = rated_capacity(chart, l0, e0);
    CHECK(still.in_chart == point.in_chart);
    CHECK(still.capacity_lb == point.capacity_lb);
    const RatedCapacity along = rated_capacity_along(chart, l0, e0, l1, e1);
    for (int k = 0; k <= kDense; ++k) {
      const double s = static_cast<double>(k) / kDense;
      const RatedCapacity at = rated_capacity(chart, l0 + s * (l1 - l0), e0 + s * (e1 - e0));
      if (!at.in_chart) {
        REQUIRE_FALSE(along.in_chart);
        break;
      }
      REQUIRE(along.capacity_lb <= at.capacity_lb);
    }
  }
}
