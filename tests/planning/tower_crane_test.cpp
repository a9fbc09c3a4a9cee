// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "mgc/planning/tower_crane.hpp"

using namespace mgc::planning;

namespace {

constexpr double kTol = 1e-9;
constexpr double kDeg = std::numbers::pi / 180.0;

TowerCrane make_crane(const Eigen::Isometry3d& base = Eigen::Isometry3d::Identity(),
                      const TowerLiftTask& task = TowerLiftTask{}) {
  return TowerCrane("tower", default_tower_crane_joints(), TowerCraneGeometry{}, task, base);
}

JointVector config(double slew_rad, double trolley_m, double hook_m) {
  JointVector q(3);
  q << slew_rad, trolley_m, hook_m;
  return q;
}

void check_point(const Eigen::Vector3d& actual, double x, double y, double z) {
  CAPTURE(actual.transpose());
  CHECK(actual.x() == Approx(x).margin(kTol));
  CHECK(actual.y() == Approx(y).margin(kTol));
  CHECK(actual.z() == Approx(z).margin(kTol));
}

void check_matrix(const Eigen::Matrix4d& actual, const Eigen::Matrix4d& expected, double tol = kTol) {
  CAPTURE(actual, expected);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) CHECK(actual(r, c) == Approx(expected(r, c)).margin(tol));
  }
}

// The thesis's App. B matrices, typed in again here so the test does not share code with the model.
Eigen::Matrix4d app_b_t01(double theta1) {
  Eigen::Matrix4d m;
  m << std::cos(theta1), -std::sin(theta1), 0, 0,
       std::sin(theta1), std::cos(theta1), 0, 0,
       0, 0, 1, 0,
       0, 0, 0, 1;
  return m;
}
Eigen::Matrix4d app_b_link(double d) {
  Eigen::Matrix4d m;
  m << -1, 0, 0, 0,
       0, 0, 1, d,
       0, 1, 0, 0,
       0, 0, 0, 1;
  return m;
}

}  // namespace

TEST_CASE("tower crane: forward kinematics at hand-computed poses", "[unit]") {
  const TowerCrane crane = make_crane();
  Kinematics k;

  SECTION("slew 90 deg, trolley 20 m, hook 10 m") {
    // theta1 = 90 - 90 = 0, so t01 = I and the hook is at (-20 sin 0, 20 cos 0, 10) = (0, 20, 10).
    crane.forward_kinematics(config(90.0 * kDeg, 20.0, 10.0), k);
    check_point(k.points[TowerCrane::kPointHook], 0.0, 20.0, 10.0);
    // Trolley straight above on the jib bottom chord (47 m); jib tip at radius 59.7 m.
    check_point(k.points[TowerCrane::kPointTrolley], 0.0, 20.0, 47.0);
    check_point(k.points[TowerCrane::kPointJibTip], 0.0, 59.7, 47.0);
    // Load bottom: 10 - sling 2 - load height 1 = 7.
    check_point(k.points[TowerCrane::kPointLoadBottom], 0.0, 20.0, 7.0);
    // Frames: {2} lies under the trolley on the base plane, {3} is the hook, the trolley frame above.
    check_point(k.frames[TowerCrane::kFrameRadius].translation(), 0.0, 20.0, 0.0);
    check_point(k.frames[TowerCrane::kFrameHook].translation(), 0.0, 20.0, 10.0);
    check_point(k.frames[TowerCrane::kFrameTrolley].translation(), 0.0, 20.0, 47.0);
  }
  SECTION("slew 0 points the jib along base +x") {
    // theta1 = -90 deg: sin = -1, cos = 0, hook = (-30 * -1, 30 * 0, 5) = (30, 0, 5).
    crane.forward_kinematics(config(0.0, 30.0, 5.0), k);
    check_point(k.points[TowerCrane::kPointHook], 30.0, 0.0, 5.0);
    check_point(k.points[TowerCrane::kPointJibTip], 59.7, 0.0, 47.0);
  }
  SECTION("slew -135 deg, trolley 10 m, hook 20 m") {
    // theta1 = -225 deg: sin = 0.70710678, cos = -0.70710678 -> hook = (-7.0710678, -7.0710678, 20).
    crane.forward_kinematics(config(-135.0 * kDeg, 10.0, 20.0), k);
    check_point(k.points[TowerCrane::kPointHook], -7.0710678118654755, -7.0710678118654755, 20.0);
  }
}

