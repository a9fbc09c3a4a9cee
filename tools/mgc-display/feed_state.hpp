// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/health_counters_t.hpp>
#include <mgc/loop_timing_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/obstacle_poses_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>

#include "scene.hpp"
#include "site_view.hpp"

namespace mgc::display {

//! How long after the last MGC_MACHINE_STATE the feed counts as stale: 50 of the controller's
//! 100 Hz cycles. The page then says so in red and shows no value as current. [µs]
inline constexpr std::int64_t kStaleAfter_us = 500'000;
//! How long after the last MGC_OBSTACLE_POSES the tracked obstacles count as not current: five of
//! the controller's 10 Hz periods. Their poses are then drawn as last reported, never as current. [µs]
inline constexpr std::int64_t kObstaclesStaleAfter_us = 500'000;
//! How long a cleared alert stays in the page's list, marked cleared. [µs]
inline constexpr std::int64_t kClearedAlertKept_us = 30'000'000;
//! Alerts kept at once; the oldest cleared ones go first. [-]
inline constexpr std::size_t kMaxAlertsKept = 32;
//! Command statuses kept for the page. [-]
inline constexpr std::size_t kStatusesKept = 8;

//! The latest message of every feed channel, as the feed thread received it. The feed thread calls
//! on_message(); the pushers call json() for the page. Thread-safe (one mutex; the feed thread
//! holds it only to copy a decoded message in).
class FeedState {
 public:
  //! scene may be null (no --scenario): then nothing is drawn and plans are not turned into paths.
  explicit FeedState(const Scene* scene) : scene_(scene) {}

  //! With a site (--site), MGC_SITE_STATE is taken and the other machines are in json(); the site
  //! outlives this state. Call before the first message.
  void set_site(SiteView* site) noexcept { site_ = site; }

  //! One message from the bus (or a log) received at now_us (monotonic). Bytes that do not decode
  //! as the channel's type are counted per channel and otherwise ignored. recorded_realtime_us: a
  //! log's wall-clock receive time, which a verified site state's sender time is checked against
  //! (-1 live: the site view's clock).
  void on_message(const std::string& channel, const void* data, int size, std::int64_t now_us,
                  std::int64_t recorded_realtime_us = -1);

  //! Everything the page shows, at now_us (monotonic): the age of each channel's latest message and
  //! whether the feed is alive. The plan's path is included only when its version differs from
  //! *plan_version, which is then updated (each page gets a new plan once).
  [[nodiscard]] std::string json(std::int64_t now_us, std::uint64_t* plan_version) const;

  //! Counts of messages received and of malformed ones, all channels together. [-]
  [[nodiscard]] std::int64_t received() const;
  [[nodiscard]] std::int64_t malformed() const;

  //! Forgets everything (playback seeks back).
  void clear();

 private:
  struct AlertEntry {
    alert_t alert{};
    std::int64_t raised_us = 0;
    std::int64_t last_us = 0;
    std::int64_t cleared_us = -1;  //!< -1 while active
  };
  template <typename T>
  struct Latest {
    T msg{};
    std::int64_t received_us = -1;  //!< -1: none yet
  };
  struct PlanView {
    std::uint64_t version = 0;
    std::string planner;
    std::int8_t status = 0;
    std::int32_t num_waypoints = 0;
    std::vector<std::int8_t> moving_joint;
    std::vector<Eigen::Vector3d> waypoint_tools;  //!< the tool point at each waypoint
    std::vector<Eigen::Vector3d> tool_path;
    std::int64_t received_us = -1;
  };

  void on_alert(const alert_t& a, std::int64_t now_us);
  void on_plan(const plan_t& p, std::int64_t now_us);
  void write_obstacles(Json& out, const Latest<obstacle_poses_t>& poses, std::int64_t now_us) const;

  const Scene* scene_;
  SiteView* site_ = nullptr;
  mutable std::mutex mutex_;
  Latest<machine_state_t> state_;
  Latest<operator_guidance_t> guidance_;
  Latest<operator_instruction_t> instruction_;
  Latest<loop_timing_t> timing_;
  Latest<health_counters_t> health_;
  Latest<obstacle_poses_t> obstacles_;
  std::vector<std::pair<command_status_t, std::int64_t>> statuses_;
  std::map<std::int32_t, AlertEntry> alerts_;
  PlanView plan_;
  std::map<std::string, std::int64_t> received_;
  std::map<std::string, std::int64_t> malformed_;
  std::int64_t state_count_ = 0;
};

}  // namespace mgc::display
