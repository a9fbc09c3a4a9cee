// SPDX-License-Identifier: Apache-2.0
// The simulated machine against the controller's Hal on one in-process bus: start-up, encoders,
// commanded motion with the documented dynamics, the valve node's fail-safe, the pilot-pressure
// cut-off node and its faults, lying encoders, UWB tags.
#include <catch2/catch.hpp>

#include <cmath>
#include <initializer_list>
#include <numbers>

#include "mgc/hal/canopen.hpp"
#include "mgc/sim/faults.hpp"
#include "sim_rig.hpp"

using namespace mgc;
using hal::Health;
using hal::pdo::CutoffReason;
using hal::pdo::CutoffState;
using hal::pdo::ValveReason;
using hal::pdo::ValveState;
using test::SimRig;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

//! The quiet rig's configuration with faults given as mgc-sim takes them (units from the machine).
sim::SimConfig with_faults(std::initializer_list<const char*> texts) {
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  sim::SimConfig config = SimRig::quiet_config();
  for (const char* text : texts) config.faults.push_back(sim::parse_machine_fault(text, scenario.machine.joints));
  return config;
}

}  // namespace

TEST_CASE("before NMT start the nodes only send heartbeats, after it, every joint is valid", "[sim][hal]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.run(200'000);
  const hal::SensorSnapshot& before = *rig.last;
  for (std::size_t j = 0; j < before.num_joints; ++j) {
    CHECK(before.encoders[j].heard);
    CHECK(before.encoders[j].boot_count == 1);
    CHECK(before.encoders[j].nmt_state == hal::canopen::NmtState::PreOperational);
    CHECK(before.joints[j].samples == 0);
    CHECK(before.joints[j].health == Health::Stale);  // alive node, no data: flagged, not invented
    CHECK_FALSE(before.joints[j].valid);
  }
  CHECK_FALSE(before.valve_active());
  CHECK(before.valve_status_t_us == 0);  // a pre-operational node sends no status
  CHECK(rig.sim->counters().commands_ignored > 0);  // commands before start are not applied

  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0) == hal::Status::Ok);
  rig.run(50'000);
  const hal::SensorSnapshot& after = *rig.last;
  REQUIRE(after.all_joints_valid());
  CHECK(after.valve_active());
  CHECK(after.valve_status_t_us > 0);
  CHECK(rig.hal->snapshot().t_us - after.valve_status_t_us <= SimRig::kCycleUs);
  CHECK(after.uwb_gateway.health == Health::Alive);
  for (std::size_t j = 0; j < after.num_joints; ++j) {
    // Quantisation only (noise is off): 0.001 deg or 0.1 mm.
    const double resolution = j < 2 ? 0.001 * kDeg : 1e-4;
    CHECK(std::abs(after.joints[j].position - rig.scenario.start[static_cast<Eigen::Index>(j)]) <= 0.5 * resolution + 1e-12);
    CHECK(rig.hal->snapshot().t_us - after.joints[j].t_us <= SimRig::kCycleUs);
  }
  CHECK(after.codec.malformed() == 0);
  CHECK(rig.sim->counters().codec.malformed() == 0);
}

