// SPDX-License-Identifier: Apache-2.0
// The controller's cycle allocates nothing after construction: a whole lift through planning,
// execution, a safety stop, waiting for the intruder, the re-plan and the goal, FCL queries and
// the guidance snapshot included; and the working envelope's limiter, stop-check sweep and planning
// rule, under a ceiling close above the boom tip; and the check of a tag on the boom tip.
#include <catch2/catch.hpp>

#include <memory>
#include <string>

#include "../sim/sim_rig.hpp"
#include "allocation_counter.hpp"
#include "mgc/firmware/controller.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_rig.hpp"
#include "site_member_support.hpp"

using namespace mgc;
using test::SimRig;

namespace {

struct Counts {
  long cycles = 0;
  long allocations = 0;  //!< made inside Controller::step
  long tracked_pose_cycles = 0;  //!< snapshots carrying a current tracked obstacle pose
};
using Counted = std::shared_ptr<Counts>;

//! The rig's cycle: the scenario's goal requested once in HOLD, the commands written, and the
//! allocations inside each step() counted.
Counted drive(SimRig& rig, firmware::Controller& controller) {
  auto counts = std::make_shared<Counts>();
  auto goal_sent = std::make_shared<bool>(false);
  rig.on_cycle = [&rig, &controller, counts, goal_sent](const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!*goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) {
      commands.goal_request = true;
      *goal_sent = true;
    }
    const long before = test::allocation_count();
    const firmware::ControllerOutput out = controller.step(s, SimRig::kCycleUs, commands, false);
    counts->allocations += test::allocation_count() - before;
    ++counts->cycles;
    const firmware::GuidanceSnapshot& snap = controller.snapshot();
    if (snap.num_obstacles > 0 && snap.obstacles[0].valid) ++counts->tracked_pose_cycles;
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
  };
  return counts;
}

}  // namespace