TEST_CASE("tower crane: hook frame is the App. B product t01 t12 t23", "[unit]") {
  const TowerCrane crane = make_crane();
  std::mt19937 rng(20240611u);
  std::uniform_real_distribution<double> slew(-std::numbers::pi, std::numbers::pi);
  std::uniform_real_distribution<double> trolley(3.0, 59.7);
  std::uniform_real_distribution<double> hook(0.0, 45.0);
  Kinematics k;
  for (int i = 0; i < 20; ++i) {
    const double s = slew(rng);
    const double d2 = trolley(rng);
    const double d3 = hook(rng);
    CAPTURE(i, s, d2, d3);
    const double theta1 = s - 0.5 * std::numbers::pi;
    crane.forward_kinematics(config(s, d2, d3), k);
    check_matrix(k.frames[TowerCrane::kFrameSlew].matrix(), app_b_t01(theta1));
    check_matrix(k.frames[TowerCrane::kFrameRadius].matrix(), app_b_t01(theta1) * app_b_link(d2));
    const Eigen::Matrix4d product = app_b_t01(theta1) * app_b_link(d2) * app_b_link(d3);
    check_matrix(k.frames[TowerCrane::kFrameHook].matrix(), product);
    // The thesis's closed form 0T3 = [c1 -s1 0 -d2 s1; s1 c1 0 d2 c1; 0 0 1 d3; 0 0 0 1].
    const double c1 = std::cos(theta1);
    const double s1 = std::sin(theta1);
    Eigen::Matrix4d closed;
    closed << c1, -s1, 0, -d2 * s1,
              s1, c1, 0, d2 * c1,
              0, 0, 1, d3,
              0, 0, 0, 1;
    check_matrix(product, closed);
    // And the documented mapping: slew measured from base +x.
    check_point(k.points[TowerCrane::kPointHook], d2 * std::cos(s), d2 * std::sin(s), d3);
  }
}

TEST_CASE("tower crane: the base pose moves every frame, body and key point", "[unit]") {
  // Base 100 m east, 50 m south, 3 m up, yawed by 30 deg.
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(100.0, -50.0, 3.0));
  base.rotate(Eigen::AngleAxisd(30.0 * kDeg, Eigen::Vector3d::UnitZ()));
  const TowerCrane local = make_crane();
  const TowerCrane placed = make_crane(base);
  Kinematics kl;
  Kinematics kw;
  const JointVector q = config(90.0 * kDeg, 20.0, 10.0);
  local.forward_kinematics(q, kl);
  placed.forward_kinematics(q, kw);

  // Hook (0, 20, 10) in the base: R_z(30) (0, 20, 10) = (-20 sin 30, 20 cos 30, 10) = (-10, 17.3205081, 10),
  // plus (100, -50, 3) = (90, -32.6794919, 13).
  check_point(kw.points[TowerCrane::kPointHook], 90.0, 17.320508075688775 - 50.0, 13.0);
  for (int p = 0; p < static_cast<int>(placed.key_point_names().size()); ++p) {
    CAPTURE(placed.key_point_names()[static_cast<std::size_t>(p)]);
    const Eigen::Vector3d expected = base * kl.points[static_cast<std::size_t>(p)];
    check_point(kw.points[static_cast<std::size_t>(p)], expected.x(), expected.y(), expected.z());
  }
  for (int b = 0; b < static_cast<int>(placed.bodies().size()); ++b) {
    CAPTURE(placed.bodies()[static_cast<std::size_t>(b)].name);
    const auto& bw = kw.bodies[static_cast<std::size_t>(b)];
    const auto& bl = kl.bodies[static_cast<std::size_t>(b)];
    check_matrix(bw.world_from_body.matrix(), (base * bl.world_from_body).matrix());
    CHECK(bw.size_m.isApprox(bl.size_m));
  }
  for (int f = 0; f < static_cast<int>(placed.frame_names().size()); ++f) {
    CAPTURE(placed.frame_names()[static_cast<std::size_t>(f)]);
    const auto i = static_cast<std::size_t>(f);
    check_matrix(kw.frames[i].matrix(), (base * kl.frames[i]).matrix());
  }
  // Constraints are about the crane's own ground plane, so the base pose does not change them.
  CHECK(placed.check_constraints(config(0.0, 10.0, 2.5)).status == ConstraintStatus::LoadBelowGround);
}

