// SPDX-License-Identifier: Apache-2.0
// The dual-crane model of seed 004: the corrected Appendix, the suspension solver against note 004's
// numerical checks, feasibility verdicts, the anchor-step edge rule and the scenario files.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "mgc/planning/dual_crane.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;
using mgc::test::source_path;

namespace {

io::LoadedScenario load(const char* name) { return io::load_and_build(source_path(std::string("scenarios/") + name)); }

const DualCraneModel& dual(const io::LoadedScenario& loaded) {
  const auto* model = dynamic_cast<const DualCraneModel*>(loaded.model.get());
  REQUIRE(model != nullptr);
  return *model;
}

JointVector config_deg(double swing_1, double elevation_1, double cable_1, double swing_2, double elevation_2, double cable_2) {
  JointVector q(6);
  q << swing_1 * kDeg, elevation_1 * kDeg, cable_1, swing_2 * kDeg, elevation_2 * kDeg, cable_2;
  return q;
}

// Note 004 §6.3, scenario 1 start with the boom foot on the ground: tips 18.53 m apart, 16.383 m up.
SuspensionInput scenario_1_start_on_ground() {
  const double reach = 20.0 * std::cos(55.0 * kDeg);
  SuspensionInput in;
  in.tip_1_m = {5.0 + reach * std::cos(60.0 * kDeg), 20.0 + reach * std::sin(60.0 * kDeg), 20.0 * std::sin(55.0 * kDeg)};
  in.tip_2_m = {35.0 + reach * std::cos(120.0 * kDeg), 20.0 + reach * std::sin(120.0 * kDeg), in.tip_1_m.z()};
  in.cable_1_m = 15.0;
  in.cable_2_m = 15.0;
  in.girder_length_m = 18.0;
  in.max_cable_tilt_rad = 10.0 * kDeg;
  return in;
}

}  // namespace

TEST_CASE("corrected Appendix: both roots of note 004's check, only one closes the chain", "[unit]") {
  // Note 004 §2: A1 = (0, 16.383), A2 = (18.53, 16.383), l_h = 15, l_obj = 18, cable 1 at 1 deg:
  // roots 1.025 and 79.79 deg; the printed (A^2 - B^2) form gives 30.58 deg instead.
  const SuspensionInput in = scenario_1_start_on_ground();
  CHECK((in.tip_2_m - in.tip_1_m).head<2>().norm() == Approx(18.53).margin(0.005));
  CHECK(in.tip_1_m.z() == Approx(16.383).margin(0.001));
  // The note's rounded numbers, so that its roots come out to its digits.
  const double span = 18.53;
  const double z = 16.383;
  std::array<double, 2> sines{};
  REQUIRE(appendix_cable_2_sines(0.0, z, span, z, 15.0, 15.0, 18.0, 1.0 * kDeg, sines) == 2);
  const double low = std::asin(std::min(sines[0], sines[1])) / kDeg;
  const double high = std::asin(std::max(sines[0], sines[1])) / kDeg;
  CHECK(low == Approx(1.025).margin(0.005));
  CHECK(high == Approx(79.79).margin(0.01));
  // Closure: only the low root gives a girder of the right length (cos^2 + sin^2 of its slope = 1).
  const auto closure = [&](double tilt_2_deg) {
    const double gx = (span - 15.0 * std::sin(1.0 * kDeg) - 15.0 * std::sin(tilt_2_deg * kDeg)) / 18.0;
    const double gz = (15.0 * std::cos(1.0 * kDeg) - 15.0 * std::cos(tilt_2_deg * kDeg)) / 18.0;
    return gx * gx + gz * gz;
  };
  CHECK(closure(low) == Approx(1.0).margin(1e-6));
  CHECK(std::abs(closure(high) - 1.0) > 0.1);
}

