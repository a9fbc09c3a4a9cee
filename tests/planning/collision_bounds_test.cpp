// SPDX-License-Identifier: Apache-2.0
// CollisionWorld answers box, cylinder and capsule pairs by bounding and inscribed boxes before
// GJK, and gives every object the AABB of its rotated box. Both are exact shortcuts, so its answer
// must match an independent one: FCL's own collide() (libccd) on the same posed, dilated shapes.
#include <catch2/catch.hpp>

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <limits>
#include <memory>
#include <random>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

using namespace mgc::planning;

namespace {

using Object = fcl::CollisionObjectd;

std::shared_ptr<fcl::CollisionGeometryd> reference_geometry(ShapeKind kind, const Eigen::Vector3d& size_m) {
  switch (kind) {
    case ShapeKind::Box: return std::make_shared<fcl::Boxd>(size_m);
    case ShapeKind::Cylinder: return std::make_shared<fcl::Cylinderd>(0.5 * size_m.x(), size_m.z());
    case ShapeKind::Capsule: return std::make_shared<fcl::Capsuled>(0.5 * size_m.x(), size_m.z());
    case ShapeKind::Mesh: break;
  }
  FAIL("no mesh in this test");
  return nullptr;
}

bool reference_collide(const Object& a, const Object& b) {
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  fcl::collide(&a, &b, request, result);
  return result.isCollision();
}

Eigen::Isometry3d random_pose(std::mt19937_64& rng, double reach_m) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(reach_m * u(rng), reach_m * u(rng), 0.5 * reach_m * (u(rng) + 1.0)));
  pose.rotate(Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized()));
  return pose;
}

ShapePart random_part(std::mt19937_64& rng, double reach_m) {
  std::uniform_real_distribution<double> size(0.05 * reach_m, 0.4 * reach_m);
  ShapePart part;
  part.kind = std::array{ShapeKind::Box, ShapeKind::Cylinder, ShapeKind::Capsule}[rng() % 3];
  const double across = 0.4 * size(rng);
  part.size_m = part.kind == ShapeKind::Box ? Eigen::Vector3d(size(rng), size(rng), size(rng))
                                            : Eigen::Vector3d(across, across, size(rng));
  part.pose = random_pose(rng, reach_m);
  return part;
}

// Random obstacles around a scenario's machine, random configurations: the world's verdict
// against the reference's, pair by pair. Returns how many configurations collided.
int compare_with_reference(const char* scenario, std::uint64_t seed, int configurations) {
  const auto loaded = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + scenario));
  const MachineModel& model = *loaded.model;
  const double dilation_m = loaded.scenario.planner.dilation_m;
  // Obstacles within the machine's reach (the swing joint's displacement bound).
  const double reach_m = model.displacement_bound(0);
  std::mt19937_64 rng(seed);

  CollisionWorld world(model, dilation_m);
  std::vector<std::unique_ptr<Object>> obstacles;
  for (int i = 0; i < 10; ++i) {
    StaticObstacle o;
    o.name = "static-" + std::to_string(i);
    o.shape = random_part(rng, reach_m);
    obstacles.push_back(std::make_unique<Object>(reference_geometry(o.shape.kind, o.shape.size_m), o.shape.pose));
    world.add_static(o);
  }
  DynamicObstacle dynamic;
  dynamic.name = "moving";
  for (int i = 0; i < 2; ++i) dynamic.parts.push_back(random_part(rng, 0.3 * reach_m));
  world.add_dynamic(dynamic);
  world.finalize();
  const Eigen::Isometry3d dynamic_pose = random_pose(rng, 0.5 * reach_m);
  world.set_dynamic_pose(0, dynamic_pose);
  for (const ShapePart& part : dynamic.parts) {
    obstacles.push_back(std::make_unique<Object>(reference_geometry(part.kind, part.size_m), dynamic_pose * part.pose));
  }

  int collisions = 0;
  Kinematics kinematics;
  for (int n = 0; n < configurations; ++n) {
    JointVector q(model.dof());
    for (int j = 0; j < model.dof(); ++j) {
      const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
      q[j] = std::uniform_real_distribution<double>(spec.position_min, spec.position_max)(rng);
    }
    model.forward_kinematics(q, kinematics);
    std::vector<std::unique_ptr<Object>> bodies;
    for (std::size_t b = 0; b < model.bodies().size(); ++b) {
      const BodyState& state = kinematics.bodies[b];
      const bool box = model.bodies()[b].shape == BodyShape::Box;
      const Eigen::Vector3d size_m =
          box ? Eigen::Vector3d(state.size_m + Eigen::Vector3d::Constant(2.0 * dilation_m))
              : Eigen::Vector3d(state.size_m.x() + 2.0 * dilation_m, 0.0, state.size_m.z());
      bodies.push_back(std::make_unique<Object>(reference_geometry(box ? ShapeKind::Box : ShapeKind::Capsule, size_m),
                                                state.world_from_body));
    }
    bool expected_free = true;
    for (const auto& body : bodies) {
      for (const auto& obstacle : obstacles) expected_free = expected_free && !reference_collide(*body, *obstacle);
    }
    for (const SelfPair& pair : model.self_pairs()) {
      expected_free = expected_free && !reference_collide(*bodies[static_cast<std::size_t>(pair.body_a)],
                                                          *bodies[static_cast<std::size_t>(pair.body_b)]);
    }
    CAPTURE(scenario, seed, n);
    REQUIRE(world.is_free(q) == expected_free);
    collisions += expected_free ? 0 : 1;
  }
  return collisions;
}

}  // namespace

