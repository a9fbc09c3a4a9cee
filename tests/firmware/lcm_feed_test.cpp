// SPDX-License-Identifier: Apache-2.0
// The publisher end to end through LCM in-process: snapshots in, messages out on their channels;
// commands in, accepted ones on the loop's queue, rejected ones as alerts. memq:// for the
// deterministic cases; one case over the default udpm provider on loopback (ttl=0).

#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/health_counters_t.hpp>
#include <mgc/firmware/lcm_feed.hpp>
#include <mgc/firmware/operator_words.hpp>
#include <mgc/loop_timing_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/obstacle_poses_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>

#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

using namespace mgc::firmware;
using mgc::alert_t;
using mgc::command_status_t;
using mgc::operator_command_t;
using mgc::operator_instruction_t;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Stepped clocks for the memq cases: CLOCK_REALTIME for the sequences, monotonic for the rates.
constexpr std::int64_t kT0 = 1'700'000'000'000'000;
std::atomic<std::int64_t> g_realtime_us{kT0};
std::atomic<std::int64_t> g_monotonic_us{1'000'000};
std::int64_t test_realtime_us() noexcept { return g_realtime_us.load(); }
std::int64_t test_monotonic_us() noexcept { return g_monotonic_us.load(); }

FeedConfig memq_config() {
  g_realtime_us = kT0;
  g_monotonic_us = 1'000'000;
  FeedConfig config;
  config.lcm_url = "memq://";
  config.realtime_us = &test_realtime_us;
  config.monotonic_us = &test_monotonic_us;
  return config;
}

std::string temp_path(const char* name) {
  return "/tmp/mgc_lcm_feed_test_" + std::to_string(::getpid()) + "_" + name;
}

CommandKey test_key() {
  std::array<std::uint8_t, kCommandKeyBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(0x5a ^ i);
  return CommandKey(k);
}

//! Records every message on the feed's channels, decoded.
struct Recorder {
  std::vector<mgc::machine_state_t> states;
  std::vector<mgc::operator_guidance_t> guidance;
  std::vector<mgc::operator_instruction_t> instructions;
  std::vector<alert_t> alerts;
  std::vector<mgc::plan_t> plans;
  std::vector<mgc::loop_timing_t> timing;
  std::vector<command_status_t> statuses;
  std::vector<mgc::health_counters_t> health;
  std::vector<mgc::obstacle_poses_t> obstacles;

  template <class Msg>
  static void keep(std::vector<Msg>& into, const lcm::ReceiveBuffer* rbuf) {
    Msg m{};
    REQUIRE(m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) == static_cast<int>(rbuf->data_size));
    into.push_back(m);
  }
  void on_state(const lcm::ReceiveBuffer* r, const std::string&) { keep(states, r); }
  void on_guidance(const lcm::ReceiveBuffer* r, const std::string&) { keep(guidance, r); }
  void on_instruction(const lcm::ReceiveBuffer* r, const std::string&) { keep(instructions, r); }
  void on_alert(const lcm::ReceiveBuffer* r, const std::string&) { keep(alerts, r); }
  void on_plan(const lcm::ReceiveBuffer* r, const std::string&) { keep(plans, r); }
  void on_timing(const lcm::ReceiveBuffer* r, const std::string&) { keep(timing, r); }
  void on_status(const lcm::ReceiveBuffer* r, const std::string&) { keep(statuses, r); }
  void on_health(const lcm::ReceiveBuffer* r, const std::string&) { keep(health, r); }
  void on_obstacles(const lcm::ReceiveBuffer* r, const std::string&) { keep(obstacles, r); }

  void subscribe(lcm::LCM& lcm) {
    lcm.subscribe(channel::kMachineState, &Recorder::on_state, this);
    lcm.subscribe(channel::kOperatorGuidance, &Recorder::on_guidance, this);
    lcm.subscribe(channel::kOperatorInstruction, &Recorder::on_instruction, this);
    lcm.subscribe(channel::kAlert, &Recorder::on_alert, this);
    lcm.subscribe(channel::kPlan, &Recorder::on_plan, this);
    lcm.subscribe(channel::kLoopTiming, &Recorder::on_timing, this);
    lcm.subscribe(channel::kCommandStatus, &Recorder::on_status, this);
    lcm.subscribe(channel::kHealth, &Recorder::on_health, this);
    lcm.subscribe(channel::kObstaclePoses, &Recorder::on_obstacles, this);
  }
};

