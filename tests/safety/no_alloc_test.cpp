// SPDX-License-Identifier: Apache-2.0
// The safety functions run every control cycle: after construction they must not touch the heap.
#include <catch2/catch.hpp>

#include "allocation_counter.hpp"
#include "fixture.hpp"
#include "mgc/guidance/envelope.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/guidance/safety.hpp"

using namespace mgc;
using namespace mgc::guidance;
using mgc::planning::MobileCrane;
using mgc::test::kDeg;
using mgc::test::ThesisCrane;

TEST_CASE("envelope, rated capacity limiter and stop check do not allocate", "[unit]") {
  ThesisCrane t;
  EnvelopeConfig c;
  c.points = {MobileCrane::kPointBoomTip, MobileCrane::kPointHook};
  c.point_count = 2;
  c.height_ceiling_enabled = true;
  c.height_ceiling_m = 25.0;
  c.depth_floor_enabled = true;
  c.slew_enabled = true;
  c.slew_left_rad = 170.0 * kDeg;
  c.slew_right_rad = -170.0 * kDeg;
  c.radius_min_enabled = true;
  c.radius_min_m = 3.0;
  c.radius_max_enabled = true;
  c.radius_max_m = 25.0;
  c.walls[0] = EnvelopeWall{Eigen::Vector3d::UnitX(), -25.0};
  c.wall_count = 1;
  Envelope envelope(t.crane, c);
  RatedCapacityLimiter rcl(t.crane, RatedCapacityConfig{});
  StopCheck check(*t.loaded.world, &envelope, StopCheckConfig{});
  planning::CollisionWorld& world = *t.loaded.world;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();

  double sink = 0.0;
  const long before = mgc::test::allocation_count();
  for (int i = 0; i < 20; ++i) {
    const double swing_deg = 60.0 + 6.0 * i;
    const planning::JointVector q = ThesisCrane::q(swing_deg, 25.0 + i, 20.0, 2.0 + 0.5 * i);
    const planning::JointVector v = ThesisCrane::v(0.05, -0.01, 0.1, -0.2);
    sink += envelope.limit_velocity(q, v).allowed_velocity.sum();
    sink += rcl.limit_velocity(q, 20000.0 + 500.0 * i, v).utilisation;
    pose.translation() = Eigen::Vector3d(-36.0, -3.0 - 0.2 * i, 1.6);
    world.set_dynamic_pose(0, pose);
    MachineState s;
    s.joints[0] = {swing_deg * kDeg, (i % 2 ? 3.75 : -3.75) * kDeg, 0.01};
    s.joints[1] = {q[1], 0.01, 0.0};
    s.joints[2] = {q[2], 0.05, 0.0};
    s.joints[3] = {q[3], -0.2, 0.0};
    const StopCheckResult r = check.check(s);
    sink += r.min_clearance_m + r.samples;
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(std::isfinite(sink));
}

TEST_CASE("stop check with bounded queries does not allocate by the frame or by crane-2", "[unit]") {
  ThesisCrane t;
  planning::CollisionWorld& world = *t.loaded.world;
  StopCheck check(world, nullptr, StopCheckConfig{});
  const Eigen::Isometry3d home = world.dynamic_pose(0);
  const auto slewing = [](double swing_deg, double velocity_deg_s, double elevation_deg, double cable_m) {
    MachineState s;
    s.joints[0] = {swing_deg * kDeg, velocity_deg_s * kDeg, 0.0};
    s.joints[1] = {elevation_deg * kDeg, 0.0, 0.0};
    s.joints[2] = {20.0, 0.0, 0.0};
    s.joints[3] = {cable_m, 0.0, 0.0};
    return s;
  };

  double sink = 0.0;
  int stops = 0;
  const long before = mgc::test::allocation_count();
  for (int i = 0; i < 40; ++i) {
    // Toward the frame from 64 deg to 56 deg (warning, stop, the boom in a column), and crane-2's
    // load brought to 2-6 m south of ours at swing 180 deg.
    const StopCheckResult near_frame = check.check(slewing(64.0 - 0.2 * i, -3.75, 25.0 + 0.1 * i, 2.0 + 0.1 * i));
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(-18.1 - 18.38, -2.0 - 0.1 * i, 7.0 - 5.38);
    world.set_dynamic_pose(0, pose);
    const StopCheckResult near_crane2 = check.check(slewing(180.0, 3.75, 25.0, 2.0));
    world.set_dynamic_pose(0, home);
    sink += near_frame.min_clearance_m + near_crane2.min_clearance_m;
    stops += (near_frame.status == StopCheckStatus::Stop) + (near_crane2.status == StopCheckStatus::Stop);
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(stops > 0);
  CHECK(std::isfinite(sink));
}
