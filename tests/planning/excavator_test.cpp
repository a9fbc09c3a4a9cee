// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "mgc/planning/excavator.hpp"

using namespace mgc::planning;

namespace {

constexpr double kTol = 1e-9;
constexpr double kDeg = std::numbers::pi / 180.0;
const double kSqrt3Half = std::sqrt(3.0) / 2.0;  // cos 30 = sin 60
const double kSqrt2Half = std::sqrt(2.0) / 2.0;  // cos 45 = sin 45

Excavator make_excavator(const Eigen::Isometry3d& base = Eigen::Isometry3d::Identity()) {
  return Excavator("cat320", default_excavator_joints(), ExcavatorGeometry{}, base);
}

JointVector config_deg(double swing, double boom, double arm, double bucket) {
  JointVector q(4);
  q << swing * kDeg, boom * kDeg, arm * kDeg, bucket * kDeg;
  return q;
}

void check_point(const Eigen::Vector3d& actual, double x, double y, double z) {
  CAPTURE(actual.transpose());
  CHECK(actual.x() == Approx(x).margin(kTol));
  CHECK(actual.y() == Approx(y).margin(kTol));
  CHECK(actual.z() == Approx(z).margin(kTol));
}

void check_matrix(const Eigen::Matrix4d& actual, const Eigen::Matrix4d& expected) {
  CAPTURE(actual, expected);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) CHECK(actual(r, c) == Approx(expected(r, c)).margin(kTol));
  }
}

// Evenly spaced samples from lo to hi, both included, at most max_step apart.
std::vector<double> samples(double lo, double hi, double max_step) {
  const int n = static_cast<int>(std::ceil((hi - lo) / max_step));
  std::vector<double> v;
  for (int i = 0; i <= n; ++i) v.push_back(lo + (hi - lo) * i / n);
  return v;
}

}  // namespace

TEST_CASE("excavator: forward kinematics at hand-computed poses", "[unit]") {
  // Cat 320 defaults: foot (a0, h0) = (0.25, 2.0), boom 5.7, arm 2.9, bucket 1.47 m.
  const Excavator ex = make_excavator();
  Kinematics k;

  SECTION("boom 30 deg, arm -90 deg relative, bucket 0") {
    // Absolute angles: boom 30, arm 30 - 90 = -60, bucket -60.
    // arm pin    = (0.25 + 5.7 cos 30, 2.0 + 5.7 sin 30)            = (0.25 + 5.7 sqrt3/2, 4.85)
    // bucket pin = arm pin + 2.9 (cos -60, sin -60)                 = (.. + 1.45, 4.85 - 2.9 sqrt3/2)
    // tip        = bucket pin + 1.47 (cos -60, sin -60)             = (.. + 0.735, .. - 1.47 sqrt3/2)
    ex.forward_kinematics(config_deg(0.0, 30.0, -90.0, 0.0), k);
    const double arm_x = 0.25 + 5.7 * kSqrt3Half;
    check_point(k.points[Excavator::kPointBoomFoot], 0.25, 0.0, 2.0);
    check_point(k.points[Excavator::kPointArmPin], arm_x, 0.0, 4.85);
    check_point(k.points[Excavator::kPointBucketPin], arm_x + 1.45, 0.0, 4.85 - 2.9 * kSqrt3Half);
    check_point(k.points[Excavator::kPointBucketTip], arm_x + 1.45 + 0.735, 0.0, 4.85 - 4.37 * kSqrt3Half);
    // About 7.3713 m out and 1.0655 m up.
    CHECK(k.points[Excavator::kPointBucketTip].x() == Approx(7.3713448).margin(1e-6));
    CHECK(k.points[Excavator::kPointBucketTip].z() == Approx(1.0654690).margin(1e-6));

    // Swinging by 90 deg turns the same points onto +y: (x, 0, z) -> (0, x, z).
    ex.forward_kinematics(config_deg(90.0, 30.0, -90.0, 0.0), k);
    check_point(k.points[Excavator::kPointBoomFoot], 0.0, 0.25, 2.0);
    check_point(k.points[Excavator::kPointBucketTip], 0.0, arm_x + 2.185, 4.85 - 4.37 * kSqrt3Half);
  }
  SECTION("boom -45, arm -45, bucket -90: arm straight down, bucket pointing back") {
    // Absolute angles -45, -90, -180.
    // arm pin = (0.25 + 5.7 sqrt2/2, 2 - 5.7 sqrt2/2); bucket pin 2.9 m straight below;
    // tip 1.47 m back towards the machine at the bucket pin's height.
    ex.forward_kinematics(config_deg(0.0, -45.0, -45.0, -90.0), k);
    const double x = 0.25 + 5.7 * kSqrt2Half;
    const double z = 2.0 - 5.7 * kSqrt2Half;
    check_point(k.points[Excavator::kPointArmPin], x, 0.0, z);
    check_point(k.points[Excavator::kPointBucketPin], x, 0.0, z - 2.9);
    check_point(k.points[Excavator::kPointBucketTip], x - 1.47, 0.0, z - 2.9);
  }
  SECTION("everything straight, swung round to the back") {
    // Reach 0.25 + 5.7 + 2.9 + 1.47 = 10.32 m at the foot height, along -x.
    ex.forward_kinematics(config_deg(180.0, 0.0, 0.0, 0.0), k);
    check_point(k.points[Excavator::kPointBucketTip], -10.32, 0.0, 2.0);
  }
}

