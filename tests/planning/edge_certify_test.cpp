// SPDX-License-Identifier: Apache-2.0
// CollisionWorld certifies edge samples collision free from clearance balls (certify_edges). Here
// that gives, edge for edge, the verdict of a world that certifies nothing and reuses nothing (and
// edge_valid(), coarse samples first, in a third world, the same yes or no), on
// every machine kind the balls apply to, with the dynamic obstacles moved between calls; and the
// balls go when an obstacle moves and stay when it is posed where it stands.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

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

namespace {

struct Tally {
  int valid = 0;
  int collision = 0;
  int dynamic = 0;
  int other = 0;  // joint range, constraint, rule
};

//! Edges as planners make them -- runs of short one-joint steps, each from where the last ended
//! (the balls' best case), and random one- and multi-joint edges -- checked by a certifying world
//! and by a reference that certifies and reuses nothing. Verdict, reason, contact and first invalid
//! sample must agree bit for bit.
//! `least`: the fewest edges of each verdict the draw must give, so that every kind is met, and
//! `certified_share` the least share of samples certified.
//! `predicted_poses` > 0: each dynamic obstacle stands in the worlds that many times more, as the
//! execution's prediction puts it (build_world); the copies are moved all to one pose (identical
//! twins) or each to its own.
void compare_with_reference(const std::string& scenario, int edges, std::uint64_t seed, double certified_share,
                            const Tally& least, int predicted_poses = 0) {
  const auto path = mgc::test::source_path("scenarios/" + scenario);
  io::LoadedScenario fast = io::load_and_build(path);
  io::LoadedScenario slow = io::load_and_build(path);
  io::LoadedScenario coarse = io::load_and_build(path);
  if (predicted_poses > 0) {
    fast.world = build_world(fast.scenario, *fast.model, 0.0, predicted_poses);
    slow.world = build_world(slow.scenario, *slow.model, 0.0, predicted_poses);
    coarse.world = build_world(coarse.scenario, *coarse.model, 0.0, predicted_poses);
  }
  CollisionWorld& world = *fast.world;
  CollisionWorld& reference = *slow.world;
  CollisionWorld& coarse_first = *coarse.world;
  int coarse_edges = 0;  // edges long enough for edge_valid() to stride through first
  reference.certify_edges(false);
  reference.reuse_results(false);
  REQUIRE(world.certifies_edges());
  REQUIRE_FALSE(reference.certifies_edges());
  const MachineModel& model = *fast.model;
  const PlanningProblem problem = planning_problem(fast.scenario, model, world);
  const JointVector& step = problem.step;
  const int dof = model.dof();
  const auto& dynamics = fast.scenario.dynamic_obstacles;

  Random random(seed);
  Tally tally;
  const auto move_dynamics = [&] {
    for (std::size_t d = 0; d < dynamics.size(); ++d) {
      // Somewhere along its script, or half the time anywhere within 25 m of the machine's base.
      Eigen::Isometry3d pose = dynamics[d].pose_at(random.uniform(0.0, dynamics[d].motion.back().t_s + 1.0));
      if (random.uniform() < 0.5) {
        const Eigen::Vector3d base_m = model.world_from_base().translation();
        pose = Eigen::Translation3d(base_m.x() + random.uniform(-25.0, 25.0), base_m.y() + random.uniform(-25.0, 25.0),
                                    pose.translation().z()) *
               Eigen::AngleAxisd(random.uniform(-3.14159, 3.14159), Eigen::Vector3d::UnitZ());
      }
      const bool twins = predicted_poses > 0 && random.uniform() < 0.5;
      for (int k = 0; k <= predicted_poses; ++k) {
        const int index = static_cast<int>(d) * (predicted_poses + 1) + k;
        if (k > 0 && !twins) pose = dynamics[d].pose_at(random.uniform(0.0, dynamics[d].motion.back().t_s + 1.0));
        world.set_dynamic_pose(index, pose);
        reference.set_dynamic_pose(index, pose);
        coarse_first.set_dynamic_pose(index, pose);
      }
    }
  };
  const auto random_configuration = [&] {
    JointVector q = uniform_sample(model, random);
    for (int tries = 0; tries < 1000 && !model.check_constraints(q).ok(); ++tries) q = uniform_sample(model, random);
    return q;
  };
  const auto check = [&](const JointVector& from, const JointVector& to) {
    JointVector at_fast = JointVector::Zero(dof);
    JointVector at_slow = JointVector::Zero(dof);
    const Validity v = world.validate_edge(from, to, step, &at_fast);
    const Validity r = reference.validate_edge(from, to, step, &at_slow);
    INFO(scenario << ": from " << from.transpose() << " to " << to.transpose() << ": " << world.describe(v)
                  << " against " << reference.describe(r));
    REQUIRE(v.status == r.status);
    REQUIRE(v.joint == r.joint);
    REQUIRE(v.constraint.status == r.constraint.status);
    REQUIRE(v.rule_limit == r.rule_limit);
    REQUIRE(v.contact.with == r.contact.with);
    REQUIRE(v.contact.body == r.contact.body);
    REQUIRE(v.contact.other == r.contact.other);
    if (!r.valid()) REQUIRE(same_bits(at_fast, at_slow));
    REQUIRE(coarse_first.edge_valid(from, to, step) == r.valid());
    // validate_edge's sample count, as its doc gives it: the larger of the steps and the dilation's.
    int steps = std::max(1, model.edge_min_samples(from, to));
    double travel_m = 0.0;
    const JointVector delta = model.difference(from, to);
    for (int i = 0; i < dof; ++i) {
      steps = std::max(steps, static_cast<int>(std::ceil(std::abs(delta[i]) / step[i] - 1e-12)));
      travel_m += model.edge_displacement_bound(from, to, i) * std::abs(delta[i]);
    }
    if (world.dilation_m() > 0.0) steps = std::max(steps, static_cast<int>(std::ceil(travel_m / world.dilation_m() - 1e-12)));
    if (steps >= 2 * CollisionWorld::kCoarseStride) ++coarse_edges;
    if (r.valid()) {
      ++tally.valid;
    } else if (r.status == Validity::Status::Collision) {
      ++tally.collision;
      if (r.contact.with == Contact::With::Dynamic) ++tally.dynamic;
    } else {
      ++tally.other;
    }
    return r.valid();
  };

  for (int e = 0; e < edges; ++e) {
    if (!dynamics.empty() && random.uniform() < 0.3) move_dynamics();
    const JointVector from = random_configuration();
    const double kind = random.uniform();
    if (kind < 0.5) {
      // A run along one joint, 1 to 5 steps at a time, until it is refused or has made 12 moves.
      const int j = static_cast<int>(random.uniform() * dof) % dof;
      const double sign = random.uniform() < 0.5 ? -1.0 : 1.0;
      JointVector q = from;
      for (int move = 0; move < 12; ++move) {
        JointVector next = q;
        next[j] += sign * random.uniform(1.0, 5.0) * step[j];
        if (model.joints()[static_cast<std::size_t>(j)].continuous) next[j] = wrap_angle(next[j]);
        if (!check(q, next)) break;
        q = next;
      }
    } else {
      JointVector to = from;
      if (kind < 0.75) {
        const int j = static_cast<int>(random.uniform() * dof) % dof;
        to[j] += random.uniform(-40.0, 40.0) * step[j];
      } else {
        for (int i = 0; i < dof; ++i) to[i] += random.uniform(-20.0, 20.0) * step[i];
      }
      for (int i = 0; i < dof; ++i) {
        if (model.joints()[static_cast<std::size_t>(i)].continuous) to[i] = wrap_angle(to[i]);
      }
      (void)check(from, to);
    }
  }
  // Certification did the work: a share of all samples went without a collision query.
  const double certified = static_cast<double>(world.certified_samples());
  const double checked = static_cast<double>(world.collision_checks());
  CAPTURE(scenario, tally.valid, tally.collision, tally.dynamic, tally.other, certified, checked,
          reference.collision_checks());
  CHECK(certified / (certified + checked) > certified_share);
  CHECK(world.collision_checks() + world.certified_samples() == reference.collision_checks());
  CHECK(tally.valid >= least.valid);
  CHECK(tally.collision >= least.collision);
  CHECK(tally.dynamic >= least.dynamic);
  CHECK(tally.other >= least.other);
  // Long edges, where edge_valid() checks out of order, are among them.
  CAPTURE(coarse_edges);
  CHECK(coarse_edges > edges / 10);
}

}  // namespace

