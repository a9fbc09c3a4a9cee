// SPDX-License-Identifier: Apache-2.0
// Working-envelope limits: each cuts only the joint motions that approach it, inside its slowdown
// band, scaled to zero at the limit; motion away stays allowed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fixture.hpp"
#include "mgc/guidance/envelope.hpp"

using namespace mgc;
using namespace mgc::guidance;
using mgc::planning::MobileCrane;
using mgc::test::kDeg;
using mgc::test::ThesisCrane;

namespace {

// Boom tip and hook of the thesis crane at swing 80 deg, boom 50 deg, 20 m, cable 14.82 m:
// tip at radius 20 cos 50 = 12.856 m, height 3 + 20 sin 50 = 18.321 m; hook 3.501 m high.
const planning::JointVector kQ = ThesisCrane::q(80, 50, 20, 14.82);
constexpr double kTipRadiusM = 12.8558;
constexpr double kTipHeightM = 18.3209;
constexpr double kHookHeightM = 18.3209 - 14.82;

EnvelopeConfig points_config() {
  EnvelopeConfig c;
  c.points = {MobileCrane::kPointBoomTip, MobileCrane::kPointHook};
  c.point_count = 2;
  return c;
}

// Positive and negative unit commands on one joint.
planning::JointVector unit(int joint, double sign) {
  planning::JointVector v = planning::JointVector::Zero(4);
  v[joint] = sign * 0.01;
  return v;
}

}  // namespace

TEST_CASE("height ceiling cuts boom up and telescope out near it, never boom down or telescope in", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.height_ceiling_enabled = true;
  c.height_ceiling_m = kTipHeightM + 0.5;  // 0.5 m of a 2 m band: a quarter of the speed
  Envelope envelope(t.crane, c);

  const EnvelopeResult up = envelope.limit_velocity(kQ, unit(MobileCrane::kBoomElevation, +1));
  CHECK(up.allowed_velocity[MobileCrane::kBoomElevation] == Approx(0.01 * 0.25).epsilon(1e-3));
  CHECK(up.acting.limit == EnvelopeLimit::HeightCeiling);
  CHECK(up.acting.point == MobileCrane::kPointBoomTip);
  CHECK(up.acting.distance_m == Approx(0.5).margin(1e-3));
  CHECK(up.nearest.limit == EnvelopeLimit::HeightCeiling);

  CHECK(envelope.limit_velocity(kQ, unit(MobileCrane::kBoomElevation, -1)).allowed_velocity[1] == -0.01);
  CHECK(envelope.limit_velocity(kQ, unit(MobileCrane::kBoomLength, +1)).joint_scale[2] == Approx(0.25).epsilon(1e-3));
  CHECK(envelope.limit_velocity(kQ, unit(MobileCrane::kBoomLength, -1)).joint_scale[2] == 1.0);
  // Slewing and hoisting do not change the tip's height.
  CHECK(envelope.limit_velocity(kQ, unit(MobileCrane::kSwing, +1)).joint_scale[0] == 1.0);
  const EnvelopeResult hoist = envelope.limit_velocity(kQ, unit(MobileCrane::kCableLength, -1));
  CHECK(hoist.joint_scale[3] == 1.0);
  CHECK(hoist.acting.limit == EnvelopeLimit::None);

  // Outside the band nothing is cut.
  c.height_ceiling_m = kTipHeightM + 2.5;
  Envelope far(t.crane, c);
  CHECK(far.limit_velocity(kQ, unit(MobileCrane::kBoomElevation, +1)).joint_scale[1] == 1.0);
}

TEST_CASE("inside the band one command's approaching components are scaled and the others pass unchanged", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.height_ceiling_enabled = true;
  c.height_ceiling_m = kTipHeightM + 0.5;  // a quarter of the speed toward the ceiling
  Envelope envelope(t.crane, c);
  // Boom up approaches; telescope in recedes; slew and hoist do not move the tip's height.
  const EnvelopeResult up = envelope.limit_velocity(kQ, ThesisCrane::v(0.02, 0.01, -0.05, 0.3));
  CHECK(up.acting.limit == EnvelopeLimit::HeightCeiling);
  CHECK(up.allowed_velocity[0] == 0.02);
  CHECK(up.allowed_velocity[1] == Approx(0.01 * 0.25).epsilon(1e-3));
  CHECK(up.allowed_velocity[2] == -0.05);
  CHECK(up.allowed_velocity[3] == 0.3);
  // Telescope out approaches; boom down recedes.
  const EnvelopeResult out = envelope.limit_velocity(kQ, ThesisCrane::v(-0.02, -0.01, 0.05, -0.3));
  CHECK(out.allowed_velocity[0] == -0.02);
  CHECK(out.allowed_velocity[1] == -0.01);
  CHECK(out.allowed_velocity[2] == Approx(0.05 * 0.25).epsilon(1e-3));
  CHECK(out.allowed_velocity[3] == -0.3);
  CHECK_FALSE(out.violated);
}