TEST_CASE("scenario 1 start: both cables about 1.0 deg, anchors about 1.39 m high (foot on the ground)", "[unit]") {
  const Suspension s = solve_suspension(scenario_1_start_on_ground());
  REQUIRE(s.ok());
  CHECK(s.cable_tilt_1_rad / kDeg == Approx(1.0).margin(0.05));
  CHECK(s.cable_tilt_2_rad / kDeg == Approx(1.0).margin(0.05));
  CHECK(s.girder_tilt_rad / kDeg == Approx(0.0).margin(1e-4));
  CHECK(s.anchor_1_m.z() == Approx(1.39).margin(0.01));
  CHECK(s.anchor_2_m.z() == Approx(1.39).margin(0.01));
  CHECK((s.anchor_2_m - s.anchor_1_m).norm() == Approx(18.0).epsilon(1e-9));
  // A symmetric chain shares the load equally, each cable m g / (2 cos tilt).
  CHECK(s.tension_share_1 == Approx(0.5 / std::cos(s.cable_tilt_1_rad)).epsilon(1e-6));
  CHECK(s.tension_share_2 == Approx(s.tension_share_1).epsilon(1e-6));
}

TEST_CASE("an asymmetric equilibrium balances the horizontal forces and matches note 004 (scenario 2 start)", "[unit]") {
  const auto loaded = load("kim-s2.yaml");
  const DualCraneModel& model = dual(loaded);
  const Suspension s = model.suspension(loaded.scenario.start);
  REQUIRE(s.ok());
  // Note 004 §6.3 (a 0.05 deg scan): -1.60 / -1.63 / -0.68 deg. The foot height lifts both tips
  // alike and leaves the angles as they are.
  CHECK(s.cable_tilt_1_rad / kDeg == Approx(-1.60).margin(0.05));
  CHECK(s.cable_tilt_2_rad / kDeg == Approx(-1.63).margin(0.05));
  CHECK(s.girder_tilt_rad / kDeg == Approx(-0.68).margin(0.05));
  // The solver uses vertical and torque balance; the lowest centre must also balance sideways
  // (seed 004 Eq. 6), which nothing in it imposes.
  CHECK(std::abs(s.tension_share_1 * std::sin(s.cable_tilt_1_rad) - s.tension_share_2 * std::sin(s.cable_tilt_2_rad)) < 1e-6);
  CHECK(s.tension_share_1 * std::cos(s.cable_tilt_1_rad) + s.tension_share_2 * std::cos(s.cable_tilt_2_rad) ==
        Approx(1.0).epsilon(1e-12));
  // The note's closed form for the shares.
  CHECK(s.tension_share_1 == Approx(std::sin(s.cable_tilt_2_rad) / std::sin(s.cable_tilt_1_rad + s.cable_tilt_2_rad)).epsilon(1e-4));
  // Any other cable-1 tilt that closes the chain hangs the centre higher.
  std::array<double, 2> sines{};
  const Eigen::Vector3d t1 = model.boom_tip(loaded.scenario.start, 0);
  const Eigen::Vector3d t2 = model.boom_tip(loaded.scenario.start, 1);
  const double span = (t2 - t1).head<2>().norm();
  const double lowest = 0.5 * (s.anchor_1_m.z() + s.anchor_2_m.z());
  for (const double delta_deg : {-0.5, -0.05, 0.05, 0.5}) {
    CAPTURE(delta_deg);
    const double tilt_1 = s.cable_tilt_1_rad + delta_deg * kDeg;
    const int n = appendix_cable_2_sines(0.0, t1.z(), span, t2.z(), 15.0, 14.0, 15.0, tilt_1, sines);
    REQUIRE(n >= 1);
    const double tilt_2 = std::asin(sines[0]);
    const double centre = 0.5 * ((t1.z() - 15.0 * std::cos(tilt_1)) + (t2.z() - 14.0 * std::cos(tilt_2)));
    CHECK(centre > lowest);
  }
}

TEST_CASE("the scenario-1 start in the shipped file: anchors 0.5 m higher, feasible", "[unit]") {
  auto loaded = load("kim-s1.yaml");
  const DualCraneModel& model = dual(loaded);
  const Suspension s = model.suspension(loaded.scenario.start);
  REQUIRE(s.ok());
  CHECK(s.anchor_1_m.z() == Approx(1.39 + model.geometry().boom_foot_height_m).margin(0.01));
  CHECK(loaded.world->validate(loaded.scenario.start).valid());
  CHECK(loaded.world->validate(loaded.scenario.goal).valid());
  CHECK(io::check_endpoints(loaded).empty());
}

