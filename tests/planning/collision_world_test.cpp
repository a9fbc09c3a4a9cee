// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <vector>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/random.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

std::unique_ptr<MobileCrane> make_crane() {
  const MachineDefinition m = io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  LiftTask task;
  task.load_lb = 20000;
  task.constraint = CraneConstraintMode::None;
  task.load_size_m = {2.0, 2.0, 1.0};
  task.sling_length_m = 1.0;
  return std::make_unique<MobileCrane>(m.name, m.joints, m.mobile_crane, *m.load_chart, m.luff_table, task,
                                       Eigen::Isometry3d::Identity());
}

JointVector q4(double swing_deg, double elevation_deg, double boom_m, double cable_m) {
  JointVector q(4);
  q << swing_deg * kDeg, elevation_deg * kDeg, boom_m, cable_m;
  return q;
}

ShapePart box_part(const Eigen::Vector3d& size_m, const Eigen::Vector3d& centre_m) {
  ShapePart part;
  part.kind = ShapeKind::Box;
  part.size_m = size_m;
  part.pose = Eigen::Isometry3d(Eigen::Translation3d(centre_m));
  return part;
}

//! An 8 x 2.5 x 3 m truck on the ground at its origin.
DynamicObstacle make_truck() {
  DynamicObstacle truck;
  truck.name = "truck";
  truck.parts.push_back(box_part({8, 2.5, 3}, {0, 0, 1.5}));
  return truck;
}

//! The truck with a 2 m box held 18 m along its x axis, 5 m up.
DynamicObstacle make_truck_with_boom() {
  DynamicObstacle truck = make_truck();
  truck.parts.push_back(box_part({2, 2, 2}, {18, 0, 5}));
  return truck;
}

StaticObstacle box(const std::string& name, const Eigen::Vector3d& centre, const Eigen::Vector3d& size) {
  StaticObstacle o;
  o.name = name;
  o.shape.kind = ShapeKind::Box;
  o.shape.size_m = size;
  o.shape.pose = Eigen::Isometry3d(Eigen::Translation3d(centre));
  return o;
}

}  // namespace

TEST_CASE("collision world names what a configuration hits", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  // A wall 2 m thick, 10 m tall, across the +x axis at x = 14..16.
  world.add_static(box("wall", {15, 0, 5}, {2, 20, 10}));
  world.add_static(box("far-block", {-40, 40, 1}, {2, 2, 2}));
  world.finalize();

  // Elevation 60, boom 20: tip at radius 10, height 20.3; hook 10 m below at radius 10: free.
  Contact contact;
  CHECK(world.is_free(q4(0, 60, 20, 10), &contact));
  CHECK(contact.with == Contact::With::Nothing);

  // Boom level at 3 m: boom reaches x = 20 and passes through the wall.
  REQUIRE_FALSE(world.is_free(q4(0, 0, 20, 1), &contact));
  CHECK(contact.with == Contact::With::Static);
  CHECK(world.static_name(contact.other) == "wall");
  CHECK(world.describe(contact) == "boom hits obstacle 'wall'");

  // Load hanging at radius 15 (elevation 41.41 deg on a 20 m boom), low: the load hits the wall.
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  REQUIRE_FALSE(world.is_free(q4(0, elevation, 20, 10), &contact));
  CHECK(world.static_name(contact.other) == "wall");
  // Hoisted above the wall top (10 m): tip height 3 + 13.23 = 16.23; cable 2 m puts the load
  // bottom at 16.23 - 2 - 1 - 1 = 12.23 m: free.
  CHECK(world.is_free(q4(0, elevation, 20, 2), &contact));
  // Swung away from the wall: free again.
  CHECK(world.is_free(q4(90, elevation, 20, 10), &contact));
}

