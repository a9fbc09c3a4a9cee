// SPDX-License-Identifier: Apache-2.0
// The load chart along an edge: an edge is chart-feasible only if every configuration on it is,
// not only its samples.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "mgc/planning/random.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

MobileCrane make_crane(double load_lb, CraneConstraintMode mode = CraneConstraintMode::LoadChart) {
  const MachineDefinition m = io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  LiftTask task;
  task.load_lb = load_lb;
  task.constraint = mode;
  task.load_size_m = {2.0, 2.0, 1.0};
  task.sling_length_m = 2.0;
  return MobileCrane(m.name, m.joints, m.mobile_crane, *m.load_chart, m.luff_table, task, Eigen::Isometry3d::Identity());
}

JointVector q4(double swing_deg, double elevation_deg, double boom_m, double cable_m) {
  JointVector q(4);
  q << swing_deg * kDeg, elevation_deg * kDeg, boom_m, cable_m;
  return q;
}

}  // namespace

TEST_CASE("an edge that crosses a chart row boundary below the longer row's angle is refused", "[unit]") {
  // 12,000 lb on the TMS870 chart: the 80-ft row rates it out to 65 ft of radius at 60 deg from
  // vertical (boom at least 30 deg up), the 90-ft row only to 70 ft at 54.5 deg (at least 35.5 deg).
  const MobileCrane crane = make_crane(12000.0);
  const double row_80ft_m = 80.0 * kMetresPerFoot;  // 24.384 m
  REQUIRE(crane.chart_rule()->min_elevation(row_80ft_m).limit == Approx(30.0 * kDeg));
  REQUIRE(crane.chart_rule()->min_elevation(row_80ft_m + 0.01).limit == Approx(35.5 * kDeg));

  // Telescoping 24.0 -> 24.6 m while luffing up 35.3 -> 35.6 deg: the boom passes 80 ft at
  // t = 0.64, at 35.492 deg, 0.008 deg short of the 90-ft row's minimum.
  const JointVector from = q4(0.0, 35.3, 24.0, 5.0);
  const JointVector to = q4(0.0, 35.6, 24.6, 5.0);
  CollisionWorld world(crane, 0.0);
  world.finalize();
  // Steps of 0.3 m of boom and more than the edge in the other joints: samples at t = 0.5 and 1.
  JointVector step(4);
  step << 10.0 * kDeg, 10.0 * kDeg, 0.3, 1.0;
  // Each sample, and the start, passes the chart: checked at its samples only, the edge would pass.
  REQUIRE(world.validate(from).valid());
  REQUIRE(world.validate(crane.interpolate(from, to, 0.5)).valid());
  REQUIRE(world.validate(to).valid());
  // Between them, the boom just past 80 ft is below 35.5 deg.
  const JointVector slice = crane.interpolate(from, to, 0.65);
  REQUIRE(crane.check_constraints(slice).status == ConstraintStatus::BoomBelowChartAngle);

  JointVector at;
  const Validity v = world.validate_edge(from, to, step, &at);
  REQUIRE(v.status == Validity::Status::Constraint);
  CHECK(v.constraint.status == ConstraintStatus::BoomBelowChartAngle);
  CHECK(v.constraint.chart_row == 5);  // 90 ft
  CHECK(v.constraint.limit == Approx(35.5 * kDeg));
  // Reported where the boom enters the 90-ft row.
  CHECK(at[MobileCrane::kBoomLength] == Approx(row_80ft_m).margin(1e-5));

  // Luffed up first (35.6 deg at both ends), the same telescoping is chart-feasible.
  CHECK(world.validate_edge(q4(0.0, 35.6, 24.0, 5.0), to, step).valid());
}

