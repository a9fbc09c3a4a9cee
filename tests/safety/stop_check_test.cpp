// SPDX-License-Identifier: Apache-2.0
// The short-horizon stop check on the thesis site: the TMS870 next to the steel frame, crane-2 as
// the dynamic obstacle. Defaults: stop margin 0.5 m, warning margin 1.0 m, crane-2 reach 1 m/s.
#include <catch2/catch.hpp>

#include <limits>

#include "fixture.hpp"
#include "mgc/guidance/safety.hpp"

using namespace mgc;
using namespace mgc::guidance;
using mgc::planning::Contact;
using mgc::planning::MobileCrane;
using mgc::test::kDeg;
using mgc::test::ThesisCrane;

namespace {

//! Boom at 25 deg, 20 m, cable 2 m; slewing at swing_velocity_deg_s.
MachineState state(double swing_deg, double swing_velocity_deg_s) {
  MachineState s;
  s.joints[0] = {swing_deg * kDeg, swing_velocity_deg_s * kDeg, 0.0};
  s.joints[1] = {25.0 * kDeg, 0.0, 0.0};
  s.joints[2] = {20.0, 0.0, 0.0};
  s.joints[3] = {2.0, 0.0, 0.0};
  return s;
}

constexpr double kFullSlewDegS = 3.75;  // the TMS870's swing speed

//! Crane-2 turned so that its hook load (at (18.38, 0, 5.38) m in its frame) hangs south_m south of
//! ours with the boom at swing 180 deg (our load at (-18.1, 0) m).
void park_crane2(planning::CollisionWorld& world, double south_m) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(-18.1 - 18.38, -south_m, 7.0 - 5.38);
  world.set_dynamic_pose(0, pose);
}

}  // namespace

TEST_CASE("stop check: clear at rest and when slewing away from the frame", "[unit]") {
  ThesisCrane t;
  StopCheck check(*t.loaded.world, nullptr, StopCheckConfig{});
  const StopCheckResult rest = check.check(state(80, 0));
  CHECK(rest.status == StopCheckStatus::Clear);
  CHECK(rest.speed_scale == 1.0);
  CHECK_FALSE(rest.replan);
  CHECK(rest.stop_duration_s == 0.0);
  CHECK(rest.samples == 1);
  // The parked carrier is nearest: its front is 1.15 m from the frame's first column.
  CHECK(rest.min_clearance_m == Approx(1.15).margin(0.01));
  CHECK(rest.nearest.body == MobileCrane::kCarrier);
  CHECK(rest.nearest.with == Contact::With::Static);

  const StopCheckResult away = check.check(state(80, kFullSlewDegS));
  CHECK(away.status == StopCheckStatus::Clear);
  // Full slew speed brakes to rest in 2 s + the jerk ramp of 0.5 s.
  CHECK(away.stop_duration_s == Approx(2.5).margin(1e-6));
  CHECK(away.stop_position[0] > 80.0 * kDeg);
  // The carrier stays nearest; it cannot move, so it is measured once and the moving bodies, far
  // from everything, let the sweep jump from start to rest.
  CHECK(away.min_clearance_m == Approx(1.15).margin(0.01));
  CHECK(away.nearest.body == MobileCrane::kCarrier);
  CHECK(away.samples == 2);
  // Measured with the moving bodies at every sample, the carrier's 0.15 m beyond the warning
  // margin holds every step to the finest: the same verdict from many more samples, and a lower
  // bound between samples, as if the carrier could move at the booms' rate.
  StopCheckConfig all_bodies;
  all_bodies.fixed_bodies_once = false;
  StopCheck slow(*t.loaded.world, nullptr, all_bodies);
  const StopCheckResult same = slow.check(state(80, kFullSlewDegS));
  CHECK(same.status == away.status);
  CHECK(same.min_clearance_m < away.min_clearance_m);
  CHECK(same.min_clearance_m > away.min_clearance_m - 0.1);
  CHECK(same.samples > 10);
}

TEST_CASE("stop check: stop when the braking motion reaches the stop margin, though the start is clear", "[unit]") {
  ThesisCrane t;
  StopCheck check(*t.loaded.world, nullptr, StopCheckConfig{});
  CHECK(check.check(state(60, 0)).status == StopCheckStatus::Clear);
  const StopCheckResult toward = check.check(state(60, -kFullSlewDegS));
  CHECK(toward.status == StopCheckStatus::Stop);
  CHECK(toward.replan);
  CHECK(toward.speed_scale == 0.0);
  CHECK(toward.min_clearance_m < 0.5);
  CHECK(toward.nearest.body == MobileCrane::kBoom);
  CHECK(toward.nearest.with == Contact::With::Static);
  CHECK(t.loaded.world->static_name(toward.nearest.other).rfind("frame/column", 0) == 0);
  CHECK(toward.nearest_time_s > 0.0);
}

