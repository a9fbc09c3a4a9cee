// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/firmware/command_auth.hpp>
#include <mgc/firmware/guidance_snapshot.hpp>
#include <mgc/firmware/spsc_queue.hpp>

#include <lcm/lcm-cpp.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

//! The LCM side of the controller (docs/operator-feed.md): a publisher thread that pops the loop's
//! guidance snapshots and publishes them, and receives operator commands, authenticates them and
//! hands the accepted ones back to the loop. The loop itself never calls LCM.
namespace mgc::firmware {

//! Channel names. One place, so tools and the controller agree.
namespace channel {
inline constexpr const char* kMachineState = "MGC_MACHINE_STATE";
inline constexpr const char* kOperatorGuidance = "MGC_OPERATOR_GUIDANCE";
inline constexpr const char* kOperatorInstruction = "MGC_OPERATOR_INSTRUCTION";
inline constexpr const char* kAlert = "MGC_ALERT";
inline constexpr const char* kPlan = "MGC_PLAN";
inline constexpr const char* kLoopTiming = "MGC_LOOP_TIMING";
inline constexpr const char* kCommand = "MGC_COMMAND";
inline constexpr const char* kCommandStatus = "MGC_COMMAND_STATUS";
inline constexpr const char* kHealth = "MGC_HEALTH";
inline constexpr const char* kObstaclePoses = "MGC_OBSTACLE_POSES";
inline constexpr const char* kSiteState = "MGC_SITE_STATE";  //!< the site channel (docs/site.md)
inline constexpr const char* kSitePlan = "MGC_SITE_PLAN";    //!< the site channel (docs/site.md)
}  // namespace channel

//! UDP multicast on this host only: ttl=0 keeps every packet off the site network.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

//! The site channel's own multicast group, apart from the operator feed's: every machine's mgc
//! joins it, while each machine's operator feed stays its own. ttl=0 keeps it on this host; a site
//! whose controllers run on several hosts sets ttl=1 (docs/site.md).
inline constexpr const char* kDefaultSiteLcmUrl = "udpm://239.255.76.68:7668?ttl=0";

//! Alerts for refused commands take ids from here up, so they never collide with the loop's
//! alert ids (which count up from 1). [-]
inline constexpr std::int32_t kCommandAlertIdBase = 0x40000000;

inline constexpr std::size_t kSnapshotQueueCapacity = 64;  //!< 0.64 s of snapshots at 100 Hz [-]
inline constexpr std::size_t kCommandQueueCapacity = 16;   //!< commands waiting for the loop [-]

//! An authenticated command for the loop (stops included).
struct AcceptedCommand {
  std::int8_t kind = 0;                 //!< operator_command_t::KIND_* [enum]
  std::int32_t sender_id = 0;           //!< [-]
  std::int64_t sequence = 0;            //!< [-]
  int num_joints = 0;                   //!< goal entries used [-]
  std::array<double, kMaxJoints> goal_position{};  //!< [rad | m]
  std::int32_t alert_id = 0;            //!< acknowledged alert, 0 = all [-]
  std::int64_t received_us = 0;         //!< monotonic time of receipt [µs]
};

using SnapshotQueue = SpscQueue<GuidanceSnapshot, kSnapshotQueueCapacity>;
using CommandQueue = SpscQueue<AcceptedCommand, kCommandQueueCapacity>;

//! CLOCK_REALTIME [µs]: the clock command sequences are compared with.
[[nodiscard]] std::int64_t realtime_clock_us() noexcept;
//! CLOCK_MONOTONIC [µs]: message times and the alert rate limit.
[[nodiscard]] std::int64_t monotonic_clock_us() noexcept;

struct FeedConfig {
  std::string lcm_url = kDefaultLcmUrl;
  std::int64_t guidance_period_us = 100'000;    //!< operator_guidance_t and the words: 10 Hz [µs]
  std::int64_t timing_period_us = 1'000'000;    //!< loop_timing_t and health_counters_t: 1 Hz [µs]
  std::int64_t obstacle_period_us = 100'000;    //!< obstacle_poses_t, while any obstacle is tracked: 10 Hz [µs]
  std::int64_t alert_repeat_period_us = 1'000'000;  //!< every active alert again: 1 Hz [µs]
  std::int64_t refusal_alert_period_us = 1'000'000;  //!< at most one alert for refused commands per period [µs]
  int receive_timeout_ms = 5;                   //!< longest wait for a command per iteration [ms]
  std::int64_t sequence_floor = 0;              //!< CommandAuthenticator's replay floor [µs]
  std::int64_t max_skew_us = kDefaultCommandSkew_us;  //!< tolerated sequence vs. clock difference [µs]
  //! Replay counters saved here before an accepted command reaches the loop, loaded at
  //! construction (docs/operator-feed.md); empty: in memory only.
  std::string command_state_path;
  std::int64_t (*realtime_us)() noexcept = &realtime_clock_us;    //!< tests step it [µs]
  std::int64_t (*monotonic_us)() noexcept = &monotonic_clock_us;  //!< tests step it [µs]
};

//! Refused commands counted per reason, and the rate limit of their alerts: one alert for the
//! first refusal after a quiet alert period, none for the others in that period. Counters are
//! read from any thread; record() is called by one. RT-safe: no alloc, no lock, no throw.
class RefusalCounter {
 public:
  static constexpr std::size_t kReasons = 16;  //!< health_counters_t::MAX_REASONS [-]