TEST_CASE("an infeasible suspension is a verdict, not an exception (scenario 3's goal as printed)", "[unit]") {
  auto loaded = load("kim-s3.yaml");
  const DualCraneModel& model = dual(loaded);
  // Table 1 prints theta2 = +130: the tips stand 17.5 m apart under a 35 m girder.
  const JointVector printed = config_deg(-130, 65, 16, 130, 65, 16);
  const ConstraintVerdict v = model.check_constraints(printed);
  CHECK(v.status == ConstraintStatus::TipDistance);
  CHECK(v.value == Approx(17.52).margin(0.01));
  const Validity validity = loaded.world->validate(printed);
  CHECK(validity.status == Validity::Status::Constraint);
  // The solver itself: the lowest centre lies on the edge of the tilt range.
  SuspensionInput in;
  in.tip_1_m = model.boom_tip(printed, 0);
  in.tip_2_m = model.boom_tip(printed, 1);
  in.cable_1_m = 16.0;
  in.cable_2_m = 16.0;
  in.girder_length_m = 35.0;
  in.max_cable_tilt_rad = 10.0 * kDeg;
  const Suspension s = solve_suspension(in);
  CHECK(s.status == SuspensionStatus::NoEquilibrium);
  CHECK(std::abs(s.boundary_tilt_rad) == Approx(10.0 * kDeg).margin(1e-6));
  // Tips one above the other span no plane.
  in.tip_2_m = in.tip_1_m + Eigen::Vector3d(0.0, 0.0, 1.0);
  CHECK(solve_suspension(in).status == SuspensionStatus::TipsAligned);
  // The corrected goal hangs level, 35 m of girder between tips 35 m apart.
  const Suspension goal = model.suspension(loaded.scenario.goal);
  REQUIRE(goal.ok());
  CHECK(goal.girder_tilt_rad == Approx(0.0).margin(1e-6));
  CHECK(loaded.world->validate(loaded.scenario.goal).valid());
}

TEST_CASE("feasibility names the rule: cable tilt, girder tilt, ground, overload", "[unit]") {
  auto loaded = load("kim-s1.yaml");
  const DualCraneModel& model = dual(loaded);
  // Hoists 5 m apart in length tilt the 18 m girder by about 16 deg.
  CHECK(model.check_constraints(config_deg(-30, 55, 10, 30, 55, 15)).status == ConstraintStatus::GirderTilt);
  // Cables paid out below the ground.
  const ConstraintVerdict ground = model.check_constraints(config_deg(-30, 55, 16.8, 30, 55, 16.8));
  CHECK(ground.status == ConstraintStatus::LoadBelowGround);
  CHECK(ground.value < 0.0);
  // Low booms: 15 deg puts each tip 19.3 m out (63.4 ft: the 65-ft column); half the 12 t girder (13,228 lb) is more than the
  // 70-ft row rates at 65 ft (9,150 lb).
  const JointVector low = config_deg(-18, 15, 4, 18, 15, 4);
  REQUIRE(model.suspension(low).ok());
  const ConstraintVerdict overload = model.check_constraints(low);
  CHECK(overload.status == ConstraintStatus::CraneOverload);
  CHECK(overload.limit == 9150.0);
  CHECK(overload.value == Approx(12000.0 / kKilogramsPerPound * model.suspension(low).tension_share_1).epsilon(1e-9));
  CHECK(overload.chart_row == 3);
  CHECK(overload.chart_column == 12);
  // The same chain with steeper booms is within the chart.
  CHECK(model.rated_capacity_lb(0, model.radius_m(loaded.scenario.start, 0)) == 29700.0);
}

TEST_CASE("edge samples keep every anchor and boom tip within the anchor step", "[unit]") {
  auto loaded = load("kim-s2.yaml");
  const DualCraneModel& model = dual(loaded);
  const double step_m = model.spec().anchor_step_m;
  const JointVector& a = loaded.scenario.start;
  const JointVector& b = loaded.scenario.goal;
  // A 90 deg swing of crane 1 alone at 50 deg: the tip's arc is 12.86 m x pi/2.
  JointVector swung = a;
  swung[DualCraneModel::kSwing1] += 90.0 * kDeg;
  CHECK(model.edge_min_samples(a, swung) >= static_cast<int>(std::ceil(20.0 * std::cos(50.0 * kDeg) * 0.5 * std::numbers::pi)));
  int checked = 0;
  for (const auto& [from, to] : {std::pair{a, b}, std::pair{a, swung}}) {
    const int n = model.edge_min_samples(from, to);
    Suspension previous = model.suspension(from);
    for (int k = 1; k <= n; ++k) {
      const JointVector q = model.interpolate(from, to, static_cast<double>(k) / n);
      const Suspension s = model.suspension(q);
      for (int crane = 0; crane < 2; ++crane) {
        const double tip_move = (model.boom_tip(q, crane) - model.boom_tip(model.interpolate(from, to, (k - 1.0) / n), crane)).norm();
        CHECK(tip_move <= step_m + 1e-9);
      }
      if (s.ok() && previous.ok()) {
        CAPTURE(k, n);
        CHECK((s.anchor_1_m - previous.anchor_1_m).norm() <= step_m * 1.05);
        CHECK((s.anchor_2_m - previous.anchor_2_m).norm() <= step_m * 1.05);
        ++checked;
      }
      previous = s;
    }
  }
  CHECK(checked > 20);
}