TEST_CASE("stop check: warning with a speed scale linear in the band between the margins", "[unit]") {
  ThesisCrane t;
  StopCheck check(*t.loaded.world, nullptr, StopCheckConfig{});
  // Slewing toward the frame from further away: the first start angle whose stop comes inside 1 m.
  int warnings = 0;
  StopCheckResult last{};
  for (double swing_deg = 62.5; swing_deg >= 60.0; swing_deg -= 0.05) {
    const StopCheckResult r = check.check(state(swing_deg, -kFullSlewDegS));
    if (r.status != StopCheckStatus::Warning) continue;
    ++warnings;
    last = r;
    CHECK(r.min_clearance_m >= 0.5);
    CHECK(r.min_clearance_m < 1.0);
    CHECK(r.speed_scale == Approx((r.min_clearance_m - 0.5) / 0.5));
    CHECK(r.speed_scale > 0.0);
    CHECK(r.speed_scale <= 1.0);
    CHECK_FALSE(r.replan);
  }
  CHECK(warnings > 0);
  // The band's scale falls as the start nears the frame: the last warning is the slowest.
  CHECK(last.speed_scale < 0.5);
}

TEST_CASE("stop check: crane-2 moved into the stop path gives a stop on the dynamic obstacle", "[unit]") {
  ThesisCrane t;
  planning::CollisionWorld& world = *t.loaded.world;
  StopCheck check(world, nullptr, StopCheckConfig{});
  // Slewing west at full speed: at swing 180 deg the load hangs at (-18.1, 0) m and moves toward -y.
  const MachineState slewing = state(180, kFullSlewDegS);
  const StopCheckResult before = check.check(slewing);
  CHECK(before.status == StopCheckStatus::Clear);

  // Crane-2 swung round so that its hook load (at (18.38, 0, 5.38) m in its frame) hangs 3.2 m south
  // of ours: 1.05 m clear at rest, inside the 1.5 m that our load travels while braking.
  park_crane2(world, 3.2);
  const StopCheckResult at_rest = check.check(state(180, 0));
  CHECK(at_rest.status != StopCheckStatus::Stop);
  CHECK(at_rest.nearest.with == Contact::With::Dynamic);
  const StopCheckResult after = check.check(slewing);
  CHECK(after.status == StopCheckStatus::Stop);
  CHECK(after.replan);
  CHECK(after.nearest.with == Contact::With::Dynamic);
  CHECK(after.nearest.other == 0);
  CHECK(world.dynamic_name(after.nearest.other) == "crane-2");
}

TEST_CASE("stop check: a dynamic obstacle's reach during the stop counts", "[unit]") {
  ThesisCrane t;
  planning::CollisionWorld& world = *t.loaded.world;
  // Crane-2's load 4.45 m south of ours: the braking slew alone keeps clear of its stop margin, its
  // reach of 1 m/s over the 2.5 s stop does not.
  park_crane2(world, 4.45);
  StopCheckConfig still;
  still.dynamic_obstacle_speed_m_s = 0.0;
  StopCheck without(world, nullptr, still);
  StopCheck with(world, nullptr, StopCheckConfig{});
  const StopCheckResult a = without.check(state(180, kFullSlewDegS));
  const StopCheckResult b = with.check(state(180, kFullSlewDegS));
  CHECK(a.nearest.with == Contact::With::Dynamic);
  CHECK(a.min_clearance_m >= 0.5);
  CHECK(a.status != StopCheckStatus::Stop);
  // The sweep ends at the first interval under the stop margin, here already at the start: the
  // crane-2 clearance less its 2.5 m reach.
  CHECK(b.status == StopCheckStatus::Stop);
  CHECK(b.nearest.with == Contact::With::Dynamic);
  CHECK(b.min_clearance_m < 0.5);
  CHECK(b.samples < a.samples);
}

TEST_CASE("stop check: the stopping motion is swept against the envelope", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c;
  c.points = {MobileCrane::kPointBoomTip, MobileCrane::kPointHook};
  c.point_count = 2;
  c.slew_enabled = true;
  c.slew_left_rad = 120.0 * kDeg;
  c.slew_right_rad = 78.0 * kDeg;
  Envelope envelope(t.crane, c);
  StopCheck check(*t.loaded.world, &envelope, StopCheckConfig{});
  // 2 deg inside the right slew limit, slewing toward it: the braking slew of ~4.7 deg crosses it.
  const StopCheckResult r = check.check(state(80, -kFullSlewDegS));
  CHECK(r.status == StopCheckStatus::Stop);
  CHECK(r.envelope.limit == EnvelopeLimit::SlewRight);
  CHECK(r.envelope.distance_m < 0.0);
  // At rest there it is not crossed.
  const StopCheckResult rest = check.check(state(80, 0));
  CHECK(rest.status == StopCheckStatus::Clear);
  CHECK(rest.envelope.distance_m == Approx(2.0 * kDeg * 20.0 * std::cos(25.0 * kDeg)).epsilon(1e-3));
}