TEST_CASE("collision world reports self contact of the load with the carrier", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.0);
  world.finalize();
  // Steep short boom over the carrier (carrier spans x -4.5..8.5, z 0..2), load lowered onto it.
  // Tip: radius 11 cos 80 = 1.91 m, height 3 + 10.83 = 13.83 m; cable 10.5 m: load bottom 1.33 m.
  Contact contact;
  REQUIRE_FALSE(world.is_free(q4(0, 80, 11, 10.5), &contact));
  CHECK(contact.with == Contact::With::Self);
  CHECK(crane->bodies()[static_cast<std::size_t>(contact.body)].name == "load");
  CHECK(crane->bodies()[static_cast<std::size_t>(contact.other)].name == "carrier");
  CHECK(world.is_free(q4(0, 80, 11, 5.0), &contact));
}

TEST_CASE("collision world clearance agrees with the analytic gap", "[oracle]") {
  auto crane = make_crane();
  const double margin = 0.15;
  CollisionWorld world(*crane, margin);
  world.add_static(box("block", {30, 0, 1}, {2, 2, 2}));
  world.finalize();
  // Boom level at 3 m along +x, 20 m: its dilated end face is at x = 20 + 0.15; the load hangs
  // below the tip. Load 2x2x1 under a 1 m sling at hook height 3 - 1 = 2: load box x 19..21,
  // z 0..1 (dilated: x to 21.15). Block face at x = 29: the gap is 29 - 21.15 = 7.85 m.
  const Clearance c = world.clearance(q4(0, 0, 20, 1));
  CHECK(c.distance_m == Approx(7.85).margin(1e-6));
  CHECK(c.with == Contact::With::Static);
  CHECK(world.static_name(c.other) == "block");
  CHECK(crane->bodies()[static_cast<std::size_t>(c.body)].name == "load");
}

TEST_CASE("edge check finds an obstacle between two free configurations", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  world.add_static(box("pillar", {0, 15, 5}, {1, 1, 10}));
  world.finalize();
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  const JointVector a = q4(60, elevation, 20, 8);
  const JointVector b = q4(120, elevation, 20, 8);
  REQUIRE(world.validate(a).valid());
  REQUIRE(world.validate(b).valid());
  JointVector steps(4);
  steps << 1 * kDeg, 1 * kDeg, 0.1, 0.1;
  JointVector at;
  const Validity v = world.validate_edge(a, b, steps, &at);
  REQUIRE(v.status == Validity::Status::Collision);
  CHECK(world.static_name(v.contact.other) == "pillar");
  // The first colliding step is still short of 90 deg, where the pillar stands.
  CHECK(at[0] < 90 * kDeg);
  CHECK(at[0] > 80 * kDeg);
  // Hoisted above the pillar, the same swing is free.
  CHECK(world.validate_edge(q4(60, elevation, 20, 1), q4(120, elevation, 20, 1), steps).valid());
}

TEST_CASE("edge check takes the short way round for a continuous swing", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  // A pillar due east: swinging from +170 to -170 must pass west (through 180), not east.
  world.add_static(box("east-pillar", {15, 0, 5}, {1, 1, 10}));
  world.finalize();
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  JointVector steps(4);
  steps << 1 * kDeg, 1 * kDeg, 0.1, 0.1;
  CHECK(world.validate_edge(q4(170, elevation, 20, 8), q4(-170, elevation, 20, 8), steps).valid());
  CHECK_FALSE(world.validate_edge(q4(10, elevation, 20, 8), q4(-10, elevation, 20, 8), steps).valid());
}

