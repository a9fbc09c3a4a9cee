// SPDX-License-Identifier: Apache-2.0
// CollisionWorld answers box, cylinder and capsule pairs by bounding and inscribed boxes before
// GJK, and gives every object the AABB of its rotated box. Both are exact shortcuts, so its answer
// must match an independent one: FCL's own collide() (libccd) on the same posed, dilated shapes.
#include <catch2/catch.hpp>

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/narrowphase/collision.h>

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
