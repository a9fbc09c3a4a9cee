// SPDX-License-Identifier: Apache-2.0
// The shipped scenarios: they load, start and goal are feasible, and the straight joint-space line
// between them is blocked, so each one needs planning.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/random.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {
io::LoadedScenario load(const std::string& name) {
  return io::load_and_build(mgc::test::source_path("scenarios/" + name));
}
}  // namespace

TEST_CASE("every shipped scenario has feasible start and goal and a blocked straight line", "[scenario]") {
  for (const char* name : {"thesis-steel-frame.yaml", "thesis-steel-frame-tower.yaml", "excavator-pipelines.yaml"}) {
    CAPTURE(name);
    auto loaded = load(name);
    const auto errors = io::check_endpoints(loaded);
    for (const auto& e : errors) FAIL(e.what());
    const JointVector steps = step_sizes(*loaded.model, loaded.scenario.planner.space_resolution);
    JointVector at;
    const Validity straight = loaded.world->validate_edge(loaded.scenario.start, loaded.scenario.goal, steps, &at);
    CAPTURE(loaded.world->describe(straight));
    CHECK(straight.status == Validity::Status::Collision);
  }
}

TEST_CASE("a dynamic obstacle moves between two times only where its keys differ", "[scenario]") {
  DynamicObstacleSpec spec;
  const auto key = [](double t_s, double x_m, double yaw_rad) {
    Keyframe k;
    k.t_s = t_s;
    k.position_m = Eigen::Vector3d(x_m, 0, 0);
    k.yaw_rad = yaw_rad;
    return k;
  };
  CHECK_FALSE(spec.moves_between(0, 100));  // no keys
  spec.motion = {key(10, 0, 0)};
  CHECK_FALSE(spec.moves_between(0, 100));  // one key: held
  // Still until 10 s, slews until 20 s, still until 30 s, drives until 40 s, held after.
  spec.motion = {key(0, 0, 0), key(10, 0, 0), key(20, 0, 1), key(30, 0, 1), key(40, 5, 1)};
  CHECK_FALSE(spec.moves_between(-5, 10));
  CHECK_FALSE(spec.moves_between(2, 9.5));
  CHECK(spec.moves_between(9.5, 10.5));
  CHECK(spec.moves_between(12, 13));
  CHECK(spec.moves_between(19, 21));
  CHECK_FALSE(spec.moves_between(20, 30));
  CHECK_FALSE(spec.moves_between(21, 29));
  CHECK(spec.moves_between(29, 31));
  CHECK(spec.moves_between(5, 35));      // spans a whole still stretch and two moves
  CHECK(spec.moves_between(0, 100));
  CHECK_FALSE(spec.moves_between(40, 100));
  CHECK_FALSE(spec.moves_between(50, 60));
  // What it answers agrees with the poses it gives, sampled finely.
  for (double from_s = -2.0; from_s < 45.0; from_s += 0.75) {
    for (const double length_s : {0.2, 1.0, 3.0, 9.0}) {
      bool moved = false;
      for (double t = from_s; t <= from_s + length_s; t += 0.01) {
        moved = moved || !spec.pose_at(t).isApprox(spec.pose_at(from_s), 0.0);
      }
      CAPTURE(from_s, length_s);
      if (moved) CHECK(spec.moves_between(from_s, from_s + length_s));
    }
  }
}