TEST_CASE("stop check: refused input is reported with the joint", "[unit]") {
  ThesisCrane t;
  StopCheck check(*t.loaded.world, nullptr, StopCheckConfig{});
  MachineState bad = state(80, 0);
  bad.joints[2].velocity = std::numeric_limits<double>::quiet_NaN();
  const StopCheckResult r = check.check(bad);
  CHECK(r.status == StopCheckStatus::ErrorInput);
  CHECK(r.invalid_joint == 2);
  CHECK(r.replan);
  CHECK(r.speed_scale == 0.0);
}

TEST_CASE("stop check: a dynamic obstacle farther than the nearest static one still counts with its reach", "[unit]") {
  ThesisCrane t;
  planning::CollisionWorld& world = *t.loaded.world;
  // Crane-2 parked beside our carrier, its carrier a few metres south of ours: farther than the
  // frame is from our carrier (1.15 m), nearer than that once its reach over our 2.5 s stop counts.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(-2.0, -5.5, 0.0);
  world.set_dynamic_pose(0, pose);
  StopCheckConfig still;
  still.dynamic_obstacle_speed_m_s = 0.0;
  StopCheck without(world, nullptr, still);
  StopCheck with(world, nullptr, StopCheckConfig{});
  StopCheckConfig full;
  full.bounded_queries = false;
  StopCheck with_full(world, nullptr, full);
  const MachineState slewing = state(180, kFullSlewDegS);
  const StopCheckResult a = without.check(slewing);
  const StopCheckResult b = with.check(slewing);
  const StopCheckResult c = with_full.check(slewing);
  const double to_crane2_m =
      world.clearance(ThesisCrane::q(180, 25, 20, 2), planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic)
          .distance_m;
  CAPTURE(a.min_clearance_m, b.min_clearance_m, c.min_clearance_m, b.stop_duration_s, to_crane2_m);
  REQUIRE(to_crane2_m > 1.15);                        // farther than the frame from our carrier
  REQUIRE(to_crane2_m - b.stop_duration_s < 0.5);     // but not with its reach
  CHECK(a.status != StopCheckStatus::Stop);
  CHECK(a.nearest.with == Contact::With::Static);
  CHECK(b.status == StopCheckStatus::Stop);
  CHECK(b.nearest.with == Contact::With::Dynamic);
  CHECK(c.status == StopCheckStatus::Stop);
  CHECK(c.nearest.with == Contact::With::Dynamic);
  CHECK(b.min_clearance_m == Approx(c.min_clearance_m).margin(1e-6));
}

TEST_CASE("stop check: with a retreat floor a machine inside the stop margin may move away but not nearer", "[unit]") {
  ThesisCrane t;
  planning::CollisionWorld& world = *t.loaded.world;
  // Crane-2's load 2.45 m south of ours: about 0.3 m clear at rest, inside the stop margin. Slewing
  // positive at swing 180 deg carries our load south, toward it; negative, away.
  park_crane2(world, 2.45);
  StopCheck check(world, nullptr, StopCheckConfig{});
  const StopCheckResult rest = check.check(state(180, 0));
  REQUIRE(rest.nearest.with == Contact::With::Dynamic);
  REQUIRE(rest.min_clearance_m < 0.5);
  REQUIRE(rest.min_clearance_m > 0.1);
  // At rest nothing lessens the clearance by a reach.
  CHECK(rest.min_geometric_m == Approx(rest.min_clearance_m).margin(1e-9));

  // Without a floor every motion from here is a stop, away too.
  const double slow_deg_s = 0.5;
  CHECK(check.check(state(180, -slow_deg_s)).status == StopCheckStatus::Stop);
  CHECK(check.check(state(180, slow_deg_s)).status == StopCheckStatus::Stop);

  check.set_retreat_floor(rest.min_geometric_m - 0.1);
  const StopCheckResult away = check.check(state(180, -slow_deg_s));
  CAPTURE(away.min_clearance_m, away.min_geometric_m);
  CHECK(away.status == StopCheckStatus::Warning);
  CHECK(away.retreat);
  CHECK_FALSE(away.replan);
  CHECK(away.speed_scale == StopCheckConfig{}.retreat_speed_scale);
  // Its own motion keeps what it had; only the assumed reach of crane-2 puts it inside the margin.
  CHECK(away.min_clearance_m < 0.5);
  CHECK(away.min_geometric_m >= rest.min_geometric_m - 0.1);

  // Toward it, braking from a swing fast enough to come more than the 0.1 m nearer.
  const StopCheckResult toward = check.check(state(180, 4.0 * slow_deg_s));
  CAPTURE(toward.min_geometric_m);
  CHECK(toward.status == StopCheckStatus::Stop);
  CHECK(toward.replan);
  CHECK_FALSE(toward.retreat);
  CHECK(toward.min_geometric_m < rest.min_geometric_m - 0.1);

  // Back to the default: away is a stop again.
  check.set_retreat_floor(std::numeric_limits<double>::infinity());
  CHECK(check.check(state(180, -slow_deg_s)).status == StopCheckStatus::Stop);
}
