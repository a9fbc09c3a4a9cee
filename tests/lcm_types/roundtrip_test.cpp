// SPDX-License-Identifier: Apache-2.0
// Round-trip tests for the generated LCM types: every field survives
// encode/decode, truncated input and foreign types are rejected, and a message
// crosses the in-process memq:// transport.

#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/health_counters_t.hpp>
#include <mgc/loop_timing_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/obstacle_poses_t.hpp>
#include <mgc/operator_command_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>

#include <lcm/lcm-cpp.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

namespace {

using Bytes = std::vector<std::uint8_t>;

// lcm-gen only accepts literal array sizes, so the .lcm repeats the capacity;
// these keep the literal and the MAX_JOINTS constant from drifting apart.
static_assert(std::extent_v<decltype(mgc::machine_state_t::joint_position)> ==
              mgc::machine_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::machine_state_t::joint_velocity)> ==
              mgc::machine_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::machine_state_t::joint_acceleration)> ==
              mgc::machine_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::machine_state_t::joint_fault_flags)> ==
              mgc::machine_state_t::MAX_JOINTS);

// Fixed-size C arrays as std::array, so Catch compares them with == and prints
// both sides on failure.
template <class T, std::size_t N>
std::array<T, N> as_array(const T (&values)[N]) {
  return std::to_array(values);
}

template <class Msg>
Bytes encode_checked(const Msg& msg) {
  const int size = msg.getEncodedSize();
  REQUIRE(size > 8);  // at least the 8-byte fingerprint plus utime
  Bytes buf(static_cast<std::size_t>(size));
  REQUIRE(msg.encode(buf.data(), 0, size) == size);
  return buf;
}

template <class Msg>
Msg decode_checked(const Bytes& buf) {
  Msg out{};  // value-initialized: every field zero, unlike the filled message
  const int size = static_cast<int>(buf.size());
  REQUIRE(out.decode(buf.data(), 0, size) == size);
  return out;
}

// Every strict prefix of a valid encoding must be rejected, not half-decoded.
template <class Msg>
void require_truncations_rejected(const Bytes& buf) {
  const int size = static_cast<int>(buf.size());
  REQUIRE(size > 8);
  for (int len = 0; len < size; ++len) {
    CAPTURE(len, size);
    Msg out{};
    REQUIRE(out.decode(buf.data(), 0, len) < 0);
  }
}

// Encoding into a buffer one byte too small must fail instead of overrunning.
template <class Msg>
void require_short_buffer_rejected(const Msg& msg) {
  const int size = msg.getEncodedSize();
  Bytes buf(static_cast<std::size_t>(size));
  REQUIRE(msg.encode(buf.data(), 0, size - 1) < 0);
}

mgc::machine_state_t make_machine_state() {
  mgc::machine_state_t m{};
  m.utime = 0x0123456789ABCDEFLL;
  m.utime_sample = 0x0123456789AB0000LL;
  m.machine_kind = mgc::machine_state_t::MACHINE_KIND_EXCAVATOR;
  m.num_joints = 7;
  m.joint_position[0] = 0.125;
  m.joint_position[1] = -1.5;
  m.joint_position[2] = 2.75;
  m.joint_position[3] = -3.0625;
  m.joint_position[4] = 12.5;
  m.joint_position[5] = 1.0 / 3.0;
  m.joint_position[6] = -7.0e-3;
  m.joint_position[7] = 42.0;
  m.joint_velocity[0] = 0.01;
  m.joint_velocity[1] = -0.02;
  m.joint_velocity[2] = 0.03;
  m.joint_velocity[3] = -0.04;
  m.joint_velocity[4] = 0.05;
  m.joint_velocity[5] = -0.06;
  m.joint_velocity[6] = 0.07;
  m.joint_velocity[7] = -0.08;
  m.joint_acceleration[0] = -1.25e-4;
  m.joint_acceleration[1] = 2.5e-3;
  m.joint_acceleration[2] = -3.75e-2;
  m.joint_acceleration[3] = 4.5e-1;
  m.joint_acceleration[4] = -5.25;
  m.joint_acceleration[5] = 6.0e1;
  m.joint_acceleration[6] = -7.125e2;
  m.joint_acceleration[7] = 8.0e3;
  m.joint_fault_flags[0] = mgc::machine_state_t::JOINT_ENCODER_STALE;
  m.joint_fault_flags[1] = mgc::machine_state_t::JOINT_ENCODER_INVALID;
  m.joint_fault_flags[2] = mgc::machine_state_t::JOINT_AT_LIMIT;
  m.joint_fault_flags[3] = mgc::machine_state_t::JOINT_ACTUATOR_FAULT;
  m.joint_fault_flags[4] = mgc::machine_state_t::JOINT_MOTION_CUT_OFF;
  m.joint_fault_flags[5] = static_cast<std::int8_t>(mgc::machine_state_t::JOINT_ENCODER_STALE |
                                                    mgc::machine_state_t::JOINT_AT_LIMIT);
  m.joint_fault_flags[6] = 0x7f;
  m.joint_fault_flags[7] = -128;
  m.tool_position[0] = 12.345;
  m.tool_position[1] = -67.89;
  m.tool_position[2] = 31.5;
  m.supervisor_state = mgc::machine_state_t::SUPERVISOR_REPLANNING;
  m.load_moment_pct = 87.25;
  return m;
}