TEST_CASE("no point of a dynamic obstacle moves farther than its travel bound", "[oracle]") {
  DynamicObstacleSpec spec;
  const auto key = [](double t_s, const Eigen::Vector3d& p_m, double yaw_rad) {
    Keyframe k;
    k.t_s = t_s;
    k.position_m = p_m;
    k.yaw_rad = yaw_rad;
    return k;
  };
  // Still, slews, drives and slews back at once, still again.
  spec.motion = {key(0, {0, 0, 0}, 0), key(10, {0, 0, 0}, 0), key(20, {0, 0, 0}, 1.5), key(30, {6, -3, 0}, -0.5),
                 key(40, {6, -3, 0}, -0.5)};
  constexpr double kReach_m = 25.0;
  // The exact figures where one key stretch holds the interval: a slew's arc at the reach.
  CHECK(spec.max_travel_m(0, 10, kReach_m) == 0.0);
  CHECK(spec.max_travel_m(10, 20, kReach_m) == Approx(1.5 * kReach_m));
  CHECK(spec.max_travel_m(12, 14, kReach_m) == Approx(0.3 * kReach_m));
  CHECK(spec.max_travel_m(20, 30, kReach_m) == Approx(std::sqrt(45.0) + 2.0 * kReach_m));
  CHECK(spec.max_travel_m(-5, 100, kReach_m) == Approx(1.5 * kReach_m + std::sqrt(45.0) + 2.0 * kReach_m));
  CHECK(spec.max_travel_m(40, 50, kReach_m) == 0.0);
  // Every point within the reach, between any two times, stays within the bound.
  Random random(11);
  for (int trial = 0; trial < 20000; ++trial) {
    const double a_s = random.uniform(-2.0, 42.0);
    const double b_s = random.uniform(a_s, 42.0);
    const double radius_m = random.uniform(0.0, kReach_m);
    const double angle = random.uniform(-3.2, 3.2);
    const Eigen::Vector3d point(radius_m * std::cos(angle), radius_m * std::sin(angle), random.uniform(-5.0, 40.0));
    const double moved_m = (spec.pose_at(b_s) * point - spec.pose_at(a_s) * point).norm();
    CAPTURE(a_s, b_s, radius_m, angle);
    REQUIRE(moved_m <= spec.max_travel_m(a_s, b_s, kReach_m) + 1e-9);
  }
}

TEST_CASE("thesis steel frame: 535 members, crane 2 swings 90 deg mid-lift", "[scenario]") {
  auto loaded = load("thesis-steel-frame.yaml");
  const Scenario& s = loaded.scenario;
  CHECK(s.obstacles.size() == 535);
  CHECK(loaded.world->num_static() == 535);
  CHECK(s.obstacles.front().name == "frame/column[0,0,0]");
  REQUIRE(s.dynamic_obstacles.size() == 1);
  const DynamicObstacleSpec& crane2 = s.dynamic_obstacles.front();
  const auto yaw_at = [&](double t) {
    const Eigen::Matrix3d r = crane2.pose_at(t).linear();
    return std::atan2(r(1, 0), r(0, 0)) / kDeg;
  };
  CHECK(yaw_at(0) == Approx(-90));
  CHECK(yaw_at(60) == Approx(-90));
  CHECK(yaw_at(72) == Approx(-45));
  CHECK(yaw_at(84) == Approx(0).margin(1e-9));
  CHECK(yaw_at(500) == Approx(0).margin(1e-9));
  CHECK(crane2.pose_at(72).translation().isApprox(Eigen::Vector3d(-30, -6, 0)));

  // The west route (swinging through 180 deg with the load low) is open before crane 2 swings
  // and blocked by it afterwards; that is the event that forces a re-plan.
  JointVector west = s.start;
  west[0] = -(180 - 27.4) * kDeg;  // on crane 2's final bearing
  Contact contact;
  CHECK(loaded.world->is_free(west, &contact));
  auto late = build_world(s, *loaded.model, 90.0);
  REQUIRE_FALSE(late->is_free(west, &contact));
  CHECK(contact.with == Contact::With::Dynamic);
  CHECK(late->dynamic_name(contact.other) == "crane-2");
}

