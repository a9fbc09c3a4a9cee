// SPDX-License-Identifier: Apache-2.0
// The retreat search (planning/retreat.hpp): a single-joint way out for a machine stopped too near
// an obstacle for any planner to start from, on the thesis site with crane-2 parked beside our load.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "allocation_counter.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/retreat.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

struct Site {
  io::LoadedScenario loaded = io::load_and_build(mgc::test::source_path("scenarios/thesis-steel-frame.yaml").string());
  //! The escape planner's world: 0.75 m more dilation.
  std::unique_ptr<CollisionWorld> escape;

  Site() {
    Scenario wider = loaded.scenario;
    wider.planner.dilation_m += 0.75;
    escape = build_world(wider, *loaded.model);
  }
  //! Crane-2's load `south_m` south of where ours hangs at swing 180 deg, in both worlds.
  void park_crane2(double south_m) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(-18.1 - 18.38, -south_m, 7.0 - 5.38);
    loaded.world->set_dynamic_pose(0, pose);
    escape->set_dynamic_pose(0, pose);
  }
  static JointVector stopped() {
    JointVector q(4);
    q << 180.0 * kDeg, 25.0 * kDeg, 20.0, 2.0;
    return q;
  }
};

RetreatSearch::Status run(RetreatSearch& search, const JointVector& q) {
  RetreatSearch::Status s = search.begin(q);
  for (int i = 0; i < 100000 && s == RetreatSearch::Status::Running; ++i) s = search.step(3);
  return s;
}

}  // namespace

TEST_CASE("retreat: one joint moves the stopped crane out of the escape margin without coming nearer", "[unit]") {
  Site site;
  site.park_crane2(2.45);
  const JointVector start = Site::stopped();
  const double start_m = site.loaded.world->clearance(start).distance_m;
  REQUIRE(start_m > 0.05);
  REQUIRE_FALSE(site.escape->validate(start).valid());

  const RetreatSettings settings;
  RetreatSearch search(*site.loaded.world, *site.escape, settings);
  const long before = mgc::test::allocation_count();
  const RetreatSearch::Status status = run(search, start);
  CHECK(mgc::test::allocation_count() - before == 0);
  REQUIRE(status == RetreatSearch::Status::Found);
  CHECK(search.start_clearance_m() == Approx(start_m));
  const JointVector& out = search.target();
  CHECK(site.escape->validate(out).valid());
  // One joint, the one named.
  const JointVector delta = site.loaded.model->difference(start, out);
  int moved = 0;
  for (int j = 0; j < 4; ++j) moved += delta[j] != 0.0 ? 1 : 0;
  CHECK(moved == 1);
  CHECK(delta[search.joint()] != 0.0);

  // Re-checked densely along the move: never more than the tolerance and half a step nearer.
  const int samples = 400;
  double least_m = 1e9;
  for (int i = 0; i <= samples; ++i) {
    least_m = std::min(least_m, site.loaded.world->clearance(site.loaded.model->interpolate(start, out, static_cast<double>(i) / samples)).distance_m);
  }
  CAPTURE(start_m, least_m, search.joint(), delta[search.joint()]);
  CHECK(least_m >= start_m - settings.tolerance_m - 0.5 * settings.step_m);

  // The same start gives the same way out.
  RetreatSearch again(*site.loaded.world, *site.escape, settings);
  REQUIRE(run(again, start) == RetreatSearch::Status::Found);
  CHECK(again.target() == out);
}

TEST_CASE("retreat: nothing is searched from contact, and a short reach finds nothing", "[unit]") {
  Site site;
  // Crane-2's load where ours hangs: contact.
  site.park_crane2(0.0);
  RetreatSearch search(*site.loaded.world, *site.escape, RetreatSettings{});
  CHECK(search.begin(Site::stopped()) == RetreatSearch::Status::InContact);
  CHECK(search.step(10) == RetreatSearch::Status::InContact);

  site.park_crane2(2.45);
  RetreatSettings short_reach;
  short_reach.max_travel_m = 0.1;
  RetreatSearch near(*site.loaded.world, *site.escape, short_reach);
  CHECK(run(near, Site::stopped()) == RetreatSearch::Status::NotFound);
}