mgc::operator_guidance_t make_operator_guidance() {
  mgc::operator_guidance_t g{};
  g.utime = 0x7EDCBA9876543210LL;
  g.instruction = mgc::operator_guidance_t::INSTRUCTION_MOVE_JOINT;
  g.segment_index = 3;
  g.num_segments = 11;
  g.moving_joint = 2;
  g.target_position = -0.785;
  g.joint_distance_remaining = -0.3125;
  g.path_distance_remaining = 1.875;
  g.time_remaining = 96.5;
  g.speed_scale = 0.625;
  return g;
}

mgc::alert_t make_alert() {
  mgc::alert_t a{};
  a.utime = 0x00FF00FF00FF00FFLL;
  a.alert_id = 0x12345678;
  a.severity = mgc::alert_t::SEVERITY_SLOW_DOWN;
  a.source = mgc::alert_t::SOURCE_COLLISION;
  a.active = 1;
  a.clear_condition = mgc::alert_t::CLEAR_ON_OPERATOR_ACK;
  a.value_unit = mgc::alert_t::UNIT_METRE;
  a.value = 2.4375;
  a.limit = 3.5;
  a.index = 17;
  a.min_clearance = 2.125;
  return a;
}

mgc::plan_t make_plan() {
  mgc::plan_t p{};
  p.utime = 0x0A0B0C0D0E0F1011LL;
  p.planner_name = "lg-rrt";
  p.seed = -0x1122334455667788LL;
  p.status = mgc::plan_t::STATUS_APPROXIMATE;
  p.num_joints = 3;
  p.num_waypoints = 4;
  p.positions = {
      {0.0, 1.5, -2.25},
      {0.5, 1.5, -2.25},
      {0.5, 2.0, -2.25},
      {0.5, 2.0, 4.125},
  };
  p.moving_joint = {0, 1, 2, mgc::plan_t::NO_JOINT};
  p.planning_time = 0.0625;
  p.iterations = 123456789012LL;
  p.path_length = 1.75;
  p.execution_time = 48.5;
  return p;
}

}  // namespace

TEST_CASE("machine_state_t round-trips every field", "[unit]") {
  const mgc::machine_state_t sent = make_machine_state();
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::machine_state_t>(buf);

  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.utime_sample == sent.utime_sample);
  REQUIRE(got.machine_kind == sent.machine_kind);
  REQUIRE(got.num_joints == sent.num_joints);
  REQUIRE(as_array(got.joint_position) == as_array(sent.joint_position));
  REQUIRE(as_array(got.joint_velocity) == as_array(sent.joint_velocity));
  REQUIRE(as_array(got.joint_acceleration) == as_array(sent.joint_acceleration));
  REQUIRE(as_array(got.joint_fault_flags) == as_array(sent.joint_fault_flags));
  REQUIRE(as_array(got.tool_position) == as_array(sent.tool_position));
  REQUIRE(got.supervisor_state == sent.supervisor_state);
  REQUIRE(got.load_moment_pct == sent.load_moment_pct);

  require_truncations_rejected<mgc::machine_state_t>(buf);
  require_short_buffer_rejected(sent);
}

