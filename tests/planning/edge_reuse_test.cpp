// SPDX-License-Identifier: Apache-2.0
// CollisionWorld reuses a body's results while its pose is unchanged (along a one-joint edge the
// bodies upstream of the joint stay put). Here that gives, edge for edge, the verdict a brute-force
// full validate() of every sample gives, with the dynamic obstacle moved between calls.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/problem.hpp"
#include "mgc/planning/random.hpp"
#include "mgc/planning/scenario.hpp"
#include "joint_bits.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::same_bits;
using mgc::test::kDeg;

namespace {

//! validate_edge's contract done the slow way: its samples (the count its header gives), each by
//! a full validate() on a world that reuses nothing.
Validity brute_force_edge(CollisionWorld& world, const JointVector& from, const JointVector& to,
                          const JointVector& max_step, JointVector& at) {
  const MachineModel& model = world.model();
  const JointVector delta = model.difference(from, to);
  int steps = std::max(1, model.edge_min_samples(from, to));
  double travel_m = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    steps = std::max(steps, static_cast<int>(std::ceil(std::abs(delta[i]) / max_step[i] - 1e-12)));
    travel_m += model.edge_displacement_bound(from, to, i) * std::abs(delta[i]);
  }
  if (world.dilation_m() > 0.0) steps = std::max(steps, static_cast<int>(std::ceil(travel_m / world.dilation_m() - 1e-12)));
  for (int k = 1; k <= steps; ++k) {
    const JointVector q = k == steps ? to : model.interpolate(from, to, static_cast<double>(k) / steps);
    const Validity v = world.validate(q);
    if (!v.valid()) {
      at = q;
      return v;
    }
  }
  // Samples all valid: the model's constraints between them, as validate_edge() defines it.
  double t_first = 1.0;
  Validity v;
  v.constraint = model.check_edge_constraints(from, to, t_first);
  if (!v.constraint.ok()) {
    v.status = Validity::Status::Constraint;
    at = model.interpolate(from, to, t_first);
  }
  return v;
}

struct Tally {
  int valid = 0;
  int out_of_range = 0;
  int constraint = 0;
  int fixed_static = 0;   // a body the one-joint edge does not move hits the site
  int moving_static = 0;
  int dynamic = 0;
  int self = 0;
  int single_joint = 0;
  int multi_joint = 0;
};

}  // namespace