TEST_CASE("thesis steel frame: lifting over the frame is possible with the boom up and the load hoisted",
          "[scenario]") {
  auto loaded = load("thesis-steel-frame.yaml");
  // 110-ft boom (33.5 m): the chart rates 20,000 lb up to 23 deg from vertical -> 67 deg; at
  // 70 deg the tip is 3 + 31.5 = 34.5 m up at radius 11.5 m; a 10 m cable keeps the load bottom
  // at 34.5 - 10 - 3 = 21.5 m, above the 20 m frame.
  JointVector over(4);
  over << 0.0, 70 * kDeg, 33.528, 10.0;
  const Validity v = loaded.world->validate(over);
  CAPTURE(loaded.world->describe(v));
  CHECK(v.valid());
  // The same pose with the load low hits the frame.
  over[3] = 25.0;
  CHECK(loaded.world->validate(over).status == Validity::Status::Collision);
}

namespace {
void check_same_joints(const std::vector<JointSpec>& file, const std::vector<JointSpec>& defaults) {
  REQUIRE(file.size() == defaults.size());
  for (std::size_t i = 0; i < file.size(); ++i) {
    CAPTURE(file[i].name);
    CHECK(file[i].name == defaults[i].name);
    CHECK(file[i].type == defaults[i].type);
    CHECK(file[i].continuous == defaults[i].continuous);
    CHECK(file[i].position_min == Approx(defaults[i].position_min).margin(1e-12));
    CHECK(file[i].position_max == Approx(defaults[i].position_max).margin(1e-12));
    CHECK(file[i].max_velocity == Approx(defaults[i].max_velocity).epsilon(1e-12));
    CHECK(file[i].max_acceleration == Approx(defaults[i].max_acceleration).epsilon(1e-12));
    CHECK(file[i].max_jerk == Approx(defaults[i].max_jerk).epsilon(1e-12));
  }
}
}  // namespace

TEST_CASE("shipped machine files hold the documented defaults", "[unit]") {
  const MachineDefinition tower = io::load_machine(mgc::test::source_path("scenarios/machines/pecco-sk180.yaml"));
  check_same_joints(tower.joints, default_tower_crane_joints());
  const TowerCraneGeometry tg;
  CHECK(tower.tower_crane.jib_height_m == tg.jib_height_m);
  CHECK(tower.tower_crane.jib_length_m == tg.jib_length_m);
  CHECK(tower.tower_crane.counterweight_size_m == tg.counterweight_size_m);
  CHECK(tower.tower_crane.min_hook_drop_m == tg.min_hook_drop_m);

  const MachineDefinition cat = io::load_machine(mgc::test::source_path("scenarios/machines/cat-320.yaml"));
  check_same_joints(cat.joints, default_excavator_joints());
  const ExcavatorGeometry eg;
  CHECK(cat.excavator.boom_length_m == eg.boom_length_m);
  CHECK(cat.excavator.arm_length_m == eg.arm_length_m);
  CHECK(cat.excavator.bucket_length_m == eg.bucket_length_m);
  CHECK(cat.excavator.boom_foot_forward_m == eg.boom_foot_forward_m);
  CHECK(cat.excavator.boom_foot_height_m == eg.boom_foot_height_m);
  CHECK(cat.excavator.house_centre_m == eg.house_centre_m);
  CHECK(cat.excavator.cab_centre_m == eg.cab_centre_m);
}

TEST_CASE("excavator scenario: the bucket is held at the same ground angle at start and goal", "[scenario]") {
  auto loaded = load("excavator-pipelines.yaml");
  CHECK(bucket_ground_angle_rad(loaded.scenario.start) == Approx(-180 * kDeg));
  CHECK(bucket_ground_angle_rad(loaded.scenario.goal) == Approx(-180 * kDeg));
  // The start bucket is below ground, between the pipelines.
  Kinematics k;
  loaded.model->forward_kinematics(loaded.scenario.start, k);
  const Eigen::Vector3d tip = k.points[Excavator::kPointBucketTip];
  CHECK(tip.z() < -1.5);
  CHECK(std::abs(tip.y()) < 0.5);
}

