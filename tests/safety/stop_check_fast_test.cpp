// SPDX-License-Identifier: Apache-2.0
// The stop check's bounded queries (StopCheckConfig::bounded_queries, CollisionWorld::nearest_below)
// against the all-distance sweep, which measures the nearest obstacle in full at every sample: a
// seeded set of states of the TMS870 around the thesis steel frame, some with crane-2 moved close.
#include <catch2/catch.hpp>

#include <random>

#include "fixture.hpp"
#include "mgc/guidance/safety.hpp"

using namespace mgc;
using namespace mgc::guidance;
using mgc::planning::CollisionWorld;
using mgc::planning::Contact;
using mgc::test::kDeg;
using mgc::test::ThesisCrane;

namespace {

//! A state near the frame (east of the crane, x 10..52 m, y -12..12 m, 20 m tall) half the time,
//! anywhere round the crane otherwise; every joint moving at up to its full speed and accelerating.
MachineState random_state(const planning::MachineModel& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto between = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  MachineState s;
  const bool near_frame = unit(rng) < 0.5;
  const double swing_deg = near_frame ? (unit(rng) < 0.5 ? 1.0 : -1.0) * between(35.0, 75.0) : between(-180.0, 180.0);
  const auto joints = model.joints();
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const planning::JointSpec& spec = joints[j];
    double position = between(spec.position_min, spec.position_max);
    if (j == 0) position = swing_deg * kDeg;
    if (j == 1) position = between(5.0, 70.0) * kDeg;
    if (j == 2) position = between(spec.position_min, 0.8 * spec.position_max);
    if (j == 3) position = between(1.0, 18.0);
    const double velocity = unit(rng) < 0.2 ? 0.0 : between(-1.0, 1.0) * spec.max_velocity;
    const double acceleration = unit(rng) < 0.5 ? 0.0 : between(-0.5, 0.5) * spec.max_acceleration;
    s.joints[j] = {position, velocity, acceleration};
  }
  return s;
}

//! The same body, or the load and its sling: they share their side faces (the sling has the load's
//! footprint), so an obstacle beside them is equally near both and either may be named.
bool same_or_side_by_side(const planning::MachineModel& model, int a, int b) {
  if (a == b) return true;
  const int load = model.body_index("load");
  const int sling = model.body_index("sling");
  return (a == load && b == sling) || (a == sling && b == load);
}

}  // namespace

