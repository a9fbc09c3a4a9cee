// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include <lcm/lcm-cpp.hpp>

#include <array>
#include <memory>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "mgc/firmware/lcm_feed.hpp"
#include "mgc/firmware/site_auth.hpp"
#include "mgc/firmware/site_member.hpp"
#include "mgc/firmware/spsc_queue.hpp"

//! The site channel of one `mgc` (docs/site.md, "mgc on a site"): an I/O thread that completes,
//! signs and publishes this machine's site_state_t and site_plan_t, and receives the other
//! machines' messages, verifies them (SiteVerifier) and hands the accepted ones to the loop as
//! fixed-size structs through lock-free queues. The loop never calls LCM.
namespace mgc::firmware {

//! Alerts for refused site messages take ids from here up, apart from the loop's and the refused
//! commands' ids. [-]
inline constexpr std::int32_t kSiteAlertIdBase = 0x50000000;

//! A state the verifier accepted, for the loop.
struct VerifiedSiteState {
  int roster_index = -1;
  std::int64_t received_us = 0;  //!< CLOCK_MONOTONIC at receipt: the loop's clock [µs]
  site_state_t state{};
};

//! A plan the verifier accepted, for the loop.
struct VerifiedSitePlan {
  int roster_index = -1;
  site_plan_t plan{};
};

struct SiteChannelConfig {
  std::string lcm_url = kDefaultSiteLcmUrl;
  //! Where the alerts for refused messages go: the operator feed's provider, so that the operator
  //! sees them; empty: the site channel's own.
  std::string alert_lcm_url;
  int receive_timeout_ms = 5;  //!< longest wait for a message per iteration [ms]
  //! At most one alert for refused site messages per period. [µs]
  std::int64_t refusal_alert_period_us = 1'000'000;
  std::int64_t max_skew_us = kDefaultSiteSkew_us;                  //!< the verifier's window [µs]
  std::int64_t (*realtime_us)() noexcept = &realtime_clock_us;    //!< tests step it [µs]
  std::int64_t (*monotonic_us)() noexcept = &monotonic_clock_us;  //!< tests step it [µs]
};

//! What the link did; read from any thread.
struct SiteChannelCounters {
  std::atomic<std::uint64_t> states_published{0};
  std::atomic<std::uint64_t> plans_published{0};
  std::atomic<std::uint64_t> publish_errors{0};  //!< lcm publish() failed
  std::atomic<std::uint64_t> own_echoes{0};      //!< this process's own messages looped back by multicast
  std::atomic<std::uint64_t> refusal_alerts{0};  //!< alerts published for refused messages
};

//! Owns its LCM instance and a verifier. Construct before the loop, start() the thread (or call
//! run_once() from a test). Thread-safety: the loop calls post_state(), post_plan() and take();
//! the I/O thread everything else; counters and the verifier's counts may be read from any thread.
class SiteChannel {
 public:
  static constexpr std::size_t kStatesIn = 64;  //!< accepted states waiting for the loop: 3 cycles of 16 machines at 20 Hz and more [-]
  static constexpr std::size_t kPlansIn = 16;   //!< accepted plans waiting for the loop [-]
  static constexpr std::size_t kStatesOut = 8;  //!< states waiting to be published [-]
  static constexpr std::size_t kPlansOut = 4;   //!< plans waiting to be published [-]

  //! Throws std::runtime_error naming the URL when LCM cannot open it, std::invalid_argument when
  //! my_id is not in the roster. Start-up only.
  SiteChannel(const SiteChannelConfig& config, const SiteKey& key, const SiteRoster& roster, std::int32_t my_id);
  ~SiteChannel();
  SiteChannel(const SiteChannel&) = delete;
  SiteChannel& operator=(const SiteChannel&) = delete;

  void start();
  void stop();
  //! Publishes what the loop posted, then waits up to timeout_ms for site messages and checks
  //! them. May block: never call it from the control loop.
  void run_once(int timeout_ms);