// The least counts are a little under what these seeds give (in brackets: valid, collision,
// dynamic, other; share certified).
TEST_CASE("certified edge checks give the full check's verdict on the mobile crane site", "[unit][oracle]") {
  // (6610, 928, 259, 1482; 0.75)
  compare_with_reference("thesis-steel-frame.yaml", 3000, 20261202, 0.6, {5000, 700, 200, 1000});
}

TEST_CASE("certified edge checks give the full check's verdict on the tower crane site", "[unit][oracle]") {
  // (15263, 529, 258, 332; 0.92)
  compare_with_reference("thesis-steel-frame-tower.yaml", 3000, 20261203, 0.8, {12000, 400, 200, 250});
}

TEST_CASE("certified edge checks give the full check's verdict on the excavator sites", "[unit][oracle]") {
  // (9341, 1460, 0, 471; 0.23): no dynamic obstacle on the pipelines site.
  compare_with_reference("excavator-pipelines.yaml", 3000, 20261204, 0.15, {7000, 1100, 0, 350});
  // (9072, 1470, 80, 483; 0.23)
  compare_with_reference("excavator-truck.yaml", 3000, 20261205, 0.15, {7000, 1100, 60, 350});
}

TEST_CASE("certified edge checks give the full check's verdict with the prediction's copies", "[unit][oracle]") {
  // Three copies of each obstacle besides the present one, as the execution poses them.
  // (3468, 442, 115, 725; 0.87)
  compare_with_reference("thesis-steel-frame.yaml", 1500, 20261206, 0.7, {3000, 380, 90, 600}, 3);
  // (7728, 247, 132, 173; 0.92)
  compare_with_reference("thesis-steel-frame-tower.yaml", 1500, 20261207, 0.8, {6500, 200, 100, 140}, 3);
}

