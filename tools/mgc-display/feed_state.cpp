// SPDX-License-Identifier: Apache-2.0
#include "feed_state.hpp"

#include <algorithm>
#include <cmath>
#include <exception>

#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/lcm_feed.hpp"

namespace mgc::display {
namespace {

namespace ch = firmware::channel;

// Decodes one message; false when the bytes are not a whole message of type T. The generated
// decoders throw (std::length_error) on a string length of 0 or below.
template <typename T>
bool decode(const void* data, int size, T& out) {
  try {
    return out.decode(data, 0, size) == size;
  } catch (const std::exception&) {
    return false;
  }
}

std::int64_t be32(const std::uint8_t* b) {
  return static_cast<std::int32_t>((std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) | (std::uint32_t{b[2]} << 8) | b[3]);
}

// The generated plan_t decoder sizes its vectors from the counts in the bytes before it checks that
// the bytes hold them: a forged count of 2^31 waypoints would take gigabytes. The counts must fit
// the bytes that follow them (fingerprint, utime, planner_name, seed, status, then the counts).
bool plan_counts_fit(const void* data, int size) {
  const auto* b = static_cast<const std::uint8_t*>(data);
  std::int64_t pos = 8 + 8;
  if (size < pos + 4) return false;
  const std::int64_t name_len = be32(b + pos);
  pos += 4;
  if (name_len < 1 || name_len > size - pos) return false;
  pos += name_len + 8 + 1;
  if (size < pos + 8) return false;
  const std::int64_t num_joints = be32(b + pos);
  const std::int64_t num_waypoints = be32(b + pos + 4);
  pos += 8;
  if (num_joints < 0 || num_joints > machine_state_t::MAX_JOINTS || num_waypoints < 0) return false;
  return num_waypoints * (8 * num_joints + 1) <= size - pos;
}

double age_s(std::int64_t received_us, std::int64_t now_us) {
  return static_cast<double>(now_us - received_us) * 1e-6;
}

}  // namespace

void FeedState::on_message(const std::string& channel, const void* data, int size, std::int64_t now_us,
                           std::int64_t recorded_realtime_us) {
  bool ok = true;
  if (channel == ch::kMachineState) {
    machine_state_t m{};
    ok = decode(data, size, m) && m.num_joints >= 0 && m.num_joints <= machine_state_t::MAX_JOINTS;
    if (ok) {
      const std::lock_guard lock(mutex_);
      state_ = {m, now_us};
      ++state_count_;
    }
  } else if (channel == ch::kOperatorGuidance) {
    operator_guidance_t g{};
    ok = decode(data, size, g);
    if (ok) {
      const std::lock_guard lock(mutex_);
      guidance_ = {g, now_us};
    }
  } else if (channel == ch::kOperatorInstruction) {
    operator_instruction_t i{};
    ok = decode(data, size, i);
    if (ok) {
      const std::lock_guard lock(mutex_);
      instruction_ = {std::move(i), now_us};
    }
  } else if (channel == ch::kLoopTiming) {
    loop_timing_t t{};
    ok = decode(data, size, t);
    if (ok) {
      const std::lock_guard lock(mutex_);
      timing_ = {t, now_us};
    }
  } else if (channel == ch::kHealth) {
    health_counters_t h{};
    ok = decode(data, size, h);
    if (ok) {
      const std::lock_guard lock(mutex_);
      health_ = {h, now_us};
    }
  } else if (channel == ch::kObstaclePoses) {
    obstacle_poses_t o{};
    ok = decode(data, size, o) && o.num_obstacles >= 0 && o.num_obstacles <= obstacle_poses_t::MAX_OBSTACLES &&
         o.num_tracked >= o.num_obstacles;
    if (ok) {
      const std::lock_guard lock(mutex_);
      obstacles_ = {o, now_us};
    }
  } else if (channel == ch::kSiteState && site_) {
    ok = site_->on_state(data, size, now_us, recorded_realtime_us);  // refused ones (bad MAC, unknown machine, ...) count here
  } else if (channel == ch::kCommandStatus) {
    command_status_t s{};
    ok = decode(data, size, s);
    if (ok) {
      const std::lock_guard lock(mutex_);
      statuses_.emplace_back(s, now_us);
      if (statuses_.size() > kStatusesKept) statuses_.erase(statuses_.begin());
    }
  } else if (channel == ch::kAlert) {
    alert_t a{};
    ok = decode(data, size, a);
    if (ok) on_alert(a, now_us);
  } else if (channel == ch::kPlan) {
    plan_t p{};
    ok = plan_counts_fit(data, size) && decode(data, size, p);
    if (ok) on_plan(p, now_us);
  } else {
    return;  // not a channel of the feed (MGC_COMMAND, other tools' traffic)
  }
  const std::lock_guard lock(mutex_);
  ++received_[channel];
  if (!ok) ++malformed_[channel];
}

void FeedState::on_alert(const alert_t& a, std::int64_t now_us) {
  const std::lock_guard lock(mutex_);
  auto it = alerts_.find(a.alert_id);
  if (it == alerts_.end()) {
    if (!a.active) return;  // a clear for an alert this display never saw raised
    it = alerts_.emplace(a.alert_id, AlertEntry{a, now_us, now_us, -1}).first;
  } else if (a.active && it->second.cleared_us >= 0) {
    it->second = AlertEntry{a, now_us, now_us, -1};  // the same id raised again
  }
  AlertEntry& e = it->second;
  e.alert = a;
  e.last_us = now_us;
  if (!a.active && e.cleared_us < 0) e.cleared_us = now_us;
  // Cleared alerts leave after a while, and the oldest cleared first when the list is full.
  for (auto i = alerts_.begin(); i != alerts_.end();) {
    const bool old = i->second.cleared_us >= 0 && now_us - i->second.cleared_us > kClearedAlertKept_us;
    i = old ? alerts_.erase(i) : std::next(i);
  }
  // A full list drops the alert cleared longest ago, and with none cleared the one heard longest
  // ago: the loop repeats its active alerts every second, while alerts for refused commands come
  // once and are never cleared.
  while (alerts_.size() > kMaxAlertsKept) {
    auto drop = alerts_.begin();
    for (auto i = alerts_.begin(); i != alerts_.end(); ++i) {
      const bool i_cleared = i->second.cleared_us >= 0;
      const bool drop_cleared = drop->second.cleared_us >= 0;
      if (i_cleared != drop_cleared) {
        if (i_cleared) drop = i;
      } else if (i_cleared ? i->second.cleared_us < drop->second.cleared_us : i->second.last_us < drop->second.last_us) {
        drop = i;
      }
    }
    alerts_.erase(drop);
  }
}

void FeedState::on_plan(const plan_t& p, std::int64_t now_us) {
  PlanView view;
  view.planner = p.planner_name;
  view.status = p.status;
  view.num_waypoints = p.num_waypoints;
  view.moving_joint = p.moving_joint;
  view.received_us = now_us;
  if (scene_ && p.num_joints == scene_->dof()) {
    std::vector<planning::JointVector> waypoints;
    for (const auto& row : p.positions) {
      planning::JointVector q(p.num_joints);
      for (int j = 0; j < p.num_joints; ++j) q[j] = row[static_cast<std::size_t>(j)];
      waypoints.push_back(q);
    }
    view.tool_path = scene_->tool_path(waypoints);
    if (!view.tool_path.empty()) {
      for (const auto& q : waypoints) view.waypoint_tools.push_back(scene_->tool_path({q}).front());
    }
  }
  const std::lock_guard lock(mutex_);
  view.version = plan_.version + 1;
  plan_ = std::move(view);
}

std::int64_t FeedState::received() const {
  const std::lock_guard lock(mutex_);
  std::int64_t n = 0;
  for (const auto& [c, count] : received_) n += count;
  return n;
}

std::int64_t FeedState::malformed() const {
  const std::lock_guard lock(mutex_);
  std::int64_t n = 0;
  for (const auto& [c, count] : malformed_) n += count;
  return n;
}

void FeedState::clear() {
  if (site_) site_->clear();
  const std::lock_guard lock(mutex_);
  const std::uint64_t plan_version = plan_.version;
  state_ = {};
  guidance_ = {};
  instruction_ = {};
  timing_ = {};
  health_ = {};
  obstacles_ = {};
  statuses_.clear();
  alerts_.clear();
  plan_ = {};
  plan_.version = plan_version + 1;
}

void FeedState::write_obstacles(Json& out, const Latest<obstacle_poses_t>& poses, std::int64_t now_us) const {
  const obstacle_poses_t& m = poses.msg;
  const bool current = now_us - poses.received_us <= kObstaclesStaleAfter_us;
  out.key("obstacles").begin_object();
  out.key("age_s").value(age_s(poses.received_us, now_us));
  out.key("current").value(current);
  out.key("num_tracked").value(static_cast<int>(m.num_tracked));
  out.key("list").begin_array();
  for (int i = 0; i < m.num_obstacles; ++i) {
    const Eigen::Vector3d p(m.x[i], m.y[i], m.z[i]);
    const bool posed = p.allFinite() && std::isfinite(m.yaw[i]);
    // What the operator may take from the drawing: a pose that is not current is never shown as
    // one. The order matters: an old message says nothing of the tracker's validity now.
    const char* status = !posed ? "never fixed" : !current ? "not current" : !m.valid[i] ? "pose unknown" : m.still[i] ? "still" : "moving";
    out.begin_object();
    out.key("index").value(m.obstacle_index[i]);
    out.key("name").value(scene_ ? scene_->dynamic_name(m.obstacle_index[i]) : std::string());
    out.key("status").value(status);
    out.key("valid").value(static_cast<bool>(m.valid[i]));
    out.key("still").value(static_cast<bool>(m.still[i]));
    if (posed) {
      out.key("position").point(p);
    } else {
      out.key("position").null();
    }
    out.key("yaw_rad").value(m.yaw[i]);
    out.key("sigma_m").value(m.position_sigma[i]);
    out.key("speed_m_s").value(m.speed[i]);
    out.key("yaw_rate_rad_s").value(m.yaw_rate[i]);
    // The fix's age now: its age when published plus the message's.
    out.key("fix_age_s").value(m.fix_age[i] + age_s(poses.received_us, now_us));
    out.key("parts");
    if (scene_ && posed) {
      scene_->write_dynamic_obstacle(out, m.obstacle_index[i], p, m.yaw[i]);
    } else {
      out.begin_array().end_array();
    }
    out.end_object();
  }
  out.end_array();
  out.end_object();
}

std::string FeedState::json(std::int64_t now_us, std::uint64_t* plan_version) const {
  std::unique_lock lock(mutex_);
  const Latest<machine_state_t> state = state_;
  const Latest<operator_guidance_t> guidance = guidance_;
  const Latest<operator_instruction_t> instruction = instruction_;
  const Latest<loop_timing_t> timing = timing_;
  const Latest<health_counters_t> health = health_;
  const Latest<obstacle_poses_t> obstacles = obstacles_;
  const auto statuses = statuses_;
  const auto alerts = alerts_;
  const auto received = received_;
  const auto malformed = malformed_;
  const std::int64_t state_count = state_count_;
  std::optional<PlanView> plan;
  if (plan_version && *plan_version != plan_.version) {
    plan = plan_;
    *plan_version = plan_.version;
  }
  const std::uint64_t current_plan_version = plan_.version;
  lock.unlock();

  Json out;
  out.begin_object();
  const bool alive = state.received_us >= 0 && now_us - state.received_us <= kStaleAfter_us;
  out.key("feed").begin_object();
  out.key("alive").value(alive);
  out.key("stale_after_s").value(static_cast<double>(kStaleAfter_us) * 1e-6);
  if (state.received_us >= 0) {
    out.key("state_age_s").value(age_s(state.received_us, now_us));
  } else {
    out.key("state_age_s").null();
  }
  out.key("states").value(static_cast<long long>(state_count));
  out.key("received").begin_object();
  for (const auto& [c, n] : received) out.key(c).value(static_cast<long long>(n));
  out.end_object();
  out.key("malformed").begin_object();
  for (const auto& [c, n] : malformed) out.key(c).value(static_cast<long long>(n));
  out.end_object();
  out.key("plan_version").value(static_cast<long long>(current_plan_version));
  out.end_object();

  if (state.received_us >= 0) {
    const machine_state_t& m = state.msg;
    out.key("state").begin_object();
    out.key("age_s").value(age_s(state.received_us, now_us));
    out.key("utime").value(static_cast<long long>(m.utime));
    out.key("kind").value(static_cast<int>(m.machine_kind));
    out.key("supervisor").value(static_cast<int>(m.supervisor_state));
    out.key("load_moment_pct").value(m.load_moment_pct);
    out.key("joints").begin_array();
    for (int j = 0; j < m.num_joints; ++j) out.value(m.joint_position[j]);
    out.end_array();
    out.key("velocities").begin_array();
    for (int j = 0; j < m.num_joints; ++j) out.value(m.joint_velocity[j]);
    out.end_array();
    out.key("faults").begin_array();
    for (int j = 0; j < m.num_joints; ++j) out.value(static_cast<int>(m.joint_fault_flags[j]));
    out.end_array();
    out.key("tool").point(Eigen::Vector3d(m.tool_position[0], m.tool_position[1], m.tool_position[2]));
    planning::JointVector q(m.num_joints);
    for (int j = 0; j < m.num_joints; ++j) q[j] = m.joint_position[j];
    if (scene_ && m.num_joints == scene_->dof() && q.allFinite()) {
      out.key("machine");
      scene_->write_machine(out, q);
    }
    out.end_object();
  }
  if (guidance.received_us >= 0) {
    const operator_guidance_t& g = guidance.msg;
    out.key("guidance").begin_object();
    out.key("age_s").value(age_s(guidance.received_us, now_us));
    out.key("instruction").value(static_cast<int>(g.instruction));
    out.key("segment_index").value(g.segment_index);
    out.key("num_segments").value(g.num_segments);
    out.key("moving_joint").value(static_cast<int>(g.moving_joint));
    out.key("target_position").value(g.target_position);
    out.key("joint_distance_remaining").value(g.joint_distance_remaining);
    out.key("path_distance_remaining").value(g.path_distance_remaining);
    out.key("time_remaining_s").value(g.time_remaining);
    out.key("speed_scale").value(g.speed_scale);
    out.end_object();
  }
  if (instruction.received_us >= 0) {
    const operator_instruction_t& i = instruction.msg;
    out.key("instruction").begin_object();
    out.key("age_s").value(age_s(instruction.received_us, now_us));
    out.key("text").value(i.text);
    out.key("obstacle_clearance_m").value(i.obstacle_clearance);
    out.key("obstacle_index").value(i.obstacle_index);
    out.key("limit_margin").value(i.limit_margin);
    out.key("limit_joint").value(static_cast<int>(i.limit_joint));
    out.key("envelope_distance_m").value(i.envelope_distance);
    out.key("envelope_limit").value(static_cast<int>(i.envelope_limit));
    out.key("load_moment_pct").value(i.load_moment_pct);
    out.end_object();
  }
  if (timing.received_us >= 0) {
    const loop_timing_t& t = timing.msg;
    out.key("timing").begin_object();
    out.key("age_s").value(age_s(timing.received_us, now_us));
    out.key("period_us").value(static_cast<long long>(t.period_us));
    out.key("cycles").value(static_cast<long long>(t.cycles));
    out.key("deadline_misses").value(static_cast<long long>(t.deadline_misses));
    out.key("skipped_periods").value(static_cast<long long>(t.skipped_periods));
    out.key("watchdog_trips").value(static_cast<long long>(t.watchdog_trips));
    out.key("compute_p99_us").value(static_cast<long long>(t.compute_p99_us));
    out.key("compute_max_us").value(static_cast<long long>(t.compute_max_us));
    out.key("lateness_p99_us").value(static_cast<long long>(t.lateness_p99_us));
    out.key("lateness_max_us").value(static_cast<long long>(t.lateness_max_us));
    out.key("snapshots_dropped").value(static_cast<long long>(t.snapshots_dropped));
    out.end_object();
  }
  if (health.received_us >= 0) {
    const health_counters_t& h = health.msg;
    out.key("health").begin_object();
    out.key("age_s").value(age_s(health.received_us, now_us));
    out.key("bus_frames_decoded").value(static_cast<long long>(h.bus_frames_decoded));
    out.key("bus_malformed").value(static_cast<long long>(h.bus_wrong_length + h.bus_wrong_id + h.bus_out_of_range +
                                                          h.bus_reserved_bits + h.bus_other));
    out.key("bus_unknown_frames").value(static_cast<long long>(h.bus_unknown_frames));
    out.key("commands_accepted").value(static_cast<long long>(h.commands_accepted));
    out.key("commands_refused").value(static_cast<long long>(h.commands_refused));
    out.end_object();
  }
  if (obstacles.received_us >= 0) write_obstacles(out, obstacles, now_us);
  if (site_) site_->write_json(out, now_us);
  out.key("alerts").begin_array();
  for (const auto& [id, e] : alerts) {
    const alert_t& a = e.alert;
    out.begin_object();
    out.key("id").value(static_cast<long long>(id));
    out.key("severity").value(static_cast<int>(a.severity));
    out.key("source").value(static_cast<int>(a.source));
    out.key("active").value(e.cleared_us < 0);
    out.key("clear_condition").value(static_cast<int>(a.clear_condition));
    out.key("unit").value(static_cast<int>(a.value_unit));
    out.key("value").value(a.value);
    out.key("limit").value(a.limit);
    out.key("index").value(a.index);
    out.key("min_clearance_m").value(a.min_clearance);
    out.key("raised_ago_s").value(age_s(e.raised_us, now_us));
    out.key("last_ago_s").value(age_s(e.last_us, now_us));
    if (e.cleared_us >= 0) {
      out.key("cleared_ago_s").value(age_s(e.cleared_us, now_us));
    } else {
      out.key("cleared_ago_s").null();
    }
    out.end_object();
  }
  out.end_array();
  out.key("statuses").begin_array();
  for (const auto& [s, at_us] : statuses) {
    out.begin_object();
    out.key("sequence").value(static_cast<long long>(s.sequence));
    out.key("sender_id").value(s.sender_id);
    out.key("kind").value(static_cast<int>(s.kind));
    out.key("accepted").value(static_cast<bool>(s.accepted));
    out.key("reason").value(firmware::command_reason_name(s.reason));
    out.key("ago_s").value(age_s(at_us, now_us));
    out.end_object();
  }
  out.end_array();
  if (plan) {
    out.key("plan").begin_object();
    out.key("version").value(static_cast<long long>(plan->version));
    out.key("planner").value(plan->planner);
    out.key("status").value(static_cast<int>(plan->status));
    out.key("num_waypoints").value(plan->num_waypoints);
    out.key("moving_joint").begin_array();
    for (const auto j : plan->moving_joint) out.value(static_cast<int>(j));
    out.end_array();
    out.key("waypoint_tools").begin_array();
    for (const auto& p : plan->waypoint_tools) out.point(p);
    out.end_array();
    out.key("tool_path").begin_array();
    for (const auto& p : plan->tool_path) out.point(p);
    out.end_array();
    out.end_object();
  }
  out.end_object();
  return out.str();
}

}  // namespace mgc::display