  //! Loop side: hands this cycle's content of my state / plan to the I/O thread, which adds the
  //! sequence, the sender time and the MAC. False (and counted) when the queue was full.
  //! RT-safe: no alloc, no lock, no throw.
  bool post_state(const site_state_t& state) noexcept { return states_out_.try_push(state); }
  bool post_plan(const site_plan_t& plan) noexcept { return plans_out_.try_push(plan); }
  //! Loop side: copies every accepted message waiting into inputs (the latest of each machine
  //! wins), with each state's receive time not later than now_us, and tells observer (the black
  //! box; may be null) of each as taken. RT-safe.
  void take(SiteInputs& inputs, std::int64_t now_us, SiteTakeObserver* observer = nullptr) noexcept;

  [[nodiscard]] const SiteChannelCounters& counters() const noexcept { return counters_; }
  //! The site channel's LCM instance (tests publish into a memq:// one and subscribe to it).
  [[nodiscard]] lcm::LCM& lcm() noexcept { return lcm_; }
  [[nodiscard]] const SiteVerifier& verifier() const noexcept { return verifier_; }
  //! Messages the loop could not post or the I/O thread could not hand over (full queues). [-]
  [[nodiscard]] std::uint64_t queue_drops() const noexcept;

 private:
  void on_state(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void on_plan(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void refused(SiteReason reason, std::int32_t machine_id, std::int64_t now_us);
  void publish_bytes(const char* channel_name, const std::uint8_t* data, int size);

  SiteChannelConfig config_;
  lcm::LCM lcm_;
  std::unique_ptr<lcm::LCM> alert_lcm_;  //!< null: alerts on lcm_
  SiteKey key_;
  SiteVerifier verifier_;
  std::int32_t my_id_;
  SiteChannelCounters counters_;

  SpscQueue<VerifiedSiteState, kStatesIn> states_in_;
  SpscQueue<VerifiedSitePlan, kPlansIn> plans_in_;
  SpscQueue<site_state_t, kStatesOut> states_out_;
  SpscQueue<site_plan_t, kPlansOut> plans_out_;

  // I/O thread's scratch: messages are several KB, so members rather than stack.
  site_state_t out_state_{};
  site_plan_t out_plan_{};
  site_state_t in_state_{};
  site_plan_t in_plan_{};
  VerifiedSiteState verified_state_{};
  VerifiedSitePlan verified_plan_{};
  // Loop's scratch for take().
  VerifiedSiteState take_state_{};
  VerifiedSitePlan take_plan_{};

  //! The last few datagrams published of one type: one received equal to one of them is this
  //! process's own message looped back by multicast, not a machine posing as this one. Several,
  //! because the loop may post several before the thread reads the first one's echo.
  template <std::size_t Bytes, std::size_t Count>
  struct SentRing {
    std::array<std::array<std::uint8_t, Bytes>, Count> bytes{};
    std::array<std::uint32_t, Count> size{};
    std::size_t next = 0;
    [[nodiscard]] std::uint8_t* slot() noexcept { return bytes[next % Count].data(); }
    void commit(int len) noexcept { size[next++ % Count] = static_cast<std::uint32_t>(len); }
    [[nodiscard]] bool contains(const void* data, std::uint32_t len) const noexcept;
  };
  // As many as a full outgoing queue publishes in one burst, and as many again.
  SentRing<512, 2 * kStatesOut> sent_states_;  // site_state_t: 286 bytes
  SentRing<8192, 2 * kPlansOut> sent_plans_;   // site_plan_t: 4,683 bytes
  std::int64_t state_sequence_ = 0;
  std::int64_t plan_sequence_ = 0;
  std::int64_t last_alert_us_ = 0;
  bool alerted_ = false;
  std::int32_t next_alert_id_ = kSiteAlertIdBase;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace mgc::firmware