namespace {

//! Random edges whose ends lie within 1 m of one chart row boundary and a few degrees of the
//! elevation limits of the rows on either side, where slices between samples occur. The hook is
//! drawn up (1 m of cable) so that the load-above-ground rule, checked at samples only, holds.
void check_against_dense_sampling(const MobileCrane& crane, std::uint64_t seed) {
  const auto& lengths_ft = crane.chart().boom_lengths_ft;
  Random random(seed);
  constexpr int kEdges = 1500;
  constexpr int kDense = 10000;
  int refused = 0;
  int accepted = 0;
  int thin = 0;
  for (int e = 0; e < kEdges; ++e) {
    const auto row = 1 + static_cast<std::size_t>(random.uniform() * static_cast<double>(lengths_ft.size() - 2));
    const double boundary_m = lengths_ft[row] * kMetresPerFoot;
    double lo_deg = 90.0;
    double hi_deg = 0.0;
    for (const double length_m : {boundary_m - 0.5, boundary_m + 0.5}) {
      JointVector probe = q4(0.0, 0.0, length_m, 1.0);
      // The lowest elevation the rule allows at this length, found by bisection on check().
      double a = 10.0;
      double b = 80.0;
      for (int k = 0; k < 40; ++k) {
        probe[MobileCrane::kBoomElevation] = 0.5 * (a + b) * kDeg;
        (crane.check_constraints(probe).ok() ? b : a) = 0.5 * (a + b);
      }
      lo_deg = std::min(lo_deg, b);
      hi_deg = std::max(hi_deg, b);
    }
    const auto end = [&] {
      return q4(random.uniform(-180.0, 180.0), std::clamp(random.uniform(lo_deg - 3.0, hi_deg + 3.0), 10.0, 80.0),
                boundary_m + random.uniform(-1.0, 1.0), 1.0);
    };
    const JointVector from = end();
    const JointVector to = end();
    CAPTURE(e, seed, from.transpose(), to.transpose());
    double t_first = 0.0;
    const ConstraintVerdict edge = crane.check_edge_constraints(from, to, t_first);
    bool dense_ok = true;
    for (int k = 0; k <= kDense && dense_ok; ++k) {
      dense_ok = crane.check_constraints(crane.interpolate(from, to, static_cast<double>(k) / kDense)).ok();
    }
    if (edge.ok()) {
      ++accepted;
      // The property: an edge is chart-feasible only if every configuration on it is.
      REQUIRE(dense_ok);
      continue;
    }
    ++refused;
    if (dense_ok) {
      // Refused where 10,000 samples found nothing: the failing slice must be real, just past
      // t_first, and thinner than the sample spacing.
      ++thin;
      bool found = false;
      for (const double dt : {1e-12, 1e-10, 1e-8, 1e-6, 1e-5}) {
        found = found || !crane.check_constraints(crane.interpolate(from, to, std::min(1.0, t_first + dt))).ok();
      }
      CHECK(found);
    }
  }
  CAPTURE(accepted, refused, thin);
  CHECK(accepted > kEdges / 10);
  CHECK(refused > kEdges / 10);
}

}  // namespace

TEST_CASE("the chart verdict along an edge agrees with dense sampling of the chart", "[oracle][property]") {
  SECTION("load chart rule") { check_against_dense_sampling(make_crane(12000.0), 7); }
  SECTION("luff range table") { check_against_dense_sampling(make_crane(15000.0, CraneConstraintMode::LuffTable), 11); }
}

TEST_CASE("validate_edge refuses exactly the edges the chart refuses somewhere along them", "[oracle]") {
  const MobileCrane crane = make_crane(12000.0);
  CollisionWorld world(crane, 0.0);
  world.finalize();
  JointVector step(4);
  step << 5.0 * kDeg, 5.0 * kDeg, 0.5, 0.5;
  Random random(3);
  int refused = 0;
  for (int e = 0; e < 300; ++e) {
    const auto end = [&] { return q4(0.0, random.uniform(28.0, 40.0), random.uniform(23.4, 25.4), 2.0); };
    const JointVector from = end();
    const JointVector to = end();
    CAPTURE(e, from.transpose(), to.transpose());
    if (!world.validate(from).valid()) continue;
    double t_first = 0.0;
    const bool chart_ok = crane.check_edge_constraints(from, to, t_first).ok();
    JointVector at;
    const Validity v = world.validate_edge(from, to, step, &at);
    CHECK(v.valid() == chart_ok);
    if (!chart_ok) {
      ++refused;
      CHECK(v.status == Validity::Status::Constraint);
      // At the first failing sample, or, when every sample passes, where the chart fails between.
      CHECK((!crane.check_constraints(at).ok() || (at - crane.interpolate(from, to, t_first)).norm() < 1e-9));
    }
  }
  CHECK(refused > 30);
}
