// SPDX-License-Identifier: Apache-2.0
// The supervisor on the bus: the Hal's snapshot mapped onto the supervisor's sensing inputs (the
// cut-off's health row by row) and onto the plausibility monitor's inputs; then, against the
// simulated crane of the thesis site, start-up reaches HOLD and every loss of sensing the simulator
// can inject ends in FAULT with its own reason, within the Hal's detection time and a cycle or two.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <vector>

#include "../sim/sim_rig.hpp"
#include "mgc/firmware/sensing.hpp"

using namespace mgc;
using guidance::CutoffHealth;
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

TEST_CASE("sensing inputs: the machine's own tags do not keep the obstacles' UWB alive", "[unit]") {
  hal::SensorSnapshot s;
  s.num_tags = 2;
  s.tags[0].tag_id = 200;  // on the boom tip
  s.tags[0].fixes = 5;
  s.tags[0].t_us = 900;
  s.tags[1].tag_id = 3;    // on crane 2
  s.tags[1].fixes = 2;
  s.tags[1].t_us = 400;
  const std::array<std::uint8_t, 1> machine{200};
  CHECK(firmware::sensing_inputs(s, machine).uwb_last_fix_us == 400);
  CHECK(firmware::sensing_inputs(s).uwb_last_fix_us == 900);
  s.tags[1].fixes = 0;
  CHECK(firmware::sensing_inputs(s, machine).uwb_last_fix_us == 0);
}

TEST_CASE("cut-off health: each row of the mapping in docs/supervisor.md", "[unit]") {
  using hal::pdo::CutoffReason;
  using hal::pdo::CutoffState;
  struct Row {
    const char* name;
    hal::Health node;   //!< the Hal's node health (Faulted: an active EMCY, or a fresh status Fault)
    bool status_fresh;  //!< cutoff_status_valid
    CutoffState state;
    CutoffReason reason;
    bool pressure;
    CutoffHealth expected;
  };
  const Row rows[] = {
      {"heartbeat lost, whatever the status says", hal::Health::Missing, true, CutoffState::Enabled, CutoffReason::None,
       true, CutoffHealth::Missing},
      {"heartbeat lost, no status", hal::Health::Missing, false, CutoffState::Cut, CutoffReason::Commanded, false,
       CutoffHealth::Missing},
      {"alive, no fresh status (not started, or its reports stopped)", hal::Health::Alive, false, CutoffState::Enabled,
       CutoffReason::None, true, CutoffHealth::NotReady},
      {"no fresh status with an active EMCY", hal::Health::Faulted, false, CutoffState::Cut, CutoffReason::Commanded,
       false, CutoffHealth::Failed},
      {"status fault", hal::Health::Faulted, true, CutoffState::Fault, CutoffReason::InternalFault, false,
       CutoffHealth::Failed},
      {"status fault, no EMCY", hal::Health::Alive, true, CutoffState::Fault, CutoffReason::InternalFault, false,
       CutoffHealth::Failed},
      {"pressure while commanded cut: the dump valve failed", hal::Health::Alive, true, CutoffState::Cut,
       CutoffReason::Commanded, true, CutoffHealth::Failed},
      {"pressure while cut after a loss", hal::Health::Faulted, true, CutoffState::Cut, CutoffReason::CommandTimeout,
       true, CutoffHealth::Failed},
      {"an EMCY while enabled with pressure", hal::Health::Faulted, true, CutoffState::Enabled, CutoffReason::None, true,
       CutoffHealth::Failed},
      {"enabled with pressure", hal::Health::Alive, true, CutoffState::Enabled, CutoffReason::None, true,
       CutoffHealth::Ready},
      {"commanded cut, no pressure", hal::Health::Alive, true, CutoffState::Cut, CutoffReason::Commanded, false,
       CutoffHealth::Cut},
      {"cut after a loss it signalled, no pressure", hal::Health::Faulted, true, CutoffState::Cut,
       CutoffReason::ControllerHeartbeatLost, false, CutoffHealth::Cut},
      {"enabled, no pressure yet", hal::Health::Alive, true, CutoffState::Enabled, CutoffReason::None, false,
       CutoffHealth::Cut},
  };
  for (const Row& row : rows) {
    CAPTURE(row.name);
    hal::SensorSnapshot s;
    s.num_joints = 4;
    s.cutoff.health = row.node;
    s.cutoff_status_valid = row.status_fresh;
    s.cutoff_status = {hal::kCutoffNodeId, row.state, row.reason, row.pressure};
    CHECK(firmware::cutoff_health(s) == row.expected);
    CHECK(firmware::sensing_inputs(s).cutoff == row.expected);
  }
  // An empty snapshot: never heard, never healthy.
  CHECK(firmware::cutoff_health(hal::SensorSnapshot{}) == CutoffHealth::Missing);
}

