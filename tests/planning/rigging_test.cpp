// SPDX-License-Identifier: Apache-2.0
// The rigging between hook and load is a collision body: an obstacle that passes between them,
// clear of hook, cable and load, is hit.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "mgc/planning/tower_crane.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

constexpr double kDilation_m = 0.15;

StaticObstacle beam(const Eigen::Vector3d& centre_m, const Eigen::Vector3d& size_m) {
  StaticObstacle o;
  o.name = "beam";
  o.shape.kind = ShapeKind::Box;
  o.shape.size_m = size_m;
  o.shape.pose = Eigen::Isometry3d(Eigen::Translation3d(centre_m));
  return o;
}

std::string body_name(const MachineModel& model, int body) {
  return model.bodies()[static_cast<std::size_t>(body)].name;
}

//! The contact of q and of the straight edge from -> to, both through the sling only; the ends of
//! the edge free.
void require_sling_hit(CollisionWorld& world, const MachineModel& model, const JointVector& q, const JointVector& from,
                       const JointVector& to, const JointVector& max_step) {
  const Validity v = world.validate(q);
  REQUIRE(v.status == Validity::Status::Collision);
  REQUIRE(v.contact.with == Contact::With::Static);
  // Bodies are checked in order and the sling comes last: naming it means no other body is hit.
  CHECK(body_name(model, v.contact.body) == "sling");
  CHECK(world.describe(v.contact) == "sling hits obstacle 'beam'");

  REQUIRE(world.validate(from).valid());
  REQUIRE(world.validate(to).valid());
  const Validity edge = world.validate_edge(from, to, max_step);
  REQUIRE(edge.status == Validity::Status::Collision);
  CHECK(body_name(model, edge.contact.body) == "sling");
}

}  // namespace

TEST_CASE("mobile crane: a beam between hook and load hits the sling", "[unit]") {
  const MachineDefinition m = io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  LiftTask task;
  task.load_lb = 20000;
  task.constraint = CraneConstraintMode::None;
  task.load_size_m = {2.0, 2.0, 1.0};
  task.sling_length_m = 2.5;
  const MobileCrane crane(m.name, m.joints, m.mobile_crane, *m.load_chart, m.luff_table, task,
                          Eigen::Isometry3d::Identity());
  REQUIRE(crane.body_index("sling") >= 0);

  // Boom 20 m at 60 deg: tip at radius 10, height 3 + 17.32 = 20.32 m; 8 m of cable puts the hook
  // at 12.32 m, the load top at 9.82 m. A 0.2 m beam at 11 m spans x 9.9..10.1, y -2..2: 1.2 m
  // below the hook and 1 m above the load, both more than the dilation.
  JointVector q(4);
  q << 0.0, 60.0 * kDeg, 20.0, 8.0;
  CollisionWorld world(crane, kDilation_m);
  world.add_static(beam({10.0, 0.0, 11.0}, {0.2, 4.0, 0.2}));
  world.finalize();

  // Swung 30 deg either way the sling's footprint (half-diagonal 1.41 m around y = +-5 m) is clear
  // of the beam; the swing between passes the sling through it.
  JointVector from = q;
  JointVector to = q;
  from[0] = -30.0 * kDeg;
  to[0] = 30.0 * kDeg;
  JointVector max_step(4);
  max_step << 1.0 * kDeg, 1.0 * kDeg, 0.1, 0.1;
  require_sling_hit(world, crane, q, from, to, max_step);

  // Hoisted 2 m the load passes over the beam: the hit was the sling, not the shape of the site.
  JointVector hoisted = q;
  hoisted[3] = 4.0;
  CHECK(world.validate(hoisted).valid());
}

TEST_CASE("tower crane: a beam between hook and load hits the sling", "[unit]") {
  TowerLiftTask task;
  task.load_size_m = {2.0, 2.0, 1.0};
  task.sling_length_m = 2.5;
  const TowerCrane crane("tower", default_tower_crane_joints(), TowerCraneGeometry{}, task,
                         Eigen::Isometry3d::Identity());
  REQUIRE(crane.body_index("sling") >= 0);

  // Hook at (20, 0, 20): the sling spans z 17.5..20, the load 16.5..17.5. A 0.2 m beam at 18.75 m
  // is 1.15 m below the hook (cable capsule radius 0.15 m) and 1.15 m above the load.
  JointVector q(3);
  q << 0.0, 20.0, 20.0;
  CollisionWorld world(crane, kDilation_m);
  world.add_static(beam({20.0, 0.0, 18.75}, {0.2, 4.0, 0.2}));
  world.finalize();

  JointVector from = q;
  JointVector to = q;
  from[0] = -20.0 * kDeg;
  to[0] = 20.0 * kDeg;
  JointVector max_step(3);
  max_step << 1.0 * kDeg, 0.1, 0.1;
  require_sling_hit(world, crane, q, from, to, max_step);

  // Trolleyed in 4 m along the same line, the sling passes the beam.
  JointVector inward = q;
  inward[1] = 16.0;
  CHECK(world.validate(inward).valid());
}

TEST_CASE("the sling box spans hook to load top with the load's footprint, turned with it", "[unit]") {
  TowerLiftTask task;
  task.load_size_m = {3.0, 1.0, 1.0};
  task.sling_length_m = 2.0;
  const TowerCrane crane("tower", default_tower_crane_joints(), TowerCraneGeometry{}, task,
                         Eigen::Isometry3d::Identity());
  JointVector q(3);
  q << 90.0 * kDeg, 10.0, 30.0;
  Kinematics k;
  crane.forward_kinematics(q, k);
  const BodyState& sling = k.bodies[static_cast<std::size_t>(crane.body_index("sling"))];
  const BodyState& load = k.bodies[static_cast<std::size_t>(crane.body_index("load"))];
  // Hook at (0, 10, 30): the sling's centre 1 m below it, its axes the load's.
  CHECK((sling.world_from_body.translation() - Eigen::Vector3d(0.0, 10.0, 29.0)).norm() < 1e-9);
  CHECK((sling.size_m - Eigen::Vector3d(3.0, 1.0, 2.0)).norm() < 1e-12);
  CHECK((sling.world_from_body.linear() - load.world_from_body.linear()).norm() < 1e-12);
  // Its bottom face is the load's top face.
  CHECK(sling.world_from_body.translation().z() - 0.5 * sling.size_m.z() ==
        Approx(load.world_from_body.translation().z() + 0.5 * load.size_m.z()));
}
