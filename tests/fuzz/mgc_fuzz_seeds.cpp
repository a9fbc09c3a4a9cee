// SPDX-License-Identifier: Apache-2.0
// Writes the binary seed inputs of the fuzz targets (tests/fuzz/corpus/<target>/) from the real
// encoders, so that the seeds stay valid messages when a codec changes:
//   build-fuzz/bin/mgc_fuzz_seeds tests/fuzz/corpus
// The text seeds (scenario files, state files) are kept by hand.
#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/firmware/command_auth.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/operator_command_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "site_fuzz.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/cannelloni.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"

using namespace mgc::hal;
using Bytes = std::vector<std::uint8_t>;

namespace {

std::filesystem::path g_root;

void write_seed(const std::string& target, const std::string& name, const Bytes& bytes) {
  const std::filesystem::path folder = g_root / target;
  std::filesystem::create_directories(folder);
  std::ofstream out(folder / name, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + (folder / name).string());
}

CanFrame ok(const Result<CanFrame>& r) {
  if (!r.ok()) throw std::runtime_error("a seed frame does not encode");
  return r.value;
}

// The frame layout of fuzz_canopen and fuzz_hal_read: id (u32 BE), dlc, payload.
void put_frame(Bytes& out, const CanFrame& f) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(f.can_id >> shift));
  out.push_back(f.dlc);
  for (std::size_t i = 0; i < f.dlc; ++i) out.push_back(f.data[i]);
}

// Everything a healthy bus of this plan carries in one cycle.
std::vector<CanFrame> cycle_frames(const BusPlan& plan, std::uint8_t sequence) {
  using canopen::NmtState;
  std::vector<CanFrame> frames;
  for (std::size_t j = 0; j < plan.num_joints; ++j) {
    const std::uint8_t node = plan.encoders[j].node_id;
    frames.push_back(ok(canopen::encode_heartbeat({node, NmtState::Operational})));
    frames.push_back(ok(pdo::encode_encoder_position({node, static_cast<std::int32_t>(1000 * (j + 1)), 0})));
  }
  for (const std::uint8_t node : {plan.uwb_gateway_node_id, plan.valve_node_id, plan.cutoff_node_id}) {
    frames.push_back(ok(canopen::encode_heartbeat({node, NmtState::Operational})));
  }
  frames.push_back(ok(pdo::encode_uwb_tag_position({plan.uwb_gateway_node_id, 7, {1200, -350, 420}, sequence, 3})));
  frames.push_back(ok(pdo::encode_uwb_tag_position({plan.uwb_gateway_node_id, 8, {pdo::kUwbNoPosition, pdo::kUwbNoPosition, pdo::kUwbNoPosition}, sequence, 0})));
  frames.push_back(ok(pdo::encode_valve_status({plan.valve_node_id, pdo::ValveState::Active, pdo::ValveReason::None, 0, sequence})));
  frames.push_back(ok(pdo::encode_valve_applied({plan.valve_node_id, 0, {1000, -2000, 0, 10000}})));
  frames.push_back(ok(pdo::encode_cutoff_status({plan.cutoff_node_id, pdo::CutoffState::Enabled, pdo::CutoffReason::None, true})));
  return frames;
}

void hal_seeds() {
  const BusPlan plans[] = {mobile_crane_bus_plan(), tower_crane_bus_plan(), excavator_bus_plan()};
  for (std::uint8_t p = 0; p < 3; ++p) {
    Bytes in{p};
    for (std::uint8_t cycle = 0; cycle < 3; ++cycle) {
      for (const CanFrame& f : cycle_frames(plans[p], cycle)) {
        in.push_back(0x00);
        put_frame(in, f);
      }
      in.push_back(0xC5);  // 10 ms, read
      in.push_back(0xF0);  // write
      for (std::size_t j = 0; j < plans[p].num_joints; ++j) {
        in.push_back(0x00);
        in.push_back(static_cast<std::uint8_t>(0x40 * j));
      }
    }
    // A fault: EMCY from the first encoder, an encoder alarm, a valve in fail-safe, a boot-up.
    const std::uint8_t enc = plans[p].encoders[0].node_id;
    for (const CanFrame& f : {ok(canopen::encode_emcy({enc, canopen::kEmcyGeneric, 0x01, {}})),
                              ok(pdo::encode_encoder_position({enc, -5, pdo::kEncoderStatusAlarm})),
                              ok(pdo::encode_valve_status({plans[p].valve_node_id, pdo::ValveState::FailSafe, pdo::ValveReason::CommandTimeout, 0x3, 9})),
                              ok(canopen::encode_heartbeat({enc, canopen::NmtState::BootUp}))}) {
      in.push_back(0x00);
      put_frame(in, f);
    }
    in.push_back(0xC5);
    write_seed("fuzz_hal_read", std::string("cycles-") + plans[p].machine, in);
  }
}