//! A mobile-crane snapshot on a two-segment plan, as the loop would fill it.
std::unique_ptr<GuidanceSnapshot> crane_snapshot(std::uint64_t cycle) {
  auto s = std::make_unique<GuidanceSnapshot>();
  s->cycle_index = cycle;
  s->utime_us = static_cast<std::int64_t>(cycle) * 10'000;
  s->utime_sample_us = s->utime_us - 500;
  s->machine_kind = mgc::planning::MachineKind::MobileCrane;
  s->num_joints = 4;
  s->joint_position = {0.0, 40 * kDeg, 20.0, 10.0};
  s->supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
  s->load_moment_pct = 63.5;
  s->plan.plan_id = 1;
  s->plan.status = mgc::plan_t::STATUS_EXACT;
  s->plan.num_joints = 4;
  s->plan.num_waypoints = 3;
  s->plan.positions[0] = {0.0, 40 * kDeg, 20.0, 10.0};
  s->plan.positions[1] = {32 * kDeg, 40 * kDeg, 20.0, 10.0};
  s->plan.positions[2] = {32 * kDeg, 44 * kDeg, 20.0, 10.0};
  s->plan.moving_joint = {0, 1, mgc::plan_t::NO_JOINT};
  s->instruction = mgc::operator_guidance_t::INSTRUCTION_MOVE_JOINT;
  s->segment_index = 0;
  s->moving_joint = 0;
  next_moves_in_words(s->machine_kind, 4, s->joint_position,
                      std::span(s->plan.positions.data(), static_cast<std::size_t>(s->plan.num_waypoints)), 0, 2,
                      s->instruction_text);
  s->obstacle_clearance_m = 4.25;
  s->obstacle_index = 2;
  s->limit_margin = 0.3;
  s->limit_joint = 1;
  s->envelope_distance_m = 6.5;
  s->envelope_limit = operator_instruction_t::ENVELOPE_HEIGHT_CEILING;
  s->num_alerts = 1;
  s->alerts[0].alert_id = 5;
  s->alerts[0].severity = alert_t::SEVERITY_WARN;
  s->alerts[0].source = alert_t::SOURCE_COLLISION;
  s->alerts[0].clear_condition = alert_t::CLEAR_WHEN_CONDITION_CLEARS;
  s->alerts[0].value_unit = alert_t::UNIT_METRE;
  s->alerts[0].value = 4.25;
  s->alerts[0].limit = 5.0;
  s->alerts[0].index = 2;
  s->alerts[0].min_clearance_m = 4.25;
  s->timing.period_us = 10'000;
  s->timing.cycles = cycle;
  s->timing.compute_max_us = 840;
  return s;
}

void send(lcm::LCM& lcm, const operator_command_t& c) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(c.getEncodedSize()));
  REQUIRE(c.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  REQUIRE(lcm.publish(channel::kCommand, buf.data(), static_cast<unsigned>(buf.size())) == 0);
}

operator_command_t signed_goal(std::int64_t sequence, const CommandKey& key, std::int32_t sender = 3) {
  operator_command_t c{};
  c.kind = operator_command_t::KIND_GOAL;
  c.sender_id = sender;
  c.sequence = sequence;
  c.num_joints = 4;
  c.goal_position[0] = 1.0;
  c.goal_position[1] = 0.8;
  c.goal_position[2] = 25.0;
  c.goal_position[3] = 12.0;
  sign_command(c, key);
  return c;
}

//! memq delivers one message per handle call: drain until quiet.
void drain(FeedPublisher& feed) {
  for (int i = 0; i < 200; ++i) feed.run_once(0);
}

}  // namespace