TEST_CASE("excavator: frames and bodies follow the links", "[unit]") {
  const Excavator ex = make_excavator();
  Kinematics k;
  ex.forward_kinematics(config_deg(0.0, 30.0, -90.0, 0.0), k);
  const double arm_x = 0.25 + 5.7 * kSqrt3Half;

  // Boom box between the foot (0.25, 2.0) and the arm pin, z along the boom (cos 30, 0, sin 30),
  // y along the pin axis.
  const auto& boom = k.bodies[Excavator::kBoomBody];
  check_point(boom.world_from_body.translation(), 0.5 * (0.25 + arm_x), 0.0, 0.5 * (2.0 + 4.85));
  check_point(boom.world_from_body.linear().col(2), kSqrt3Half, 0.0, 0.5);
  check_point(boom.world_from_body.linear().col(1), 0.0, 1.0, 0.0);
  check_point(boom.size_m, 0.8, 0.6, 5.7);
  // Arm and bucket both point at -60 deg: z = (0.5, 0, -sqrt3/2).
  const auto& arm = k.bodies[Excavator::kArmBody];
  check_point(arm.world_from_body.linear().col(2), 0.5, 0.0, -kSqrt3Half);
  check_point(arm.size_m, 0.6, 0.45, 2.9);
  const auto& bucket = k.bodies[Excavator::kBucketBody];
  check_point(bucket.world_from_body.translation(), arm_x + 1.45 + 0.3675, 0.0,
              4.85 - (2.9 + 0.735) * kSqrt3Half);
  check_point(bucket.size_m, 1.0, 1.2, 1.47);
  // Link frames sit on the pins with the link's axes; the tip frame has the bucket's axes.
  check_point(k.frames[Excavator::kFrameArmPin].translation(), arm_x, 0.0, 4.85);
  check_point(k.frames[Excavator::kFrameBucketTip].linear().col(2), 0.5, 0.0, -kSqrt3Half);
  check_point(k.frames[Excavator::kFrameBucketTip].translation(), arm_x + 2.185, 0.0, 4.85 - 4.37 * kSqrt3Half);

  // Swing by 90 deg: the undercarriage stays, house and cab turn about z: (x, y) -> (-y, x).
  ex.forward_kinematics(config_deg(90.0, 30.0, -90.0, 0.0), k);
  check_point(k.bodies[Excavator::kUndercarriage].world_from_body.translation(), 0.0, 0.0, 0.5);
  check_point(k.bodies[Excavator::kUndercarriage].world_from_body.linear().col(0), 1.0, 0.0, 0.0);
  check_point(k.bodies[Excavator::kUndercarriage].size_m, 4.45, 3.17, 1.0);
  check_point(k.bodies[Excavator::kHouse].world_from_body.translation(), 0.0, -0.815, 1.775);
  check_point(k.bodies[Excavator::kHouse].world_from_body.linear().col(0), 0.0, 1.0, 0.0);
  check_point(k.bodies[Excavator::kCab].world_from_body.translation(), -0.89, 0.15, 2.005);
  check_point(k.bodies[Excavator::kCab].size_m, 1.8, 1.0, 1.91);
}