void canopen_seeds() {
  const BusPlan plan = mobile_crane_bus_plan();
  Bytes all;
  for (const CanFrame& f : cycle_frames(plan, 3)) put_frame(all, f);
  for (const CanFrame& f : {ok(canopen::encode_nmt({canopen::NmtCommand::Start, 0})), ok(canopen::encode_sync({1})),
                            ok(canopen::encode_sync({0})), ok(canopen::encode_emcy({0x11, canopen::kEmcyHeartbeat, 0x11, {1, 2, 3, 4, 5}})),
                            ok(pdo::encode_valve_command({plan.valve_node_id, 1, {10000, -10000, 5, 0}})),
                            ok(pdo::encode_valve_applied({plan.valve_node_id, 1, {1, 2, 3, 4}})),
                            ok(pdo::encode_cutoff_command({plan.cutoff_node_id, pdo::PilotCommand::Enable}))}) {
    put_frame(all, f);
  }
  write_seed("fuzz_canopen", "every-message", all);
  Bytes one;
  put_frame(one, ok(pdo::encode_encoder_position({0x11, 123456, pdo::kEncoderStatusWarning})));
  write_seed("fuzz_canopen", "encoder-position", one);
}

void cannelloni_seeds() {
  const std::vector<CanFrame> frames = cycle_frames(mobile_crane_bus_plan(), 5);
  Bytes buf(cannelloni::kMaxDatagramBytes);
  const std::size_t n = cannelloni::encode(frames, 42, buf);
  write_seed("fuzz_cannelloni", "cycle", Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)));
  CanFrame extended;
  extended.can_id = kCanEffFlag | 0x1234567U;
  extended.dlc = 3;
  extended.data = {1, 2, 3};
  const std::vector<CanFrame> mixed{ok(canopen::encode_sync({7})), extended};
  const std::size_t m = cannelloni::encode(mixed, 255, buf);
  write_seed("fuzz_cannelloni", "sync-and-extended", Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(m)));
  write_seed("fuzz_cannelloni", "empty-data", {cannelloni::kVersion, cannelloni::kOpData, 0, 0, 0});
  write_seed("fuzz_cannelloni", "ack", {cannelloni::kVersion, 1, 9, 0, 0});
}

template <class Msg>
Bytes encode(const Msg& msg, std::initializer_list<std::uint8_t> prefix = {}) {
  Bytes out(prefix);
  const std::size_t at = out.size();
  out.resize(at + static_cast<std::size_t>(msg.getEncodedSize()));
  if (msg.encode(out.data() + at, 0, msg.getEncodedSize()) != msg.getEncodedSize()) throw std::runtime_error("encode");
  return out;
}

void command_seeds() {
  using mgc::operator_command_t;
  const mgc::firmware::CommandKey key(mgc::fuzz::command_key_bytes());
  operator_command_t goal{};
  goal.utime = 1'000'000;
  goal.kind = operator_command_t::KIND_GOAL;
  goal.sender_id = 3;
  goal.sequence = mgc::fuzz::kCommandNowUs - 1'000;
  goal.num_joints = 4;
  goal.goal_position[0] = 0.5;
  goal.goal_position[1] = 0.7;
  goal.goal_position[2] = 22.0;
  goal.goal_position[3] = 9.0;
  mgc::firmware::sign_command(goal, key);
  write_seed("fuzz_operator_command", "signed-goal", encode(goal));
  operator_command_t ack{};
  ack.kind = operator_command_t::KIND_ACKNOWLEDGE;
  ack.sender_id = 4;
  ack.sequence = mgc::fuzz::kCommandNowUs + 2'000'000;
  ack.alert_id = 17;
  mgc::firmware::sign_command(ack, key);
  write_seed("fuzz_operator_command", "signed-acknowledge", encode(ack));
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  stop.sender_id = 9;
  stop.sequence = 1;
  write_seed("fuzz_operator_command", "unsigned-stop", encode(stop));
  operator_command_t forged = goal;
  forged.goal_position[0] = 1.5;
  write_seed("fuzz_operator_command", "goal-bad-mac", encode(forged));
}