  explicit RefusalCounter(std::int64_t alert_period_us) noexcept : alert_period_us_(alert_period_us) {}

  //! Counts one refusal for reason at now_us (monotonic); true when an alert is due for it.
  bool record(std::int8_t reason, std::int64_t now_us) noexcept;

  [[nodiscard]] std::uint64_t count(std::int8_t reason) const noexcept;  //!< refusals for reason [-]
  [[nodiscard]] std::uint64_t total() const noexcept { return total_.load(std::memory_order_relaxed); }  //!< [-]
  [[nodiscard]] std::uint64_t alerts() const noexcept { return alerts_.load(std::memory_order_relaxed); }  //!< [-]

 private:
  std::int64_t alert_period_us_;
  std::array<std::atomic<std::uint64_t>, kReasons> by_reason_{};
  std::atomic<std::uint64_t> total_{0};
  std::atomic<std::uint64_t> alerts_{0};
  std::int64_t last_alert_us_ = 0;
  bool alerted_ = false;
};

//! Counters for tests and the health page; read from any thread.
struct FeedCounters {
  std::atomic<std::uint64_t> snapshots_published{0};
  std::atomic<std::uint64_t> messages_published{0};
  std::atomic<std::uint64_t> commands_accepted{0};
  std::atomic<std::uint64_t> commands_rejected{0};
  std::atomic<std::uint64_t> stops_received{0};  //!< also counted when the command queue was full
  std::atomic<std::uint64_t> state_saves{0};     //!< replay counters written to the state file
  std::atomic<int> last_state_save_errno{0};     //!< errno of the last failed save, 0 after a good one
};

//! Owns the LCM instance. Construct, then start() a thread, or call run_once() from a test.
//! Thread-safety: the queues' producer/consumer sides are fixed: the loop pushes snapshots and
//! pops commands; this class pops snapshots and pushes commands, all on one thread.
class FeedPublisher {
 public:
  //! Throws std::runtime_error naming the URL when LCM cannot open it, and CommandStateError when
  //! config.command_state_path cannot be read, is malformed or cannot be written. Start-up only.
  FeedPublisher(const FeedConfig& config, const CommandKey& key, SnapshotQueue& snapshots,
                CommandQueue& commands);
  ~FeedPublisher();
  FeedPublisher(const FeedPublisher&) = delete;
  FeedPublisher& operator=(const FeedPublisher&) = delete;

  //! Runs run_once(config.receive_timeout_ms) on a thread until stop().
  void start();
  void stop();

  //! Publishes every waiting snapshot, then waits up to timeout_ms for commands and handles them.
  //! May block (LCM I/O): never call it from the control loop.
  void run_once(int timeout_ms);

  [[nodiscard]] const FeedCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const RefusalCounter& refusals() const noexcept { return refusals_; }
  [[nodiscard]] const CommandAuthenticator& authenticator() const noexcept { return auth_; }
  //! Stops received since construction: the loop may poll this as well as the queue, so a stop
  //! is obeyed even when the command queue was full. [-]
  [[nodiscard]] std::uint64_t stops_received() const noexcept {
    return counters_.stops_received.load(std::memory_order_acquire);
  }
  [[nodiscard]] lcm::LCM& lcm() noexcept { return lcm_; }

 private:
  void publish_snapshot(const GuidanceSnapshot& s);
  void publish_alerts(const GuidanceSnapshot& s, std::int64_t now_us);
  void on_command(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void reject(const operator_command_t& cmd, std::int8_t reason, std::int64_t now_us);
  //! Saves the replay counters if they changed since the last save; false when that failed.
  bool save_state();
  template <class Msg>
  void publish(const char* channel, const Msg& msg);

  FeedConfig config_;
  lcm::LCM lcm_;
  CommandAuthenticator auth_;
  SnapshotQueue& snapshots_;
  CommandQueue& commands_;
  FeedCounters counters_;
  RefusalCounter refusals_;
  std::uint64_t saved_revision_ = 0;
  std::vector<std::uint8_t> encode_buf_;

  GuidanceSnapshot snapshot_{};  //!< pop target; a member because it is several KB
  std::int64_t last_guidance_us_ = 0;
  std::int64_t last_timing_us_ = 0;
  std::int64_t last_obstacles_us_ = 0;
  std::int64_t last_alert_repeat_us_ = 0;
  std::array<char, kInstructionTextBytes> last_text_{};
  std::int8_t last_instruction_ = -1;
  std::uint32_t last_plan_id_ = 0;
  int num_prev_alerts_ = 0;
  std::array<SnapshotAlert, kSnapshotMaxAlerts> prev_alerts_{};
  std::int32_t next_command_alert_id_;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace mgc::firmware