TEST_CASE("dynamic obstacles move without rebuilding the world", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  world.finalize();
  const DynamicObstacle truck = make_truck();
  CHECK_THROWS_AS(world.add_dynamic(truck), std::logic_error);

  CollisionWorld world2(*crane, 0.15);
  const int id = world2.add_dynamic(truck);
  world2.finalize();
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  // Load at radius 15: tip 16.23 m up, 12 m cable, 1 m sling, 1 m load: bottom 2.23 m up, below
  // the 3 m truck.
  const JointVector q = q4(0, elevation, 20, 12);
  world2.set_dynamic_pose(id, Eigen::Isometry3d(Eigen::Translation3d(-50, 0, 0)));
  CHECK(world2.is_free(q));
  world2.set_dynamic_pose(id, Eigen::Isometry3d(Eigen::Translation3d(15, 0, 0)));
  Contact contact;
  REQUIRE_FALSE(world2.is_free(q, &contact));
  CHECK(contact.with == Contact::With::Dynamic);
  CHECK(world2.dynamic_name(contact.other) == "truck");
  CHECK(world2.describe(contact) == "load hits dynamic obstacle 'truck'");
  const Clearance c = world2.clearance(q4(90, elevation, 20, 10));
  CHECK(c.with == Contact::With::Dynamic);
}

TEST_CASE("validity checks joint ranges, then constraints, then collision", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  world.finalize();
  const Validity range = world.validate(q4(0, 85, 20, 5));
  CHECK(range.status == Validity::Status::JointOutOfRange);
  CHECK(range.joint == MobileCrane::kBoomElevation);
  const Validity ground = world.validate(q4(0, 10, 20, 20));
  CHECK(ground.status == Validity::Status::Constraint);
  CHECK(ground.constraint.status == ConstraintStatus::LoadBelowGround);
  CHECK(world.validate(q4(0, 45, 20, 5)).valid());
  // A swing value far outside [-pi, pi) is still a valid continuous-joint position.
  CHECK(world.validate(q4(720 + 45, 45, 20, 5)).valid());
}

TEST_CASE("mesh and rotated-box obstacles block like the box they describe", "[unit]") {
  auto crane = make_crane();
  // The same 2 x 20 x 10 m wall at x = 14..16: once as a triangle mesh (12 triangles), once as a
  // box rotated by 90 deg about z (so its given 20 x 2 x 10 size lies across the x axis).
  StaticObstacle mesh;
  mesh.name = "wall-mesh";
  mesh.shape.kind = ShapeKind::Mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.shape.vertices_m.emplace_back((i & 1) ? 16.0 : 14.0, (i & 2) ? 10.0 : -10.0, (i & 4) ? 10.0 : 0.0);
  }
  mesh.shape.triangles = {{0, 1, 3}, {0, 3, 2}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1},
                          {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
  StaticObstacle rotated = box("wall-rotated", {15, 0, 5}, {20, 2, 10});
  rotated.shape.pose.rotate(Eigen::AngleAxisd(90 * kDeg, Eigen::Vector3d::UnitZ()));

  for (const StaticObstacle& wall : {mesh, rotated}) {
    CAPTURE(wall.name);
    CollisionWorld world(*crane, 0.15);
    world.add_static(wall);
    world.finalize();
    const double elevation = std::acos(15.0 / 20.0) / kDeg;
    Contact contact;
    REQUIRE_FALSE(world.is_free(q4(0, elevation, 20, 10), &contact));
    CHECK(world.static_name(contact.other) == wall.name);
    CHECK(world.is_free(q4(0, elevation, 20, 2)));
    CHECK(world.is_free(q4(90, elevation, 20, 10)));
    // Load at radius 10 (elevation 60 on a 20 m boom): its dilated face at x = 11.15; the wall at 14.
    const Clearance c = world.clearance(q4(0, 60, 20, 12));
    CHECK(c.distance_m == Approx(14.0 - 11.15).margin(1e-6));
  }
}

TEST_CASE("collision world rejects degenerate shapes", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.1);
  CHECK_THROWS_AS(world.add_static(box("flat", {0, 0, 0}, {1, 0, 1})), std::invalid_argument);
  StaticObstacle mesh;
  mesh.name = "bad-mesh";
  mesh.shape.kind = ShapeKind::Mesh;
  mesh.shape.vertices_m = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  CHECK_THROWS_AS(world.add_static(mesh), std::invalid_argument);  // no triangles
  mesh.shape.triangles = {{0, 1, 5}};
  CHECK_THROWS_AS(world.add_static(mesh), std::invalid_argument);  // index out of range
  CHECK_THROWS_AS(CollisionWorld(*crane, -0.1), std::invalid_argument);
}