TEST_CASE("excavator: the base pose moves every frame, body and key point", "[unit]") {
  // Base at (-20, 35, 1.5), yawed by -60 deg.
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(-20.0, 35.0, 1.5));
  base.rotate(Eigen::AngleAxisd(-60.0 * kDeg, Eigen::Vector3d::UnitZ()));
  const Excavator local = make_excavator();
  const Excavator placed = make_excavator(base);
  Kinematics kl;
  Kinematics kw;
  const JointVector q = config_deg(180.0, 0.0, 0.0, 0.0);
  local.forward_kinematics(q, kl);
  placed.forward_kinematics(q, kw);

  // Tip (-10.32, 0, 2) in the base: R_z(-60) (-10.32, 0, 2) = (-10.32 cos 60, 10.32 sin 60, 2)
  // = (-5.16, 8.9374, 2); plus the base origin: (-25.16, 35 + 10.32 sqrt3/2, 3.5).
  check_point(kw.points[Excavator::kPointBucketTip], -25.16, 35.0 + 10.32 * kSqrt3Half, 3.5);
  for (std::size_t p = 0; p < placed.key_point_names().size(); ++p) {
    CAPTURE(placed.key_point_names()[p]);
    const Eigen::Vector3d expected = base * kl.points[p];
    check_point(kw.points[p], expected.x(), expected.y(), expected.z());
  }
  for (std::size_t b = 0; b < placed.bodies().size(); ++b) {
    CAPTURE(placed.bodies()[b].name);
    check_matrix(kw.bodies[b].world_from_body.matrix(), (base * kl.bodies[b].world_from_body).matrix());
    CHECK(kw.bodies[b].size_m.isApprox(kl.bodies[b].size_m));
  }
  for (std::size_t f = 0; f < placed.frame_names().size(); ++f) {
    CAPTURE(placed.frame_names()[f]);
    check_matrix(kw.frames[f].matrix(), (base * kl.frames[f]).matrix());
  }
}