TEST_CASE("machine_state_t has a fixed encoded size", "[unit]") {
  // Crosses the loop: the size must not depend on the content, so a static
  // buffer sized once is always enough.
  mgc::machine_state_t empty{};
  REQUIRE(empty.getEncodedSize() == make_machine_state().getEncodedSize());
}

static_assert(std::extent_v<decltype(mgc::obstacle_poses_t::x)> == mgc::obstacle_poses_t::MAX_OBSTACLES);
static_assert(std::extent_v<decltype(mgc::obstacle_poses_t::fix_age)> == mgc::obstacle_poses_t::MAX_OBSTACLES);

TEST_CASE("obstacle_poses_t round-trips every field and has a fixed encoded size", "[unit]") {
  mgc::obstacle_poses_t sent{};
  sent.utime = 123'456;
  sent.num_tracked = 3;
  sent.num_obstacles = 2;
  for (int i = 0; i < mgc::obstacle_poses_t::MAX_OBSTACLES; ++i) {
    sent.obstacle_index[i] = i < 2 ? 4 - i : -1;
    sent.valid[i] = i == 0;
    sent.still[i] = i == 1;
    sent.x[i] = -30.0 + i;
    sent.y[i] = -6.0 - i;
    sent.z[i] = 0.25 * i;
    sent.yaw[i] = -1.5 + 0.1 * i;
    sent.position_sigma[i] = 0.1 + 0.01 * i;
    sent.speed[i] = 1.25 * i;
    sent.yaw_rate[i] = -0.05 * i;
    sent.fix_age[i] = 0.02 + i;
  }
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::obstacle_poses_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.num_tracked == 3);
  REQUIRE(got.num_obstacles == 2);
  REQUIRE(as_array(got.obstacle_index) == as_array(sent.obstacle_index));
  REQUIRE(as_array(got.valid) == as_array(sent.valid));
  REQUIRE(as_array(got.still) == as_array(sent.still));
  REQUIRE(as_array(got.x) == as_array(sent.x));
  REQUIRE(as_array(got.y) == as_array(sent.y));
  REQUIRE(as_array(got.z) == as_array(sent.z));
  REQUIRE(as_array(got.yaw) == as_array(sent.yaw));
  REQUIRE(as_array(got.position_sigma) == as_array(sent.position_sigma));
  REQUIRE(as_array(got.speed) == as_array(sent.speed));
  REQUIRE(as_array(got.yaw_rate) == as_array(sent.yaw_rate));
  REQUIRE(as_array(got.fix_age) == as_array(sent.fix_age));
  require_truncations_rejected<mgc::obstacle_poses_t>(buf);
  require_short_buffer_rejected(sent);
  // Crosses the loop: the size does not depend on the content.
  REQUIRE(mgc::obstacle_poses_t{}.getEncodedSize() == sent.getEncodedSize());
  REQUIRE(mgc::obstacle_poses_t::getHash() != mgc::machine_state_t::getHash());
}

TEST_CASE("operator_guidance_t round-trips every field", "[unit]") {
  const mgc::operator_guidance_t sent = make_operator_guidance();
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::operator_guidance_t>(buf);

  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.instruction == sent.instruction);
  REQUIRE(got.segment_index == sent.segment_index);
  REQUIRE(got.num_segments == sent.num_segments);
  REQUIRE(got.moving_joint == sent.moving_joint);
  REQUIRE(got.target_position == sent.target_position);
  REQUIRE(got.joint_distance_remaining == sent.joint_distance_remaining);
  REQUIRE(got.path_distance_remaining == sent.path_distance_remaining);
  REQUIRE(got.time_remaining == sent.time_remaining);
  REQUIRE(got.speed_scale == sent.speed_scale);

  require_truncations_rejected<mgc::operator_guidance_t>(buf);
  require_short_buffer_rejected(sent);
}

TEST_CASE("alert_t round-trips every field", "[unit]") {
  const mgc::alert_t sent = make_alert();
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::alert_t>(buf);

  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.alert_id == sent.alert_id);
  REQUIRE(got.severity == sent.severity);
  REQUIRE(got.source == sent.source);
  REQUIRE(got.active == sent.active);
  REQUIRE(got.clear_condition == sent.clear_condition);
  REQUIRE(got.value_unit == sent.value_unit);
  REQUIRE(got.value == sent.value);
  REQUIRE(got.limit == sent.limit);
  REQUIRE(got.index == sent.index);
  REQUIRE(got.min_clearance == sent.min_clearance);

  require_truncations_rejected<mgc::alert_t>(buf);
  require_short_buffer_rejected(sent);
}

