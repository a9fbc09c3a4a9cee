// SPDX-License-Identifier: Apache-2.0
// The site channel of one mgc (docs/site.md, "mgc on a site") on an in-process LCM (memq://):
// what the loop posts is published signed and completed, its own echo is told from a machine
// posing as it, accepted messages reach the loop's inputs and refused ones never do, are counted
// and alerted; the loop's side allocates nothing.
#include <mgc/alert_t.hpp>
#include <mgc/firmware/site_auth.hpp>
#include <mgc/firmware/site_channel.hpp>

#include "allocation_counter.hpp"
#include "site_support.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <memory>
#include <span>
#include <string>
#include <vector>

using namespace mgc::firmware;
using mgc::site_plan_t;
using mgc::site_state_t;
using mgc::test::kSiteT0_us;

namespace {

std::atomic<std::int64_t> g_realtime_us{kSiteT0_us};
std::atomic<std::int64_t> g_monotonic_us{5'000'000};
std::int64_t fake_realtime_us() noexcept { return g_realtime_us.load(); }
std::int64_t fake_monotonic_us() noexcept { return g_monotonic_us.load(); }

//! Machine 1's (the receiver's, the TMS870's) own state as its controller gives it: no sequence,
//! time or MAC.
site_state_t crane_state() {
  site_state_t s{};
  s.machine_id = 1;
  s.priority = 2;
  s.supervisor_state = mgc::machine_state_t::SUPERVISOR_HOLD;
  s.num_joints = 4;
  s.joint_position[0] = 0.5;
  s.joint_position[1] = 0.8;
  s.joint_position[2] = 20.0;
  s.joint_position[3] = 14.0;
  return s;
}

template <class Msg>
std::vector<std::uint8_t> encode(const Msg& msg) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  REQUIRE(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
  return bytes;
}

//! What was seen on a channel of the channel's own LCM instance.
struct Tap {
  std::vector<std::vector<std::uint8_t>> messages;
  void on(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
    const auto* data = static_cast<const std::uint8_t*>(rbuf->data);
    messages.emplace_back(data, data + rbuf->data_size);
  }
};

std::unique_ptr<SiteChannel> make_channel(const SiteKey& key) {
  g_realtime_us = kSiteT0_us;
  g_monotonic_us = 5'000'000;
  SiteChannelConfig config;
  config.lcm_url = "memq://";
  config.realtime_us = &fake_realtime_us;
  config.monotonic_us = &fake_monotonic_us;
  return std::make_unique<SiteChannel>(config, key, mgc::test::two_machine_roster(), 1);
}

void pump(SiteChannel& channel) {
  for (int i = 0; i < 8; ++i) channel.run_once(0);
}

}  // namespace