TEST_CASE("plausibility inputs: the snapshot's positions, spools and counter, drive enabled by valve and pilot", "[unit]") {
  hal::SensorSnapshot s;
  s.t_us = 5'000'000;
  s.num_joints = 3;
  for (std::size_t j = 0; j < 3; ++j) {
    s.joints[j].position = 0.5 + static_cast<double>(j);
    s.joints[j].t_us = 4'990'000 + static_cast<std::int64_t>(j);
    s.joints[j].valid = j != 1;
    s.joints[j].updated = j != 2;
    s.valve_applied_fraction[j] = 0.1 * static_cast<double>(j + 1);
    s.valve_command_fraction[j] = -0.2 * static_cast<double>(j + 1);
  }
  // Beyond num_joints: not the machine's, never copied.
  s.joints[3].position = 99.0;
  s.joints[3].valid = true;
  s.valve_applied_fraction[3] = 0.9;
  s.valve_status.command_counter = 201;
  s.valve_commands_sent = 4567;
  const std::array<double, 2> commanded{0.03, -0.04};  // shorter than the joints: the rest is zero

  guidance::PlausibilityInputs in = firmware::plausibility_inputs(s, commanded, true);
  CHECK(in.now_us == 5'000'000);
  for (std::size_t j = 0; j < 3; ++j) {
    CAPTURE(j);
    CHECK(in.position[j] == s.joints[j].position);
    CHECK(in.valid[j] == s.joints[j].valid);
    CHECK(in.updated[j] == s.joints[j].updated);
    CHECK(in.valve_applied[j] == s.valve_applied_fraction[j]);
    CHECK(in.valve_commanded[j] == s.valve_command_fraction[j]);
  }
  CHECK(in.commanded_velocity[0] == 0.03);
  CHECK(in.commanded_velocity[1] == -0.04);
  CHECK(in.commanded_velocity[2] == 0.0);
  CHECK(in.position[3] == 0.0);
  CHECK_FALSE(in.valid[3]);
  CHECK(in.valve_applied[3] == 0.0);
  CHECK(in.valve_command_counter == 201);
  CHECK(in.valve_commands_sent == 4567);
  // Nothing heard from the valve: its spools are not checked, and the machine is taken at its
  // commands (a stop run down as commanded is no runaway).
  CHECK_FALSE(in.valve_active);
  CHECK(in.drive_enabled);

  s.valve.health = hal::Health::Alive;
  s.valve.nmt_state = hal::canopen::NmtState::Operational;
  s.valve_status_valid = true;
  s.valve_status.state = hal::pdo::ValveState::Active;
  REQUIRE(s.valve_active());
  in = firmware::plausibility_inputs(s, commanded, true);
  CHECK(in.valve_active);
  CHECK(in.drive_enabled);
  in = firmware::plausibility_inputs(s, commanded, false);  // pilot cut: the valve obeys, nothing moves
  CHECK(in.valve_active);
  CHECK_FALSE(in.drive_enabled);
  s.valve_status_valid = false;  // its status stopped: not checked, still taken at its commands
  in = firmware::plausibility_inputs(s, commanded, true);
  CHECK_FALSE(in.valve_active);
  CHECK(in.drive_enabled);
  s.valve_status_valid = true;  // it says it neutralised: the commands move nothing
  s.valve_status.state = hal::pdo::ValveState::FailSafe;
  s.valve_status.reason = hal::pdo::ValveReason::CommandTimeout;
  in = firmware::plausibility_inputs(s, commanded, true);
  CHECK_FALSE(in.drive_enabled);
  s.valve_status.state = hal::pdo::ValveState::Active;  // its heartbeat says it left Operational
  s.valve_status.reason = hal::pdo::ValveReason::None;
  s.valve.nmt_state = hal::canopen::NmtState::PreOperational;
  in = firmware::plausibility_inputs(s, commanded, true);
  CHECK_FALSE(in.drive_enabled);
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
