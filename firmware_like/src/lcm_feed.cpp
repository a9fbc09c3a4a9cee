// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/lcm_feed.hpp"

#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/health_counters_t.hpp>
#include <mgc/loop_timing_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/obstacle_poses_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace mgc::firmware {
namespace {

static_assert(RefusalCounter::kReasons == health_counters_t::MAX_REASONS);
static_assert(command_status_t::NUM_REASONS <= health_counters_t::MAX_REASONS);
static_assert(kSnapshotMaxObstacles == obstacle_poses_t::MAX_OBSTACLES);

std::int8_t machine_kind_code(planning::MachineKind kind) noexcept {
  switch (kind) {
    case planning::MachineKind::MobileCrane: return machine_state_t::MACHINE_KIND_MOBILE_CRANE;
    case planning::MachineKind::TowerCrane: return machine_state_t::MACHINE_KIND_TOWER_CRANE;
    case planning::MachineKind::Excavator: return machine_state_t::MACHINE_KIND_EXCAVATOR;
  }
  return machine_state_t::MACHINE_KIND_UNKNOWN;
}

bool same_alert(const SnapshotAlert& a, const SnapshotAlert& b) noexcept {
  // Bitwise for the doubles, so NaN == NaN and an unchanged alert is not re-sent every cycle.
  const auto eq = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return a.alert_id == b.alert_id && a.severity == b.severity && a.source == b.source &&
         a.clear_condition == b.clear_condition && a.value_unit == b.value_unit && eq(a.value, b.value) &&
         eq(a.limit, b.limit) && a.index == b.index && eq(a.min_clearance_m, b.min_clearance_m);
}

alert_t to_message(const SnapshotAlert& a, bool active, std::int64_t now_us) noexcept {
  alert_t m{};
  m.utime = now_us;
  m.alert_id = a.alert_id;
  m.severity = a.severity;
  m.source = a.source;
  m.active = active;
  m.clear_condition = a.clear_condition;
  m.value_unit = a.value_unit;
  m.value = a.value;
  m.limit = a.limit;
  m.index = a.index;
  m.min_clearance = a.min_clearance_m;
  return m;
}

std::int64_t to_i64(std::uint64_t v) noexcept { return static_cast<std::int64_t>(v); }

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

std::int64_t realtime_clock_us() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::int64_t monotonic_clock_us() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

bool RefusalCounter::record(std::int8_t reason, std::int64_t now_us) noexcept {
  // Out-of-range codes share the REASON_UNKNOWN slot, so every refusal is counted somewhere.
  const std::size_t slot = reason > 0 && static_cast<std::size_t>(reason) < kReasons ? static_cast<std::size_t>(reason) : 0;
  by_reason_[slot].fetch_add(1, std::memory_order_relaxed);
  total_.fetch_add(1, std::memory_order_relaxed);
  if (alerted_ && now_us - last_alert_us_ < alert_period_us_) return false;
  alerted_ = true;
  last_alert_us_ = now_us;
  alerts_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

std::uint64_t RefusalCounter::count(std::int8_t reason) const noexcept {
  if (reason < 0 || static_cast<std::size_t>(reason) >= kReasons) return 0;
  return by_reason_[static_cast<std::size_t>(reason)].load(std::memory_order_relaxed);
}

FeedPublisher::FeedPublisher(const FeedConfig& config, const CommandKey& key, SnapshotQueue& snapshots,
                             CommandQueue& commands)
    : config_(config),
      lcm_(config.lcm_url),
      auth_(key, config.sequence_floor, config.max_skew_us),
      snapshots_(snapshots),
      commands_(commands),
      refusals_(config.refusal_alert_period_us),
      encode_buf_(4096),
      next_command_alert_id_(kCommandAlertIdBase) {
  if (!lcm_.good()) {
    throw std::runtime_error("LCM: cannot open provider " + config.lcm_url +
                             " (for udpm on loopback: a multicast route on lo, see docs/operator-feed.md)");
  }
  if (!config_.command_state_path.empty()) {
    const std::vector<SenderCounter> saved = load_command_state(config_.command_state_path);
    auth_.restore(saved);
    // Written once now, so that a file that cannot be written is a start error rather than the
    // first goal's refusal, and the counters raised to the floor are what a crash leaves.
    if (!save_state()) {
      const int err = counters_.last_state_save_errno.load();
      throw CommandStateError("command state file " + config_.command_state_path + ": cannot write (" +
                              errno_text(err) + "); expected a writable file in a writable directory");
    }
  }
  lcm_.subscribe(channel::kCommand, &FeedPublisher::on_command, this);
}

FeedPublisher::~FeedPublisher() { stop(); }

void FeedPublisher::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    while (running_.load(std::memory_order_acquire)) run_once(config_.receive_timeout_ms);
  });
}