TEST_CASE("tower crane: body poses and sizes", "[unit]") {
  const TowerCrane crane = make_crane();
  Kinematics k;
  crane.forward_kinematics(config(90.0 * kDeg, 20.0, 10.0), k);

  REQUIRE(crane.bodies()[TowerCrane::kCable].resizable);
  CHECK_FALSE(crane.bodies()[TowerCrane::kJib].resizable);
  CHECK(crane.bodies()[TowerCrane::kCable].shape == BodyShape::Capsule);

  // Cable: capsule from the trolley (z 47) down to the hook (z 10): length 37, centre z 28.5,
  // diameter 2 x 0.15.
  const auto& cable = k.bodies[TowerCrane::kCable];
  check_point(cable.world_from_body.translation(), 0.0, 20.0, 28.5);
  check_point(cable.size_m, 0.3, 0.3, 37.0);
  check_point(cable.world_from_body.linear().col(2), 0.0, 0.0, 1.0);

  // Load 2 x 2 x 1 m hung 2 m under the hook: centre z = 10 - 2 - 0.5 = 7.5.
  const auto& load = k.bodies[TowerCrane::kLoad];
  check_point(load.world_from_body.translation(), 0.0, 20.0, 7.5);
  check_point(load.size_m, 2.0, 2.0, 1.0);

  // Jib along +y (slew 90 deg): centre at half the jib length, half its depth above the bottom chord.
  const auto& jib = k.bodies[TowerCrane::kJib];
  check_point(jib.world_from_body.translation(), 0.0, 29.85, 47.75);
  check_point(jib.world_from_body.linear().col(2), 0.0, 1.0, 0.0);
  check_point(jib.size_m, 1.5, 1.2, 59.7);

  // Counter-jib behind the mast (-y): 20 m long; counterweight 2.0 m tall under the 48.5 m top
  // chord makes the box 2.0 m tall (centre z 47.5) and 2.4 m wide.
  const auto& counter_jib = k.bodies[TowerCrane::kCounterJib];
  check_point(counter_jib.world_from_body.translation(), 0.0, -10.0, 47.5);
  check_point(counter_jib.world_from_body.linear().col(2), 0.0, -1.0, 0.0);
  check_point(counter_jib.size_m, 2.0, 2.4, 20.0);

  // Mast: 1.8 x 1.8 m, ground to the jib.
  const auto& mast = k.bodies[TowerCrane::kMast];
  check_point(mast.world_from_body.translation(), 0.0, 0.0, 23.5);
  check_point(mast.size_m, 1.8, 1.8, 47.0);

  SECTION("the cable shortens as the hook rises") {
    crane.forward_kinematics(config(0.0, 20.0, 45.0), k);
    CHECK(k.bodies[TowerCrane::kCable].size_m.z() == Approx(2.0).margin(kTol));
    crane.forward_kinematics(config(0.0, 20.0, 0.0), k);
    CHECK(k.bodies[TowerCrane::kCable].size_m.z() == Approx(47.0).margin(kTol));
    // Above the jib (outside every range) the shape keeps a zero, not a negative, length.
    crane.forward_kinematics(config(0.0, 20.0, 48.0), k);
    CHECK(k.bodies[TowerCrane::kCable].size_m.z() == Approx(0.0).margin(kTol));
  }
}

TEST_CASE("tower crane: engineering constraints", "[unit]") {
  const TowerCrane crane = make_crane();  // load 1 m tall on a 2 m sling: needs hook >= 3 m

  CHECK(crane.check_constraints(config(0.0, 20.0, 20.0)).ok());
  // The hook at its upper limit (47 - 2 = 45 m) and the load resting on the ground are allowed.
  CHECK(crane.check_constraints(config(0.0, 20.0, 45.0)).ok());
  CHECK(crane.check_constraints(config(0.0, 20.0, 3.0)).ok());

  const ConstraintVerdict high = crane.check_constraints(config(0.0, 20.0, 45.5));
  CHECK(high.status == ConstraintStatus::CableTooShort);
  CHECK(high.value == Approx(45.5));
  CHECK(high.limit == Approx(45.0));

  const ConstraintVerdict low = crane.check_constraints(config(1.0, 20.0, 2.5));
  CHECK(low.status == ConstraintStatus::LoadBelowGround);
  CHECK(low.value == Approx(-0.5));
  CHECK(low.limit == Approx(0.0).margin(kTol));

  // A longer sling moves the limit up: 5 m sling + 1 m load needs the hook at 6 m or higher.
  TowerLiftTask long_sling;
  long_sling.sling_length_m = 5.0;
  const TowerCrane crane2 = make_crane(Eigen::Isometry3d::Identity(), long_sling);
  CHECK(crane2.check_constraints(config(0.0, 20.0, 5.9)).status == ConstraintStatus::LoadBelowGround);
  CHECK(crane2.check_constraints(config(0.0, 20.0, 6.0)).ok());
}

