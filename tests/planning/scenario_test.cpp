// SPDX-License-Identifier: Apache-2.0
// The shipped scenarios: they load, start and goal are feasible, and the straight joint-space line
// between them is blocked, so each one needs planning.
#include <catch2/catch.hpp>

#include "mgc/planning/io/scenario_loader.hpp"
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