TEST_CASE("the site channel signs and publishes what the loop posts, and takes its own echo for no one else", "[unit][lcm]") {
  const SiteKey key(mgc::test::site_key_bytes(1));
  auto channel = make_channel(key);
  Tap states;
  channel->lcm().subscribe(channel::kSiteState, &Tap::on, &states);

  g_realtime_us = kSiteT0_us + 1'000;
  REQUIRE(channel->post_state(crane_state()));
  pump(*channel);
  REQUIRE(states.messages.size() == 1);
  CHECK(channel->counters().states_published.load() == 1);
  // memq delivers the channel's own message back to it, as multicast does: an echo, not a refusal.
  CHECK(channel->counters().own_echoes.load() == 1);
  CHECK(channel->verifier().refused() == 0);

  // What went out verifies at the other machine: signed, its sequence above the sender's clock at
  // start, its time the sender's clock at signing.
  SiteVerifier other(key, mgc::test::two_machine_roster(), 2);
  site_state_t got{};
  const std::vector<std::uint8_t>& bytes = states.messages.front();
  CHECK(other.check_state_bytes(std::span<const std::uint8_t>(bytes.data(), bytes.size()), got, g_realtime_us.load()) ==
        SiteReason::Accepted);
  CHECK(got.sequence == kSiteT0_us + 1);
  CHECK(got.sender_time_us == kSiteT0_us + 1'000);
  CHECK(got.joint_position[2] == 20.0);

  // The same state sent by someone else (a replay of an older one, or another sender with the key
  // and machine 1's id) is not an echo: refused as the receiver's own machine.
  site_state_t posing = crane_state();
  posing.sequence = kSiteT0_us + 500;
  posing.sender_time_us = g_realtime_us.load();
  sign_site_state(posing, key);
  const std::vector<std::uint8_t> posing_bytes = encode(posing);
  channel->lcm().publish(channel::kSiteState, posing_bytes.data(), static_cast<unsigned>(posing_bytes.size()));
  pump(*channel);
  CHECK(channel->verifier().count(SiteReason::OwnMachine) == 1);
  CHECK(channel->counters().own_echoes.load() == 1);
}

TEST_CASE("accepted site messages reach the loop's inputs, refused ones are counted, alerted at most once a second, and never reach it", "[unit][lcm]") {
  const SiteKey key(mgc::test::site_key_bytes(1));
  auto channel = make_channel(key);
  Tap alerts;
  channel->lcm().subscribe(channel::kAlert, &Tap::on, &alerts);
  auto inputs = std::make_unique<SiteInputs>();

  site_state_t tower = mgc::test::tower_state(kSiteT0_us + 1, kSiteT0_us);
  sign_site_state(tower, key);
  const std::vector<std::uint8_t> good = encode(tower);
  channel->lcm().publish(channel::kSiteState, good.data(), static_cast<unsigned>(good.size()));
  auto plan = mgc::test::tower_plan(kSiteT0_us + 1, 4, kSiteT0_us);
  sign_site_plan(*plan, key);
  const std::vector<std::uint8_t> good_plan = encode(*plan);
  channel->lcm().publish(channel::kSitePlan, good_plan.data(), static_cast<unsigned>(good_plan.size()));
  g_monotonic_us = 5'000'100;
  pump(*channel);
  CHECK(channel->verifier().count(SiteReason::Accepted) == 2);
  // Nothing reaches the loop before it takes it; then the roster's second entry (machine 2).
  CHECK_FALSE(inputs->peers[1].has_state);
  channel->take(*inputs, 5'000'050);
  REQUIRE(inputs->peers[1].has_state);
  REQUIRE(inputs->peers[1].has_plan);
  CHECK(inputs->peers[1].state.sequence == kSiteT0_us + 1);
  CHECK(inputs->peers[1].plan.num_waypoints == 4);
  // Received after the cycle began: counted as received at its start.
  CHECK(inputs->peers[1].state_received_us == 5'000'050);
  CHECK_FALSE(inputs->peers[0].has_state);

  // Another key, then a tampered one, then the good one replayed: refused, counted, one alert in
  // the second, and the loop's inputs keep the accepted state.
  const SiteKey other_key(mgc::test::site_key_bytes(2));
  site_state_t forged = mgc::test::tower_state(kSiteT0_us + 2, kSiteT0_us);
  forged.joint_position[0] = 1.0;
  sign_site_state(forged, other_key);
  const std::vector<std::uint8_t> forged_bytes = encode(forged);
  std::vector<std::uint8_t> tampered = good;
  tampered[40] ^= 0x01U;
  for (const std::vector<std::uint8_t>* bytes : {&forged_bytes, static_cast<const std::vector<std::uint8_t>*>(&tampered), &good}) {
    channel->lcm().publish(channel::kSiteState, bytes->data(), static_cast<unsigned>(bytes->size()));
  }
  g_monotonic_us = 5'200'000;
  pump(*channel);
  CHECK(channel->verifier().count(SiteReason::BadMac) == 2);
  CHECK(channel->verifier().count(SiteReason::StaleSequence) == 1);
  CHECK(channel->counters().refusal_alerts.load() == 1);
  REQUIRE(alerts.messages.size() == 1);
  mgc::alert_t alert{};
  REQUIRE(alert.decode(alerts.messages.front().data(), 0, static_cast<int>(alerts.messages.front().size())) > 0);
  CHECK(alert.alert_id == kSiteAlertIdBase);
  CHECK(alert.source == mgc::alert_t::SOURCE_SENSING);
  CHECK(alert.index == 2);
  CHECK(alert.value == static_cast<double>(SiteReason::BadMac));
  channel->take(*inputs, 5'200'000);
  CHECK(inputs->peers[1].state.sequence == kSiteT0_us + 1);
  CHECK(inputs->peers[1].state.joint_position[0] == tower.joint_position[0]);

  // A second later the next refusal raises the next alert.
  channel->lcm().publish(channel::kSiteState, forged_bytes.data(), static_cast<unsigned>(forged_bytes.size()));
  g_monotonic_us = 6'300'000;
  pump(*channel);
  CHECK(channel->counters().refusal_alerts.load() == 2);
  CHECK(alerts.messages.size() == 2);
}

TEST_CASE("the loop's side of the site channel allocates nothing", "[unit]") {
  const SiteKey key(mgc::test::site_key_bytes(1));
  auto channel = make_channel(key);
  auto inputs = std::make_unique<SiteInputs>();
  auto plan = mgc::test::tower_plan(1, 64);
  plan->machine_id = 1;
  const site_state_t state = crane_state();
  site_state_t tower = mgc::test::tower_state(kSiteT0_us + 1, kSiteT0_us);
  sign_site_state(tower, key);
  const std::vector<std::uint8_t> good = encode(tower);
  channel->lcm().publish(channel::kSiteState, good.data(), static_cast<unsigned>(good.size()));
  pump(*channel);

  const long before = mgc::test::allocation_count();
  for (int i = 0; i < 100; ++i) {
    (void)channel->post_state(state);
    if (i % 20 == 0) (void)channel->post_plan(*plan);
    channel->take(*inputs, 5'000'000 + i * 10'000);
  }
  CHECK(mgc::test::allocation_count() - before == 0);
  CHECK(inputs->peers[1].has_state);
  // The outgoing queues hold 8 states and 4 plans: the rest were dropped and counted.
  CHECK(channel->queue_drops() == (100 - SiteChannel::kStatesOut) + (5 - SiteChannel::kPlansOut));
}
