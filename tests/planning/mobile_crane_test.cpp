// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <random>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

MachineDefinition tms870() { return io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml")); }

MobileCrane make_crane(const Eigen::Isometry3d& base = Eigen::Isometry3d::Identity(),
                       CraneConstraintMode mode = CraneConstraintMode::None) {
  const MachineDefinition m = tms870();
  LiftTask task;
  task.load_lb = 20000;
  task.constraint = mode;
  task.load_size_m = {3.0, 2.0, 1.0};
  task.sling_length_m = 2.0;
  return MobileCrane(m.name, m.joints, m.mobile_crane, *m.load_chart, m.luff_table, task, base);
}

JointVector q4(double swing_deg, double elevation_deg, double boom_m, double cable_m) {
  JointVector q(4);
  q << swing_deg * kDeg, elevation_deg * kDeg, boom_m, cable_m;
  return q;
}

}  // namespace

TEST_CASE("mobile crane forward kinematics match hand-computed poses", "[unit]") {
  const MobileCrane crane = make_crane();
  Kinematics k;
  // Boom foot at (0, 0, 3) (TMS870 file: on the swing axis, 3 m up).
  SECTION("boom level along +x") {
    crane.forward_kinematics(q4(0, 0, 20, 5), k);
    CHECK(k.points[MobileCrane::kPointBoomFoot].isApprox(Eigen::Vector3d(0, 0, 3), 1e-12));
    CHECK(k.points[MobileCrane::kPointBoomTip].isApprox(Eigen::Vector3d(20, 0, 3), 1e-12));
    CHECK(k.points[MobileCrane::kPointHook].isApprox(Eigen::Vector3d(20, 0, -2), 1e-12));
  }
  SECTION("swing 90 deg, elevation 30 deg") {
    // tip = (0, 20 cos 30, 3 + 20 sin 30) = (0, 17.3205..., 13); hook 5 m below.
    crane.forward_kinematics(q4(90, 30, 20, 5), k);
    CHECK((k.points[MobileCrane::kPointBoomTip] - Eigen::Vector3d(0, 20 * std::sqrt(3.0) / 2, 13)).norm() < 1e-9);
    CHECK((k.points[MobileCrane::kPointHook] - Eigen::Vector3d(0, 20 * std::sqrt(3.0) / 2, 8)).norm() < 1e-9);
    // Load: 2 m sling, 1 m tall box: bottom 3 m below the hook.
    CHECK((k.points[MobileCrane::kPointLoadBottom] - Eigen::Vector3d(0, 20 * std::sqrt(3.0) / 2, 5)).norm() < 1e-9);
  }
  SECTION("swing -135 deg, elevation 60 deg, boom 30 m") {
    // radius 30 cos 60 = 15 -> (15 cos -135, 15 sin -135) = (-10.6066, -10.6066); height 3 + 25.98
    crane.forward_kinematics(q4(-135, 60, 30, 10), k);
    const double r = 15.0 / std::sqrt(2.0);
    CHECK((k.points[MobileCrane::kPointBoomTip] - Eigen::Vector3d(-r, -r, 3 + 15 * std::sqrt(3.0))).norm() < 1e-9);
    CHECK(crane.load_radius_m(q4(-135, 60, 30, 10)) == Approx(15.0).epsilon(1e-12));
  }
}

TEST_CASE("dh_modified is Craig's product Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d)", "[unit]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
  std::uniform_real_distribution<double> length(-40.0, 40.0);
  for (int n = 0; n < 500; ++n) {
    const double alpha = angle(rng);
    const double a = length(rng);
    const double theta = angle(rng);
    const double d = length(rng);
    const Eigen::Isometry3d product = Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()) * Eigen::Translation3d(a, 0.0, 0.0) *
                                      Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(0.0, 0.0, d);
    const Eigen::Isometry3d t = dh_modified(alpha, a, theta, d);
    CAPTURE(n, alpha, a, theta, d);
    CHECK((t.matrix() - product.matrix()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((t.matrix().row(3) - Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)).norm() == 0.0);
  }
}