void lcm_seeds() {
  mgc::machine_state_t state{};
  state.utime = 5;
  state.machine_kind = mgc::machine_state_t::MACHINE_KIND_MOBILE_CRANE;
  state.num_joints = 4;
  for (int j = 0; j < 8; ++j) state.joint_position[j] = 0.1 * j;
  state.supervisor_state = 3;
  state.load_moment_pct = 42.0;
  write_seed("fuzz_lcm_messages", "machine-state", encode(state, {0}));
  mgc::operator_instruction_t words{};
  words.utime = 6;
  words.text = "Slew left 12 degrees, then lower the hook";
  words.segment_index = 2;
  write_seed("fuzz_lcm_messages", "operator-instruction", encode(words, {1}));
  mgc::alert_t alert{};
  alert.alert_id = 12;
  alert.severity = mgc::alert_t::SEVERITY_WARN;
  alert.active = true;
  alert.value = 1.5;
  write_seed("fuzz_lcm_messages", "alert", encode(alert, {2}));
  mgc::command_status_t status{};
  status.sender_id = 3;
  status.sequence = 99;
  status.kind = 1;
  status.accepted = true;
  status.reason = mgc::command_status_t::REASON_ACCEPTED;
  write_seed("fuzz_lcm_messages", "command-status", encode(status, {3}));
}

// fuzz_site_messages: the first byte picks type and mode (0 state as received, 1 state signed by
// the target, 2 plan as received, 3 plan signed by the target).
void site_seeds() {
  namespace site = mgc::fuzz::site;
  mgc::site_state_t state{};
  state.utime = 7;
  state.machine_id = site::kOther;
  state.priority = 2;
  state.supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
  state.num_joints = 3;
  const double position[3] = {0.4, 20.0, 12.0};
  const double velocity[3] = {0.05, 0.3, -0.5};
  for (int j = 0; j < 3; ++j) {
    state.joint_position[j] = position[j];
    state.joint_velocity[j] = velocity[j];
    state.stop_travel[j] = 0.5 * velocity[j];
  }
  state.time_to_rest_s = 1.2;
  state.plan_id = 3;
  state.plan_time_s = 14.5;
  state.sequence = 41;
  state.sender_time_us = site::kNowUs - 20'000;
  mgc::firmware::sign_site_state(state, site::site_key());
  write_seed("fuzz_site_messages", "state-as-received", encode(state, {0}));
  write_seed("fuzz_site_messages", "state-to-sign", encode(state, {1}));
  mgc::site_plan_t plan{};
  plan.utime = 8;
  plan.machine_id = site::kOther;
  plan.plan_id = 3;
  plan.num_joints = 3;
  plan.num_waypoints = 3;
  for (int w = 0; w < 3; ++w) {
    plan.waypoint_time_s[w] = 6.0 * w;
    plan.positions[w][0] = 0.4 + 0.3 * w;
    plan.positions[w][1] = 20.0 - 4.0 * w;
    plan.positions[w][2] = 12.0;
  }
  plan.ends_at_goal = true;
  plan.sequence = 5;
  plan.sender_time_us = site::kNowUs - 30'000;
  mgc::firmware::sign_site_plan(plan, site::site_key());
  write_seed("fuzz_site_messages", "plan-as-received", encode(plan, {2}));
  write_seed("fuzz_site_messages", "plan-to-sign", encode(plan, {3}));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: mgc_fuzz_seeds CORPUS_FOLDER (tests/fuzz/corpus)\n");
    return 2;
  }
  g_root = argv[1];
  try {
    hal_seeds();
    canopen_seeds();
    cannelloni_seeds();
    command_seeds();
    lcm_seeds();
    site_seeds();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc_fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
