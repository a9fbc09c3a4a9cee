// SPDX-License-Identifier: Apache-2.0
// Site channel authentication and checks (docs/site.md): a signed, fresh, well-formed message of
// a machine of the site is accepted; every refusal reason is refused, counted under its reason and
// leaves the machine's sequence counter where it was.

#include <mgc/firmware/site_auth.hpp>

#include "site_support.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

using namespace mgc::firmware;
using mgc::site_plan_t;
using mgc::site_state_t;
using mgc::test::kSiteT0_us;
using mgc::test::site_key_bytes;
using mgc::test::tower_plan;
using mgc::test::tower_state;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Receiver {
  SiteKey key{site_key_bytes(1)};
  SiteVerifier verifier{key, mgc::test::two_machine_roster(), 1};
  std::map<SiteReason, std::uint64_t> expected;  // what the test caused, per reason

  SiteReason state(site_state_t s, std::int64_t now_us = kSiteT0_us) {
    sign_site_state(s, key);
    const SiteReason r = verifier.check_state(s, now_us);
    ++expected[r];
    return r;
  }
  SiteReason plan(std::unique_ptr<site_plan_t> p, std::int64_t now_us = kSiteT0_us) {
    sign_site_plan(*p, key);
    const SiteReason r = verifier.check_plan(*p, now_us);
    ++expected[r];
    return r;
  }
  void require_counts() const {
    std::uint64_t refused = 0;
    for (std::size_t i = 0; i < kNumSiteReasons; ++i) {
      const auto reason = static_cast<SiteReason>(i);
      const auto it = expected.find(reason);
      const std::uint64_t want = it == expected.end() ? 0 : it->second;
      CAPTURE(site_reason_name(reason));
      CHECK(verifier.count(reason) == want);
      if (reason != SiteReason::Accepted) refused += want;
    }
    CHECK(verifier.refused() == refused);
  }
};

std::vector<std::uint8_t> bytes_of(const site_state_t& s) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(s.getEncodedSize()));
  REQUIRE(s.encode(b.data(), 0, static_cast<int>(b.size())) == static_cast<int>(b.size()));
  return b;
}

}  // namespace

TEST_CASE("site key file: 32 raw bytes, refusals name the site key file", "[unit]") {
  const std::string path = "/tmp/mgc_site_auth_test_" + std::to_string(::getpid()) + ".key";
  {
    std::ofstream f(path, std::ios::binary);
    f << std::string(31, 'k');
  }
  try {
    (void)load_site_key(path);
    FAIL("a 31-byte key loaded");
  } catch (const CommandKeyError& e) {
    CHECK(std::string(e.what()) == "site key file " + path + ": 31 bytes; expected exactly 32 raw bytes");
  }
  {
    std::ofstream f(path, std::ios::binary);
    f << std::string(32, 'k');
  }
  const SiteKey key = load_site_key(path);
  std::remove(path.c_str());
  CHECK(key.bytes()[0] == 'k');
  CHECK(key.bytes()[31] == 'k');
}

TEST_CASE("a verifier needs its own machine in the roster and a positive skew", "[unit]") {
  const SiteKey key(site_key_bytes(1));
  CHECK_THROWS_AS(SiteVerifier(key, mgc::test::two_machine_roster(), 9), std::invalid_argument);
  CHECK_THROWS_AS(SiteVerifier(key, mgc::test::two_machine_roster(), 1, 0), std::invalid_argument);
  CHECK_NOTHROW(SiteVerifier(key, mgc::test::two_machine_roster(), 2));
}

TEST_CASE("a signed, fresh, well-formed state and plan of another machine are accepted", "[unit]") {
  Receiver rx;
  CHECK(rx.state(tower_state(100)) == SiteReason::Accepted);
  CHECK(rx.verifier.last_state_sequence(2) == 100);
  CHECK(rx.plan(tower_plan(40, 64)) == SiteReason::Accepted);  // its own counter: below the state's is fine
  CHECK(rx.verifier.last_plan_sequence(2) == 40);
  CHECK(rx.verifier.last_state_sequence(2) == 100);
  rx.require_counts();
}

TEST_CASE("forged MACs are refused: another key, a field changed after signing, no MAC", "[unit]") {
  Receiver rx;
  site_state_t s = tower_state(100);
  sign_site_state(s, SiteKey(site_key_bytes(2)));
  CHECK(rx.verifier.check_state(s, kSiteT0_us) == SiteReason::BadMac);
  s = tower_state(100);
  sign_site_state(s, rx.key);
  s.joint_position[1] = 31.0;
  CHECK(rx.verifier.check_state(s, kSiteT0_us) == SiteReason::BadMac);
  s = tower_state(100);  // mac all zero
  CHECK(rx.verifier.check_state(s, kSiteT0_us) == SiteReason::BadMac);
  auto p = tower_plan(5);
  sign_site_plan(*p, rx.key);
  p->waypoint_time_s[3] = 31.0;
  CHECK(rx.verifier.check_plan(*p, kSiteT0_us) == SiteReason::BadMac);
  rx.expected[SiteReason::BadMac] = 4;
  CHECK(rx.verifier.last_state_sequence(2) == 0);
  // An authentic message after them still goes through: nothing forged moved the counter.
  CHECK(rx.state(tower_state(100)) == SiteReason::Accepted);
  rx.require_counts();
}