TEST_CASE("alert_t severities are ordered by precedence", "[unit]") {
  REQUIRE(mgc::alert_t::SEVERITY_UNKNOWN < mgc::alert_t::SEVERITY_INFO);
  REQUIRE(mgc::alert_t::SEVERITY_INFO < mgc::alert_t::SEVERITY_WARN);
  REQUIRE(mgc::alert_t::SEVERITY_WARN < mgc::alert_t::SEVERITY_SLOW_DOWN);
  REQUIRE(mgc::alert_t::SEVERITY_SLOW_DOWN < mgc::alert_t::SEVERITY_STOP);
  REQUIRE(mgc::alert_t::SEVERITY_STOP < mgc::alert_t::SEVERITY_FAULT);
}

TEST_CASE("plan_t round-trips every field", "[unit]") {
  const mgc::plan_t sent = make_plan();
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::plan_t>(buf);

  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.planner_name == sent.planner_name);
  REQUIRE(got.seed == sent.seed);
  REQUIRE(got.status == sent.status);
  REQUIRE(got.num_joints == sent.num_joints);
  REQUIRE(got.num_waypoints == sent.num_waypoints);
  REQUIRE(got.positions.size() == 4);
  REQUIRE(got.positions == sent.positions);
  REQUIRE(got.moving_joint.size() == 4);
  REQUIRE(got.moving_joint == sent.moving_joint);
  REQUIRE(got.planning_time == sent.planning_time);
  REQUIRE(got.iterations == sent.iterations);
  REQUIRE(got.path_length == sent.path_length);
  REQUIRE(got.execution_time == sent.execution_time);

  require_truncations_rejected<mgc::plan_t>(buf);
  require_short_buffer_rejected(sent);
}

TEST_CASE("plan_t without waypoints round-trips (failed plan)", "[unit]") {
  mgc::plan_t sent = make_plan();
  sent.status = mgc::plan_t::STATUS_TIMEOUT;
  sent.num_waypoints = 0;
  sent.positions.clear();
  sent.moving_joint.clear();

  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::plan_t>(buf);

  REQUIRE(got.status == mgc::plan_t::STATUS_TIMEOUT);
  REQUIRE(got.num_joints == sent.num_joints);
  REQUIRE(got.num_waypoints == 0);
  REQUIRE(got.positions.empty());
  REQUIRE(got.moving_joint.empty());
  REQUIRE(got.planner_name == sent.planner_name);
  REQUIRE(got.execution_time == sent.execution_time);
}

TEST_CASE("fingerprints differ between types and reject foreign messages", "[unit]") {
  const std::int64_t machine_state = mgc::machine_state_t::getHash();
  const std::int64_t guidance = mgc::operator_guidance_t::getHash();
  const std::int64_t alert = mgc::alert_t::getHash();
  const std::int64_t plan = mgc::plan_t::getHash();

  REQUIRE(machine_state != guidance);
  REQUIRE(machine_state != alert);
  REQUIRE(machine_state != plan);
  REQUIRE(guidance != alert);
  REQUIRE(guidance != plan);
  REQUIRE(alert != plan);

  // A valid message of one type must not decode as another.
  const Bytes state_buf = encode_checked(make_machine_state());
  const int state_size = static_cast<int>(state_buf.size());
  mgc::alert_t as_alert{};
  REQUIRE(as_alert.decode(state_buf.data(), 0, state_size) < 0);
  mgc::operator_guidance_t as_guidance{};
  REQUIRE(as_guidance.decode(state_buf.data(), 0, state_size) < 0);
  mgc::plan_t as_plan{};
  REQUIRE(as_plan.decode(state_buf.data(), 0, state_size) < 0);

  const Bytes alert_buf = encode_checked(make_alert());
  mgc::machine_state_t as_state{};
  REQUIRE(as_state.decode(alert_buf.data(), 0, static_cast<int>(alert_buf.size())) < 0);
}

