// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/site_channel.hpp"

#include <mgc/alert_t.hpp>

#include <algorithm>
#include <cstring>
#include <limits>
#include <span>
#include <stdexcept>

namespace mgc::firmware {

SiteChannel::SiteChannel(const SiteChannelConfig& config, const SiteKey& key, const SiteRoster& roster, std::int32_t my_id)
    : config_(config), lcm_(config.lcm_url), key_(key), verifier_(key, roster, my_id, config.max_skew_us), my_id_(my_id) {
  if (!lcm_.good()) {
    throw std::runtime_error("LCM: cannot open provider " + config.lcm_url +
                             " for the site channel (for udpm on loopback: a multicast route on lo, see docs/operator-feed.md)");
  }
  if (!config_.alert_lcm_url.empty() && config_.alert_lcm_url != config_.lcm_url) {
    alert_lcm_ = std::make_unique<lcm::LCM>(config_.alert_lcm_url);
    if (!alert_lcm_->good()) throw std::runtime_error("LCM: cannot open provider " + config_.alert_lcm_url + " for the site channel's alerts");
  }
  // Sequences start at the real-time clock: a restarted mgc continues above what it sent before,
  // so the other machines' verifiers do not take its first messages for replays.
  state_sequence_ = config_.realtime_us();
  plan_sequence_ = state_sequence_;
  lcm_.subscribe(channel::kSiteState, &SiteChannel::on_state, this);
  lcm_.subscribe(channel::kSitePlan, &SiteChannel::on_plan, this);
}

SiteChannel::~SiteChannel() { stop(); }

void SiteChannel::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    while (running_.load(std::memory_order_acquire)) run_once(config_.receive_timeout_ms);
  });
}

void SiteChannel::stop() {
  running_.store(false, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

std::uint64_t SiteChannel::queue_drops() const noexcept {
  return states_in_.dropped() + plans_in_.dropped() + states_out_.dropped() + plans_out_.dropped();
}

void SiteChannel::publish_bytes(const char* channel_name, const std::uint8_t* data, int size) {
  if (lcm_.publish(channel_name, data, static_cast<unsigned>(size)) != 0) counters_.publish_errors.fetch_add(1, std::memory_order_relaxed);
}

void SiteChannel::run_once(int timeout_ms) {
  // Plans before states: a state that names a new plan posted with it follows the plan.
  while (plans_out_.try_pop(out_plan_)) {
    out_plan_.utime = config_.monotonic_us();
    out_plan_.sequence = ++plan_sequence_;
    out_plan_.sender_time_us = config_.realtime_us();
    sign_site_plan(out_plan_, key_);
    const int len = out_plan_.encode(sent_plans_.slot(), 0, 8192);
    if (len <= 0) continue;
    publish_bytes(channel::kSitePlan, sent_plans_.slot(), len);
    sent_plans_.commit(len);
    counters_.plans_published.fetch_add(1, std::memory_order_relaxed);
  }
  while (states_out_.try_pop(out_state_)) {
    out_state_.utime = config_.monotonic_us();
    out_state_.sequence = ++state_sequence_;
    out_state_.sender_time_us = config_.realtime_us();
    sign_site_state(out_state_, key_);
    const int len = out_state_.encode(sent_states_.slot(), 0, 512);
    if (len <= 0) continue;
    publish_bytes(channel::kSiteState, sent_states_.slot(), len);
    sent_states_.commit(len);
    counters_.states_published.fetch_add(1, std::memory_order_relaxed);
  }
  // handleTimeout, never handle(): stop() must be able to end the thread within one timeout.
  lcm_.handleTimeout(timeout_ms);
}

template <std::size_t Bytes, std::size_t Count>
bool SiteChannel::SentRing<Bytes, Count>::contains(const void* data, std::uint32_t len) const noexcept {
  for (std::size_t i = 0; i < Count; ++i) {
    if (size[i] == len && len > 0 && std::memcmp(bytes[i].data(), data, len) == 0) return true;
  }
  return false;
}

void SiteChannel::on_state(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  if (sent_states_.contains(rbuf->data, rbuf->data_size)) {
    counters_.own_echoes.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::int64_t received_us = config_.monotonic_us();
  const std::span<const std::uint8_t> bytes(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size);
  const SiteReason verdict = verifier_.check_state_bytes(bytes, in_state_, config_.realtime_us());
  if (verdict != SiteReason::Accepted) {
    refused(verdict, in_state_.machine_id, received_us);
    return;
  }
  verified_state_.roster_index = verifier_.roster().index_of(in_state_.machine_id);
  verified_state_.received_us = received_us;
  verified_state_.state = in_state_;
  (void)states_in_.try_push(verified_state_);
}

void SiteChannel::on_plan(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  if (sent_plans_.contains(rbuf->data, rbuf->data_size)) {
    counters_.own_echoes.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::int64_t received_us = config_.monotonic_us();
  const std::span<const std::uint8_t> bytes(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size);
  const SiteReason verdict = verifier_.check_plan_bytes(bytes, in_plan_, config_.realtime_us());
  if (verdict != SiteReason::Accepted) {
    refused(verdict, in_plan_.machine_id, received_us);
    return;
  }
  verified_plan_.roster_index = verifier_.roster().index_of(in_plan_.machine_id);
  verified_plan_.plan = in_plan_;
  (void)plans_in_.try_push(verified_plan_);
}

void SiteChannel::refused(SiteReason reason, std::int32_t machine_id, std::int64_t now_us) {
  // A flood of refusals (a member with another key sends 20 a second) raises one alert per
  // period; the verifier's counts say how many and why.
  if (alerted_ && now_us - last_alert_us_ < config_.refusal_alert_period_us) return;
  alerted_ = true;
  last_alert_us_ = now_us;
  alert_t a{};
  a.utime = now_us;
  a.alert_id = next_alert_id_++;
  a.severity = alert_t::SEVERITY_WARN;
  a.source = alert_t::SOURCE_SENSING;
  a.active = true;
  // An event rather than a condition that clears: someone has to look at the site's keys.
  a.clear_condition = alert_t::CLEAR_ON_OPERATOR_ACK;
  a.value_unit = alert_t::UNIT_NONE;
  a.value = static_cast<double>(reason);  // SiteReason
  a.limit = std::numeric_limits<double>::quiet_NaN();
  a.index = machine_id;  // as the message claims it; 0 when it did not decode
  a.min_clearance = std::numeric_limits<double>::quiet_NaN();
  std::array<std::uint8_t, 256> buf{};
  const int len = a.encode(buf.data(), 0, static_cast<int>(buf.size()));
  if (len > 0) {
    lcm::LCM& out = alert_lcm_ ? *alert_lcm_ : lcm_;
    if (out.publish(channel::kAlert, buf.data(), static_cast<unsigned>(len)) != 0) counters_.publish_errors.fetch_add(1, std::memory_order_relaxed);
  }
  counters_.refusal_alerts.fetch_add(1, std::memory_order_relaxed);
}

void SiteChannel::take(SiteInputs& inputs, std::int64_t now_us, SiteTakeObserver* observer) noexcept {
  while (states_in_.try_pop(take_state_)) {
    // Received during this cycle's wait at the latest: never later than the cycle's own time.
    take_site_state(inputs, take_state_.roster_index, take_state_.state, std::min(take_state_.received_us, now_us), observer);
  }
  while (plans_in_.try_pop(take_plan_)) take_site_plan(inputs, take_plan_.roster_index, take_plan_.plan, observer);
}

}  // namespace mgc::firmware