TEST_CASE("tower variant: crane 2's jib crosses the west route after it slews", "[scenario]") {
  auto loaded = load("thesis-steel-frame-tower.yaml");
  CHECK(loaded.world->num_static() == 535);
  // Hook low on the bearing where crane 2's jib (y = -10, x < 5 once it points east) meets our
  // 15 m trolley radius: x = -sqrt(15^2 - 10^2) = -11.18, bearing -138.2 deg.
  JointVector west = loaded.scenario.start;
  west[TowerCrane::kSlew] = -138.2 * kDeg;
  CHECK(loaded.world->is_free(west));
  auto late = build_world(loaded.scenario, *loaded.model, 85.0);
  Contact contact;
  REQUIRE_FALSE(late->is_free(west, &contact));
  CHECK(late->dynamic_name(contact.other) == "tower-crane-2");
}

TEST_CASE("displacement bounds hold for every body corner of every model", "[oracle]") {
  for (const char* name : {"thesis-steel-frame.yaml", "thesis-steel-frame-tower.yaml", "excavator-pipelines.yaml"}) {
    CAPTURE(name);
    auto loaded = load(name);
    const MachineModel& model = *loaded.model;
    Random random(11);
    Kinematics a;
    Kinematics b;
    double tightest = 0.0;
    for (int n = 0; n < 4000; ++n) {
      // A point q on a random edge; the bound for that edge must hold at q.
      JointVector from(model.dof());
      JointVector to(model.dof());
      for (int j = 0; j < model.dof(); ++j) {
        const JointSpec& s = model.joints()[static_cast<std::size_t>(j)];
        from[j] = random.uniform(s.position_min, s.position_max);
        to[j] = random.uniform(s.position_min, s.position_max);
      }
      if (n % 2 == 0) to = from;  // half the edges are single points: the bound at q itself
      const JointVector q = model.interpolate(from, to, random.uniform());
      // Drawn, not n % dof: every joint meets both kinds of q below.
      const int joint = std::min(static_cast<int>(random.uniform() * model.dof()), model.dof() - 1);
      // Every fourth q is instead a point of the box spanned by from and to, under the box bound.
      const bool in_box = n % 4 == 1;
      const JointVector lo = from.cwiseMin(to);
      const JointVector hi = from.cwiseMax(to);
      JointVector p = q;
      if (in_box) {
        for (int j = 0; j < model.dof(); ++j) p[j] = random.uniform(lo[j], hi[j]);
      }
      const double bound =
          in_box ? model.box_displacement_bound(lo, hi, joint) : model.edge_displacement_bound(from, to, joint);
      REQUIRE(bound <= model.displacement_bound(joint) + 1e-12);
      // Clearance balls rely on a box's bound being nowhere below the bound at one of its points.
      if (in_box) REQUIRE(bound >= model.box_displacement_bound(p, p, joint));
      const double delta = 1e-4;
      JointVector moved = p;
      moved[joint] += delta;
      model.forward_kinematics(p, a);
      model.forward_kinematics(moved, b);
      for (std::size_t body = 0; body < model.bodies().size(); ++body) {
        // The corners of each body's bounding box (a capsule's too), before and after.
        for (int c = 0; c < 8; ++c) {
          const Eigen::Vector3d corner((c & 1 ? 0.5 : -0.5), (c & 2 ? 0.5 : -0.5), (c & 4 ? 0.5 : -0.5));
          const Eigen::Vector3d pa = a.bodies[body].world_from_body * corner.cwiseProduct(a.bodies[body].size_m);
          const Eigen::Vector3d pb = b.bodies[body].world_from_body * corner.cwiseProduct(b.bodies[body].size_m);
          const double ratio = (pb - pa).norm() / (bound * delta);
          CAPTURE(joint, body, ratio);
          REQUIRE(ratio <= 1.0 + 1e-6);
          tightest = std::max(tightest, ratio);
        }
      }
    }
    // The bounds are not loose by orders of magnitude either.
    CHECK(tightest > 0.5);
  }
}