namespace {

// Copies what arrives; assertions happen on the test's side, after handle().
struct Receiver {
  void on_machine_state(const lcm::ReceiveBuffer* /*rbuf*/, const std::string& channel,
                        const mgc::machine_state_t* msg) {
    ++machine_state_count;
    machine_state_channel = channel;
    machine_state = *msg;
  }
  void on_plan(const lcm::ReceiveBuffer* /*rbuf*/, const std::string& channel,
               const mgc::plan_t* msg) {
    ++plan_count;
    plan_channel = channel;
    plan = *msg;
  }

  int machine_state_count = 0;
  std::string machine_state_channel;
  mgc::machine_state_t machine_state{};
  int plan_count = 0;
  std::string plan_channel;
  mgc::plan_t plan{};
};

}  // namespace

TEST_CASE("messages cross the memq:// transport to a subscriber", "[lcm]") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());

  Receiver receiver;
  REQUIRE(lcm.subscribe("MGC_MACHINE_STATE", &Receiver::on_machine_state, &receiver) != nullptr);
  REQUIRE(lcm.subscribe("MGC_PLAN", &Receiver::on_plan, &receiver) != nullptr);

  // The loop's way: encode into a caller-owned buffer, publish the raw bytes.
  const mgc::machine_state_t sent_state = make_machine_state();
  std::array<std::uint8_t, 1024> buf{};
  const int len = sent_state.encode(buf.data(), 0, static_cast<int>(buf.size()));
  REQUIRE(len == sent_state.getEncodedSize());
  REQUIRE(lcm.publish("MGC_MACHINE_STATE", buf.data(), static_cast<unsigned int>(len)) == 0);

  // Off-loop tools may use the allocating convenience overload.
  const mgc::plan_t sent_plan = make_plan();
  REQUIRE(lcm.publish("MGC_PLAN", &sent_plan) == 0);

  // memq delivers in publish order; one message per handle call.
  REQUIRE(lcm.handle() == 0);
  REQUIRE(receiver.machine_state_count == 1);
  REQUIRE(receiver.plan_count == 0);
  REQUIRE(lcm.handleTimeout(1000) > 0);
  REQUIRE(receiver.plan_count == 1);

  // Nothing left: a bounded wait times out instead of blocking.
  REQUIRE(lcm.handleTimeout(10) == 0);

  REQUIRE(receiver.machine_state_count == 1);
  REQUIRE(receiver.machine_state_channel == "MGC_MACHINE_STATE");
  REQUIRE(receiver.machine_state.utime == sent_state.utime);
  REQUIRE(receiver.machine_state.utime_sample == sent_state.utime_sample);
  REQUIRE(receiver.machine_state.num_joints == sent_state.num_joints);
  REQUIRE(as_array(receiver.machine_state.joint_position) == as_array(sent_state.joint_position));
  REQUIRE(receiver.machine_state.supervisor_state == sent_state.supervisor_state);
  REQUIRE(receiver.machine_state.load_moment_pct == sent_state.load_moment_pct);

  REQUIRE(receiver.plan_channel == "MGC_PLAN");
  REQUIRE(receiver.plan.planner_name == sent_plan.planner_name);
  REQUIRE(receiver.plan.positions == sent_plan.positions);
  REQUIRE(receiver.plan.moving_joint == sent_plan.moving_joint);
}

// The operator feed's types (docs/operator-feed.md).

TEST_CASE("operator_command_t round-trips every field and keeps mac last", "[unit]") {
  static_assert(std::extent_v<decltype(mgc::operator_command_t::goal_position)> ==
                mgc::operator_command_t::MAX_JOINTS);
  static_assert(std::extent_v<decltype(mgc::operator_command_t::mac)> == mgc::operator_command_t::MAC_BYTES);
  mgc::operator_command_t sent{};
  sent.utime = 0x0102030405060708LL;
  sent.kind = mgc::operator_command_t::KIND_GOAL;
  sent.sender_id = -12345;
  sent.sequence = 1'700'000'000'123'456LL;
  sent.num_joints = 4;
  for (int j = 0; j < 8; ++j) sent.goal_position[j] = 0.25 * (j + 1) - 1.0;
  sent.alert_id = 42;
  for (int i = 0; i < 32; ++i) sent.mac[i] = static_cast<std::uint8_t>(0xA0 + i);

  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::operator_command_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.kind == sent.kind);
  REQUIRE(got.sender_id == sent.sender_id);
  REQUIRE(got.sequence == sent.sequence);
  REQUIRE(got.num_joints == sent.num_joints);
  REQUIRE(as_array(got.goal_position) == as_array(sent.goal_position));
  REQUIRE(got.alert_id == sent.alert_id);
  REQUIRE(as_array(got.mac) == as_array(sent.mac));
  // The MAC covers the encoding without its last 32 bytes, so those must be the mac field.
  REQUIRE(std::equal(buf.end() - 32, buf.end(), std::begin(sent.mac)));
  require_truncations_rejected<mgc::operator_command_t>(buf);
}

