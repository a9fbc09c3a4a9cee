// SPDX-License-Identifier: Apache-2.0
// Command authentication: key file errors, MAC and replay checks, stops from anyone.

#include <mgc/command_status_t.hpp>
#include <mgc/firmware/command_auth.hpp>

#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <limits>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

using mgc::command_status_t;
using mgc::operator_command_t;
using namespace mgc::firmware;

namespace {

std::array<std::uint8_t, kCommandKeyBytes> key_bytes(std::uint8_t seed) {
  std::array<std::uint8_t, kCommandKeyBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(seed + 7 * i);
  return k;
}

operator_command_t goal(std::int32_t sender, std::int64_t sequence) {
  operator_command_t c{};
  c.utime = 1'000'000;
  c.kind = operator_command_t::KIND_GOAL;
  c.sender_id = sender;
  c.sequence = sequence;
  c.num_joints = 4;
  c.goal_position[0] = 0.5;
  c.goal_position[1] = 0.7;
  c.goal_position[2] = 22.0;
  c.goal_position[3] = 9.0;
  return c;
}

std::string temp_path(const char* name) {
  return "/tmp/mgc_feed_test_" + std::to_string(::getpid()) + "_" + name;
}

void write_file(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::uint8_t> encode(const operator_command_t& c) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(c.getEncodedSize()));
  REQUIRE(c.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  return buf;
}

}  // namespace

TEST_CASE("key file: 32 bytes load, missing, short and long files fail with the path", "[unit]") {
  const auto k = key_bytes(3);
  const std::string good = temp_path("good.key");
  write_file(good, std::vector<std::uint8_t>(k.begin(), k.end()));
  REQUIRE(load_command_key(good).bytes() == k);

  const std::string shorter = temp_path("short.key");
  write_file(shorter, std::vector<std::uint8_t>(k.begin(), k.begin() + 31));
  REQUIRE_THROWS_WITH(load_command_key(shorter), Catch::Contains(shorter) && Catch::Contains("31 bytes") &&
                                                     Catch::Contains("expected exactly 32"));
  const std::string longer = temp_path("long.key");
  std::vector<std::uint8_t> more(k.begin(), k.end());
  more.push_back('\n');
  write_file(longer, more);
  REQUIRE_THROWS_WITH(load_command_key(longer), Catch::Contains("more than 32"));
  const std::string missing = temp_path("missing.key");
  REQUIRE_THROWS_AS(load_command_key(missing), CommandKeyError);
  REQUIRE_THROWS_WITH(load_command_key(missing), Catch::Contains(missing) && Catch::Contains("cannot open"));
  std::remove(good.c_str());
  std::remove(shorter.c_str());
  std::remove(longer.c_str());
}

TEST_CASE("the MAC covers every field but itself", "[unit]") {
  const operator_command_t c = goal(1, 10);
  std::array<std::uint8_t, 256> buf{};
  const std::size_t n = command_canonical_bytes(c, buf);
  REQUIRE(n + kCommandMacBytes == static_cast<std::size_t>(c.getEncodedSize()));
  // The same command with a different MAC has the same canonical bytes.
  operator_command_t other = c;
  other.mac[0] = 0xff;
  std::array<std::uint8_t, 256> buf2{};
  REQUIRE(command_canonical_bytes(other, buf2) == n);
  REQUIRE(std::equal(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n), buf2.begin()));
  // And a change in any other field changes them.
  other.goal_position[3] += 0.001;
  REQUIRE(command_canonical_bytes(other, buf2) == n);
  REQUIRE_FALSE(std::equal(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n), buf2.begin()));
}

TEST_CASE("a signed goal is accepted once, replays and older sequences are refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  operator_command_t c = goal(7, 100);
  sign_command(c, key);
  const CommandVerdict first = auth.check(c);
  REQUIRE(first.accepted);
  REQUIRE(first.reason == command_status_t::REASON_ACCEPTED);
  REQUIRE(auth.last_sequence(7) == 100);

  const CommandVerdict replay = auth.check(c);
  REQUIRE_FALSE(replay.accepted);
  REQUIRE(replay.reason == command_status_t::REASON_STALE_SEQUENCE);

  operator_command_t older = goal(7, 99);
  sign_command(older, key);
  REQUIRE(auth.check(older).reason == command_status_t::REASON_STALE_SEQUENCE);

  operator_command_t newer = goal(7, 101);
  newer.kind = operator_command_t::KIND_ACKNOWLEDGE;
  newer.num_joints = 0;
  newer.alert_id = 12;
  sign_command(newer, key);
  REQUIRE(auth.check(newer).accepted);
  REQUIRE(auth.last_sequence(7) == 101);

  // Counters are per sender: another sender may use a lower sequence.
  operator_command_t other = goal(8, 5);
  sign_command(other, key);
  REQUIRE(auth.check(other).accepted);
  REQUIRE(auth.last_sequence(7) == 101);
}