TEST_CASE("a swing command moves the joint with the documented lag, acceleration limit and speed", "[sim][hal]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  REQUIRE(rig.last->valve_active());
  const planning::JointSpec& swing = rig.scenario.machine.joints[0];
  const double q0 = rig.sim->truth().position[0];

  rig.command[0] = 0.5 * swing.max_velocity;
  rig.run(3'000'000);
  const sim::TrueState& t = rig.sim->truth();
  // Half spool beyond a 3 % deadband: (0.5 - 0.03) / 0.97 of full speed, reached after many lags.
  const double expected_v = (0.5 - 0.03) / 0.97 * swing.max_velocity;
  CHECK(t.velocity[0] == Approx(expected_v).epsilon(1e-3));
  CHECK(t.spool[0] == Approx(0.5).margin(1e-4));
  // Other joints held still.
  for (std::size_t j = 1; j < t.num_joints; ++j) CHECK(t.velocity[j] == 0.0);
  // The encoder follows the truth, one cycle behind at most.
  CHECK(std::abs(rig.last->joints[0].position - t.position[0]) <= expected_v * 0.011 + 1e-5);
  CHECK(rig.last->valve_applied_fraction[0] == Approx(0.5).margin(1e-4));
  CHECK(t.position[0] > q0 + 0.9 * expected_v * 2.5);

  // Back to zero: it comes to rest (the lag and acceleration limit are checked exactly in
  // actuator_test.cpp) and stays there.
  rig.command[0] = 0.0;
  rig.run(3'000'000);
  CHECK(std::abs(rig.sim->truth().velocity[0]) < 1e-9);
  const double rest = rig.sim->truth().position[0];
  rig.run(500'000);
  CHECK(rig.sim->truth().position[0] == rest);
}

TEST_CASE("a command inside the deadband moves nothing", "[sim]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  const double q0 = rig.sim->truth().position[1];
  rig.command[1] = 0.02 * rig.scenario.machine.joints[1].max_velocity;
  rig.run(1'000'000);
  CHECK(rig.sim->truth().position[1] == q0);
  CHECK(rig.sim->truth().spool[1] == Approx(0.02).margin(1e-4));
}

TEST_CASE("the valve node blocks every spool when the controller's heartbeat stops", "[sim][hal][failsafe]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  rig.command[0] = rig.scenario.machine.joints[0].max_velocity;
  rig.run(1'000'000);
  REQUIRE(rig.sim->truth().spool[0] > 0.9);

  // The controller dies: no heartbeat, no commands.
  const std::int64_t dead_at = rig.t_us;
  std::int64_t fail_safe_at = 0;
  while (rig.t_us - dead_at < 1'000'000) {
    rig.run(1'000, false);
    if (rig.sim->truth().valve_state == ValveState::FailSafe) {
      fail_safe_at = rig.t_us;
      break;
    }
  }
  REQUIRE(fail_safe_at != 0);
  // The command timeout (50 ms) fires first, well inside the heartbeat timeout (150 ms).
  CHECK(fail_safe_at - dead_at <= rig.hal->plan().timing.valve_command_timeout_us + SimRig::kCycleUs + 1'000);
  CHECK(rig.sim->truth().valve_reason == ValveReason::CommandTimeout);
  for (std::size_t j = 0; j < rig.sim->truth().num_joints; ++j) CHECK(rig.sim->truth().spool[j] == 0.0);

  // The controller comes back: the node stays in fail-safe, its EMCY and status are visible.
  rig.run(100'000);
  const hal::SensorSnapshot& s = *rig.last;
  CHECK(s.valve.emcy_code == hal::canopen::kEmcyRpdoTimeout);
  CHECK(s.valve_status.state == ValveState::FailSafe);
  CHECK(s.valve.health == Health::Faulted);
  CHECK_FALSE(s.valve_active());
  CHECK(rig.sim->truth().spool[0] == 0.0);

  // Only a new NMT start makes it follow commands again.
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, hal::kValveNodeId) == hal::Status::Ok);
  rig.run(200'000);
  CHECK(rig.sim->truth().valve_state == ValveState::Active);
  CHECK(rig.sim->truth().spool[0] > 0.9);
}

TEST_CASE("heartbeat loss alone (commands still flowing) trips the valve within its consumer time", "[sim][failsafe]") {
  sim::SimConfig config = SimRig::quiet_config();
  SimRig rig("thesis-steel-frame.yaml", config);
  rig.start();
  // Keep commanding but stop the controller heartbeat: the Hal's write() sends it, so send the
  // command frames by hand.
  rig.send_commands = false;
  const hal::BusPlan plan = rig.hal->plan();
  const std::int64_t from = rig.t_us;
  std::int64_t tripped = 0;
  while (rig.t_us - from < 500'000 && tripped == 0) {
    rig.t_us += 1'000;
    rig.clock.set_us(rig.t_us);
    if (rig.t_us % SimRig::kCycleUs == 0) {
      const auto frame = hal::pdo::encode_valve_command({plan.valve_node_id, 0, {{1000, 0, 0, 0}}});
      REQUIRE(rig.controller_bus->send(frame.value) == hal::Status::Ok);
    }
    rig.sim->step(rig.t_us);
    if (rig.sim->truth().valve_state == ValveState::FailSafe) tripped = rig.t_us;
  }
  REQUIRE(tripped != 0);
  CHECK(rig.sim->truth().valve_reason == ValveReason::ControllerHeartbeatLost);
  // Last heartbeat at most one controller period before `from`; timeout 150 ms.
  CHECK(tripped - from <= plan.timing.valve_heartbeat_timeout_us + 1'000);
  CHECK(tripped - from >= plan.timing.valve_heartbeat_timeout_us - plan.timing.controller_heartbeat_period_us);
}

TEST_CASE("UWB tags report the second crane's tags at their true positions, rate and latency", "[sim][uwb]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  REQUIRE(rig.sim->tags().size() == 3);
  rig.run(2'000'000);
  const hal::SensorSnapshot& s = *rig.last;
  REQUIRE(s.num_tags == 3);
  for (const sim::SimTag& tag : rig.sim->tags()) {
    const hal::TagReading* r = s.find_tag(tag.tag_id);
    REQUIRE(r != nullptr);
    CHECK(r->valid);
    // Crane 2 stands still before 60 s, so the 50 ms latency does not show; 1 cm quantisation.
    const Eigen::Vector3d truth = rig.sim->tag_position(tag);
    for (int a = 0; a < 3; ++a) CHECK(std::abs(r->position_m[static_cast<std::size_t>(a)] - truth[a]) <= 0.005 + 1e-9);
    CHECK(r->missed == 0);
    // 10 Hz for about 2.25 s since the gateway became operational.
    CHECK(r->fixes >= 20);
    CHECK(r->fixes <= 24);
  }
}

TEST_CASE("UWB noise and dropouts are what was configured", "[sim][uwb]") {
  sim::SimConfig config = SimRig::quiet_config();
  config.uwb.noise_sigma_m = 0.2;
  config.uwb.dropout_probability = 0.1;
  config.uwb.rate_hz = 20.0;
  SimRig rig("thesis-steel-frame.yaml", config);
  rig.start();
  double sum_sq = 0.0;
  int n = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    for (const sim::SimTag& tag : rig.sim->tags()) {
      const hal::TagReading* r = s.find_tag(tag.tag_id);
      if (r == nullptr || !r->updated) continue;
      const Eigen::Vector3d truth = rig.sim->tag_position(tag);
      for (int a = 0; a < 3; ++a) {
        const double e = r->position_m[static_cast<std::size_t>(a)] - truth[a];
        sum_sq += e * e;
        ++n;
      }
      CHECK(r->quality == 2);       // 0.2 m: quality × 10 cm covers it at q = 2
      CHECK(r->sigma_m == Approx(0.2));
    }
  };
  rig.run(30'000'000);
  REQUIRE(n > 3000);
  const double sigma = std::sqrt(sum_sq / n);
  CHECK(sigma == Approx(0.2).epsilon(0.08));
  const sim::SimCounters& c = rig.sim->counters();
  const double dropped = static_cast<double>(c.tag_fixes_dropped) / static_cast<double>(c.tag_fixes);
  CHECK(dropped == Approx(0.1).margin(0.03));
  // The Hal sees the losses in the sequence numbers, one for one.
  std::uint64_t missed = 0;
  for (std::size_t i = 0; i < rig.last->num_tags; ++i) missed += rig.last->tags[i].missed;
  CHECK(missed == Approx(static_cast<double>(c.tag_fixes_dropped)).margin(3));
}

TEST_CASE("the same seed gives the same run, a different seed a different one", "[sim]") {
  const auto run = [](std::uint64_t seed) {
    sim::SimConfig config;
    config.seed = seed;
    SimRig rig("thesis-steel-frame.yaml", config, "seed");
    rig.start();
    rig.command[0] = 0.3;
    std::vector<double> seen;
    rig.on_cycle = [&](const hal::SensorSnapshot& s) {
      seen.push_back(s.joints[0].position);
      for (std::size_t i = 0; i < s.num_tags; ++i) seen.push_back(s.tags[i].position_m[0]);
    };
    rig.run(1'000'000);
    return seen;
  };
  const auto a = run(7);
  CHECK(a == run(7));
  CHECK(a != run(8));
}

TEST_CASE("a Stop from NMT disables the valve and the encoders stop sending", "[sim][hal]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  rig.command[2] = 0.1;
  rig.run(500'000);
  REQUIRE(rig.sim->truth().spool[2] > 0.0);
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Stop, 0) == hal::Status::Ok);
  rig.run(100'000);
  CHECK(rig.sim->truth().valve_state == ValveState::Disabled);
  CHECK(rig.sim->truth().spool[2] == 0.0);
  for (std::size_t j = 0; j < rig.last->num_joints; ++j) {
    CHECK(rig.last->encoders[j].nmt_state == hal::canopen::NmtState::Stopped);
    CHECK(rig.last->joints[j].health == Health::Stale);
  }
}

TEST_CASE("the cut-off node holds the pilot cut until it is started and enabled", "[sim][hal][cutoff]") {
  SimRig rig("thesis-steel-frame.yaml");
  // Enable commands flow from the first cycle, but a pre-operational node does not act on them.
  rig.run(200'000);
  const hal::SensorSnapshot& before = *rig.last;
  CHECK(before.cutoff.heard);
  CHECK(before.cutoff.nmt_state == hal::canopen::NmtState::PreOperational);
  CHECK(before.cutoff.health == Health::Alive);
  CHECK_FALSE(before.cutoff_status_valid);  // a pre-operational node sends no status
  CHECK(before.pilot_enable_sent);
  CHECK(rig.sim->truth().cutoff_state == CutoffState::Cut);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);

  // Started with the controller asking for the cut: Operational, reporting, still cut.
  rig.hal->set_pilot_enabled(false);
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0) == hal::Status::Ok);
  rig.run(50'000);
  const hal::SensorSnapshot& started = *rig.last;
  CHECK(started.cutoff.nmt_state == hal::canopen::NmtState::Operational);
  REQUIRE(started.cutoff_status_valid);
  CHECK(started.cutoff_status.node_id == hal::kCutoffNodeId);
  CHECK(started.cutoff_status.state == CutoffState::Cut);
  CHECK(started.cutoff_status.reason == CutoffReason::Commanded);
  CHECK_FALSE(started.cutoff_status.pressure);
  CHECK_FALSE(started.pilot_enable_sent);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);

  // The first enable command turns the pressure on. Its cycle's SYNC went out before it, so the
  // status says so at the next SYNC, read a cycle later.
  rig.hal->set_pilot_enabled(true);
  rig.run(20'000);
  CHECK(rig.sim->truth().pilot_pressure);
  CHECK_FALSE(rig.last->cutoff_status.pressure);
  rig.run(10'000);
  const hal::SensorSnapshot& enabled = *rig.last;
  CHECK(enabled.pilot_enable_sent);
  CHECK(enabled.cutoff_status.state == CutoffState::Enabled);
  CHECK(enabled.cutoff_status.reason == CutoffReason::None);
  CHECK(enabled.cutoff_status.pressure);
  CHECK(enabled.cutoff.health == Health::Alive);
  CHECK(rig.sim->truth().cutoff_state == CutoffState::Enabled);
  CHECK(rig.sim->truth().pilot_pressure);
  CHECK(rig.sim->counters().pilot_cuts == 0);
  CHECK(enabled.codec.malformed() == 0);
  CHECK(rig.sim->counters().codec.malformed() == 0);
}

TEST_CASE("a commanded cut stops a moving joint while the valve still drives its spool", "[sim][hal][cutoff]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  const double vmax = rig.scenario.machine.joints[0].max_velocity;
  rig.command[0] = vmax;
  rig.run(3'000'000);
  REQUIRE(rig.sim->truth().pilot_pressure);
  REQUIRE(rig.sim->truth().velocity[0] > 0.9 * vmax);

  rig.hal->set_pilot_enabled(false);
  rig.run(30'000);
  CHECK(rig.sim->truth().cutoff_state == CutoffState::Cut);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);
  CHECK(rig.last->cutoff_status.state == CutoffState::Cut);
  CHECK(rig.last->cutoff_status.reason == CutoffReason::Commanded);
  CHECK_FALSE(rig.last->cutoff_status.pressure);
  CHECK(rig.sim->counters().pilot_cuts == 1);

  // The lag's tail from full speed is cut once below a millionth of it (actuator_test.cpp).
  rig.run(5'000'000);
  const sim::TrueState& t = rig.sim->truth();
  CHECK(t.velocity[0] == 0.0);
  // The valve node knows nothing of it: it still applies the full spool and reports it.
  CHECK(t.spool[0] > 0.99);
  CHECK(rig.last->valve_active());
  CHECK(rig.last->valve_applied_fraction[0] > 0.99);
  const double rest = t.position[0];
  rig.run(500'000);
  CHECK(rig.sim->truth().position[0] == rest);

  // A commanded cut does not latch: the next enable drives the joint again.
  rig.hal->set_pilot_enabled(true);
  rig.run(3'000'000);
  CHECK(rig.sim->truth().pilot_pressure);
  CHECK(rig.sim->truth().velocity[0] > 0.5 * vmax);
  CHECK(rig.sim->counters().pilot_cuts == 1);
}

TEST_CASE("commands that stop cut and latch the pilot with an EMCY, only an NMT start re-arms it", "[sim][hal][cutoff][failsafe]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  rig.command[0] = 0.5 * rig.scenario.machine.joints[0].max_velocity;
  rig.run(500'000);
  REQUIRE(rig.sim->truth().pilot_pressure);
  const std::uint32_t emcys_before = rig.last->cutoff.emcy_count;

  // The controller's heartbeat goes on, its commands stop.
  rig.send_commands = false;
  const std::int64_t stopped_at = rig.t_us;
  std::int64_t cut_at = 0;
  while (rig.t_us - stopped_at < 1'000'000 && cut_at == 0) {
    rig.run(1'000);
    if (!rig.sim->truth().pilot_pressure) cut_at = rig.t_us;
  }
  REQUIRE(cut_at != 0);
  const hal::BusTiming& timing = rig.hal->plan().timing;
  CHECK(cut_at - stopped_at > timing.cutoff_command_timeout_us - SimRig::kCycleUs);
  CHECK(cut_at - stopped_at <= timing.cutoff_command_timeout_us + SimRig::kCycleUs + 1'000);
  CHECK(rig.sim->truth().cutoff_state == CutoffState::Cut);
  CHECK(rig.sim->counters().pilot_cuts == 1);

  // Enable commands again: refused, the cut is latched and the Hal sees why.
  rig.send_commands = true;
  rig.run(300'000);
  const hal::SensorSnapshot& latched = *rig.last;
  CHECK(latched.pilot_enable_sent);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);
  CHECK(latched.cutoff.emcy_code == hal::canopen::kEmcyRpdoTimeout);
  CHECK(latched.cutoff.emcy_count == emcys_before + 1);
  CHECK(latched.cutoff.health == Health::Faulted);
  REQUIRE(latched.cutoff_status_valid);
  CHECK(latched.cutoff_status.state == CutoffState::Cut);
  CHECK(latched.cutoff_status.reason == CutoffReason::CommandTimeout);
  CHECK_FALSE(latched.cutoff_status.pressure);
  // A controller in FAULT commands the cut: the node still reports why it latched.
  rig.hal->set_pilot_enabled(false);
  rig.run(100'000);
  CHECK(rig.last->cutoff_status.state == CutoffState::Cut);
  CHECK(rig.last->cutoff_status.reason == CutoffReason::CommandTimeout);
  CHECK(rig.last->cutoff.emcy_code == hal::canopen::kEmcyRpdoTimeout);
  rig.hal->set_pilot_enabled(true);

  // An NMT start of the cut-off alone re-arms it and resets its EMCY; the enables then take.
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, hal::kCutoffNodeId) == hal::Status::Ok);
  rig.run(50'000);
  const hal::SensorSnapshot& restarted = *rig.last;
  CHECK(restarted.cutoff.emcy_code == hal::canopen::kEmcyNoError);
  CHECK(restarted.cutoff.emcy_count == emcys_before + 2);
  CHECK(restarted.cutoff.health == Health::Alive);
  CHECK(restarted.cutoff_status.state == CutoffState::Enabled);
  CHECK(restarted.cutoff_status.pressure);
  CHECK(rig.sim->truth().pilot_pressure);
  // Started without a latch, a node sends no reset.
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, hal::kCutoffNodeId) == hal::Status::Ok);
  rig.run(50'000);
  CHECK(rig.last->cutoff.emcy_count == emcys_before + 2);
}

TEST_CASE("a dead controller leaves the pilot cut and latched when it comes back", "[sim][hal][cutoff][failsafe]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  rig.run(100'000);
  REQUIRE(rig.sim->truth().pilot_pressure);
  const std::int64_t dead_at = rig.t_us;
  std::int64_t cut_at = 0;
  while (rig.t_us - dead_at < 1'000'000 && cut_at == 0) {
    rig.run(1'000, false);
    if (!rig.sim->truth().pilot_pressure) cut_at = rig.t_us;
  }
  REQUIRE(cut_at != 0);
  // The command timeout (50 ms) fires first, well inside the heartbeat timeout (150 ms).
  CHECK(cut_at - dead_at <= rig.hal->plan().timing.cutoff_command_timeout_us + SimRig::kCycleUs + 1'000);
  rig.run(1'000'000, false);
  rig.run(100'000);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);
  CHECK(rig.last->cutoff.emcy_code == hal::canopen::kEmcyRpdoTimeout);
  CHECK(rig.last->cutoff_status.reason == CutoffReason::CommandTimeout);
  CHECK(rig.sim->counters().pilot_cuts == 1);
}

TEST_CASE("a lost controller heartbeat with commands still flowing latches the cut with its own EMCY", "[sim][cutoff][failsafe]") {
  SimRig rig("thesis-steel-frame.yaml");
  rig.start();
  rig.run(100'000);
  REQUIRE(rig.sim->truth().pilot_pressure);
  // Enable commands by hand, no heartbeat (the Hal's write() would send it).
  rig.send_commands = false;
  const hal::BusPlan plan = rig.hal->plan();
  const auto enable = hal::pdo::encode_cutoff_command({plan.cutoff_node_id, hal::pdo::PilotCommand::Enable});
  REQUIRE(enable.ok());
  const std::int64_t from = rig.t_us;
  std::int64_t cut_at = 0;
  while (rig.t_us - from < 500'000 && cut_at == 0) {
    rig.t_us += 1'000;
    rig.clock.set_us(rig.t_us);
    if (rig.t_us % SimRig::kCycleUs == 0) REQUIRE(rig.controller_bus->send(enable.value) == hal::Status::Ok);
    rig.sim->step(rig.t_us);
    if (!rig.sim->truth().pilot_pressure) cut_at = rig.t_us;
  }
  REQUIRE(cut_at != 0);
  CHECK(cut_at - from <= plan.timing.cutoff_heartbeat_timeout_us + 1'000);
  CHECK(cut_at - from >= plan.timing.cutoff_heartbeat_timeout_us - plan.timing.controller_heartbeat_period_us);
  // The controller comes back with its heartbeat and enables: the cut stays, the EMCY names the loss.
  rig.send_commands = true;
  rig.run(100'000);
  CHECK_FALSE(rig.sim->truth().pilot_pressure);
  CHECK(rig.last->cutoff.emcy_code == hal::canopen::kEmcyHeartbeat);
  CHECK(rig.last->cutoff_status.reason == CutoffReason::ControllerHeartbeatLost);
}

TEST_CASE("cutoff-fail: pilot pressure stays while the node reports the cut", "[sim][faults][cutoff]") {
  SimRig rig("thesis-steel-frame.yaml", with_faults({"cutoff-fail@1"}));
  rig.hal->set_pilot_enabled(false);
  rig.start();
  const double vmax = rig.scenario.machine.joints[0].max_velocity;
  rig.command[0] = vmax;
  rig.run(600'000);  // 0.85 s: the dump valve still works
  CHECK_FALSE(rig.sim->truth().pilot_pressure);
  CHECK_FALSE(rig.last->cutoff_status.pressure);
  CHECK(rig.sim->truth().velocity[0] == 0.0);

  rig.run(1'500'000);  // 2.35 s: stuck closed since 1 s
  const hal::SensorSnapshot& s = *rig.last;
  CHECK(rig.sim->truth().cutoff_state == CutoffState::Cut);
  CHECK(rig.sim->truth().pilot_pressure);
  REQUIRE(s.cutoff_status_valid);
  CHECK(s.cutoff_status.state == CutoffState::Cut);
  CHECK(s.cutoff_status.reason == CutoffReason::Commanded);
  CHECK(s.cutoff_status.pressure);  // the switch tells the truth
  CHECK(s.cutoff.health == Health::Alive);
  CHECK(rig.sim->truth().velocity[0] > 0.5 * vmax);  // the machine moves with its pilot cut
}

TEST_CASE("heartbeat-lost:cutoff makes the Hal see the node Missing after the consumer timeout", "[sim][faults][cutoff]") {
  SimRig rig("thesis-steel-frame.yaml", with_faults({"heartbeat-lost:cutoff@1"}));
  rig.start();
  std::int64_t missing_at = 0;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    if (missing_at == 0 && s.cutoff.health == Health::Missing) missing_at = s.t_us;
  };
  rig.run(1'500'000);
  REQUIRE(missing_at != 0);
  const std::int64_t fault_at = SimRig::at_sim_s(1.0);
  const hal::BusTiming& timing = rig.hal->plan().timing;
  CHECK(missing_at - fault_at <= timing.device_heartbeat_timeout_us + SimRig::kCycleUs);
  CHECK(missing_at - fault_at >= timing.device_heartbeat_timeout_us - timing.device_heartbeat_period_us);
  // Only its heartbeat is lost: its status goes on and the pilot stays enabled.
  CHECK(rig.last->cutoff_status_valid);
  CHECK(rig.last->cutoff_status.state == CutoffState::Enabled);
  CHECK(rig.sim->truth().pilot_pressure);
  CHECK(rig.last->valve.health == Health::Alive);
}

TEST_CASE("encoder-offset: the lie appears in the Hal's position as configured, deg or m by joint", "[sim][faults]") {
  // A constant lie (deg), a growing one from an offset (deg, deg/s), one from zero (m/s), and a
  // constant one (m) for one second only.
  SimRig rig("thesis-steel-frame.yaml",
             with_faults({"encoder-offset:swing@1,offset=2", "encoder-offset:boom_elevation@1,offset=-1,rate=0.5",
                          "encoder-offset:boom_length@1,rate=0.1", "encoder-offset:cable_length@1+1,offset=0.5"}));
  REQUIRE(rig.scenario.machine.joints[2].type == planning::JointType::Prismatic);
  rig.start();
  const auto error = [&](std::size_t j) { return rig.last->joints[j].position - rig.sim->truth().position[j]; };
  const double rotary_half_count = 0.5 * 0.001 * kDeg + 1e-12;
  const double linear_half_count = 0.5e-4 + 1e-12;
  rig.run(700'000);  // 0.95 s: honest
  REQUIRE(rig.last->all_joints_valid());
  for (std::size_t j = 0; j < 4; ++j) CHECK(std::abs(error(j)) <= (j < 2 ? rotary_half_count : linear_half_count));

  // The sample was taken at its SYNC, which the Hal sent when the frame's receive time says.
  const auto sample_s = [&] { return static_cast<double>(rig.last->joints[0].t_us - SimRig::kSimZeroUs) * 1e-6; };
  const auto lie_at = [&](double offset, double rate) { return offset + rate * (sample_s() - 1.0); };
  for (const std::int64_t step_us : {500'000, 1'000'000, 1'000'000}) {  // 1.45 s, 2.45 s, 3.45 s
    rig.run(step_us);
    const hal::SensorSnapshot& s = *rig.last;
    REQUIRE(s.all_joints_valid());
    CAPTURE(s.t_us);
    CHECK(std::abs(error(0) - lie_at(2.0 * kDeg, 0.0)) <= rotary_half_count);
    CHECK(std::abs(error(1) - lie_at(-1.0 * kDeg, 0.5 * kDeg)) <= rotary_half_count);
    CHECK(std::abs(error(2) - lie_at(0.0, 0.1)) <= linear_half_count);
    CHECK(std::abs(error(3) - (sample_s() < 2.0 ? 0.5 : 0.0)) <= linear_half_count);
  }
  // The truth does not move: only the reports do.
  for (std::size_t j = 0; j < 4; ++j) CHECK(rig.sim->truth().position[j] == rig.scenario.start[static_cast<Eigen::Index>(j)]);
}

TEST_CASE("machine tags are reported where the true joints put them, whatever the encoders say", "[sim][uwb]") {
  // A stuck telescope encoder while the telescope creeps out at 0.1 m/s: the encoder stands, the
  // boom-tip tag moves with the truth.
  const auto tip_tag = [](planning::Scenario& s) {
    planning::MachineTagSpec tag;
    tag.id = 200;
    tag.body = "boom_tip";
    tag.position_m = Eigen::Vector3d(0.0, 0.0, -0.5);
    s.machine_tags.push_back(tag);
  };
  SimRig rig("thesis-steel-frame.yaml", with_faults({"encoder-stuck:boom_length@1", "joint-creep:boom_length@1,rate=0.1"}), "rig",
             tip_tag);
  REQUIRE(rig.sim->tags().size() == 4);
  REQUIRE(rig.sim->tags().back().on_machine);
  rig.start();
  rig.run(3'000'000);  // 3.25 s: 2.25 s of creep
  const hal::SensorSnapshot& s = *rig.last;
  const double truth_m = rig.sim->truth().position[2];
  CHECK(truth_m - rig.scenario.start[2] == Approx(0.225).margin(0.002));
  // Stuck at its first sample after the fault began: at most a SYNC period (1 mm) of creep in it.
  CHECK(std::abs(s.joints[2].position - rig.scenario.start[2]) < 1.1e-3);
  const hal::TagReading* r = s.find_tag(200);
  REQUIRE(r != nullptr);
  CHECK(r->valid);
  CHECK(r->fixes >= 30);
  // The truth at the fix's time: at most 50 ms latency and 100 ms between fixes behind, at 0.1 m/s.
  const auto model = planning::build_model(rig.scenario);
  planning::JointVector q = rig.scenario.start;
  planning::Kinematics k;
  const auto tip_at = [&](double telescope_m) {
    q[2] = telescope_m;
    model->forward_kinematics(q, k);
    return planning::tag_position(k, planning::resolve_tag_mount(*model, "boom_tip"), Eigen::Vector3d(0.0, 0.0, -0.5));
  };
  const Eigen::Vector3d reported(r->position_m[0], r->position_m[1], r->position_m[2]);
  CHECK((reported - tip_at(truth_m)).norm() < 0.016);
  CHECK((reported - tip_at(rig.scenario.start[2])).norm() > 0.2);
  // The joint-creep stops with pilot pressure.
  rig.hal->set_pilot_enabled(false);
  rig.run(200'000);
  const double cut_m = rig.sim->truth().position[2];
  rig.run(1'000'000);
  CHECK(rig.sim->truth().position[2] == cut_m);
}

TEST_CASE("machine tags leave the obstacles' tag noise as it was", "[sim][uwb]") {
  sim::SimConfig config = SimRig::quiet_config();
  config.uwb.noise_sigma_m = 0.15;
  config.seed = 9;
  const auto first_fixes = [&](bool with_tag) {
    SimRig rig("thesis-steel-frame.yaml", config, "rig", [with_tag](planning::Scenario& s) {
      if (!with_tag) return;
      planning::MachineTagSpec tag;
      tag.id = 200;
      tag.body = "superstructure";
      s.machine_tags.push_back(tag);
    });
    rig.start();
    std::vector<double> seen;
    for (int c = 0; c < 60; ++c) {
      rig.run(10'000);
      for (const std::uint8_t id : {1, 2, 3}) {
        const hal::TagReading* r = rig.last->find_tag(id);
        if (r != nullptr && r->updated) seen.push_back(r->position_m[0]);
      }
    }
    return seen;
  };
  const std::vector<double> without = first_fixes(false);
  REQUIRE(without.size() > 10);
  CHECK(first_fixes(true) == without);
}