TEST_CASE("replayed and older sequences are refused per machine and type", "[unit]") {
  Receiver rx;
  CHECK(rx.state(tower_state(100)) == SiteReason::Accepted);
  CHECK(rx.state(tower_state(100)) == SiteReason::StaleSequence);  // the same message again
  CHECK(rx.state(tower_state(99)) == SiteReason::StaleSequence);   // an older one
  CHECK(rx.state(tower_state(0)) == SiteReason::StaleSequence);
  CHECK(rx.state(tower_state(101)) == SiteReason::Accepted);
  CHECK(rx.plan(tower_plan(7)) == SiteReason::Accepted);
  CHECK(rx.plan(tower_plan(7)) == SiteReason::StaleSequence);
  CHECK(rx.plan(tower_plan(6)) == SiteReason::StaleSequence);
  CHECK(rx.verifier.last_state_sequence(2) == 101);
  CHECK(rx.verifier.last_plan_sequence(2) == 7);
  rx.require_counts();
}

TEST_CASE("a sender time outside the tolerated skew of the receiver's clock is refused", "[unit]") {
  Receiver rx;
  const std::int64_t skew = kDefaultSiteSkew_us;
  CHECK(rx.state(tower_state(1, kSiteT0_us + skew + 1)) == SiteReason::TimeAhead);
  CHECK(rx.state(tower_state(2, kSiteT0_us - skew - 1)) == SiteReason::TimeBehind);
  CHECK(rx.plan(tower_plan(1, 4, kSiteT0_us + skew + 1)) == SiteReason::TimeAhead);
  CHECK(rx.plan(tower_plan(2, 4, kSiteT0_us - skew - 1)) == SiteReason::TimeBehind);
  CHECK(rx.state(tower_state(3, 0)) == SiteReason::TimeBehind);
  // The window's edges are inside it.
  CHECK(rx.state(tower_state(4, kSiteT0_us - skew)) == SiteReason::Accepted);
  CHECK(rx.state(tower_state(5, kSiteT0_us + skew)) == SiteReason::Accepted);
  // A recording replayed later: authentic, above the counter, but old by the receiver's clock.
  CHECK(rx.state(tower_state(6), kSiteT0_us + skew + 1) == SiteReason::TimeBehind);
  rx.require_counts();
}

TEST_CASE("a machine the site file does not list, my own id and a wrong priority are refused", "[unit]") {
  Receiver rx;
  site_state_t s = tower_state(1);
  s.machine_id = 9;
  CHECK(rx.state(s) == SiteReason::UnknownMachine);
  auto p = tower_plan(1);
  p->machine_id = 9;
  CHECK(rx.plan(std::move(p)) == SiteReason::UnknownMachine);
  s = tower_state(2);
  s.machine_id = 1;  // the receiver's own id, with its own priority
  s.priority = 2;
  CHECK(rx.state(s) == SiteReason::OwnMachine);
  p = tower_plan(2);
  p->machine_id = 1;
  CHECK(rx.plan(std::move(p)) == SiteReason::OwnMachine);
  s = tower_state(3);
  s.priority = 2;  // machine 2 claiming another's priority
  CHECK(rx.state(s) == SiteReason::WrongPriority);
  s.priority = 0;
  CHECK(rx.state(s) == SiteReason::WrongPriority);
  CHECK(rx.verifier.last_state_sequence(2) == 0);
  rx.require_counts();
}

TEST_CASE("malformed states are refused: NaN, joint count, ranges, speeds, fields", "[unit]") {
  Receiver rx;
  std::int64_t seq = 1000;
  const auto refused = [&](auto change, SiteReason want) {
    site_state_t s = tower_state(++seq);
    change(s);
    CHECK(rx.state(s) == want);
  };
  refused([](site_state_t& s) { s.joint_position[1] = kNaN; }, SiteReason::NotFinite);
  refused([](site_state_t& s) { s.joint_velocity[2] = std::numeric_limits<double>::infinity(); }, SiteReason::NotFinite);
  refused([](site_state_t& s) { s.stop_travel[0] = kNaN; }, SiteReason::NotFinite);
  refused([](site_state_t& s) { s.time_to_rest_s = kNaN; }, SiteReason::NotFinite);
  refused([](site_state_t& s) { s.plan_time_s = kNaN; }, SiteReason::NotFinite);
  refused([](site_state_t& s) { s.num_joints = 4; }, SiteReason::JointCount);
  refused([](site_state_t& s) { s.num_joints = 9; }, SiteReason::JointCount);
  refused([](site_state_t& s) { s.num_joints = -1; }, SiteReason::JointCount);
  refused([](site_state_t& s) { s.joint_position[1] = 59.7 + 0.1 + 1e-6; }, SiteReason::OutOfRange);  // trolley past its tolerance
  refused([](site_state_t& s) { s.joint_position[2] = -0.1 - 1e-6; }, SiteReason::OutOfRange);
  refused([](site_state_t& s) { s.stop_travel[1] = 30.0; }, SiteReason::OutOfRange);  // would stop past the jib tip
  refused([](site_state_t& s) { s.joint_velocity[1] = 1.5 * 0.633 + 0.01; }, SiteReason::OutOfRange);
  refused([](site_state_t& s) { s.supervisor_state = 0; }, SiteReason::BadField);
  refused([](site_state_t& s) { s.supervisor_state = 9; }, SiteReason::BadField);
  refused([](site_state_t& s) { s.time_to_rest_s = -0.1; }, SiteReason::BadField);
  refused([](site_state_t& s) { s.plan_id = -1; }, SiteReason::BadField);
  refused([](site_state_t& s) { s.plan_time_s = -1.0; }, SiteReason::BadField);
  // Inside the tolerances, and a continuous slew anywhere: accepted.
  site_state_t s = tower_state(++seq);
  s.joint_position[0] = 7.0;
  s.joint_position[1] = 59.7 + 0.09;
  s.joint_position[2] = -0.09;
  s.joint_velocity[1] = -1.5 * 0.633;
  CHECK(rx.state(s) == SiteReason::Accepted);
  rx.require_counts();
}