TEST_CASE("the per-thread suspension cache never mixes two models", "[unit]") {
  auto one = load("kim-s1.yaml");
  auto two = load("kim-s2.yaml");
  const DualCraneModel& m1 = dual(one);
  const DualCraneModel& m2 = dual(two);
  // The same q on both models, in turn: each answer must be its own model's.
  const JointVector& q = one.scenario.start;
  for (int round = 0; round < 3; ++round) {
    const Suspension s1 = m1.suspension(q);
    const Suspension s2 = m2.suspension(q);
    CHECK(s1.anchor_1_m == solve_suspension({m1.boom_tip(q, 0), m1.boom_tip(q, 1), q[2], q[5], 18.0, 10.0 * kDeg}).anchor_1_m);
    CHECK(s2.status == solve_suspension({m2.boom_tip(q, 0), m2.boom_tip(q, 1), q[2], q[5], 15.0, 10.0 * kDeg}).status);
  }
}

TEST_CASE("dual_crane section: errors name the file, line and field", "[unit]") {
  const std::string machine = source_path("scenarios/machines/kim-crane.yaml").string();
  const auto scenario = [&](const std::string& crane_1_boom, const std::string& extra, const std::string& cable_1 = "5") {
    return "name: t\nmachine: " + machine +
           "\ndual_crane:\n  crane_1:\n    base_position_m: [0, 0, 0]\n    base_yaw_deg: 0\n    boom_length_m: " + crane_1_boom +
           "\n  crane_2:\n    base_position_m: [30, 0, 0]\n    base_yaw_deg: 0\n    boom_length_m: 20\n"
           "  girder:\n    length_m: 18\n    mass_kg: 1000\n    radius_m: 0.1\n"
           "  max_cable_tilt_deg: 10\n  max_girder_tilt_deg: 10\n  anchor_step_m: 1\n" + extra +
           "obstacles: []\nstart: {swing_1_deg: 0, boom_elevation_1_deg: 50, cable_length_1_m: " + cable_1 + ", swing_2_deg: 0, "
           "boom_elevation_2_deg: 50, cable_length_2_m: 5}\n"
           "goal: {swing_1_deg: 0, boom_elevation_1_deg: 50, cable_length_1_m: 5, swing_2_deg: 0, "
           "boom_elevation_2_deg: 50, cable_length_2_m: 5}\nplanner: {dilation_m: 0}\n";
  };
  const auto error = [&](const std::string& text) -> std::string {
    mgc::test::TempFile file("dual.yaml", text);
    try {
      (void)io::load_scenario(file.path());
    } catch (const io::InputError& e) {
      return e.what();
    }
    return "";
  };
  CHECK(error(scenario("20", "")).empty());
  const std::string boom = error(scenario("40", ""));
  CHECK(boom.find(":7: dual_crane.crane_1.boom_length_m") != std::string::npos);
  CHECK(boom.find("outside the crane's boom_length range") != std::string::npos);
  CHECK(error(scenario("20", "task: {}\n")).find("a dual-crane scenario has no task") != std::string::npos);
  CHECK(error(scenario("20", "base: {}\n")).find("dual_crane.crane_1 and crane_2") != std::string::npos);
  // The cable may not be longer than the boom (seed 004 Table 1: C_max = l_b).
  CHECK(error(scenario("20", "", "21")).find("start.cable_length_1_m: expected a value within the joint range [1, 20]") != std::string::npos);
}