TEST_CASE("nearest_below: the nearest static and dynamic obstacle below their bounds as clearance() measures them", "[unit]") {
  ThesisCrane t;
  CollisionWorld& world = *t.loaded.world;
  const Eigen::Isometry3d crane2_home = world.dynamic_pose(0);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int exact[2] = {0, 0};
  int beyond[2] = {0, 0};
  CollisionWorld::NearestBelow hint;
  for (int i = 0; i < 300; ++i) {
    const MachineState s = random_state(t.crane, rng);
    planning::JointVector q(4);
    for (int j = 0; j < 4; ++j) q[j] = s.joints[static_cast<std::size_t>(j)].position;
    // Every other state with crane-2's load brought within a few metres of ours.
    if (i % 2 == 1) {
      const double radius_m = q[2] * std::cos(q[1]);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(radius_m * std::cos(q[0]) - 18.38, radius_m * std::sin(q[0]) - 2.0 - 6.0 * unit(rng),
                                           7.0 - 5.38 - 4.0 * unit(rng));
      world.set_dynamic_pose(0, pose);
    } else {
      world.set_dynamic_pose(0, crane2_home);
    }
    const double bound_m = i % 3 == 0 ? 1.0 : (i % 3 == 1 ? 4.0 : 12.0);
    // Every other query with the previous answer as its hint: the hint changes only the cost.
    const CollisionWorld::NearestBelow below =
        world.nearest_below(q, CollisionWorld::Bodies::Moving, bound_m, bound_m + 1.0, i % 4 < 2 ? &hint : nullptr);
    hint = below;
    const planning::Clearance full[2] = {
        world.clearance(q, CollisionWorld::Bodies::Moving, CollisionWorld::Obstacles::Static),
        world.clearance(q, CollisionWorld::Bodies::Moving, CollisionWorld::Obstacles::Dynamic)};
    const planning::Clearance* got[2] = {&below.static_obstacle, &below.dynamic_obstacle};
    const Contact::With kind[2] = {Contact::With::Static, Contact::With::Dynamic};
    const double bounds[2] = {bound_m, bound_m + 1.0};
    for (int k = 0; k < 2; ++k) {
      INFO("state " << i << ", " << (k == 0 ? "static" : "dynamic") << ", bound " << bounds[k] << " m, full "
                    << full[k].distance_m << " m, bounded " << got[k]->distance_m << " m");
      if (full[k].distance_m < 1e-3) {
        // In contact (anywhere, for the full query's collision pass): the bounded query gives 0 (or a
        // GJK hair above) where its own bodies touch, and never more than the full distance otherwise.
        CHECK(got[k]->distance_m <= bounds[k]);
        continue;
      }
      if (full[k].distance_m < bounds[k]) {
        ++exact[k];
        // Equal up to GJK's tolerance: where two obstacles are about equally near (a column and the
        // beams framing into it) either may be named.
        CHECK(got[k]->distance_m == Approx(full[k].distance_m).margin(1e-6));
        CHECK(got[k]->with == kind[k]);
        if (got[k]->other == full[k].other) {
          CHECK(same_or_side_by_side(t.crane, got[k]->body, full[k].body));
          if (got[k]->body == full[k].body) CHECK(got[k]->distance_m == full[k].distance_m);
        }
      } else {
        ++beyond[k];
        CHECK(got[k]->distance_m == bounds[k]);
        CHECK(got[k]->with == Contact::With::Nothing);
      }
    }
  }
  world.set_dynamic_pose(0, crane2_home);
  CHECK(exact[0] > 50);
  CHECK(beyond[0] > 50);
  CHECK(exact[1] > 20);
  CHECK(beyond[1] > 20);
}