TEST_CASE("a clearance ball goes when a dynamic obstacle moves and stays when it is posed where it stands", "[unit]") {
  io::LoadedScenario loaded = io::load_and_build(mgc::test::source_path("scenarios/thesis-steel-frame.yaml"));
  CollisionWorld& world = *loaded.world;
  const MachineModel& model = *loaded.model;
  const PlanningProblem problem = planning_problem(loaded.scenario, model, world);
  REQUIRE(world.num_dynamic() == 1);
  // Crane 2 far away; a slew from the start, checked once so that balls cover it.
  world.set_dynamic_pose(0, Eigen::Isometry3d(Eigen::Translation3d(-500.0, 0.0, 0.0)));
  const JointVector from = loaded.scenario.start;
  JointVector to = from;
  to[0] = wrap_angle(to[0] + 20.0 * problem.step[0]);
  REQUIRE(world.validate_edge(from, to, problem.step).valid());
  const std::uint64_t certified = world.certified_samples();
  std::uint64_t checks = world.collision_checks();
  REQUIRE(world.validate_edge(from, to, problem.step).valid());
  REQUIRE(world.certified_samples() > certified);  // the second pass went through the balls
  REQUIRE(world.collision_checks() == checks);      // all of it

  // Posed again exactly where it stands, crane 2 has not moved: the balls stay.
  world.set_dynamic_pose(0, Eigen::Isometry3d(Eigen::Translation3d(-500.0, 0.0, 0.0)));
  checks = world.collision_checks();
  REQUIRE(world.validate_edge(from, to, problem.step).valid());
  CHECK(world.collision_checks() == checks);
  // A millimetre is a move: they go, and the first sample is checked in full again.
  world.set_dynamic_pose(0, Eigen::Isometry3d(Eigen::Translation3d(-500.001, 0.0, 0.0)));
  REQUIRE(world.validate_edge(from, to, problem.step).valid());
  CHECK(world.collision_checks() > checks);

  // Crane 2 moved until it stands in the edge's midpoint: the balls found without it must go.
  const JointVector middle = model.interpolate(from, to, 0.5);
  Kinematics k;
  model.forward_kinematics(middle, k);
  const auto load = static_cast<std::size_t>(model.body_index("load"));
  const Eigen::Vector3d load_m = k.bodies[load].world_from_body.translation();
  bool hit = false;
  for (double dx = -40.0; dx <= 40.0 && !hit; dx += 0.5) {
    for (double dy = -40.0; dy <= 40.0 && !hit; dy += 0.5) {
      world.set_dynamic_pose(0, Eigen::Isometry3d(Eigen::Translation3d(load_m.x() + dx, load_m.y() + dy, 0.0)));
      hit = world.hits_dynamic(middle);
    }
  }
  REQUIRE(hit);
  JointVector at;
  const Validity v = world.validate_edge(from, to, problem.step, &at);
  CHECK(v.status == Validity::Status::Collision);
  CHECK(v.contact.with == Contact::With::Dynamic);
}

TEST_CASE("the dual crane never certifies an edge: its displacement bound leaves out the girder's shift", "[unit]") {
  io::LoadedScenario loaded = io::load_and_build(mgc::test::source_path("scenarios/kim-s1.yaml"));
  CollisionWorld& world = *loaded.world;
  REQUIRE_FALSE(loaded.model->displacement_bound_is_strict());
  CHECK_FALSE(world.certifies_edges());
  const PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, world);
  Random random(7);
  for (int e = 0; e < 200; ++e) {
    const JointVector from = uniform_sample(*loaded.model, random);
    const JointVector to = uniform_sample(*loaded.model, random);
    (void)world.validate_edge(from, to, problem.step);
  }
  CHECK(world.certified_samples() == 0);
  CHECK(world.collision_checks() > 0);
}