TEST_CASE("collision answers match FCL's collide() on random boxes, cylinders and capsules", "[unit]") {
  // The excavator's bodies are boxes; the mobile crane adds its hoist rope, a capsule.
  for (const char* scenario : {"excavator-pipelines.yaml", "thesis-steel-frame.yaml"}) {
    int collisions = 0;
    constexpr int kWorlds = 50;
    constexpr int kConfigurations = 100;
    for (std::uint64_t seed = 0; seed < kWorlds; ++seed) collisions += compare_with_reference(scenario, seed, kConfigurations);
    // Both answers well represented, so agreeing on them means something.
    CAPTURE(scenario);
    CHECK(collisions > kWorlds * kConfigurations / 10);
    CHECK(collisions < kWorlds * kConfigurations * 9 / 10);
  }
}

namespace {

// Distance from the segment a-b to a posed box by sampling the segment densely: independent of the
// world's closed form, and off by far less than the margin the test below leaves. [m]
double sampled_segment_box_distance_m(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Isometry3d& box_pose,
                                      const Eigen::Vector3d& half_m) {
  constexpr int kSamples = 5000;
  const Eigen::Isometry3d box_from_world = box_pose.inverse();
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= kSamples; ++k) {
    const Eigen::Vector3d p = box_from_world * (a + (b - a) * (static_cast<double>(k) / kSamples));
    best = std::min(best, (p.cwiseAbs() - half_m).cwiseMax(0.0).norm());
  }
  return best;
}

}  // namespace

TEST_CASE("a hoist line beside a box collides exactly when its axis comes within its radius", "[unit]") {
  // The tower crane's hoist line is a capsule; a box slides up to it from every side and angle,
  // to within a few centimetres either side of touching, where the bounding and inscribed boxes
  // leave the answer open.
  const auto loaded = io::load_and_build(mgc::test::source_path("scenarios/thesis-steel-frame-tower.yaml"));
  const MachineModel& model = *loaded.model;
  const double dilation_m = loaded.scenario.planner.dilation_m;
  int cable = -1;
  for (std::size_t b = 0; b < model.bodies().size(); ++b) {
    if (model.bodies()[b].shape == BodyShape::Capsule) cable = static_cast<int>(b);
  }
  REQUIRE(cable >= 0);
  const JointVector q = loaded.scenario.start;
  Kinematics kinematics;
  model.forward_kinematics(q, kinematics);
  const BodyState& line = kinematics.bodies[static_cast<std::size_t>(cable)];
  const double radius_m = 0.5 * line.size_m.x() + dilation_m;
  const Eigen::Vector3d axis = line.world_from_body.linear().col(2);
  const Eigen::Vector3d top = line.world_from_body.translation() + 0.5 * line.size_m.z() * axis;
  const Eigen::Vector3d bottom = line.world_from_body.translation() - 0.5 * line.size_m.z() * axis;
  REQUIRE(line.size_m.z() > 10.0);

  CollisionWorld world(model, dilation_m);
  DynamicObstacle box;
  box.name = "box";
  ShapePart part;
  part.kind = ShapeKind::Box;
  part.size_m = {1, 1, 1};
  box.parts.push_back(part);
  world.add_dynamic(box);
  world.finalize();

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0, misses = 0;
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d half_m(0.05 + 0.45 * (u(rng) + 1.0), 0.05 + 0.45 * (u(rng) + 1.0), 0.05 + 0.45 * (u(rng) + 1.0));
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.rotate(Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized()));
    // Beside the middle of the line, away from the jib above and the load below.
    const Eigen::Vector3d beside = bottom + (0.5 + 0.15 * u(rng)) * (top - bottom);
    Eigen::Vector3d out(u(rng), u(rng), 0.3 * u(rng));
    out -= out.dot(axis) * axis;
    out.normalize();
    // Slide the box along `out` until its gap to the line's surface is the wanted one.
    const double wanted_gap_m = 0.05 * u(rng);
    double offset_m = radius_m + half_m.norm();
    double distance_m = 0.0;
    for (int k = 0; k < 6; ++k) {
      pose.translation() = beside + offset_m * out;
      distance_m = sampled_segment_box_distance_m(bottom, top, pose, half_m);
      offset_m += radius_m + wanted_gap_m - distance_m;
    }
    // Too close to touching for the sampled distance to settle it.
    if (std::abs(distance_m - radius_m) < 1e-3) continue;
    world.set_dynamic_part_size(0, 0, 2.0 * half_m);
    world.set_dynamic_pose(0, pose);
    Contact contact;
    const bool hit = world.hits_dynamic(q, &contact);
    CAPTURE(n, distance_m, radius_m);
    REQUIRE(hit == (distance_m < radius_m));
    if (hit) CHECK(contact.body == cable);
    ++(hit ? hits : misses);
  }
  CHECK(hits > 300);
  CHECK(misses > 300);
}