TEST_CASE("stop check: bounded queries give the all-distance sweep's verdicts on seeded states near the frame", "[unit]") {
  ThesisCrane t;
  CollisionWorld& world = *t.loaded.world;
  StopCheckConfig fast_config;
  REQUIRE(fast_config.bounded_queries);
  StopCheckConfig full_config;
  full_config.bounded_queries = false;
  StopCheck fast(world, nullptr, fast_config);
  StopCheck full(world, nullptr, full_config);
  const double exact_m = std::max(fast_config.warning_margin_m, fast_config.exact_clearance_m);
  const Eigen::Isometry3d crane2_home = world.dynamic_pose(0);

  std::mt19937 rng(20261123);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int counts[3] = {0, 0, 0};
  int dynamic_nearest = 0;
  int fast_full_queries = 0;
  int fast_samples = 0;
  constexpr int kStates = 600;
  for (int i = 0; i < kStates; ++i) {
    const MachineState s = random_state(t.crane, rng);
    // A quarter of the states with crane-2 swung round within a few metres of our hook load.
    if (i % 4 == 3) {
      const double swing = s.joints[0].position;
      const double radius_m = s.joints[2].position * std::cos(s.joints[1].position);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      const double gap_m = 2.5 + 4.0 * unit(rng);
      // Crane-2's own hook load sits 18.38 m along its x axis from its origin.
      pose.translation() = Eigen::Vector3d(radius_m * std::cos(swing) - 18.38,
                                           radius_m * std::sin(swing) - gap_m, 7.0 - 5.38 - 4.0 * unit(rng));
      world.set_dynamic_pose(0, pose);
    } else {
      world.set_dynamic_pose(0, crane2_home);
    }
    const StopCheckResult a = fast.check(s);
    const StopCheckResult b = full.check(s);
    INFO("state " << i << ": swing " << s.joints[0].position / kDeg << " deg, elevation "
                  << s.joints[1].position / kDeg << " deg, boom " << s.joints[2].position << " m, cable "
                  << s.joints[3].position << " m; full sweep " << to_string(b.status) << " at "
                  << b.min_clearance_m << " m, bounded " << to_string(a.status) << " at " << a.min_clearance_m << " m");
    REQUIRE(a.status == b.status);
    CHECK(a.samples == b.samples);
    CHECK(a.stop_duration_s == b.stop_duration_s);
    CHECK(a.replan == b.replan);
    // Never more than the full sweep's clearance; the same where it can matter, up to GJK's
    // tolerance where two obstacles are about equally near.
    CHECK(a.min_clearance_m <= b.min_clearance_m + 1e-6);
    if (b.min_clearance_m < exact_m) {
      CHECK(a.min_clearance_m == Approx(b.min_clearance_m).margin(1e-6));
      CHECK(a.speed_scale == Approx(b.speed_scale).margin(2e-6));
      CHECK(a.nearest.with == b.nearest.with);
      CHECK(a.nearest_time_s == Approx(b.nearest_time_s).margin(1e-6));
    } else {
      CHECK(a.speed_scale == 1.0);
      CHECK(b.speed_scale == 1.0);
      CHECK(a.min_clearance_m >= exact_m - 1e-9);
    }
    if (a.status != StopCheckStatus::ErrorInput) ++counts[static_cast<int>(a.status)];
    if (b.nearest.with == Contact::With::Dynamic) ++dynamic_nearest;
    if (a.status != StopCheckStatus::Stop) {
      fast_full_queries += fast.full_queries();
      fast_samples += a.samples;
    }
  }
  world.set_dynamic_pose(0, crane2_home);
  INFO("clear " << counts[0] << ", warning " << counts[1] << ", stop " << counts[2] << ", crane-2 nearest "
                << dynamic_nearest << ", full queries " << fast_full_queries << " in " << fast_samples
                << " samples of the checks that do not stop");
  // The set covers every verdict and the dynamic obstacle.
  CHECK(counts[0] > 50);
  CHECK(counts[1] > 10);
  CHECK(counts[2] > 50);
  CHECK(dynamic_nearest > 10);
  // Short of a stop (a contact, measured in full) the bounded sweep rarely needs a full query.
  CHECK(fast_full_queries * 10 < fast_samples);
}

TEST_CASE("stop check: the slew toward the frame with bounded queries matches the full sweep sample for sample", "[unit]") {
  ThesisCrane t;
  StopCheckConfig full_config;
  full_config.bounded_queries = false;
  StopCheck fast(*t.loaded.world, nullptr, StopCheckConfig{});
  StopCheck full(*t.loaded.world, nullptr, full_config);
  // The warning test's range: 62.5 deg down to 60 deg, slewing at full speed toward the frame.
  int warnings = 0;
  for (double swing_deg = 64.0; swing_deg >= 59.0; swing_deg -= 0.05) {
    MachineState s;
    s.joints[0] = {swing_deg * kDeg, -3.75 * kDeg, 0.0};
    s.joints[1] = {25.0 * kDeg, 0.0, 0.0};
    s.joints[2] = {20.0, 0.0, 0.0};
    s.joints[3] = {2.0, 0.0, 0.0};
    const StopCheckResult a = fast.check(s);
    const StopCheckResult b = full.check(s);
    INFO("swing " << swing_deg << " deg");
    CHECK(a.status == b.status);
    CHECK(a.samples == b.samples);
    CHECK(a.speed_scale == Approx(b.speed_scale).margin(2e-6));
    CHECK(a.min_clearance_m == Approx(b.min_clearance_m).margin(1e-6));
    CHECK(same_or_side_by_side(t.crane, a.nearest.body, b.nearest.body));
    CHECK(a.nearest.with == b.nearest.with);
    CHECK(a.nearest_time_s == Approx(b.nearest_time_s).margin(1e-6));
    if (a.status != StopCheckStatus::Stop) CHECK(fast.full_queries() == 0);
    if (a.status == StopCheckStatus::Warning) ++warnings;
  }
  CHECK(warnings > 5);
}
