// SPDX-License-Identifier: Apache-2.0
// What runs per site message on the LCM I/O thread (decode and verify, accepted or refused) and
// what the loop runs every cycle (the site rules) never touch the heap once constructed.

#include <mgc/firmware/site_auth.hpp>
#include <mgc/firmware/site_rules.hpp>

#include "allocation_counter.hpp"
#include "site_support.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <vector>

using namespace mgc::firmware;
using mgc::site_plan_t;
using mgc::site_state_t;
using mgc::test::allocation_count;
using mgc::test::kSiteT0_us;

TEST_CASE("decoding and verifying site messages and deciding the site rules do not allocate", "[unit]") {
  const SiteKey key(mgc::test::site_key_bytes(1));
  SiteVerifier verifier(key, mgc::test::two_machine_roster(), 1);
  const SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;

  // The wire bytes, made before counting: 100 states and 10 plans, a tenth of the states forged.
  std::vector<std::vector<std::uint8_t>> states;
  std::vector<std::vector<std::uint8_t>> plans;
  for (int i = 1; i <= 100; ++i) {
    site_state_t s = mgc::test::tower_state(i, kSiteT0_us + i * 50'000);
    sign_site_state(s, key);
    if (i % 10 == 0) s.joint_position[0] += 0.1;
    states.emplace_back(static_cast<std::size_t>(s.getEncodedSize()));
    REQUIRE(s.encode(states.back().data(), 0, s.getEncodedSize()) == s.getEncodedSize());
  }
  for (int i = 1; i <= 10; ++i) {
    auto p = mgc::test::tower_plan(i, 64, kSiteT0_us + i * 500'000);
    sign_site_plan(*p, key);
    plans.emplace_back(static_cast<std::size_t>(p->getEncodedSize()));
    REQUIRE(p->encode(plans.back().data(), 0, p->getEncodedSize()) == p->getEncodedSize());
  }
  auto state = std::make_unique<site_state_t>();
  auto plan = std::make_unique<site_plan_t>();
  std::array<SitePeerInput, 2> peers{};
  peers[1].state = state.get();
  peers[1].plan = plan.get();
  peers[1].meet_in_s = 0.9;

  // The feed thread's pattern: decode into scratch, copy into what the loop sees only when accepted.
  auto state_scratch = std::make_unique<site_state_t>();
  auto plan_scratch = std::make_unique<site_plan_t>();
  const auto receive = [&](const std::vector<std::uint8_t>& bytes, std::int64_t now_us) {
    if (verifier.check_state_bytes(bytes, *state_scratch, now_us) != SiteReason::Accepted) return 0;
    *state = *state_scratch;
    peers[1].state_received_us = now_us;
    return 1;
  };

  const long before = allocation_count();
  int accepted = 0;
  int stops = 0;
  for (int i = 1; i <= 100; ++i) {
    const std::int64_t now_us = kSiteT0_us + i * 50'000;
    accepted += receive(states[static_cast<std::size_t>(i - 1)], now_us);
    accepted += receive(states[static_cast<std::size_t>(i - 1)], now_us);  // replayed
    if (i % 10 == 0 && verifier.check_plan_bytes(plans[static_cast<std::size_t>(i / 10 - 1)], *plan_scratch, now_us) == SiteReason::Accepted) {
      *plan = *plan_scratch;
      ++accepted;
    }
    const SiteDecision d = decide_site(roster, 1, peers, now_us, config);
    stops += d.motion == SiteMotion::Stop ? 1 : 0;
  }
  const long after = allocation_count();
  CHECK(accepted == 90 + 10);
  CHECK(verifier.count(SiteReason::BadMac) == 20);
  CHECK(verifier.count(SiteReason::StaleSequence) == 90);
  CHECK(stops == 100);  // the lower-priority machine stops 2 H = 1 s before meeting
  CHECK(state->sequence == 99);  // the last accepted: the forged 100th never reached the loop's copy
  REQUIRE(after - before == 0);
}
