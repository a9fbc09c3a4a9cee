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
}  // namespace channel

//! UDP multicast on this host only: ttl=0 keeps every packet off the site network.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

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

struct FeedConfig {
  std::string lcm_url = kDefaultLcmUrl;
  std::int64_t guidance_period_us = 100'000;    //!< operator_guidance_t and the words: 10 Hz [µs]
  std::int64_t timing_period_us = 1'000'000;    //!< loop_timing_t: 1 Hz [µs]
  std::int64_t alert_repeat_period_us = 1'000'000;  //!< every active alert again: 1 Hz [µs]
  int receive_timeout_ms = 5;                   //!< longest wait for a command per iteration [ms]
  std::int64_t sequence_floor = 0;              //!< CommandAuthenticator's replay floor [-]
};

//! Counters for tests and the health page; read from any thread.
struct FeedCounters {
  std::atomic<std::uint64_t> snapshots_published{0};
  std::atomic<std::uint64_t> messages_published{0};
  std::atomic<std::uint64_t> commands_accepted{0};
  std::atomic<std::uint64_t> commands_rejected{0};
  std::atomic<std::uint64_t> stops_received{0};  //!< also counted when the command queue was full
};

//! Owns the LCM instance. Construct, then start() a thread, or call run_once() from a test.
//! Thread-safety: the queues' producer/consumer sides are fixed: the loop pushes snapshots and
//! pops commands; this class pops snapshots and pushes commands, all on one thread.
class FeedPublisher {
 public:
  //! Throws std::runtime_error naming the URL when LCM cannot open it. Start-up only.
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
  template <class Msg>
  void publish(const char* channel, const Msg& msg);

  FeedConfig config_;
  lcm::LCM lcm_;
  CommandAuthenticator auth_;
  SnapshotQueue& snapshots_;
  CommandQueue& commands_;
  FeedCounters counters_;
  std::vector<std::uint8_t> encode_buf_;

  GuidanceSnapshot snapshot_{};  //!< pop target; a member because it is several KB
  std::int64_t last_guidance_us_ = 0;
  std::int64_t last_timing_us_ = 0;
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
