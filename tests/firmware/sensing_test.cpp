// SPDX-License-Identifier: Apache-2.0
// The supervisor on the bus (issue 7): the Hal's snapshot mapped onto the supervisor's sensing
// inputs, against the simulated crane of the thesis site. Start-up reaches HOLD; every loss of
// sensing the simulator can inject ends in FAULT with its own reason, within the Hal's detection
// time and a cycle or two.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "../sim/sim_rig.hpp"
#include "mgc/firmware/sensing.hpp"

using namespace mgc;
using guidance::DeviceHealth;
using guidance::SupervisorState;
using guidance::TransitionReason;
using guidance::ValveHealth;
using test::SimRig;

namespace {

std::vector<std::string> joint_names(const planning::Scenario& s) {
  std::vector<std::string> names;
  for (const auto& j : s.machine.joints) names.push_back(j.name);
  return names;
}

//! The rig with a supervisor fed from the Hal every cycle; NMT start when it asks.
struct SupervisedRig {
  SimRig rig;
  guidance::Supervisor supervisor;
  guidance::SupervisorOutput out{};
  std::int64_t fault_at_us = -1;

  explicit SupervisedRig(sim::SimConfig config)
      : rig("thesis-steel-frame.yaml", std::move(config)), supervisor(supervisor_config(rig)) {
    rig.on_cycle = [this](const hal::SensorSnapshot& s) {
      guidance::SupervisorInputs in;
      in.now_us = s.t_us;
      in.sensing = firmware::sensing_inputs(s);
      in.progress.at_rest = true;
      in.progress.command_at_rest = true;
      out = supervisor.update(in);
      if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
      if (out.state == SupervisorState::Fault && fault_at_us < 0) fault_at_us = s.t_us;
    };
  }
  static guidance::SupervisorConfig supervisor_config(const SimRig& rig) {
    guidance::SupervisorConfig c;
    c.num_joints = static_cast<int>(rig.scenario.machine.joints.size());
    return c;
  }
};

}  // namespace

TEST_CASE("sensing inputs: an empty snapshot is all missing, never healthy", "[unit]") {
  hal::SensorSnapshot s;
  s.num_joints = 4;
  const guidance::SensingInputs in = firmware::sensing_inputs(s);
  for (std::size_t j = 0; j < in.joint.size(); ++j) CHECK(in.joint[j] == DeviceHealth::Missing);
  CHECK(in.valve == ValveHealth::Missing);
  CHECK(in.uwb_gateway == DeviceHealth::Missing);
  CHECK(in.uwb_last_fix_us == 0);
  CHECK_FALSE(in.bus_off);
}

TEST_CASE("sensing inputs: each Hal health and valve state maps as docs/supervisor.md says", "[unit]") {
  hal::SensorSnapshot s;
  s.num_joints = 4;
  s.joints[0].health = hal::Health::Alive;
  s.joints[1].health = hal::Health::Stale;
  s.joints[2].health = hal::Health::Faulted;
  s.joints[3].health = hal::Health::Missing;
  s.bus_state = hal::BusState::BusOff;
  s.uwb_gateway.health = hal::Health::Alive;
  s.num_tags = 2;
  s.tags[0].fixes = 3;
  s.tags[0].t_us = 500;
  s.tags[1].fixes = 1;
  s.tags[1].t_us = 700;
  s.valve.health = hal::Health::Alive;
  s.valve_status_valid = true;
  s.valve_status.state = hal::pdo::ValveState::Active;
  guidance::SensingInputs in = firmware::sensing_inputs(s);
  CHECK(in.joint[0] == DeviceHealth::Alive);
  CHECK(in.joint[1] == DeviceHealth::Stale);
  CHECK(in.joint[2] == DeviceHealth::Faulted);
  CHECK(in.joint[3] == DeviceHealth::Missing);
  CHECK(in.bus_off);
  CHECK(in.uwb_gateway == DeviceHealth::Alive);
  CHECK(in.uwb_last_fix_us == 700);
  CHECK(in.valve == ValveHealth::Active);

  s.valve_status.state = hal::pdo::ValveState::Disabled;
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::NotStarted);
  s.valve_status_valid = false;
  s.valve_status.state = hal::pdo::ValveState::Active;
  s.valve.nmt_state = hal::canopen::NmtState::Operational;
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::NotStarted);  // no status frame since start
  // An Operational node whose status frames stopped: stale, not a node that left Active.
  s.valve_status_t_us = 400;
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::StatusStale);
  s.valve.nmt_state = hal::canopen::NmtState::PreOperational;  // rebooted: it left Active
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::NotStarted);
  s.valve.nmt_state = hal::canopen::NmtState::Operational;
  s.valve_status_valid = true;
  s.valve_status.state = hal::pdo::ValveState::FailSafe;
  s.valve.health = hal::Health::Faulted;  // the Hal counts fail-safe as a fault too
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::FailSafe);
  s.valve_status.state = hal::pdo::ValveState::Fault;
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::Faulted);
  s.valve.health = hal::Health::Missing;
  CHECK(firmware::sensing_inputs(s).valve == ValveHealth::Missing);
}

TEST_CASE("supervisor on the bus: start-up reaches HOLD and stays there while the crane is healthy", "[firmware][sim]") {
  SupervisedRig r(SimRig::quiet_config());
  r.rig.run(600'000);
  CHECK(r.out.state == SupervisorState::Hold);
  CHECK(r.out.reason == TransitionReason::StartupComplete);
  r.rig.run(3'000'000);
  CHECK(r.out.state == SupervisorState::Hold);
  CHECK(r.fault_at_us < 0);
}

TEST_CASE("supervisor on the bus: every loss of sensing ends in FAULT with its reason", "[firmware][sim]") {
  struct Case {
    const char* fault;
    TransitionReason reason;
    std::int64_t detect_us;  //!< the Hal's detection time for this loss (docs/protocol.md) [µs]
  };
  const Case cases[] = {
      {"heartbeat-lost:swing@1", TransitionReason::EncoderMissing, 250'000},
      {"encoder-dropout:boom_elevation@1", TransitionReason::EncoderStale, 30'000},
      {"heartbeat-lost:valve@1", TransitionReason::ValveHeartbeatLost, 250'000},
      {"heartbeat-lost:uwb@1", TransitionReason::UwbGatewayLost, 250'000},
      {"uwb-silent@1", TransitionReason::UwbSilent, 1'000'000},
      {"bus-off@1", TransitionReason::BusOff, 0},
  };
  for (const Case& c : cases) {
    CAPTURE(c.fault);
    sim::SimConfig config = SimRig::quiet_config();
    const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
    config.faults.push_back(sim::parse_fault(c.fault, joint_names(scenario)));
    SupervisedRig r(std::move(config));
    r.rig.run(900'000);
    REQUIRE(r.out.state == SupervisorState::Hold);
    r.rig.run(2'500'000);
    CHECK(r.out.state == SupervisorState::Fault);
    CHECK(r.out.reason == c.reason);
    REQUIRE(r.fault_at_us > 0);
    // At rest, a loss is a FAULT at once: within the Hal's detection time, the last good sample's
    // age and two cycles.
    const std::int64_t latest_us = SimRig::at_sim_s(1.0) + c.detect_us + 2 * SimRig::kCycleUs + 100'000;
    CHECK(r.fault_at_us <= latest_us);
  }
}