TEST_CASE("clearance splits into the moving and the fixed bodies, only the carrier and undercarriage are fixed", "[unit]") {
  for (const char* name : {"thesis-steel-frame.yaml", "thesis-steel-frame-tower.yaml", "excavator-pipelines.yaml"}) {
    CAPTURE(name);
    auto loaded = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + name));
    CollisionWorld& world = *loaded.world;
    const MachineModel& model = *loaded.model;
    // Exactly one fixed body: the mobile crane's carrier, the tower's base, the excavator's
    // undercarriage -- body 0 in every model.
    for (int b = 0; b < static_cast<int>(model.bodies().size()); ++b) {
      CAPTURE(model.bodies()[static_cast<std::size_t>(b)].name);
      CHECK(world.body_moves(b) == (b != 0));
    }
    Random random(11);
    int compared = 0;
    for (int i = 0; i < 300; ++i) {
      JointVector q(model.dof());
      for (int j = 0; j < model.dof(); ++j) {
        const JointSpec& s = model.joints()[static_cast<std::size_t>(j)];
        q[j] = random.uniform(s.position_min, s.position_max);
      }
      const Clearance all = world.clearance(q);
      if (all.distance_m == 0.0) continue;
      const Clearance moving = world.clearance(q, CollisionWorld::Bodies::Moving);
      const Clearance fixed = world.clearance(q, CollisionWorld::Bodies::Fixed);
      CHECK(all.distance_m == std::min(moving.distance_m, fixed.distance_m));
      CHECK(world.body_moves(moving.body));
      CHECK_FALSE(world.body_moves(fixed.body));
      ++compared;
    }
    CHECK(compared > 100);
  }
}

TEST_CASE("collision world: the fixed bodies keep their own dilation when it is set", "[unit]") {
  // The thesis site: the parked carrier is the only fixed body, 1.15 m from the frame.
  Scenario s = io::load_scenario(mgc::test::source_path("scenarios/thesis-steel-frame.yaml"));
  const auto model = build_model(s);
  const auto plain = build_world(s, *model);
  s.planner.dilation_m += 0.5;
  const auto wider = build_world(s, *model);
  const JointVector& q = s.start;
  using B = CollisionWorld::Bodies;
  const double fixed_m = plain->clearance(q, B::Fixed).distance_m;
  const double moving_m = wider->clearance(q, B::Moving).distance_m;
  REQUIRE(fixed_m > 0.6);
  CHECK(wider->clearance(q, B::Fixed).distance_m == Approx(fixed_m - 0.5).margin(1e-6));
  CHECK(wider->fixed_body_dilation_m() == wider->dilation_m());

  wider->set_fixed_body_dilation(plain->dilation_m());
  CHECK(wider->fixed_body_dilation_m() == plain->dilation_m());
  CHECK(wider->clearance(q, B::Fixed).distance_m == Approx(fixed_m).margin(1e-6));
  CHECK(wider->clearance(q, B::Moving).distance_m == Approx(moving_m).margin(1e-9));
  CHECK_THROWS_AS(wider->set_fixed_body_dilation(-0.1), std::invalid_argument);
}