TEST_CASE("snapshots come out on their channels over memq://", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  FeedPublisher feed(config, test_key(), *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());

  REQUIRE(snapshots->try_push(*crane_snapshot(1)));
  REQUIRE(snapshots->try_push(*crane_snapshot(2)));
  auto cleared = crane_snapshot(3);
  cleared->num_alerts = 0;
  REQUIRE(snapshots->try_push(*cleared));
  drain(feed);

  REQUIRE(rec.states.size() == 3);
  REQUIRE(rec.states[0].machine_kind == mgc::machine_state_t::MACHINE_KIND_MOBILE_CRANE);
  REQUIRE(rec.states[0].num_joints == 4);
  REQUIRE(rec.states[0].joint_position[2] == 20.0);
  REQUIRE(std::isnan(rec.states[0].joint_position[4]));
  REQUIRE(rec.states[0].load_moment_pct == 63.5);
  REQUIRE(rec.states[0].utime_sample == 9'500);

  // One plan per plan id.
  REQUIRE(rec.plans.size() == 1);
  REQUIRE(rec.plans[0].num_waypoints == 3);
  REQUIRE(rec.plans[0].positions[1][0] == Approx(32 * kDeg));
  REQUIRE(rec.plans[0].moving_joint[1] == 1);

  // Guidance at 10 Hz: the three snapshots were published within one period and say the same.
  REQUIRE(rec.guidance.size() == 1);
  REQUIRE(rec.guidance[0].num_segments == 2);
  REQUIRE(rec.instructions.size() == 1);
  REQUIRE(rec.instructions[0].text == "swing left 32 deg, then boom up 4 deg");
  REQUIRE(rec.instructions[0].obstacle_clearance == 4.25);
  REQUIRE(rec.instructions[0].limit_joint == 1);
  REQUIRE(rec.instructions[0].envelope_distance == 6.5);
  REQUIRE(rec.instructions[0].envelope_limit == operator_instruction_t::ENVELOPE_HEIGHT_CEILING);
  REQUIRE(rec.instructions[0].envelope_wall == -1);
  REQUIRE(rec.instructions[0].load_moment_pct == 63.5);

  // Alert raised once (unchanged in the second snapshot), then cleared with active = false.
  REQUIRE(rec.alerts.size() == 2);
  REQUIRE(rec.alerts[0].alert_id == 5);
  REQUIRE(rec.alerts[0].active);
  REQUIRE(rec.alerts[0].value == 4.25);
  REQUIRE(rec.alerts[1].alert_id == 5);
  REQUIRE_FALSE(rec.alerts[1].active);

  REQUIRE(rec.timing.size() == 1);
  REQUIRE(rec.timing[0].period_us == 10'000);
  REQUIRE(rec.timing[0].compute_max_us == 840);
  REQUIRE(feed.counters().snapshots_published == 3);
}

TEST_CASE("a changed instruction is published at once, a full queue's drops reach loop_timing_t", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  config.timing_period_us = 0;  // every snapshot, to see the counter move
  FeedPublisher feed(config, test_key(), *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());

  auto s = crane_snapshot(1);
  for (std::size_t i = 0; i < kSnapshotQueueCapacity + 5; ++i) snapshots->try_push(*s);
  REQUIRE(snapshots->dropped() == 5);
  auto next = crane_snapshot(2);
  drain(feed);
  next->joint_position[0] = 32 * kDeg;
  next->segment_index = 1;
  next_moves_in_words(next->machine_kind, 4, next->joint_position,
                      std::span(next->plan.positions.data(), 3), 1, 2, next->instruction_text);
  REQUIRE(snapshots->try_push(*next));
  drain(feed);
  REQUIRE(rec.instructions.size() == 2);
  REQUIRE(rec.instructions[1].text == "boom up 4 deg");
  REQUIRE(rec.timing.back().snapshots_dropped == 5);
}

TEST_CASE("tracked obstacles go out at 10 Hz with their pose, validity and stillness, none without trackers", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  FeedPublisher feed(config, test_key(), *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());

  auto s = crane_snapshot(1000);  // the loop's clock at 10 s
  REQUIRE(snapshots->try_push(*s));  // no trackers: no message
  drain(feed);
  REQUIRE(rec.states.size() == 1);
  REQUIRE(rec.obstacles.empty());

  s->num_tracked = 2;
  s->num_obstacles = 2;
  s->obstacles[0] = {0, true, false, {-30.0, -6.0, 0.0}, -90 * kDeg, 0.12, 1.5, 0.05, s->utime_us - 40'000};
  s->obstacles[1] = {3, false, true, {4.0, 5.0, 0.0}, 0.25, 0.3, kNaN, kNaN, s->utime_us - 2'500'000};
  // 100 Hz snapshots over 0.25 s of the publisher's clock: poses at 0, 0.1 and 0.2 s.
  for (int k = 0; k < 25; ++k) {
    REQUIRE(snapshots->try_push(*s));
    drain(feed);
    g_monotonic_us += 10'000;
  }
  REQUIRE(rec.obstacles.size() == 3);
  const mgc::obstacle_poses_t& m = rec.obstacles[0];
  REQUIRE(m.num_tracked == 2);
  REQUIRE(m.num_obstacles == 2);
  REQUIRE(m.obstacle_index[0] == 0);
  REQUIRE(m.valid[0]);
  REQUIRE_FALSE(m.still[0]);
  REQUIRE(m.x[0] == -30.0);
  REQUIRE(m.y[0] == -6.0);
  REQUIRE(m.yaw[0] == Approx(-90 * kDeg));
  REQUIRE(m.position_sigma[0] == 0.12);
  REQUIRE(m.speed[0] == 1.5);
  REQUIRE(m.yaw_rate[0] == 0.05);
  REQUIRE(m.fix_age[0] == Approx(0.04));
  REQUIRE(m.obstacle_index[1] == 3);
  REQUIRE_FALSE(m.valid[1]);
  REQUIRE(m.still[1]);
  REQUIRE(m.x[1] == 4.0);
  REQUIRE(std::isnan(m.speed[1]));
  REQUIRE(std::isnan(m.yaw_rate[1]));
  REQUIRE(m.fix_age[1] == Approx(2.5));
  // The unused entries are marked unused.
  REQUIRE(m.obstacle_index[2] == -1);
  REQUIRE_FALSE(m.valid[2]);
  REQUIRE(std::isnan(m.x[7]));
  REQUIRE(rec.obstacles[1].utime - rec.obstacles[0].utime == 100'000);
}

TEST_CASE("commands: accepted ones reach the loop's queue, rejected ones raise alerts", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  const CommandKey key = test_key();
  FeedPublisher feed(config, key, *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());

  send(feed.lcm(), signed_goal(kT0 + 10, key));
  send(feed.lcm(), signed_goal(kT0 + 10, key));  // replay
  drain(feed);
  g_monotonic_us += 1'000'000;  // the next refusal is a period later: alerted too
  operator_command_t tampered = signed_goal(kT0 + 11, key);
  tampered.goal_position[2] = 40.0;
  send(feed.lcm(), tampered);
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  stop.sender_id = 77;
  send(feed.lcm(), stop);
  drain(feed);

  AcceptedCommand got{};
  REQUIRE(commands->try_pop(got));
  REQUIRE(got.kind == operator_command_t::KIND_GOAL);
  REQUIRE(got.sequence == kT0 + 10);
  REQUIRE(got.num_joints == 4);
  REQUIRE(got.goal_position[2] == 25.0);
  REQUIRE(commands->try_pop(got));
  REQUIRE(got.kind == operator_command_t::KIND_STOP);
  REQUIRE(got.sender_id == 77);
  REQUIRE_FALSE(commands->try_pop(got));
  REQUIRE(feed.stops_received() == 1);

  REQUIRE(rec.statuses.size() == 4);
  REQUIRE(rec.statuses[0].accepted);
  REQUIRE(rec.statuses[1].reason == command_status_t::REASON_STALE_SEQUENCE);
  REQUIRE(rec.statuses[2].reason == command_status_t::REASON_BAD_MAC);
  REQUIRE(rec.statuses[3].accepted);

  REQUIRE(rec.alerts.size() == 2);
  for (const alert_t& a : rec.alerts) {
    REQUIRE(a.active);
    REQUIRE(a.source == alert_t::SOURCE_OPERATOR);
    REQUIRE(a.severity == alert_t::SEVERITY_WARN);
    REQUIRE(a.index == 3);
  }
  REQUIRE(rec.alerts[0].value == command_status_t::REASON_STALE_SEQUENCE);
  REQUIRE(rec.alerts[1].value == command_status_t::REASON_BAD_MAC);
  REQUIRE(rec.alerts[0].alert_id != rec.alerts[1].alert_id);
  REQUIRE(feed.counters().commands_accepted == 2);
  REQUIRE(feed.counters().commands_rejected == 2);
}

TEST_CASE("1000 refusals within a second raise one alert, every refusal is counted by reason", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  const CommandKey key = test_key();
  const CommandKey wrong(std::array<std::uint8_t, kCommandKeyBytes>{});
  FeedPublisher feed(config, key, *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());

  send(feed.lcm(), signed_goal(kT0, key));  // the real station
  drain(feed);
  // 1000 refusals 0.999 ms apart: 0 .. 0.999 s after the first one.
  for (int i = 0; i < 1000; ++i) {
    operator_command_t c;
    if (i % 4 == 0) {
      c = signed_goal(kT0 + 1 + i, wrong);  // BAD_MAC
    } else if (i % 4 == 1) {
      c = signed_goal(kT0, key);  // STALE_SEQUENCE: a replay
    } else if (i % 4 == 2) {
      c = signed_goal(std::numeric_limits<std::int64_t>::max(), key);  // FUTURE_SEQUENCE
    } else {
      c = signed_goal(kT0 - 60'000'000, key, 50 + i);  // OLD_SEQUENCE, from many sender ids
    }
    send(feed.lcm(), c);
    // memq hands over one message per call, and each subscription queues at most 30: keep up.
    for (int k = 0; k < 4; ++k) feed.run_once(0);
    g_monotonic_us += 999;
  }
  drain(feed);
  CHECK(rec.alerts.size() == 1);
  CHECK(feed.refusals().alerts() == 1);
  CHECK(feed.refusals().total() == 1000);
  CHECK(feed.refusals().count(command_status_t::REASON_BAD_MAC) == 250);
  CHECK(feed.refusals().count(command_status_t::REASON_STALE_SEQUENCE) == 250);
  CHECK(feed.refusals().count(command_status_t::REASON_FUTURE_SEQUENCE) == 250);
  CHECK(feed.refusals().count(command_status_t::REASON_OLD_SEQUENCE) == 250);
  CHECK(rec.statuses.size() == 1001);  // every sender still learns its verdict

  // The real station is still accepted, and a refusal a second after the alert is alerted again.
  g_realtime_us += 1'000'000;
  g_monotonic_us += 1'000;  // exactly one period after the first refusal
  send(feed.lcm(), signed_goal(kT0 + 1'000'000, key));
  send(feed.lcm(), signed_goal(kT0 + 1'000'000, key));
  drain(feed);
  CHECK(rec.statuses[1001].accepted);
  CHECK(rec.statuses[1002].reason == command_status_t::REASON_STALE_SEQUENCE);
  CHECK(rec.alerts.size() == 2);

  // The counts reach the feed with the 1 Hz timing, the bus counters from the snapshot with them.
  auto s = crane_snapshot(1);
  s->bus.decoded = 900;
  s->bus.unknown_id = 3;
  s->bus.wrong_length = 2;
  s->bus.out_of_range = 1;
  s->bus.implausible = 4;
  REQUIRE(snapshots->try_push(*s));
  drain(feed);
  REQUIRE(rec.health.size() == 1);
  const mgc::health_counters_t& h = rec.health[0];
  CHECK(h.commands_accepted == 2);
  CHECK(h.commands_refused == 1001);
  CHECK(h.refused_by_reason[command_status_t::REASON_BAD_MAC] == 250);
  CHECK(h.refused_by_reason[command_status_t::REASON_STALE_SEQUENCE] == 251);
  CHECK(h.refused_by_reason[command_status_t::REASON_FUTURE_SEQUENCE] == 250);
  CHECK(h.refused_by_reason[command_status_t::REASON_OLD_SEQUENCE] == 250);
  CHECK(h.refused_by_reason[command_status_t::REASON_ACCEPTED] == 0);
  CHECK(h.refusal_alerts == 2);
  CHECK(h.bus_frames_decoded == 900);
  CHECK(h.bus_unknown_frames == 3);
  CHECK(h.bus_wrong_length == 2);
  CHECK(h.bus_out_of_range == 1);
  CHECK(h.bus_implausible_values == 4);
}

TEST_CASE("the feed saves the counters before the loop sees a goal, a restarted feed refuses its replay", "[lcm]") {
  const std::string path = temp_path("feed.state");
  std::remove(path.c_str());
  const CommandKey key = test_key();
  const operator_command_t recorded = signed_goal(kT0 + 10, key);
  {
    auto snapshots = std::make_unique<SnapshotQueue>();
    auto commands = std::make_unique<CommandQueue>();
    FeedConfig config = memq_config();
    config.command_state_path = path;
    config.sequence_floor = kT0 - kDefaultCommandSkew_us;
    FeedPublisher feed(config, key, *snapshots, *commands);
    send(feed.lcm(), recorded);
    drain(feed);
    AcceptedCommand got{};
    REQUIRE(commands->try_pop(got));
    REQUIRE(load_command_state(path).size() == 1);
    REQUIRE(load_command_state(path)[0].last_sequence == kT0 + 10);
  }
  // Restarted 1 s later: the recording is inside the clock window and above the new floor.
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  g_realtime_us = kT0 + 1'000'000;
  config.command_state_path = path;
  config.sequence_floor = g_realtime_us - kDefaultCommandSkew_us;
  FeedPublisher feed(config, key, *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());
  send(feed.lcm(), recorded);
  drain(feed);
  AcceptedCommand got{};
  CHECK_FALSE(commands->try_pop(got));
  REQUIRE(rec.statuses.size() == 1);
  CHECK(rec.statuses[0].reason == command_status_t::REASON_STALE_SEQUENCE);
  std::remove(path.c_str());
}

TEST_CASE("state file: a corrupt or unwritable one stops the start, a failed save refuses the goal", "[lcm]") {
  const CommandKey key = test_key();
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  const std::string corrupt = temp_path("corrupt.state");
  {
    std::FILE* f = std::fopen(corrupt.c_str(), "w");
    REQUIRE(f != nullptr);
    std::fputs("mgc-command-state 1\nsender 3 oops\n", f);
    std::fclose(f);
  }
  FeedConfig config = memq_config();
  config.command_state_path = corrupt;
  REQUIRE_THROWS_WITH(FeedPublisher(config, key, *snapshots, *commands),
                      Catch::Contains(corrupt) && Catch::Contains("line 2") && Catch::Contains("oops"));
  std::remove(corrupt.c_str());
  config.command_state_path = temp_path("no-such-dir") + "/x.state";
  REQUIRE_THROWS_WITH(FeedPublisher(config, key, *snapshots, *commands), Catch::Contains("cannot write"));

  // The directory disappears while running: the goal is refused, a stop is still obeyed.
  const std::string dir = temp_path("state-dir");
  REQUIRE(::mkdir(dir.c_str(), 0700) == 0);
  config.command_state_path = dir + "/mgc.state";
  FeedPublisher feed(config, key, *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());
  REQUIRE(std::remove(config.command_state_path.c_str()) == 0);
  REQUIRE(::rmdir(dir.c_str()) == 0);
  send(feed.lcm(), signed_goal(kT0 + 1, key));
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  send(feed.lcm(), stop);
  drain(feed);
  REQUIRE(rec.statuses.size() == 2);
  CHECK(rec.statuses[0].reason == command_status_t::REASON_STATE_NOT_SAVED);
  CHECK(rec.statuses[1].accepted);
  CHECK(feed.counters().last_state_save_errno == ENOENT);
  AcceptedCommand got{};
  REQUIRE(commands->try_pop(got));
  CHECK(got.kind == operator_command_t::KIND_STOP);
  CHECK_FALSE(commands->try_pop(got));
}

TEST_CASE("a full command queue refuses with QUEUE_FULL but still counts the stop", "[lcm]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  FeedConfig config = memq_config();
  FeedPublisher feed(config, test_key(), *snapshots, *commands);
  Recorder rec;
  rec.subscribe(feed.lcm());
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  for (std::size_t i = 0; i < kCommandQueueCapacity + 1; ++i) send(feed.lcm(), stop);
  drain(feed);
  REQUIRE(feed.stops_received() == kCommandQueueCapacity + 1);
  REQUIRE(rec.statuses.back().reason == command_status_t::REASON_QUEUE_FULL);
  REQUIRE(commands->size() == kCommandQueueCapacity);
}

TEST_CASE("the publisher thread over the default udpm provider on loopback", "[lcm]") {
  // The default URL's group on a port of this test's own, so parallel runs do not hear each other.
  const int port = 7700 + static_cast<int>(::getpid() % 200);
  FeedConfig config;
  config.lcm_url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  lcm::LCM probe(config.lcm_url);
  if (!probe.good()) {
    WARN("udpm multicast unavailable here (no multicast route); covered by the memq:// cases only");
    return;
  }
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  const CommandKey key = test_key();
  FeedPublisher feed(config, key, *snapshots, *commands);
  Recorder rec;
  rec.subscribe(probe);
  feed.start();

  REQUIRE(snapshots->try_push(*crane_snapshot(1)));
  const std::int64_t sequence = realtime_clock_us();
  send(probe, signed_goal(sequence, key));
  AcceptedCommand got{};
  bool have_command = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < deadline && 
         (rec.states.empty() || rec.instructions.empty() || rec.statuses.empty() || !have_command)) {
    probe.handleTimeout(20);
    have_command = have_command || commands->try_pop(got);
  }
  feed.stop();
  REQUIRE(have_command);
  REQUIRE(got.sequence == sequence);
  REQUIRE(rec.states.size() == 1);
  REQUIRE(rec.instructions.size() == 1);
  REQUIRE(rec.instructions[0].text == "swing left 32 deg, then boom up 4 deg");
  REQUIRE(rec.statuses.size() == 1);
  REQUIRE(rec.statuses[0].accepted);
}