TEST_CASE("the controller's cycle does not allocate through a plan, a stop, a re-plan and the goal", "[firmware][sim][alloc]") {
  sim::SimConfig config = SimRig::quiet_config();
  config.scenario_time_offset_s = 40.0;  // crane 2 swings into the lift (controller_test.cpp)
  // A tag on the boom tip: the machine tag check judges every fix.
  SimRig rig("thesis-steel-frame.yaml", config, "ctl-alloc", [](planning::Scenario& s) {
    planning::MachineTagSpec tag;
    tag.id = 200;
    tag.body = "boom_tip";
    s.machine_tags.push_back(tag);
  });
  rig.calibrate_valves();
  planning::Scenario scenario = rig.scenario;
  const auto model = planning::build_model(scenario);
  planning::Kinematics k;
  model->forward_kinematics(scenario.start, k);
  planning::EnvelopeSpec ceiling;
  ceiling.points = {"boom_tip", "hook"};
  ceiling.height_ceiling_m = k.points[1].z() + 1.5;  // key point 1: boom_tip
  ceiling.walls.push_back({Eigen::Vector3d::UnitY(), -60.0});
  scenario.envelope = ceiling;
  firmware::Controller controller(scenario, firmware::ControllerConfig{});
  const Counted counted = drive(rig, controller);
  // The repaired path runs under the ceiling's slowdown band: some 210 s to the goal.
  while (controller.stats().goals_reached == 0 && rig.t_us < SimRig::at_sim_s(800.0)) rig.run(10'000'000);
  const firmware::ControllerStats& st = controller.stats();
  CAPTURE(counted->cycles, st.plans, st.replans, st.safety_stops, st.goals_reached, st.envelope_cut_cycles);
  REQUIRE(st.plans == 1);
  REQUIRE(st.safety_stops >= 1);
  REQUIRE(st.replans >= 1);
  REQUIRE(st.goals_reached == 1);
  REQUIRE(st.envelope_cut_cycles > 0);
  REQUIRE(st.machine_tag_fixes_judged > 1000);
  CHECK(counted->cycles > 15'000);
  CHECK(counted->tracked_pose_cycles > 10'000);  // the snapshot's obstacle poses were filled
  CHECK(counted->allocations == 0);
}

TEST_CASE("the controller's cycle does not allocate through a retreat and an escape", "[firmware][sim][alloc]") {
  // 20.4 s ahead crane 2 parks so near the stopped crane that only a retreat gets it out
  // (controller_test.cpp): the retreat search, the escape plan with its larger cap, and the
  // escape followed under the retreat floor.
  sim::SimConfig config = SimRig::quiet_config();
  config.scenario_time_offset_s = 20.4;
  SimRig rig("thesis-steel-frame.yaml", config, "ctl-alloc-retreat");
  rig.calibrate_valves();
  // The thesis's DRRT takes the west route, where crane 2 parks (controller_test.cpp).
  firmware::ControllerConfig controller_config;
  controller_config.replanner = "drrt";
  firmware::Controller controller(rig.scenario, controller_config);
  const Counted counted = drive(rig, controller);
  while (controller.stats().goals_reached == 0 && rig.t_us < SimRig::at_sim_s(800.0)) rig.run(10'000'000);
  const firmware::ControllerStats& st = controller.stats();
  CAPTURE(st.safety_stops, st.escapes, st.retreats, st.retreat_cycles, st.goals_reached);
  REQUIRE(st.retreats >= 1);
  REQUIRE(st.approach_warnings >= 1);  // crane 2 swings at the stopped crane: the approach scan ran
  REQUIRE(st.retreat_cycles > 0);
  REQUIRE(st.goals_reached == 1);
  CHECK(counted->allocations == 0);
}

TEST_CASE("a site member's cycle does not allocate: the rules, the meet scan, the peers posed, its messages", "[firmware][sim][alloc][site]") {
  // The crossing lifts of the site rig's tests: the lower-priority machine stops for the higher
  // one, re-plans round its plan and waits; both produce their site messages every cycle.
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 0.0};
  config.allocation_count = [] { return test::allocation_count(); };
  sim::SiteRig rig(planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/crossing-cranes.yaml"), config, "site-alloc");
  rig.run_until(200.0, true);
  for (const sim::SiteRigMember& m : rig.members()) {
    const firmware::ControllerStats& st = m.controller->stats();
    CAPTURE(m.machine_id, m.cycles, st.goals_reached, st.site_stop_cycles, st.replans, st.site_plans_published);
    REQUIRE(st.goals_reached == 1);
    CHECK(m.cycles > 5'000);
    CHECK(m.step_allocations == 0);
  }
  REQUIRE(rig.member(1).controller->stats().site_stop_cycles > 0);
  REQUIRE(rig.member(1).controller->stats().replans >= 1);
}

TEST_CASE("a site member posing a stale machine from its UWB tags does not allocate: the fit, its scan, its worlds", "[firmware][sim][alloc][site]") {
  // The tower crane of the crossing lifts with the site's tags on it, its messages stopped 1 s in
  // while it lifts on: the TMS870 fits it from its tags every cycle and poses it from them.
  const planning::Site site = test::tagged_crossing_site();
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 0.0};
  config.uwb = sim::UwbParams{};
  config.allocation_count = [] { return test::allocation_count(); };
  sim::SiteRig rig(site, config, "site-tags-alloc");
  rig.run_until(1.0);
  rig.mute(2);
  rig.run_until(200.0, true);
  const sim::SiteRigMember& lower = rig.member(1);
  const firmware::ControllerStats& st = lower.controller->stats();
  CAPTURE(st.goals_reached, st.site_tag_cycles, st.site_stop_cycles);
  REQUIRE(st.goals_reached == 1);
  REQUIRE(st.site_tag_cycles > 5'000);
  REQUIRE(st.site_stop_cycles > 0);
  CHECK(lower.step_allocations == 0);
}