void FeedPublisher::stop() {
  running_.store(false, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void FeedPublisher::run_once(int timeout_ms) {
  while (snapshots_.try_pop(snapshot_)) publish_snapshot(snapshot_);
  // handleTimeout, never handle(): stop() must be able to end the thread within one timeout.
  lcm_.handleTimeout(timeout_ms);
}

template <class Msg>
void FeedPublisher::publish(const char* channel_name, const Msg& msg) {
  const int size = msg.getEncodedSize();
  if (static_cast<std::size_t>(size) > encode_buf_.size()) encode_buf_.resize(static_cast<std::size_t>(size));
  const int len = msg.encode(encode_buf_.data(), 0, size);
  if (len <= 0) return;
  if (lcm_.publish(channel_name, encode_buf_.data(), static_cast<unsigned>(len)) == 0) {
    counters_.messages_published.fetch_add(1, std::memory_order_relaxed);
  }
}

void FeedPublisher::publish_snapshot(const GuidanceSnapshot& s) {
  const std::int64_t now_us = config_.monotonic_us();
  const int nj = std::clamp(s.num_joints, 0, kMaxJoints);

  machine_state_t state{};
  state.utime = now_us;
  state.utime_sample = s.utime_sample_us;
  state.machine_kind = machine_kind_code(s.machine_kind);
  state.num_joints = static_cast<std::int8_t>(nj);
  for (int j = 0; j < machine_state_t::MAX_JOINTS; ++j) {
    const bool used = j < nj;
    state.joint_position[j] = used ? s.joint_position[static_cast<std::size_t>(j)] : kNaN;
    state.joint_velocity[j] = used ? s.joint_velocity[static_cast<std::size_t>(j)] : kNaN;
    state.joint_acceleration[j] = used ? s.joint_acceleration[static_cast<std::size_t>(j)] : kNaN;
    state.joint_fault_flags[j] = used ? s.joint_fault_flags[static_cast<std::size_t>(j)] : 0;
  }
  std::copy(s.tool_position_m.begin(), s.tool_position_m.end(), state.tool_position);
  state.supervisor_state = s.supervisor_state;
  state.load_moment_pct = s.load_moment_pct;
  publish(channel::kMachineState, state);

  if (s.plan.plan_id != 0 && s.plan.plan_id != last_plan_id_) {
    last_plan_id_ = s.plan.plan_id;
    const int pj = std::clamp(s.plan.num_joints, 0, kMaxJoints);
    const int pw = std::clamp(s.plan.num_waypoints, 0, kSnapshotMaxWaypoints);
    plan_t plan{};
    plan.utime = now_us;
    plan.planner_name = "mgc";
    plan.status = s.plan.status;
    plan.num_joints = pj;
    plan.num_waypoints = pw;
    plan.positions.assign(static_cast<std::size_t>(pw), std::vector<double>(static_cast<std::size_t>(pj)));
    plan.moving_joint.assign(static_cast<std::size_t>(pw), plan_t::NO_JOINT);
    for (int w = 0; w < pw; ++w) {
      const auto wi = static_cast<std::size_t>(w);
      std::copy_n(s.plan.positions[wi].begin(), pj, plan.positions[wi].begin());
      plan.moving_joint[wi] = s.plan.moving_joint[wi];
    }
    plan.planning_time = kNaN;
    plan.iterations = -1;
    plan.path_length = s.plan.path_length;
    plan.execution_time = s.plan.execution_time_s;
    publish(channel::kPlan, plan);
  }

  const bool text_changed = std::strncmp(s.instruction_text.data(), last_text_.data(), last_text_.size()) != 0;
  if (text_changed || s.instruction != last_instruction_ || now_us - last_guidance_us_ >= config_.guidance_period_us) {
    last_guidance_us_ = now_us;
    last_instruction_ = s.instruction;
    last_text_ = s.instruction_text;
    last_text_.back() = '\0';  // the loop's text may be unterminated; never read past the array

    operator_guidance_t g{};
    g.utime = now_us;
    g.instruction = s.instruction;
    g.segment_index = s.segment_index;
    g.num_segments = s.plan.num_waypoints > 0 ? s.plan.num_waypoints - 1 : 0;
    g.moving_joint = s.moving_joint;
    g.target_position = s.target_position;
    g.joint_distance_remaining = s.joint_distance_remaining;
    g.path_distance_remaining = s.path_distance_remaining;
    g.time_remaining = s.time_remaining_s;
    g.speed_scale = s.speed_scale;
    publish(channel::kOperatorGuidance, g);

    operator_instruction_t words{};
    words.utime = now_us;
    words.text = last_text_.data();
    words.segment_index = s.segment_index;
    words.obstacle_clearance = s.obstacle_clearance_m;
    words.obstacle_index = s.obstacle_index;
    words.limit_margin = s.limit_margin;
    words.limit_joint = s.limit_joint;
    words.envelope_distance = s.envelope_distance_m;
    words.envelope_limit = s.envelope_limit;
    words.envelope_wall = s.envelope_wall;
    words.load_moment_pct = s.load_moment_pct;
    publish(channel::kOperatorInstruction, words);
  }

  publish_alerts(s, now_us);

  if (s.num_tracked > 0 && now_us - last_obstacles_us_ >= config_.obstacle_period_us) {
    last_obstacles_us_ = now_us;
    const int no = std::clamp(s.num_obstacles, 0, kSnapshotMaxObstacles);
    obstacle_poses_t poses{};
    poses.utime = now_us;
    poses.num_tracked = static_cast<std::int8_t>(std::clamp(s.num_tracked, 0, 127));
    poses.num_obstacles = static_cast<std::int8_t>(no);
    for (int i = 0; i < obstacle_poses_t::MAX_OBSTACLES; ++i) {
      const bool used = i < no;
      const SnapshotObstacle& o = s.obstacles[static_cast<std::size_t>(i)];
      poses.obstacle_index[i] = used ? o.obstacle_index : -1;
      poses.valid[i] = used && o.valid;
      poses.still[i] = used && o.still;
      poses.x[i] = used ? o.position_m[0] : kNaN;
      poses.y[i] = used ? o.position_m[1] : kNaN;
      poses.z[i] = used ? o.position_m[2] : kNaN;
      poses.yaw[i] = used ? o.yaw_rad : kNaN;
      poses.position_sigma[i] = used ? o.position_sigma_m : kNaN;
      poses.speed[i] = used ? o.speed_m_s : kNaN;
      poses.yaw_rate[i] = used ? o.yaw_rate_rad_s : kNaN;
      poses.fix_age[i] = used && o.fix_us > 0 ? static_cast<double>(s.utime_us - o.fix_us) * 1e-6 : kNaN;
    }
    publish(channel::kObstaclePoses, poses);
  }

  if (now_us - last_timing_us_ >= config_.timing_period_us) {
    last_timing_us_ = now_us;
    loop_timing_t t{};
    t.utime = now_us;
    t.period_us = s.timing.period_us;
    t.cycles = to_i64(s.timing.cycles);
    t.deadline_misses = to_i64(s.timing.deadline_misses);
    t.skipped_periods = to_i64(s.timing.skipped_periods);
    t.watchdog_trips = to_i64(s.timing.watchdog_trips);
    t.compute_p99_us = s.timing.compute_p99_us;
    t.compute_max_us = s.timing.compute_max_us;
    t.lateness_p99_us = s.timing.lateness_p99_us;
    t.lateness_max_us = s.timing.lateness_max_us;
    // The queue counts its own drops; the loop cannot see them in the snapshot it failed to push.
    t.snapshots_dropped = to_i64(std::max(s.timing.snapshots_dropped, snapshots_.dropped()));
    publish(channel::kLoopTiming, t);

    health_counters_t h{};
    h.utime = now_us;
    h.bus_frames_decoded = to_i64(s.bus.decoded);
    h.bus_unknown_frames = to_i64(s.bus.unknown_id);
    h.bus_wrong_length = to_i64(s.bus.wrong_length);
    h.bus_wrong_id = to_i64(s.bus.wrong_id);
    h.bus_out_of_range = to_i64(s.bus.out_of_range);
    h.bus_reserved_bits = to_i64(s.bus.reserved_bits);
    h.bus_other = to_i64(s.bus.other);
    h.bus_implausible_values = to_i64(s.bus.implausible);
    h.commands_accepted = to_i64(counters_.commands_accepted.load(std::memory_order_relaxed));
    h.commands_refused = to_i64(refusals_.total());
    for (int r = 0; r < health_counters_t::MAX_REASONS; ++r) h.refused_by_reason[r] = to_i64(refusals_.count(static_cast<std::int8_t>(r)));
    h.refusal_alerts = to_i64(refusals_.alerts());
    publish(channel::kHealth, h);
  }
  counters_.snapshots_published.fetch_add(1, std::memory_order_relaxed);
}

void FeedPublisher::publish_alerts(const GuidanceSnapshot& s, std::int64_t now_us) {
  const int n = std::clamp(s.num_alerts, 0, kSnapshotMaxAlerts);
  const bool repeat_due = now_us - last_alert_repeat_us_ >= config_.alert_repeat_period_us;
  if (repeat_due) last_alert_repeat_us_ = now_us;
  for (int i = 0; i < n; ++i) {
    const SnapshotAlert& a = s.alerts[static_cast<std::size_t>(i)];
    const auto prev_end = prev_alerts_.begin() + num_prev_alerts_;
    const auto prev = std::find_if(prev_alerts_.begin(), prev_end,
                                   [&](const SnapshotAlert& p) { return p.alert_id == a.alert_id; });
    if (repeat_due || prev == prev_end || !same_alert(*prev, a)) publish(channel::kAlert, to_message(a, true, now_us));
  }
  for (int i = 0; i < num_prev_alerts_; ++i) {
    const SnapshotAlert& p = prev_alerts_[static_cast<std::size_t>(i)];
    const auto end = s.alerts.begin() + n;
    if (std::none_of(s.alerts.begin(), end, [&](const SnapshotAlert& a) { return a.alert_id == p.alert_id; })) {
      // Cleared: one message with active = false, as docs/lcm-types.md promises.
      publish(channel::kAlert, to_message(p, false, now_us));
    }
  }
  std::copy_n(s.alerts.begin(), n, prev_alerts_.begin());
  num_prev_alerts_ = n;
}

void FeedPublisher::reject(const operator_command_t& cmd, std::int8_t reason, std::int64_t now_us) {
  counters_.commands_rejected.fetch_add(1, std::memory_order_relaxed);
  // A flood of refusals raises one alert per period; the counts say how many and why.
  if (!refusals_.record(reason, now_us)) return;
  alert_t a{};
  a.utime = now_us;
  a.alert_id = next_command_alert_id_++;
  a.severity = alert_t::SEVERITY_WARN;
  a.source = alert_t::SOURCE_OPERATOR;
  a.active = true;
  // A refused command is an event, not a condition that goes away: someone has to look at it.
  a.clear_condition = alert_t::CLEAR_ON_OPERATOR_ACK;
  a.value_unit = alert_t::UNIT_NONE;
  a.value = static_cast<double>(reason);  // command_status_t::REASON_*
  a.limit = kNaN;
  a.index = cmd.sender_id;
  a.min_clearance = kNaN;
  publish(channel::kAlert, a);
}

bool FeedPublisher::save_state() {
  if (config_.command_state_path.empty() || auth_.revision() == saved_revision_) return true;
  const int err = save_command_state(config_.command_state_path, auth_.senders());
  counters_.last_state_save_errno.store(err, std::memory_order_relaxed);
  if (err != 0) return false;
  saved_revision_ = auth_.revision();
  counters_.state_saves.fetch_add(1, std::memory_order_relaxed);
  return true;
}

void FeedPublisher::on_command(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  const std::int64_t now_us = config_.monotonic_us();
  operator_command_t cmd{};
  CommandVerdict verdict = auth_.check_bytes(
      std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size), cmd,
      config_.realtime_us());
  // Write-ahead: the counter is on disk before the command can move the machine, so a restart
  // cannot accept it again. A stop changes no counter and is never held up here.
  if (verdict.accepted && cmd.kind != operator_command_t::KIND_STOP && !save_state()) verdict = {false, command_status_t::REASON_STATE_NOT_SAVED};

  if (verdict.accepted) {
    if (cmd.kind == operator_command_t::KIND_STOP) counters_.stops_received.fetch_add(1, std::memory_order_release);
    AcceptedCommand out{};
    out.kind = cmd.kind;
    out.sender_id = cmd.sender_id;
    out.sequence = cmd.sequence;
    out.num_joints = std::clamp<int>(cmd.num_joints, 0, kMaxJoints);
    std::copy_n(cmd.goal_position, out.num_joints, out.goal_position.begin());
    out.alert_id = cmd.alert_id;
    out.received_us = now_us;
    if (!commands_.try_push(out)) verdict = {false, command_status_t::REASON_QUEUE_FULL};
  }
  if (verdict.accepted) {
    counters_.commands_accepted.fetch_add(1, std::memory_order_relaxed);
  } else {
    reject(cmd, verdict.reason, now_us);
  }

  command_status_t status{};
  status.utime = now_us;
  status.sender_id = cmd.sender_id;
  status.sequence = cmd.sequence;
  status.kind = cmd.kind;
  status.accepted = verdict.accepted;
  status.reason = verdict.reason;
  publish(channel::kCommandStatus, status);
}

}  // namespace mgc::firmware