TEST_CASE("tower crane: joints and geometry are validated", "[unit]") {
  const TowerCraneGeometry g;
  const TowerLiftTask t;
  const Eigen::Isometry3d id = Eigen::Isometry3d::Identity();
  CHECK_NOTHROW(TowerCrane("ok", default_tower_crane_joints(), g, t, id));

  auto joints = default_tower_crane_joints();
  joints.pop_back();
  CHECK_THROWS_AS(TowerCrane("two joints", joints, g, t, id), std::invalid_argument);

  joints = default_tower_crane_joints();
  joints[1].name = "trolley";
  CHECK_THROWS_AS(TowerCrane("bad name", joints, g, t, id), std::invalid_argument);

  joints = default_tower_crane_joints();
  std::swap(joints[1], joints[2]);
  CHECK_THROWS_AS(TowerCrane("swapped", joints, g, t, id), std::invalid_argument);

  joints = default_tower_crane_joints();
  joints[0].type = JointType::Prismatic;
  CHECK_THROWS_AS(TowerCrane("prismatic slew", joints, g, t, id), std::invalid_argument);

  TowerCraneGeometry bad = g;
  bad.min_hook_drop_m = 50.0;
  CHECK_THROWS_AS(TowerCrane("drop above jib", default_tower_crane_joints(), bad, t, id), std::invalid_argument);
  bad = g;
  bad.mast_width_m = 0.0;
  CHECK_THROWS_AS(TowerCrane("no mast", default_tower_crane_joints(), bad, t, id), std::invalid_argument);

  TowerLiftTask flat = t;
  flat.load_size_m.z() = 0.0;
  CHECK_THROWS_AS(TowerCrane("flat load", default_tower_crane_joints(), g, flat, id), std::invalid_argument);
}

TEST_CASE("tower crane: model description and default joints", "[unit]") {
  const TowerCrane crane = make_crane();
  CHECK(crane.kind() == MachineKind::TowerCrane);
  CHECK(crane.dof() == 3);
  CHECK(crane.body_index("mast") == TowerCrane::kMast);
  CHECK(crane.body_index("counter_jib") == TowerCrane::kCounterJib);
  CHECK(crane.body_index("load") == TowerCrane::kLoad);
  CHECK(crane.body_index("sling") == TowerCrane::kSling);
  CHECK(crane.key_point_index("jib_tip") == TowerCrane::kPointJibTip);
  CHECK(crane.key_point_index("load_bottom") == TowerCrane::kPointLoadBottom);
  REQUIRE(crane.self_pairs().size() == 2);
  CHECK(crane.self_pairs()[0].body_a == TowerCrane::kLoad);
  CHECK(crane.self_pairs()[0].body_b == TowerCrane::kMast);
  CHECK(crane.self_pairs()[1].body_a == TowerCrane::kSling);
  CHECK(crane.self_pairs()[1].body_b == TowerCrane::kMast);

  const auto j = default_tower_crane_joints();
  REQUIRE(j.size() == 3);
  CHECK(j[0].name == "slew");
  CHECK(j[0].continuous);
  CHECK(j[0].position_min == Approx(-std::numbers::pi));
  CHECK(j[0].position_max == Approx(std::numbers::pi));
  // 0.8 rpm = 0.8 x 2 pi / 60 = 0.0837758 rad/s; full speed in 3 s; full acceleration in 0.5 s.
  CHECK(j[0].max_velocity == Approx(0.08377580409572781));
  CHECK(j[0].max_acceleration == Approx(0.08377580409572781 / 3.0));
  CHECK(j[0].max_jerk == Approx(0.08377580409572781 / 3.0 / 0.5));
  // Trolley 3.0 m to the 59.7 m jib tip at 38 m/min = 0.63333 m/s, full speed in 2 s.
  CHECK(j[1].name == "trolley_radius");
  CHECK_FALSE(j[1].continuous);
  CHECK(j[1].position_min == Approx(3.0));
  CHECK(j[1].position_max == Approx(59.7));
  CHECK(j[1].max_velocity == Approx(0.6333333333333333));
  CHECK(j[1].max_acceleration == Approx(0.31666666666666665));
  CHECK(j[1].max_jerk == Approx(0.6333333333333333));
  // Hook from the ground to 47 - 2 = 45 m at 65 m/min = 1.0833 m/s, full speed in 2 s.
  CHECK(j[2].name == "hook_height");
  CHECK(j[2].position_min == Approx(0.0).margin(kTol));
  CHECK(j[2].position_max == Approx(45.0));
  CHECK(j[2].max_velocity == Approx(1.0833333333333333));
  CHECK(j[2].max_acceleration == Approx(0.5416666666666666));
  CHECK(j[2].max_jerk == Approx(1.0833333333333333));
  CHECK(j[1].unit() == std::string("m"));
}