TEST_CASE("mobile crane follows the thesis DH product (Eq. 3.1) under the stated frame mapping", "[unit]") {
  const MobileCrane crane = make_crane();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Kinematics k;
  for (int n = 0; n < 200; ++n) {
    const double swing = (-180 + 360 * u(rng)) * kDeg;
    const double elevation = 80 * u(rng) * kDeg;
    const double d3 = 10.9728 + 22.5 * u(rng);
    const double d4 = 1 + 30 * u(rng);
    JointVector q(4);
    q << swing, elevation, d3, d4;
    crane.forward_kinematics(q, k);
    // Eq. 3.1 as printed: 0P3 = (d3 c1 s2, d3 s1 s2, -d3 c2) with theta1 = -swing,
    // theta2 = 90 deg - elevation, in the thesis's z-down frame; world = R_x(pi) * thesis + foot.
    const double t1 = -swing;
    const double t2 = 0.5 * std::numbers::pi - elevation;
    const Eigen::Vector3d tip_thesis(d3 * std::cos(t1) * std::sin(t2), d3 * std::sin(t1) * std::sin(t2),
                                     -d3 * std::cos(t2));
    const Eigen::Vector3d tip_world(tip_thesis.x(), -tip_thesis.y(), -tip_thesis.z());
    const Eigen::Vector3d foot(0, 0, 3);
    CAPTURE(n, swing, elevation, d3, d4);
    CHECK((k.points[MobileCrane::kPointBoomTip] - (foot + tip_world)).norm() < 1e-9);
    // Eq. 3.8: the cable stays vertical whatever the boom does.
    const Eigen::Vector3d cable = k.points[MobileCrane::kPointHook] - k.points[MobileCrane::kPointBoomTip];
    CHECK(cable.head<2>().norm() < 1e-9);
    CHECK(cable.z() == Approx(-d4).epsilon(1e-12));
    // The boom body spans foot to tip; its length is the boom length.
    CHECK(k.bodies[MobileCrane::kBoom].size_m.z() == Approx(d3));
    CHECK((k.bodies[MobileCrane::kBoom].world_from_body.translation() - 0.5 * (foot + foot + tip_world)).norm() < 1e-9);
    CHECK((k.bodies[MobileCrane::kBoom].world_from_body.linear().col(2) - tip_world.normalized()).norm() < 1e-9);
    CHECK(k.bodies[MobileCrane::kCable].size_m.z() == Approx(d4));
  }
}

TEST_CASE("mobile crane base pose moves every point", "[unit]") {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(100, -50, 2));
  base.rotate(Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ()));
  const MobileCrane moved = make_crane(base);
  const MobileCrane origin = make_crane();
  Kinematics a;
  Kinematics b;
  const JointVector q = q4(40, 55, 25, 8);
  moved.forward_kinematics(q, a);
  origin.forward_kinematics(q, b);
  for (int p = 0; p < 4; ++p) CHECK((a.points[p] - base * b.points[p]).norm() < 1e-9);
  // Swinging by 30 deg at the origin gives the same heading as the yawed base.
  Kinematics c;
  origin.forward_kinematics(q4(70, 55, 25, 8), c);
  CHECK((a.points[MobileCrane::kPointHook] - base.translation() - c.points[MobileCrane::kPointHook]).norm() < 1e-9);
}

TEST_CASE("mobile crane rejects joints that are not the thesis's four", "[unit]") {
  const MachineDefinition m = tms870();
  LiftTask task;
  task.load_lb = 20000;
  auto joints = m.joints;
  joints.pop_back();
  CHECK_THROWS_AS(MobileCrane(m.name, joints, m.mobile_crane, *m.load_chart, m.luff_table, task, Eigen::Isometry3d::Identity()),
                  std::invalid_argument);
  joints = m.joints;
  std::swap(joints[2], joints[3]);
  CHECK_THROWS_AS(MobileCrane(m.name, joints, m.mobile_crane, *m.load_chart, m.luff_table, task, Eigen::Isometry3d::Identity()),
                  std::invalid_argument);
}

TEST_CASE("mobile crane keeps the load above the ground", "[unit]") {
  const MobileCrane crane = make_crane();
  // Tip height 3 + 20 sin 30 = 13 m; sling 2 m and load 1 m: cable 10 m puts the load bottom at 0.
  CHECK(crane.check_constraints(q4(0, 30, 20, 10.0)).ok());
  const ConstraintVerdict v = crane.check_constraints(q4(0, 30, 20, 10.5));
  CHECK(v.status == ConstraintStatus::LoadBelowGround);
  CHECK(v.value == Approx(-0.5));
}