TEST_CASE("malformed plans are refused: waypoint count and times, NaN, ranges, ids", "[unit]") {
  Receiver rx;
  std::int64_t seq = 1000;
  const auto refused = [&](auto change, SiteReason want) {
    auto p = tower_plan(++seq);
    change(*p);
    CHECK(rx.plan(std::move(p)) == want);
  };
  refused([](site_plan_t& p) { p.waypoint_time_s[2] = p.waypoint_time_s[1]; }, SiteReason::WaypointTimes);
  refused([](site_plan_t& p) { p.waypoint_time_s[3] = 5.0; }, SiteReason::WaypointTimes);
  refused([](site_plan_t& p) { p.waypoint_time_s[0] = -0.5; }, SiteReason::WaypointTimes);
  refused([](site_plan_t& p) { p.waypoint_time_s[1] = kNaN; }, SiteReason::NotFinite);
  refused([](site_plan_t& p) { p.positions[2][1] = kNaN; }, SiteReason::NotFinite);
  refused([](site_plan_t& p) { p.positions[3][2] = 45.2; }, SiteReason::OutOfRange);
  refused([](site_plan_t& p) { p.num_joints = 4; }, SiteReason::JointCount);
  refused([](site_plan_t& p) { p.num_waypoints = 1; }, SiteReason::BadField);
  refused([](site_plan_t& p) { p.num_waypoints = site_plan_t::MAX_WAYPOINTS + 1; }, SiteReason::BadField);
  refused([](site_plan_t& p) { p.num_waypoints = -3; }, SiteReason::BadField);
  refused([](site_plan_t& p) { p.plan_id = 0; }, SiteReason::BadField);
  // Values past num_waypoints are not the plan's: a NaN there is not looked at.
  refused([](site_plan_t& p) { p.waypoint_time_s[10] = kNaN; }, SiteReason::Accepted);
  rx.require_counts();
}

TEST_CASE("a refused message never moves the counter: the next authentic one is judged on its own", "[unit]") {
  Receiver rx;
  site_state_t bad = tower_state(500);
  bad.joint_position[2] = kNaN;
  CHECK(rx.state(bad) == SiteReason::NotFinite);
  CHECK(rx.verifier.last_state_sequence(2) == 0);
  CHECK(rx.state(tower_state(400)) == SiteReason::Accepted);
  CHECK(rx.verifier.last_state_sequence(2) == 400);
  rx.require_counts();
}

TEST_CASE("bytes from the bus: decoded exactly or refused as undecodable", "[unit]") {
  Receiver rx;
  site_state_t s = tower_state(10);
  sign_site_state(s, rx.key);
  std::vector<std::uint8_t> bytes = bytes_of(s);
  site_state_t out{};
  CHECK(rx.verifier.check_state_bytes(std::span(bytes.data(), bytes.size() - 1), out, kSiteT0_us) == SiteReason::Undecodable);
  CHECK(out.machine_id == 0);
  bytes.push_back(0);
  CHECK(rx.verifier.check_state_bytes(bytes, out, kSiteT0_us) == SiteReason::Undecodable);
  bytes.pop_back();
  auto plan = std::make_unique<site_plan_t>();
  CHECK(rx.verifier.check_plan_bytes(bytes, *plan, kSiteT0_us) == SiteReason::Undecodable);  // a state is no plan
  CHECK(rx.verifier.check_state_bytes(bytes, out, kSiteT0_us) == SiteReason::Accepted);
  CHECK(out.machine_id == 2);
  CHECK(out.joint_position[1] == 30.0);
  bytes[40] ^= 0x01;  // a bit flipped in transit, inside the joint positions
  CHECK(rx.verifier.check_state_bytes(bytes, out, kSiteT0_us) == SiteReason::BadMac);
  rx.expected[SiteReason::Undecodable] = 3;
  rx.expected[SiteReason::Accepted] = 1;
  rx.expected[SiteReason::BadMac] = 1;
  rx.require_counts();
}