TEST_CASE("command_status_t round-trips every field", "[unit]") {
  mgc::command_status_t sent{};
  sent.utime = 77;
  sent.sender_id = 3;
  sent.sequence = -9;
  sent.kind = mgc::operator_command_t::KIND_ACKNOWLEDGE;
  sent.accepted = false;
  sent.reason = mgc::command_status_t::REASON_STALE_SEQUENCE;
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::command_status_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.sender_id == sent.sender_id);
  REQUIRE(got.sequence == sent.sequence);
  REQUIRE(got.kind == sent.kind);
  REQUIRE(got.accepted == sent.accepted);
  REQUIRE(got.reason == sent.reason);
  require_truncations_rejected<mgc::command_status_t>(buf);
}

TEST_CASE("loop_timing_t round-trips every field", "[unit]") {
  mgc::loop_timing_t sent{};
  sent.utime = 1;
  sent.period_us = 10'000;
  sent.cycles = 123'456'789'012LL;
  sent.deadline_misses = 3;
  sent.skipped_periods = 2;
  sent.watchdog_trips = 1;
  sent.compute_p99_us = 410;
  sent.compute_max_us = 1'250;
  sent.lateness_p99_us = 60;
  sent.lateness_max_us = 900;
  sent.snapshots_dropped = 5;
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::loop_timing_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.period_us == sent.period_us);
  REQUIRE(got.cycles == sent.cycles);
  REQUIRE(got.deadline_misses == sent.deadline_misses);
  REQUIRE(got.skipped_periods == sent.skipped_periods);
  REQUIRE(got.watchdog_trips == sent.watchdog_trips);
  REQUIRE(got.compute_p99_us == sent.compute_p99_us);
  REQUIRE(got.compute_max_us == sent.compute_max_us);
  REQUIRE(got.lateness_p99_us == sent.lateness_p99_us);
  REQUIRE(got.lateness_max_us == sent.lateness_max_us);
  REQUIRE(got.snapshots_dropped == sent.snapshots_dropped);
  require_truncations_rejected<mgc::loop_timing_t>(buf);
}

TEST_CASE("health_counters_t round-trips every field", "[unit]") {
  static_assert(std::extent_v<decltype(mgc::health_counters_t::refused_by_reason)> ==
                mgc::health_counters_t::MAX_REASONS);
  static_assert(mgc::command_status_t::NUM_REASONS <= mgc::health_counters_t::MAX_REASONS);
  mgc::health_counters_t sent{};
  sent.utime = 9;
  sent.bus_frames_decoded = 123'456'789'012LL;
  sent.bus_unknown_frames = 2;
  sent.bus_wrong_length = 3;
  sent.bus_wrong_id = 4;
  sent.bus_out_of_range = 5;
  sent.bus_reserved_bits = 6;
  sent.bus_other = 7;
  sent.bus_implausible_values = 8;
  sent.commands_accepted = 10;
  sent.commands_refused = 11;
  for (int r = 0; r < mgc::health_counters_t::MAX_REASONS; ++r) sent.refused_by_reason[r] = 100 + r;
  sent.refusal_alerts = 12;
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::health_counters_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.bus_frames_decoded == sent.bus_frames_decoded);
  REQUIRE(got.bus_unknown_frames == sent.bus_unknown_frames);
  REQUIRE(got.bus_wrong_length == sent.bus_wrong_length);
  REQUIRE(got.bus_wrong_id == sent.bus_wrong_id);
  REQUIRE(got.bus_out_of_range == sent.bus_out_of_range);
  REQUIRE(got.bus_reserved_bits == sent.bus_reserved_bits);
  REQUIRE(got.bus_other == sent.bus_other);
  REQUIRE(got.bus_implausible_values == sent.bus_implausible_values);
  REQUIRE(got.commands_accepted == sent.commands_accepted);
  REQUIRE(got.commands_refused == sent.commands_refused);
  REQUIRE(as_array(got.refused_by_reason) == as_array(sent.refused_by_reason));
  REQUIRE(got.refusal_alerts == sent.refusal_alerts);
  require_truncations_rejected<mgc::health_counters_t>(buf);
}