TEST_CASE("excavator: bucket ground angle is boom + arm + bucket", "[unit]") {
  CHECK(bucket_ground_angle_rad(config_deg(0.0, 30.0, -90.0, 0.0)) == Approx(-60.0 * kDeg));
  CHECK(bucket_ground_angle_rad(config_deg(45.0, -45.0, -45.0, -90.0)) == Approx(-180.0 * kDeg));

  // It is the direction of the pin-to-tip line in the swing plane, whatever the swing.
  const Excavator ex = make_excavator();
  std::mt19937 rng(7u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Kinematics k;
  for (int i = 0; i < 50; ++i) {
    JointVector q(4);
    for (int j = 0; j < 4; ++j) {
      const JointSpec& s = ex.joints()[static_cast<std::size_t>(j)];
      q[j] = s.position_min + u(rng) * s.range();
    }
    CAPTURE(i, q.transpose());
    ex.forward_kinematics(q, k);
    const Eigen::Vector3d d = k.points[Excavator::kPointBucketTip] - k.points[Excavator::kPointBucketPin];
    const Eigen::Vector3d outward(std::cos(q[0]), std::sin(q[0]), 0.0);
    const double measured = std::atan2(d.z(), d.dot(outward));
    CHECK(wrap_angle(measured - bucket_ground_angle_rad(q)) == Approx(0.0).margin(1e-9));
  }
}

TEST_CASE("excavator: no engineering rule beyond the joint ranges", "[unit]") {
  const Excavator ex = make_excavator();
  Kinematics k;
  const JointVector deep = config_deg(0.0, -45.0, -45.0, -90.0);
  ex.forward_kinematics(deep, k);
  REQUIRE(k.points[Excavator::kPointBucketTip].z() < -4.0);  // digging well below the ground
  CHECK(ex.check_constraints(deep).ok());
  CHECK(ex.joint_out_of_range(deep) == -1);
  CHECK(ex.joint_out_of_range(config_deg(0.0, 65.0, -90.0, 0.0)) == Excavator::kBoom);
  CHECK(ex.joint_out_of_range(config_deg(0.0, 0.0, -20.0, 0.0)) == Excavator::kArm);
}

TEST_CASE("excavator: joints and geometry are validated", "[unit]") {
  const ExcavatorGeometry g;
  const Eigen::Isometry3d id = Eigen::Isometry3d::Identity();
  CHECK_NOTHROW(Excavator("ok", default_excavator_joints(), g, id));

  auto joints = default_excavator_joints();
  joints.pop_back();
  CHECK_THROWS_AS(Excavator("three joints", joints, g, id), std::invalid_argument);

  joints = default_excavator_joints();
  joints[2].name = "stick";
  CHECK_THROWS_AS(Excavator("stick", joints, g, id), std::invalid_argument);

  joints = default_excavator_joints();
  std::swap(joints[2], joints[3]);
  CHECK_THROWS_AS(Excavator("swapped", joints, g, id), std::invalid_argument);

  joints = default_excavator_joints();
  joints[1].type = JointType::Prismatic;
  CHECK_THROWS_AS(Excavator("prismatic boom", joints, g, id), std::invalid_argument);

  ExcavatorGeometry bad = g;
  bad.bucket_length_m = 0.0;
  CHECK_THROWS_AS(Excavator("no bucket", default_excavator_joints(), bad, id), std::invalid_argument);
  bad = g;
  bad.cab_size_m.y() = -1.0;
  CHECK_THROWS_AS(Excavator("negative cab", default_excavator_joints(), bad, id), std::invalid_argument);
}

TEST_CASE("excavator: model description and default joints", "[unit]") {
  const Excavator ex = make_excavator();
  CHECK(ex.kind() == MachineKind::Excavator);
  CHECK(ex.dof() == 4);
  CHECK(ex.body_index("undercarriage") == Excavator::kUndercarriage);
  CHECK(ex.body_index("bucket") == Excavator::kBucketBody);
  CHECK(ex.key_point_index("bucket_tip") == Excavator::kPointBucketTip);
  REQUIRE(ex.self_pairs().size() == 3);
  for (const SelfPair& p : ex.self_pairs()) CHECK(p.body_a == Excavator::kBucketBody);
  CHECK(ex.self_pairs()[0].body_b == Excavator::kUndercarriage);
  CHECK(ex.self_pairs()[1].body_b == Excavator::kCab);
  CHECK(ex.self_pairs()[2].body_b == Excavator::kHouse);

  const auto j = default_excavator_joints();
  REQUIRE(j.size() == 4);
  CHECK(j[0].name == "swing");
  CHECK(j[0].continuous);
  // 11.3 rpm = 11.3 x 2 pi / 60 = 1.18333 rad/s = 67.8 deg/s; full speed in 1 s.
  CHECK(j[0].max_velocity == Approx(1.1833332328521553));
  CHECK(j[0].max_acceleration == Approx(1.1833332328521553));
  CHECK(j[0].max_jerk == Approx(4.0 * 1.1833332328521553));
  CHECK(j[1].name == "boom");
  CHECK(j[1].position_min == Approx(-50.0 * kDeg));
  CHECK(j[1].position_max == Approx(60.0 * kDeg));
  CHECK(j[1].max_velocity == Approx(24.0 * kDeg));
  CHECK(j[1].max_acceleration == Approx(48.0 * kDeg));
  CHECK(j[2].name == "arm");
  CHECK(j[2].position_min == Approx(-155.0 * kDeg));
  CHECK(j[2].position_max == Approx(-30.0 * kDeg));
  CHECK(j[2].max_velocity == Approx(34.0 * kDeg));
  CHECK(j[3].name == "bucket");
  CHECK(j[3].position_min == Approx(-170.0 * kDeg));
  CHECK(j[3].position_max == Approx(10.0 * kDeg));
  CHECK(j[3].max_velocity == Approx(45.0 * kDeg));
  CHECK(j[3].max_jerk == Approx(45.0 * kDeg / 0.5 / 0.25));
}

TEST_CASE("excavator: working envelope reproduces the Cat 320 spec sheet", "[unit]") {
  // Cat 320 (reach boom 5.7 m, R2.9 stick, 1.19 m3 HD bucket), "Working Ranges and Forces" on
  // https://www.stowerscat.com/new-equipment/machines/medium-excavators/cat-320-hydraulic-excavator
  // (values published in feet; 1 ft = 0.3048 m).
  constexpr double kSpecMaxDiggingDepthM = 22.0 * 0.3048;       // 6.706 m
  constexpr double kSpecMaxReachAtGroundM = 32.3 * 0.3048;      // 9.845 m
  constexpr double kSpecMaxCuttingHeightM = 30.7 * 0.3048;      // 9.357 m

  const Excavator ex = make_excavator();
  const auto& joints = ex.joints();
  // Sample the default ranges at <= 2.5 deg, both ends included. The reach at ground level is
  // where the tip crosses z = 0 while the bucket turns, interpolated between neighbouring samples.
  const std::vector<double> booms = samples(joints[1].position_min, joints[1].position_max, 2.5 * kDeg);
  const std::vector<double> arms = samples(joints[2].position_min, joints[2].position_max, 2.5 * kDeg);
  const std::vector<double> buckets = samples(joints[3].position_min, joints[3].position_max, 2.5 * kDeg);
  Kinematics k;
  JointVector q(4);
  q[0] = 0.7;  // any swing: the envelope is about the swing axis
  double min_z = 1e9;
  double max_z = -1e9;
  double max_ground_reach = 0.0;
  for (double b2 : booms) {
    for (double b3 : arms) {
      Eigen::Vector3d prev = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < buckets.size(); ++i) {
        q[1] = b2;
        q[2] = b3;
        q[3] = buckets[i];
        ex.forward_kinematics(q, k);
        const Eigen::Vector3d tip = k.points[Excavator::kPointBucketTip];
        min_z = std::min(min_z, tip.z());
        max_z = std::max(max_z, tip.z());
        if (i > 0 && (prev.z() <= 0.0) != (tip.z() <= 0.0)) {
          const double s = prev.z() / (prev.z() - tip.z());
          const Eigen::Vector3d crossing = prev + s * (tip - prev);
          max_ground_reach = std::max(max_ground_reach, std::hypot(crossing.x(), crossing.y()));
        }
        prev = tip;
      }
    }
  }
  const double depth_m = -min_z;
  CAPTURE(depth_m, max_ground_reach, max_z);
  CHECK(depth_m == Approx(kSpecMaxDiggingDepthM).epsilon(0.05));
  CHECK(max_ground_reach == Approx(kSpecMaxReachAtGroundM).epsilon(0.05));
  CHECK(max_z == Approx(kSpecMaxCuttingHeightM).epsilon(0.05));
}