TEST_CASE("wrap_angle returns the fmod formula's value bit for bit", "[unit]") {
  constexpr double kPi = std::numbers::pi;
  const auto reference = [](double angle_rad) {
    double wrapped = std::fmod(angle_rad + kPi, 2.0 * kPi);
    if (wrapped < 0.0) wrapped += 2.0 * kPi;
    if (wrapped >= 2.0 * kPi) wrapped -= 2.0 * kPi;
    return wrapped - kPi;
  };
  const auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  Random random(5);
  // Differences of wrapped angles and one-step moves past +-pi (the fast path), the exact edges
  // of each branch, and angles many turns out (fmod itself).
  std::vector<double> angles = {0.0, -0.0, kPi, -kPi, 2.0 * kPi, -2.0 * kPi, 3.0 * kPi, -3.0 * kPi, 4.0 * kPi,
                                std::nextafter(kPi, 0.0), std::nextafter(-kPi, 0.0), std::nextafter(3.0 * kPi, 0.0),
                                std::nextafter(3.0 * kPi, 10.0), std::nextafter(-kPi, -10.0), 1e6, -1e6};
  for (int n = 0; n < 200000; ++n) angles.push_back(random.uniform(-4.0 * kPi, 4.0 * kPi));
  for (int n = 0; n < 2000; ++n) angles.push_back(random.uniform(-1e4, 1e4));
  for (const double angle : angles) {
    CAPTURE(angle);
    REQUIRE(same(wrap_angle(angle), reference(angle)));
  }
  CHECK(std::isnan(wrap_angle(std::numeric_limits<double>::quiet_NaN())));
  CHECK(std::isnan(wrap_angle(std::numeric_limits<double>::infinity())));
}


TEST_CASE("a dynamic obstacle's reach is its farthest corner from its vertical axis", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  const int id = world.add_dynamic(make_truck_with_boom());
  world.finalize();
  CHECK(world.dynamic_reach_m(id) == Approx(std::hypot(19.0, 1.0)));
  // Posing it elsewhere changes nothing: the reach is about its own axis.
  world.set_dynamic_pose(id, Eigen::Isometry3d(Eigen::Translation3d(40, 10, 0)));
  CHECK(world.dynamic_reach_m(id) == Approx(std::hypot(19.0, 1.0)));
}

TEST_CASE("a dynamic obstacle said to be farther than a distance does not reach the machine when moved by less", "[oracle]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  const int id = world.add_dynamic(make_truck_with_boom());
  world.finalize();
  Random random(5);
  int far = 0;
  int near = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const JointVector q = uniform_sample(*crane, random);
    const Eigen::Vector3d at(random.uniform(-40, 40), random.uniform(-40, 40), 0.0);
    const double yaw = random.uniform(-3.2, 3.2);
    const Eigen::Isometry3d pose = Eigen::Translation3d(at) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    world.set_dynamic_pose(id, pose);
    const double distance_m = random.uniform(0.0, 6.0);
    if (world.dynamic_may_be_within(q, id, distance_m)) {
      ++near;
      continue;
    }
    ++far;
    CAPTURE(trial, distance_m);
    REQUIRE_FALSE(world.hits_dynamic(q));
    // Any motion whose points travel less than the distance: a shift, and a turn about its axis
    // by the angle that moves its farthest corner that far.
    const Eigen::Vector3d direction = Eigen::Vector3d(random.uniform(-1, 1), random.uniform(-1, 1), random.uniform(-1, 1)).normalized();
    world.set_dynamic_pose(id, Eigen::Translation3d(0.999 * distance_m * direction) * pose);
    REQUIRE_FALSE(world.hits_dynamic(q));
    const double turn = 0.999 * distance_m / world.dynamic_reach_m(id);
    world.set_dynamic_pose(id, pose * Eigen::AngleAxisd(random.uniform() < 0.5 ? turn : -turn, Eigen::Vector3d::UnitZ()));
    REQUIRE_FALSE(world.hits_dynamic(q));
  }
  // Both answers were exercised.
  CHECK(far > 300);
  CHECK(near > 300);
}

