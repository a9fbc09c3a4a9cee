// SPDX-License-Identifier: Apache-2.0
// Rated capacity limiting on the TMS870's chart (scenarios/machines/grove-tms870.yaml) with the
// thesis's 20,000 lb load on a 20 m boom: row 70 ft, whose cells run 43.5 deg from vertical:
// 24,650 lb, 50.5 deg: 20,700 lb, 58 deg: 17,500 lb.
#include <catch2/catch.hpp>

#include <cmath>

#include "fixture.hpp"
#include "mgc/guidance/rated_capacity.hpp"

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