TEST_CASE("on the road site inside the band each joint is scaled by the nearest limit it approaches, per limit alone", "[unit]") {
  // thesis-steel-frame-road.yaml's envelope (a wall and a ceiling on three points) at seeded random
  // configurations inside its band, each limit of each point checked alone as an envelope of its own:
  // a joint is scaled to the least distance / band of the limits in the band it approaches, and a
  // joint that approaches none passes unchanged.
  const auto loaded = planning::io::load_and_build(std::string(MGC_SOURCE_DIR) + "/scenarios/thesis-steel-frame-road.yaml");
  const planning::MachineModel& model = *loaded.model;
  const EnvelopeConfig config = envelope_config(*loaded.scenario.envelope, model);
  REQUIRE(config.wall_count == 1);
  REQUIRE(config.height_ceiling_enabled);
  Envelope envelope(model, config);
  const double band_m = config.slowdown_band_m;
  std::vector<Envelope> single;
  for (int i = 0; i < config.point_count; ++i) {
    EnvelopeConfig one;
    one.points[0] = config.points[static_cast<std::size_t>(i)];
    one.point_count = 1;
    one.slowdown_band_m = band_m;
    EnvelopeConfig ceiling = one;
    ceiling.height_ceiling_enabled = true;
    ceiling.height_ceiling_m = config.height_ceiling_m;
    single.emplace_back(model, ceiling);
    EnvelopeConfig wall = one;
    wall.walls[0] = config.walls[0];
    wall.wall_count = 1;
    single.emplace_back(model, wall);
  }

  const int n = model.dof();
  const auto joints = model.joints();
  std::mt19937 rng(20261201);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int in_band = 0;
  int scaled = 0;
  int passed = 0;
  for (int draw = 0; draw < 20000 && in_band < 200; ++draw) {
    planning::JointVector q(n);
    planning::JointVector v(n);
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& spec = joints[static_cast<std::size_t>(j)];
      q[j] = spec.position_min + unit(rng) * spec.range();
      v[j] = (2.0 * unit(rng) - 1.0) * spec.max_velocity;
    }
    const EnvelopeDistance nearest = envelope.nearest(q);
    if (nearest.distance_m < 0.0 || nearest.distance_m >= band_m) continue;
    ++in_band;
    const EnvelopeResult r = envelope.limit_velocity(q, v);
    CHECK_FALSE(r.violated);
    CHECK(r.nearest.distance_m == Approx(nearest.distance_m).margin(1e-9));
    for (int j = 0; j < n; ++j) {
      double expected = 1.0;
      bool unclear = false;  // a gradient between rounding noise and a real effect: not judged
      for (Envelope& e : single) {
        const double d = e.nearest(q).distance_m;
        if (d >= band_m) continue;
        const double h = 1e-5;
        planning::JointVector q_step = q;
        q_step[j] = q[j] + h;
        const double d_plus = e.nearest(q_step).distance_m;
        q_step[j] = q[j] - h;
        const double g = (d_plus - e.nearest(q_step).distance_m) / (2.0 * h);
        if (std::abs(g) > 1e-8 && std::abs(g) < 1e-4) unclear = true;
        if (std::abs(g) >= 1e-4 && g * v[j] < 0.0) expected = std::min(expected, std::clamp(d / band_m, 0.0, 1.0));
      }
      if (unclear) continue;
      const auto k = static_cast<std::size_t>(j);
      CHECK(r.joint_scale[k] == Approx(expected).margin(1e-6));
      CHECK(r.allowed_velocity[j] == v[j] * r.joint_scale[k]);
      if (expected < 1.0) {
        ++scaled;
      } else {
        CHECK(r.allowed_velocity[j] == v[j]);
        ++passed;
      }
    }
  }
  CHECK(in_band == 200);
  CHECK(scaled > 100);
  CHECK(passed > 100);
}