TEST_CASE("a silo beside a load collides as FCL's collide() says, to within a millimetre of touching", "[unit]") {
  // A cylinder (a silo, a pipe) near the tower crane's load, a box, from every side and angle:
  // the world's answer against FCL's collide() (libccd) on the same shapes, where that answer does
  // not change when the load grows or shrinks by a millimetre.
  const auto loaded = io::load_and_build(mgc::test::source_path("scenarios/thesis-steel-frame-tower.yaml"));
  const MachineModel& model = *loaded.model;
  const double dilation_m = loaded.scenario.planner.dilation_m;
  int load = -1;
  for (std::size_t b = 0; b < model.bodies().size(); ++b) {
    if (model.bodies()[b].name == "load") load = static_cast<int>(b);
  }
  REQUIRE(load >= 0);
  const JointVector q = loaded.scenario.start;
  Kinematics kinematics;
  model.forward_kinematics(q, kinematics);
  const BodyState& body = kinematics.bodies[static_cast<std::size_t>(load)];
  const Eigen::Vector3d load_size_m = body.size_m + Eigen::Vector3d::Constant(2.0 * dilation_m);

  CollisionWorld world(model, dilation_m);
  DynamicObstacle silo;
  silo.name = "silo";
  ShapePart part;
  part.kind = ShapeKind::Cylinder;
  part.size_m = {1, 1, 1};
  silo.parts.push_back(part);
  world.add_dynamic(silo);
  world.finalize();

  const auto load_with = [&](double grow_m) {
    return Object(std::make_shared<fcl::Boxd>(load_size_m + Eigen::Vector3d::Constant(2.0 * grow_m)), body.world_from_body);
  };
  const Object smaller = load_with(-1e-3);
  const Object larger = load_with(1e-3);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0, misses = 0;
  for (int n = 0; n < 2000; ++n) {
    const double radius_m = 0.3 + 2.0 * (u(rng) + 1.0);
    const double length_m = 0.5 + 5.0 * (u(rng) + 1.0);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.rotate(Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized()));
    const Eigen::Vector3d out = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    // From where it touches nothing, in towards the load to a random gap of a few centimetres either side.
    double offset_m = load_size_m.norm() + radius_m + length_m;
    const auto silo_at = [&](double o) {
      Eigen::Isometry3d p = pose;
      p.translation() = body.world_from_body.translation() + o * out;
      return p;
    };
    const auto cylinder = std::make_shared<fcl::Cylinderd>(radius_m, length_m);
    fcl::DistanceRequestd request;
    fcl::DistanceResultd result;
    for (int k = 0; k < 8; ++k) {
      const Object trial(cylinder, silo_at(offset_m));
      result.clear();
      fcl::distance(&larger, &trial, request, result);
      if (result.min_distance <= 0.0) break;
      offset_m -= result.min_distance;
    }
    offset_m += 0.05 * u(rng);
    const Object reference(cylinder, silo_at(offset_m));
    const bool deep = reference_collide(smaller, reference);
    const bool near = reference_collide(larger, reference);
    if (deep != near) continue;  // within a millimetre of touching
    world.set_dynamic_part_size(0, 0, Eigen::Vector3d(2.0 * radius_m, 2.0 * radius_m, length_m));
    world.set_dynamic_pose(0, silo_at(offset_m));
    Contact contact;
    const bool hit = world.hits_dynamic(q, &contact);
    if (hit && contact.body != load) continue;  // another body reached it first: not this pair's answer
    CAPTURE(n, radius_m, length_m, offset_m);
    REQUIRE(hit == deep);
    ++(hit ? hits : misses);
  }
  CHECK(hits > 300);
  CHECK(misses > 300);
}