TEST_CASE("edge checks that reuse unmoved bodies give the brute-force verdict with a moving dynamic obstacle",
          "[unit][oracle]") {
  const auto path = mgc::test::source_path("scenarios/thesis-steel-frame.yaml");
  io::LoadedScenario fast = io::load_and_build(path);
  io::LoadedScenario slow = io::load_and_build(path);
  CollisionWorld& world = *fast.world;
  CollisionWorld& reference = *slow.world;
  reference.reuse_results(false);
  // Reuse alone here; certification has its own oracle (edge_certify_test.cpp).
  world.certify_edges(false);
  reference.certify_edges(false);
  REQUIRE(world.reuses_results());
  REQUIRE(world.num_dynamic() == 1);
  const MachineModel& model = *fast.model;
  const PlanningProblem problem = planning_problem(fast.scenario, model, world);
  const JointVector& step = problem.step;
  const int dof = model.dof();

  Random random(20261123);
  Tally tally;
  const auto move_crane_2 = [&] {
    // Anywhere west of our crane, close enough that its boom and load reach ours.
    const Eigen::Isometry3d pose = Eigen::Translation3d(random.uniform(-32.0, -8.0), random.uniform(-16.0, 16.0), 0.0) *
                                   Eigen::AngleAxisd(random.uniform(-180.0, 180.0) * kDeg, Eigen::Vector3d::UnitZ());
    world.set_dynamic_pose(0, pose);
    reference.set_dynamic_pose(0, pose);
  };
  const auto random_configuration = [&] {
    // Mostly within the load chart (most of the joint box is not), so that collisions decide.
    JointVector q = uniform_sample(model, random);
    const bool within_chart = random.uniform() < 0.85;
    for (int tries = 0; within_chart && tries < 1000 && !model.check_constraints(q).ok(); ++tries) {
      q = uniform_sample(model, random);
    }
    // Now and then a little outside a joint's range, which validate() must catch per sample.
    if (random.uniform() < 0.05) {
      const int j = static_cast<int>(random.uniform() * dof) % dof;
      const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
      if (!spec.continuous) q[j] = random.uniform() < 0.5 ? spec.position_min - 0.01 : spec.position_max + 0.01;
    }
    return q;
  };

  // The mobile crane's bodies: carrier, superstructure, boom, cable, load, sling. The first one
  // each joint (swing, elevation, boom length, cable length) moves; those before it stay put.
  REQUIRE(dof == 4);
  REQUIRE(model.bodies().size() == 6);
  constexpr std::array<int, 4> kFirstMoved = {1, 2, 2, 3};
  constexpr int kEdges = 3000;
  for (int e = 0; e < kEdges; ++e) {
    if (random.uniform() < 0.5) move_crane_2();
    const JointVector from = random_configuration();  // not validated: it may well be invalid
    JointVector to = from;
    const bool single = random.uniform() < 0.7;
    int j = -1;
    if (single) {
      // One joint, up to 40 steps either way (the swing across +-180 deg now and then).
      j = static_cast<int>(random.uniform() * dof) % dof;
      to[j] += random.uniform(-40.0, 40.0) * step[j];
      if (model.joints()[static_cast<std::size_t>(j)].continuous) to[j] = wrap_angle(to[j]);
      ++tally.single_joint;
    } else {
      for (int i = 0; i < dof; ++i) to[i] += random.uniform(-20.0, 20.0) * step[i];
      if (random.uniform() < 0.3) to = random_configuration();
      for (int i = 0; i < dof; ++i) {
        if (model.joints()[static_cast<std::size_t>(i)].continuous) to[i] = wrap_angle(to[i]);
      }
      ++tally.multi_joint;
    }
    // The same edge twice, the dynamic obstacle moved in between half the time, and plain
    // validate() calls in between that pose the machine elsewhere.
    for (int pass = 0; pass < 2; ++pass) {
      if (pass == 1 && random.uniform() < 0.5) move_crane_2();
      if (random.uniform() < 0.3) {
        const JointVector q = random_configuration();
        const Validity a = world.validate(q);
        const Validity b = reference.validate(q);
        REQUIRE(a.status == b.status);
        REQUIRE(a.contact.with == b.contact.with);
        REQUIRE(a.contact.body == b.contact.body);
        REQUIRE(a.contact.other == b.contact.other);
      }
      JointVector at_fast = JointVector::Zero(dof);
      JointVector at_slow = JointVector::Zero(dof);
      const Validity v = world.validate_edge(from, to, step, &at_fast);
      const Validity r = brute_force_edge(reference, from, to, step, at_slow);
      INFO("edge " << e << " pass " << pass << ": from " << from.transpose() << " to " << to.transpose() << ": "
                   << world.describe(v) << " against " << reference.describe(r));
      REQUIRE(v.status == r.status);
      REQUIRE(v.joint == r.joint);
      REQUIRE(v.constraint.status == r.constraint.status);
      REQUIRE(v.contact.with == r.contact.with);
      REQUIRE(v.contact.body == r.contact.body);
      REQUIRE(v.contact.other == r.contact.other);
      if (!r.valid()) REQUIRE(same_bits(at_fast, at_slow));
      switch (r.status) {
        case Validity::Status::Valid: ++tally.valid; break;
        case Validity::Status::JointOutOfRange: ++tally.out_of_range; break;
        case Validity::Status::Constraint: ++tally.constraint; break;
        case Validity::Status::Rule: FAIL("these worlds have no configuration rule"); break;
        case Validity::Status::Collision:
          if (r.contact.with == Contact::With::Dynamic) {
            ++tally.dynamic;
          } else if (r.contact.with == Contact::With::Self) {
            ++tally.self;
          } else if (single && r.contact.body < kFirstMoved[static_cast<std::size_t>(j)]) {
            ++tally.fixed_static;
          } else {
            ++tally.moving_static;
          }
          break;
      }
    }
  }
  // The draw covers every kind of verdict, and the reuse saved checks.
  CAPTURE(tally.valid, tally.out_of_range, tally.constraint, tally.fixed_static, tally.moving_static, tally.dynamic,
          tally.self, tally.single_joint, tally.multi_joint);
  CHECK(tally.valid > 50);
  CHECK(tally.out_of_range > 10);
  CHECK(tally.constraint > 50);
  CHECK(tally.moving_static > 50);
  CHECK(tally.fixed_static > 10);
  CHECK(tally.dynamic > 10);
  CHECK(world.collision_checks() == reference.collision_checks());
  CHECK(world.body_checks() < reference.body_checks());
}