TEST_CASE("past the ceiling the approaching motion stops and the way back stays open", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.height_ceiling_enabled = true;
  c.height_ceiling_m = kTipHeightM - 0.2;
  Envelope envelope(t.crane, c);
  const EnvelopeResult up = envelope.limit_velocity(kQ, ThesisCrane::v(0.0, 0.01, 0.05, 0.0));
  CHECK(up.violated);
  CHECK(up.allowed_velocity[1] == 0.0);
  CHECK(up.allowed_velocity[2] == 0.0);
  const EnvelopeResult down = envelope.limit_velocity(kQ, ThesisCrane::v(0.0, -0.01, -0.05, 0.0));
  CHECK(down.allowed_velocity[1] == -0.01);
  CHECK(down.allowed_velocity[2] == -0.05);
}

TEST_CASE("depth floor on the hook cuts lowering and boom down, allows hoisting and boom up", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.depth_floor_enabled = true;
  c.depth_floor_m = kHookHeightM - 1.0;  // half the band
  Envelope envelope(t.crane, c);
  const EnvelopeResult lower = envelope.limit_velocity(kQ, ThesisCrane::v(0.0, -0.01, 0.0, 0.2));
  CHECK(lower.joint_scale[3] == Approx(0.5).epsilon(1e-3));
  CHECK(lower.joint_scale[1] == Approx(0.5).epsilon(1e-3));
  CHECK(lower.acting.limit == EnvelopeLimit::DepthFloor);
  CHECK(lower.acting.point == MobileCrane::kPointHook);
  const EnvelopeResult raise = envelope.limit_velocity(kQ, ThesisCrane::v(0.0, 0.01, 0.0, -0.2));
  CHECK(raise.joint_scale[1] == 1.0);
  CHECK(raise.joint_scale[3] == 1.0);
}

TEST_CASE("slew limits cut slewing toward them only", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.slew_enabled = true;
  c.slew_left_rad = 85.0 * kDeg;   // 5 deg at 12.856 m: 1.122 m of arc, 56 % of the band
  c.slew_right_rad = -60.0 * kDeg;
  Envelope envelope(t.crane, c);
  const EnvelopeResult left = envelope.limit_velocity(kQ, unit(MobileCrane::kSwing, +1));
  CHECK(left.acting.limit == EnvelopeLimit::SlewLeft);
  CHECK(left.acting.distance_m == Approx(5.0 * kDeg * kTipRadiusM).epsilon(1e-3));
  CHECK(left.joint_scale[0] == Approx(5.0 * kDeg * kTipRadiusM / 2.0).epsilon(1e-3));
  CHECK(envelope.limit_velocity(kQ, unit(MobileCrane::kSwing, -1)).joint_scale[0] == 1.0);
  // Luffing and telescoping do not change the azimuth.
  CHECK(envelope.limit_velocity(kQ, ThesisCrane::v(0, 0.01, 0.1, 0.1)).acting.limit == EnvelopeLimit::None);

  // The right limit near -80 deg, checked across the +-180 deg seam from the other side.
  c.slew_left_rad = 170.0 * kDeg;
  c.slew_right_rad = 79.0 * kDeg;
  Envelope right(t.crane, c);
  CHECK(right.limit_velocity(kQ, unit(MobileCrane::kSwing, -1)).acting.limit == EnvelopeLimit::SlewRight);
  CHECK(right.limit_velocity(kQ, unit(MobileCrane::kSwing, -1)).joint_scale[0] == Approx(kDeg * kTipRadiusM / 2.0).epsilon(1e-3));
  CHECK(right.limit_velocity(kQ, unit(MobileCrane::kSwing, +1)).joint_scale[0] == 1.0);
}

TEST_CASE("radius limits: max cuts boom down and telescope out, min cuts boom up and telescope in", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.radius_max_enabled = true;
  c.radius_max_m = kTipRadiusM + 1.0;
  Envelope max_env(t.crane, c);
  const EnvelopeResult out = max_env.limit_velocity(kQ, ThesisCrane::v(0.0, -0.01, 0.05, 0.0));
  CHECK(out.acting.limit == EnvelopeLimit::RadiusMax);
  CHECK(out.joint_scale[1] == Approx(0.5).epsilon(1e-3));
  CHECK(out.joint_scale[2] == Approx(0.5).epsilon(1e-3));
  const EnvelopeResult in = max_env.limit_velocity(kQ, ThesisCrane::v(0.05, 0.01, -0.05, 0.1));
  for (int j = 0; j < 4; ++j) CHECK(in.joint_scale[static_cast<std::size_t>(j)] == 1.0);

  EnvelopeConfig m = points_config();
  m.radius_min_enabled = true;
  m.radius_min_m = kTipRadiusM - 1.5;
  Envelope min_env(t.crane, m);
  const EnvelopeResult inward = min_env.limit_velocity(kQ, ThesisCrane::v(0.0, 0.01, -0.05, 0.0));
  CHECK(inward.acting.limit == EnvelopeLimit::RadiusMin);
  CHECK(inward.joint_scale[1] == Approx(0.75).epsilon(1e-3));
  CHECK(inward.joint_scale[2] == Approx(0.75).epsilon(1e-3));
  CHECK(min_env.limit_velocity(kQ, ThesisCrane::v(0.0, -0.01, 0.05, 0.0)).joint_scale[1] == 1.0);
}

