// SPDX-License-Identifier: Apache-2.0
// Injected faults: the parser, and what each fault looks like to the controller's Hal.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
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

//! The crane's joints as the machine file gives them: two revolute, two prismatic.
std::vector<planning::JointSpec> crane_joint_specs() {
  std::vector<planning::JointSpec> specs(kCraneJoints.size());
  for (std::size_t j = 0; j < specs.size(); ++j) {
    specs[j].name = kCraneJoints[j];
    specs[j].type = j < 2 ? planning::JointType::Revolute : planning::JointType::Prismatic;
  }
  return specs;
}

std::string machine_parse_error(const std::string& text) {
  try {
    (void)sim::parse_machine_fault(text, crane_joint_specs());
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

TEST_CASE("the cut-off and encoder-offset faults parse, offsets in the joint's unit", "[sim][faults]") {
  const std::vector<planning::JointSpec> joints = crane_joint_specs();
  constexpr double kDeg = std::numbers::pi / 180.0;

  const sim::Fault swing = sim::parse_machine_fault("encoder-offset:swing@4,offset=-20", joints);
  CHECK(swing.kind == FaultKind::EncoderOffset);
  CHECK(swing.target.kind == FaultTarget::Kind::Joint);
  CHECK(swing.target.index == 0);
  CHECK(swing.start_s == 4.0);
  CHECK(std::isinf(swing.duration_s));
  CHECK(swing.offset == Approx(-20.0 * kDeg));
  CHECK(swing.offset_rate == 0.0);

  const sim::Fault elevation = sim::parse_machine_fault("encoder-offset:boom_elevation@4+2,rate=0.5,offset=1.5", joints);
  CHECK(elevation.target.index == 1);
  CHECK(elevation.duration_s == 2.0);
  CHECK(elevation.offset == Approx(1.5 * kDeg));
  CHECK(elevation.offset_rate == Approx(0.5 * kDeg));

  // Prismatic: metres as given.
  const sim::Fault length = sim::parse_machine_fault("encoder-offset:boom_length,rate=-0.25", joints);
  CHECK(length.target.index == 2);
  CHECK(length.start_s == 0.0);
  CHECK(length.offset == 0.0);
  CHECK(length.offset_rate == -0.25);
  CHECK(sim::parse_machine_fault("encoder-offset:cable_length,offset=0.3", joints).offset == 0.3);

  const sim::Fault fail = sim::parse_machine_fault("cutoff-fail@7+1", joints);
  CHECK(fail.kind == FaultKind::CutoffFail);
  CHECK(fail.target.kind == FaultTarget::Kind::None);
  CHECK(fail.start_s == 7.0);
  CHECK(fail.duration_s == 1.0);
  CHECK(sim::parse_fault("cutoff-fail", kCraneJoints).kind == FaultKind::CutoffFail);

  const sim::Fault lost = sim::parse_fault("heartbeat-lost:cutoff@2", kCraneJoints);
  CHECK(lost.kind == FaultKind::HeartbeatLost);
  CHECK(lost.target.kind == FaultTarget::Kind::Cutoff);
  CHECK(lost.target.index == -1);
  CHECK(sim::parse_machine_fault("heartbeat-lost:cutoff", joints).target.kind == FaultTarget::Kind::Cutoff);
  // The machine's joints change nothing for the other kinds.
  const sim::Fault stuck = sim::parse_machine_fault("encoder-stuck:boom_length@3", joints);
  CHECK(stuck.target.index == 2);
  CHECK(stuck.offset == 0.0);

  CHECK(std::string(sim::to_string(FaultKind::EncoderOffset)) == "encoder-offset");
  CHECK(std::string(sim::to_string(FaultKind::CutoffFail)) == "cutoff-fail");
  CHECK_THAT(sim::fault_syntax(), Catch::Contains("encoder-offset:JOINT") && Catch::Contains("; cutoff-fail") &&
                                      Catch::Contains("heartbeat-lost:JOINT | uwb | valve | cutoff") &&
                                      Catch::Contains("[,offset=X][,rate=X]"));
}

TEST_CASE("bad cut-off and encoder-offset texts are refused with the part at fault", "[sim][faults]") {
  CHECK_THAT(machine_parse_error("encoder-offset:swing"),
             Catch::Contains("fault \"encoder-offset:swing\"") && Catch::Contains("needs offset=X or rate=X"));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,offset=0,rate=0"), Catch::Contains("not both zero"));
  CHECK_THAT(machine_parse_error("encoder-offset,offset=1"), Catch::Contains("encoder-offset needs a target JOINT"));
  CHECK_THAT(machine_parse_error("encoder-offset:cutoff,offset=1"),
             Catch::Contains("unknown target \"cutoff\"") && !Catch::Contains("uwb, valve"));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,offset=x"),
             Catch::Contains("offset: expected a number within +-1e6, got \"x\""));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,rate=2e6"), Catch::Contains("rate: expected a number within +-1e6"));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,rate=nan"), Catch::Contains("rate: expected a number"));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,offset="), Catch::Contains("offset: expected a number"));
  CHECK_THAT(machine_parse_error("encoder-offset:swing,sigma_m=2"),
             Catch::Contains("unknown option \"sigma_m=2\" for encoder-offset (offset=X, rate=X per s; deg or m)"));
  // offset and rate belong to encoder-offset alone.
  CHECK_THAT(machine_parse_error("encoder-stuck:swing,offset=2"),
             Catch::Contains("unknown option \"offset=2\" for encoder-stuck (none)"));
  CHECK_THAT(machine_parse_error("tag-noise:2,rate=1"), Catch::Contains("unknown option \"rate=1\" for tag-noise (sigma_m=M)"));
  CHECK_THAT(machine_parse_error("cutoff-fail,offset=1"), Catch::Contains("unknown option \"offset=1\" for cutoff-fail (none)"));
  CHECK_THAT(machine_parse_error("cutoff-fail:valve"), Catch::Contains("cutoff-fail takes no target, got \"valve\""));
  // cutoff is a heartbeat-lost target only, named in that kind's list of targets.
  CHECK_THAT(machine_parse_error("encoder-stuck:cutoff"), Catch::Contains("unknown target \"cutoff\"") && !Catch::Contains("valve"));
  CHECK_THAT(machine_parse_error("heartbeat-lost:cut-off"),
             Catch::Contains("unknown target \"cut-off\"") && Catch::Contains("uwb, valve, cutoff"));
  // Without the machine's joints the unit of an offset is unknown: refused, never guessed.
  CHECK_THAT(parse_error("encoder-offset:swing,offset=2"),
             Catch::Contains("encoder-offset needs the machine's joints to know the unit of its values"));
  CHECK_THAT(parse_error("encoder-offset:boom_length@1,rate=0.1"), Catch::Contains("needs the machine's joints"));
  CHECK_FALSE(parse_error("encoder-offset:swing").empty());
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