TEST_CASE("copies of one obstacle at one pose report the first, and a copy elsewhere is still checked", "[unit]") {
  auto crane = make_crane();
  CollisionWorld world(*crane, 0.15);
  const int first = world.add_dynamic(make_truck_with_boom());
  const int second = world.add_dynamic(make_truck_with_boom());
  DynamicObstacle other = make_truck_with_boom();
  other.parts[1].size_m = {2, 2, 2.5};
  const int third = world.add_dynamic(other);
  world.finalize();
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  const JointVector q = q4(0, elevation, 20, 12);  // load 2.23 m up at radius 15, over the truck at x = 15
  const Eigen::Isometry3d on(Eigen::Translation3d(15, 0, 0));
  const Eigen::Isometry3d away(Eigen::Translation3d(-60, 0, 0));
  world.set_dynamic_pose(third, away);
  world.set_dynamic_pose(first, on);
  world.set_dynamic_pose(second, on);
  Contact contact;
  REQUIRE(world.hits_dynamic(q, &contact));
  CHECK(contact.other == first);
  world.set_dynamic_pose(first, away);
  REQUIRE(world.hits_dynamic(q, &contact));
  CHECK(contact.other == second);
  world.set_dynamic_pose(second, away);
  CHECK_FALSE(world.hits_dynamic(q));
  world.set_dynamic_pose(third, on);
  REQUIRE(world.hits_dynamic(q, &contact));
  CHECK(contact.other == third);
}

TEST_CASE("a dynamic obstacle resized in place measures as one built at that size, and is no longer its twin's", "[unit]") {
  auto crane = make_crane();
  const auto box = [](double side_m) {
    DynamicObstacle d;
    d.name = "box";
    ShapePart part;
    part.kind = ShapeKind::Box;
    part.size_m = Eigen::Vector3d(side_m, side_m, side_m);
    d.parts.push_back(part);
    return d;
  };
  // Two copies of the same box (twins), one to be resized; and the reference built large.
  CollisionWorld world(*crane, 0.15);
  const int small = world.add_dynamic(box(1.0));
  const int twin = world.add_dynamic(box(1.0));
  world.finalize();
  CollisionWorld reference(*crane, 0.15);
  const int reference_small = reference.add_dynamic(box(1.0));
  const int reference_twin = reference.add_dynamic(box(5.0));
  reference.finalize();
  const Eigen::Isometry3d at(Eigen::Translation3d(14, 0, 1));
  world.set_dynamic_pose(small, at);
  world.set_dynamic_pose(twin, at);
  reference.set_dynamic_pose(reference_small, at);
  reference.set_dynamic_pose(reference_twin, at);
  const double elevation = std::acos(15.0 / 20.0) / kDeg;
  // The load's bottom 2.23 m up (as above): clear of the 1 m box's top, inside the 5 m box.
  const JointVector q = q4(0, elevation, 20, 12);
  REQUIRE(world.is_free(q));
  REQUIRE_FALSE(reference.is_free(q));
  const double before_m = world.clearance(q, CollisionWorld::Bodies::All, CollisionWorld::Obstacles::Dynamic).distance_m;
  world.set_dynamic_part_size(twin, 0, Eigen::Vector3d(5.0, 5.0, 5.0));
  const Clearance after = world.clearance(q, CollisionWorld::Bodies::All, CollisionWorld::Obstacles::Dynamic);
  const Clearance expected = reference.clearance(q, CollisionWorld::Bodies::All, CollisionWorld::Obstacles::Dynamic);
  CHECK(after.distance_m == Approx(expected.distance_m).margin(1e-9));
  CHECK(after.distance_m < before_m);
  // Where it stands on the other copy's very pose, it answers for itself.
  Contact contact;
  CHECK_FALSE(world.is_free(q, &contact));
  CHECK(contact.other == twin);
  CHECK(world.dynamic_reach_m(twin) == Approx(reference.dynamic_reach_m(reference_twin)));
  // A size that is not positive and finite changes nothing.
  world.set_dynamic_part_size(twin, 0, Eigen::Vector3d(0.0, 5.0, 5.0));
  world.set_dynamic_part_size(twin, 3, Eigen::Vector3d(1.0, 1.0, 1.0));
  CHECK(world.clearance(q, CollisionWorld::Bodies::All, CollisionWorld::Obstacles::Dynamic).distance_m == Approx(after.distance_m));
  CHECK_FALSE(world.is_free(q));
}