TEST_CASE("a tampered byte anywhere in the command is refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  operator_command_t c = goal(7, 100);
  sign_command(c, key);
  const std::vector<std::uint8_t> bytes = encode(c);
  int refused = 0;
  int bad_mac = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    CommandAuthenticator auth(key);  // fresh counters: only the flipped byte can be the reason
    std::vector<std::uint8_t> tampered = bytes;
    tampered[i] ^= 0x01;
    operator_command_t decoded{};
    const CommandVerdict v = auth.check_bytes(tampered, decoded);
    refused += v.accepted ? 0 : 1;
    bad_mac += v.reason == command_status_t::REASON_BAD_MAC ? 1 : 0;
    CAPTURE(i, static_cast<int>(v.reason));
    REQUIRE_FALSE(v.accepted);
  }
  REQUIRE(refused == static_cast<int>(bytes.size()));
  // Flips in the fingerprint fail to decode (MALFORMED); a flip in kind may make it a stop or an
  // unknown kind; every other flip is a bad MAC.
  REQUIRE(bad_mac >= static_cast<int>(bytes.size()) - 8 - 8);
  CommandAuthenticator auth(key);
  operator_command_t decoded{};
  REQUIRE(auth.check_bytes(bytes, decoded).accepted);
}

TEST_CASE("a goal signed with another key, or unsigned, is refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  const CommandKey wrong(key_bytes(2));
  CommandAuthenticator auth(key);
  operator_command_t c = goal(7, 100);
  sign_command(c, wrong);
  REQUIRE(auth.check(c).reason == command_status_t::REASON_BAD_MAC);
  operator_command_t unsigned_goal = goal(7, 101);
  REQUIRE(auth.check(unsigned_goal).reason == command_status_t::REASON_BAD_MAC);
  // A refused command does not move the counter.
  REQUIRE(auth.last_sequence(7) == 0);
}

TEST_CASE("a stop is accepted from anyone, without a MAC, and leaves the counters alone", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  stop.sender_id = 99;
  stop.sequence = 1'000'000;
  REQUIRE(auth.check(stop).accepted);
  REQUIRE(auth.check(stop).accepted);  // repeated stops too
  REQUIRE(auth.last_sequence(99) == 0);
}

TEST_CASE("unknown kinds, malformed bytes and bad fields are refused with their reason", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  operator_command_t odd = goal(7, 1);
  odd.kind = 42;
  sign_command(odd, key);
  REQUIRE(auth.check(odd).reason == command_status_t::REASON_UNKNOWN_KIND);

  operator_command_t decoded{};
  const std::vector<std::uint8_t> junk = {1, 2, 3};
  REQUIRE(auth.check_bytes(junk, decoded).reason == command_status_t::REASON_MALFORMED);
  std::vector<std::uint8_t> longer = encode(goal(7, 2));
  longer.push_back(0);
  REQUIRE(auth.check_bytes(longer, decoded).reason == command_status_t::REASON_MALFORMED);

  operator_command_t too_many = goal(7, 3);
  too_many.num_joints = 9;
  sign_command(too_many, key);
  REQUIRE(auth.check(too_many).reason == command_status_t::REASON_MALFORMED);
  operator_command_t nan_goal = goal(7, 4);
  nan_goal.goal_position[1] = std::numeric_limits<double>::quiet_NaN();
  sign_command(nan_goal, key);
  REQUIRE(auth.check(nan_goal).reason == command_status_t::REASON_MALFORMED);
}

TEST_CASE("the sequence floor refuses commands from before a restart", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key, 1'700'000'000'000'000);
  operator_command_t before = goal(7, 1'699'999'999'000'000);
  sign_command(before, key);
  REQUIRE(auth.check(before).reason == command_status_t::REASON_STALE_SEQUENCE);
  operator_command_t after = goal(7, 1'700'000'000'000'001);
  sign_command(after, key);
  REQUIRE(auth.check(after).accepted);
}

TEST_CASE("the replay table has a fixed size, further senders are refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  for (std::int32_t s = 0; s < static_cast<std::int32_t>(CommandAuthenticator::kMaxSenders); ++s) {
    operator_command_t c = goal(s, 1);
    sign_command(c, key);
    REQUIRE(auth.check(c).accepted);
  }
  operator_command_t extra = goal(1000, 1);
  sign_command(extra, key);
  REQUIRE(auth.check(extra).reason == command_status_t::REASON_TOO_MANY_SENDERS);
}