TEST_CASE("operator_instruction_t round-trips every field", "[unit]") {
  mgc::operator_instruction_t sent{};
  sent.utime = 5;
  sent.text = "swing left 32 deg, then boom up 4 deg";
  sent.segment_index = 2;
  sent.obstacle_clearance = 4.25;
  sent.obstacle_index = 7;
  sent.limit_margin = 0.125;
  sent.limit_joint = 1;
  sent.envelope_distance = 1.75;
  sent.envelope_limit = mgc::operator_instruction_t::ENVELOPE_WALL;
  sent.envelope_wall = 2;
  sent.load_moment_pct = 63.5;
  const Bytes buf = encode_checked(sent);
  const auto got = decode_checked<mgc::operator_instruction_t>(buf);
  REQUIRE(got.utime == sent.utime);
  REQUIRE(got.text == sent.text);
  REQUIRE(got.segment_index == sent.segment_index);
  REQUIRE(got.obstacle_clearance == sent.obstacle_clearance);
  REQUIRE(got.obstacle_index == sent.obstacle_index);
  REQUIRE(got.limit_margin == sent.limit_margin);
  REQUIRE(got.limit_joint == sent.limit_joint);
  REQUIRE(got.envelope_distance == sent.envelope_distance);
  REQUIRE(got.envelope_limit == sent.envelope_limit);
  REQUIRE(got.envelope_wall == sent.envelope_wall);
  REQUIRE(got.load_moment_pct == sent.load_moment_pct);
  require_truncations_rejected<mgc::operator_instruction_t>(buf);
}

TEST_CASE("a string length below 1 from the wire is refused, not thrown", "[unit]") {
  // The length counts the string's NUL, so it is at least 1; lcm-gen's decoder took length - 1
  // characters of whatever it read, and threw std::length_error out of decode() for 0 or less.
  mgc::operator_instruction_t words{};
  words.text = "hold";
  Bytes good = encode_checked(words);
  mgc::plan_t plan{};
  plan.planner_name = "mgc";
  Bytes good_plan = encode_checked(plan);
  constexpr std::size_t kLengthAt = 16;  // after the fingerprint and utime
  for (const std::int32_t length : {0, -1, -5, std::numeric_limits<std::int32_t>::min()}) {
    CAPTURE(length);
    for (Bytes* buf : {&good, &good_plan}) {
      const auto u = static_cast<std::uint32_t>(length);
      for (std::size_t i = 0; i < 4; ++i) (*buf)[kLengthAt + i] = static_cast<std::uint8_t>(u >> (24 - 8 * i));
    }
    mgc::operator_instruction_t got{};
    int used = 0;
    REQUIRE_NOTHROW(used = got.decode(good.data(), 0, static_cast<int>(good.size())));
    CHECK(used < 0);
    mgc::plan_t got_plan{};
    REQUIRE_NOTHROW(used = got_plan.decode(good_plan.data(), 0, static_cast<int>(good_plan.size())));
    CHECK(used < 0);
  }
}

TEST_CASE("the feed's fingerprints differ from each other and from the loop's types", "[unit]") {
  const std::array<std::int64_t, 9> hashes = {
      mgc::machine_state_t::getHash(),      mgc::operator_guidance_t::getHash(),
      mgc::alert_t::getHash(),              mgc::plan_t::getHash(),
      mgc::operator_command_t::getHash(),   mgc::command_status_t::getHash(),
      mgc::loop_timing_t::getHash(),        mgc::operator_instruction_t::getHash(),
      mgc::health_counters_t::getHash(),
  };
  for (std::size_t i = 0; i < hashes.size(); ++i) {
    for (std::size_t j = i + 1; j < hashes.size(); ++j) {
      CAPTURE(i, j);
      REQUIRE(hashes[i] != hashes[j]);
    }
  }
}
