// SPDX-License-Identifier: Apache-2.0
// Injected faults: the parser, and what each fault looks like to the controller's Hal.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "mgc/hal/canopen.hpp"
#include "sim_rig.hpp"

using namespace mgc;
using hal::Health;
using sim::FaultKind;
using sim::FaultTarget;
using test::SimRig;

namespace {

const std::vector<std::string> kCraneJoints{"swing", "boom_elevation", "boom_length", "cable_length"};

sim::SimConfig with_fault(const std::string& text) {
  sim::SimConfig config = SimRig::quiet_config();
  config.faults.push_back(sim::parse_fault(text, kCraneJoints));
  return config;
}

std::string parse_error(const std::string& text) {
  try {
    (void)sim::parse_fault(text, kCraneJoints);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("fault texts parse into kind, target, window and options", "[sim][faults]") {
  const sim::Fault stuck = sim::parse_fault("encoder-stuck:boom_elevation@20+5", kCraneJoints);
  CHECK(stuck.kind == FaultKind::EncoderStuck);
  CHECK(stuck.target.kind == FaultTarget::Kind::Joint);
  CHECK(stuck.target.index == 1);
  CHECK(stuck.start_s == 20.0);
  CHECK(stuck.duration_s == 5.0);
  CHECK(stuck.active(20.0));
  CHECK(stuck.active(24.999));
  CHECK_FALSE(stuck.active(25.0));
  CHECK_FALSE(stuck.active(19.999));

  const sim::Fault noise = sim::parse_fault("tag-noise:2@10,sigma_m=3", kCraneJoints);
  CHECK(noise.kind == FaultKind::TagNoise);
  CHECK(noise.target.index == 2);
  CHECK(noise.sigma_m == 3.0);
  CHECK(std::isinf(noise.duration_s));

  const sim::Fault hb = sim::parse_fault("heartbeat-lost:valve", kCraneJoints);
  CHECK(hb.target.kind == FaultTarget::Kind::Valve);
  CHECK(hb.start_s == 0.0);
  CHECK(sim::parse_fault("frame-delay@1+2,delay_ms=80", kCraneJoints).delay_ms == 80.0);
  CHECK(sim::parse_fault("bus-off@3+0.5", kCraneJoints).kind == FaultKind::BusOff);
}

TEST_CASE("bad fault texts are refused with the part at fault", "[sim][faults]") {
  CHECK_THAT(parse_error("encoder-melt:swing"), Catch::Contains("unknown kind \"encoder-melt\""));
  CHECK_THAT(parse_error("encoder-stuck"), Catch::Contains("needs a target JOINT"));
  CHECK_THAT(parse_error("encoder-stuck:jib"), Catch::Contains("unknown target \"jib\"") &&
                                                   Catch::Contains("swing, boom_elevation, boom_length, cable_length"));
  CHECK_THAT(parse_error("bus-off:swing"), Catch::Contains("takes no target"));
  CHECK_THAT(parse_error("uwb-silent@x"), Catch::Contains("start time: expected a number >= 0, got \"x\""));
  CHECK_THAT(parse_error("uwb-silent@1+-2"), Catch::Contains("duration"));
  CHECK_THAT(parse_error("tag-noise:300"), Catch::Contains("tag id"));
  CHECK_THAT(parse_error("uwb-silent,sigma_m=2"), Catch::Contains("unknown option"));
}

TEST_CASE("encoder dropout: the joint goes stale within the stale limit, the others stay valid", "[sim][faults]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("encoder-dropout:boom_length@1"));
  rig.start();
  REQUIRE(rig.last->all_joints_valid());
  // The fault begins 1 s after the simulator's start; find when the Hal flags it.
  std::int64_t stale_at = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    if (stale_at == 0 && s.joints[2].health == Health::Stale) stale_at = s.t_us;
  };
  rig.run(1'500'000);
  REQUIRE(stale_at != 0);
  const std::int64_t fault_at = SimRig::at_sim_s(1.0);
  CHECK(stale_at - fault_at <= rig.hal->plan().timing.encoder_stale_after_us + SimRig::kCycleUs);
  CHECK_FALSE(rig.last->joints[2].valid);
  CHECK(rig.last->encoders[2].health == Health::Alive);  // the node itself still beats
  CHECK(rig.last->joints[0].valid);
  CHECK(rig.last->joints[1].valid);
  CHECK(rig.last->joints[3].valid);
}

TEST_CASE("a stuck encoder keeps reporting one value while the joint moves", "[sim][faults]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("encoder-stuck:swing@1"));
  rig.start();
  rig.command[0] = rig.scenario.machine.joints[0].max_velocity;
  rig.run(2'000'000);
  const double reported = rig.last->joints[0].position;
  rig.run(500'000);
  CHECK(rig.last->joints[0].position == reported);
  CHECK(rig.last->joints[0].valid);  // the encoder cannot know: the controller must compare with the valve
  CHECK(rig.last->valve_applied_fraction[0] > 0.9);
  CHECK(rig.sim->truth().position[0] > reported + 0.01);
}

TEST_CASE("a node's lost heartbeat makes it Missing after the consumer timeout", "[sim][faults]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("heartbeat-lost:cable_length@1"));
  rig.start();
  std::int64_t missing_at = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    if (missing_at == 0 && s.encoders[3].health == Health::Missing) missing_at = s.t_us;
  };
  rig.run(1'500'000);
  REQUIRE(missing_at != 0);
  const std::int64_t fault_at = SimRig::at_sim_s(1.0);
  const hal::BusTiming& timing = rig.hal->plan().timing;
  CHECK(missing_at - fault_at <= timing.device_heartbeat_timeout_us + SimRig::kCycleUs);
  CHECK(missing_at - fault_at >= timing.device_heartbeat_timeout_us - timing.device_heartbeat_period_us);
  CHECK(rig.last->joints[3].health == Health::Missing);
  CHECK_FALSE(rig.last->joints[3].valid);
}

TEST_CASE("UWB silence: every tag goes invalid after the tag stale limit", "[sim][faults][uwb]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("uwb-silent@2"));
  rig.start();
  rig.run(1'500'000);  // 1.75 s
  REQUIRE(rig.last->num_tags == 3);
  for (std::size_t i = 0; i < rig.last->num_tags; ++i) CHECK(rig.last->tags[i].valid);
  // The last fixes were made before 2 s and arrived 50 ms later; 500 ms on they are stale.
  rig.run(850'000);  // 2.6 s
  for (std::size_t i = 0; i < rig.last->num_tags; ++i) CHECK_FALSE(rig.last->tags[i].valid);
  CHECK(rig.last->uwb_gateway.health == Health::Alive);
}

TEST_CASE("a noisy tag reports errors far beyond its quality", "[sim][faults][uwb]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("tag-noise:2,sigma_m=3"));
  rig.start();
  double worst_2 = 0.0;
  double worst_1 = 0.0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    for (const sim::SimTag& tag : rig.sim->tags()) {
      const hal::TagReading* r = s.find_tag(tag.tag_id);
      if (r == nullptr || !r->updated) continue;
      const Eigen::Vector3d truth = rig.sim->tag_position(tag);
      const double e = (Eigen::Vector3d(r->position_m[0], r->position_m[1], r->position_m[2]) - truth).norm();
      (tag.tag_id == 2 ? worst_2 : worst_1) = std::max(tag.tag_id == 2 ? worst_2 : worst_1, e);
    }
  };
  rig.run(3'000'000);
  CHECK(worst_2 > 3.0);
  CHECK(worst_1 < 0.01);
  CHECK(rig.last->find_tag(2)->sigma_m == Approx(0.1));  // the gateway does not know
}

TEST_CASE("delayed frames: a gap as the delay begins, then data that looks fresh but lags", "[sim][faults]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("frame-delay@1+2,delay_ms=80"));
  rig.start();
  rig.command[0] = rig.scenario.machine.joints[0].max_velocity;
  bool went_stale = false;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    if (s.t_us > SimRig::at_sim_s(1.0) && s.t_us < SimRig::at_sim_s(1.1) && s.joints[0].health == Health::Stale) {
      went_stale = true;
    }
  };
  rig.run(1'500'000);  // 1.75 s
  CHECK(went_stale);
  // Frames arrive every cycle again, so the Hal cannot tell (the PDO carries no SYNC counter);
  // the positions lag the truth by the delay, which the controller must catch by other means.
  CHECK(rig.last->joints[0].valid);
  const double speed = rig.sim->truth().velocity[0];
  REQUIRE(speed > 0.0);
  const double lag_s = (rig.sim->truth().position[0] - rig.last->joints[0].position) / speed;
  CHECK(lag_s > 0.08);
  CHECK(lag_s < 0.08 + 0.021);
}

TEST_CASE("bus-off: the controller's endpoint reports it, the valve blocks, NMT start recovers", "[sim][faults][failsafe]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("bus-off@1.5+0.5"));
  rig.start();
  rig.command[0] = rig.scenario.machine.joints[0].max_velocity;
  rig.run(1'500'000);  // 1.75 s
  CHECK(rig.last->bus_state == hal::BusState::BusOff);
  CHECK_FALSE(rig.last->all_joints_valid());
  CHECK(rig.sim->truth().valve_state == hal::pdo::ValveState::FailSafe);
  CHECK(rig.sim->truth().spool[0] == 0.0);
  rig.run(500'000);  // 2.25 s: restarted
  CHECK(rig.last->bus_state == hal::BusState::ErrorActive);
  CHECK(rig.last->all_joints_valid());
  CHECK(rig.sim->truth().valve_state == hal::pdo::ValveState::FailSafe);  // until a new start
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0) == hal::Status::Ok);
  rig.run(300'000);
  CHECK(rig.sim->truth().valve_state == hal::pdo::ValveState::Active);
  CHECK(rig.sim->truth().spool[0] > 0.9);
}

TEST_CASE("a valve that ignores commands keeps applying the last one, and says so", "[sim][faults]") {
  SimRig rig("thesis-steel-frame.yaml", with_fault("valve-ignore@1.5"));
  rig.start();
  rig.command[1] = 0.5 * rig.scenario.machine.joints[1].max_velocity;
  rig.run(1'500'000);  // 1.75 s; the fault began at 1.5 s with the command in force
  rig.command[1] = 0.0;
  rig.run(500'000);
  CHECK(rig.last->valve_applied_fraction[1] == Approx(0.5).margin(1e-3));
  CHECK(rig.sim->truth().spool[1] == Approx(0.5).margin(1e-3));
  CHECK(rig.last->valve_active());  // its status claims all is well
  CHECK(rig.sim->counters().commands_ignored > 40);
}