TEST_CASE("a virtual wall cuts the motions that carry a point toward it", "[unit]") {
  ThesisCrane t;
  // Allowed side y <= tip y + 0.8 (normal -y): slewing toward +90 deg raises y; so do telescope out
  // and boom down at this swing.
  const double tip_y_m = kTipRadiusM * std::sin(80.0 * kDeg);
  EnvelopeConfig c = points_config();
  c.walls[0] = EnvelopeWall{-Eigen::Vector3d::UnitY(), -(tip_y_m + 0.8)};
  c.wall_count = 1;
  Envelope envelope(t.crane, c);
  const EnvelopeResult toward = envelope.limit_velocity(kQ, ThesisCrane::v(0.01, -0.01, 0.05, 0.0));
  CHECK(toward.acting.limit == EnvelopeLimit::Wall);
  CHECK(toward.acting.wall == 0);
  CHECK(toward.acting.distance_m == Approx(0.8).margin(1e-3));
  CHECK(toward.joint_scale[0] == Approx(0.4).epsilon(1e-3));
  CHECK(toward.joint_scale[1] == Approx(0.4).epsilon(1e-3));
  CHECK(toward.joint_scale[2] == Approx(0.4).epsilon(1e-3));
  const EnvelopeResult away = envelope.limit_velocity(kQ, ThesisCrane::v(-0.01, 0.01, -0.05, 0.3));
  CHECK(away.allowed_velocity == ThesisCrane::v(-0.01, 0.01, -0.05, 0.3));
  CHECK(envelope.nearest(kQ).distance_m == Approx(0.8).margin(1e-3));
}

TEST_CASE("a scenario's envelope section becomes the limiter's configuration, unknown key points are refused", "[unit]") {
  ThesisCrane t;
  planning::EnvelopeSpec spec;
  spec.points = {"hook", "boom_tip"};
  spec.points_ref = {"site.yaml", 31, "envelope.points"};
  spec.height_ceiling_m = 40.0;
  spec.slew_left_rad = 2.0;
  spec.slew_right_rad = -2.0;
  spec.walls.push_back({Eigen::Vector3d::UnitX(), -8.0});
  spec.slowdown_band_m = 3.0;
  const EnvelopeConfig c = envelope_config(spec, t.crane);
  REQUIRE(c.point_count == 2);
  CHECK(c.points[0] == MobileCrane::kPointHook);
  CHECK(c.points[1] == MobileCrane::kPointBoomTip);
  CHECK(c.height_ceiling_enabled);
  CHECK(c.height_ceiling_m == 40.0);
  CHECK_FALSE(c.depth_floor_enabled);
  CHECK(c.slew_enabled);
  CHECK(c.slew_left_rad == 2.0);
  CHECK(c.slew_right_rad == -2.0);
  CHECK_FALSE(c.radius_min_enabled);
  CHECK_FALSE(c.radius_max_enabled);
  REQUIRE(c.wall_count == 1);
  CHECK(c.walls[0].offset_m == -8.0);
  CHECK(c.slowdown_band_m == 3.0);

  spec.points = {"hook", "hock"};
  CHECK_THROWS_WITH(envelope_config(spec, t.crane),
                    "site.yaml:31: envelope.points: expected a key point of the mobile_crane machine (boom_foot, boom_tip, hook, "
                    "load_bottom), got 'hock'");
}

TEST_CASE("the envelope as a planning rule refuses configurations within its margin and names the limit", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c = points_config();
  c.height_ceiling_enabled = true;
  c.height_ceiling_m = kTipHeightM + 1.0;
  EnvelopeRule rule(t.crane, c, 1.25);
  int limit = -1;
  CHECK_FALSE(rule.allows(kQ, &limit));  // 1 m below the ceiling: inside the 1.25 m margin
  CHECK(rule.describe(limit) == "working envelope: boom_tip within 1.25 m of the height ceiling");
  const planning::JointVector lower = ThesisCrane::q(80, 45, 20, 14.82);  // tip 1.9 m lower
  CHECK(rule.allows(lower, &limit));
  EnvelopeRule exact(t.crane, c, 0.0);
  CHECK(exact.allows(kQ, &limit));
}
