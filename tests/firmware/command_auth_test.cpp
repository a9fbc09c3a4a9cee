// SPDX-License-Identifier: Apache-2.0
// Command authentication: key file errors, MAC and replay checks, stops from anyone, the clock
// window, and the replay counters across a restart (the state file).

#include <mgc/command_status_t.hpp>
#include <mgc/firmware/command_auth.hpp>

#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <array>
#include <cstddef>
#include <limits>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

using mgc::command_status_t;
using mgc::operator_command_t;
using namespace mgc::firmware;

namespace {

// A controller clock (CLOCK_REALTIME) in µs: 2023-11-14. Sequences are stated relative to it.
constexpr std::int64_t kT0 = 1'700'000'000'000'000;

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
  operator_command_t c = goal(7, kT0 + 100);
  sign_command(c, key);
  const CommandVerdict first = auth.check(c, kT0);
  REQUIRE(first.accepted);
  REQUIRE(first.reason == command_status_t::REASON_ACCEPTED);
  REQUIRE(auth.last_sequence(7) == kT0 + 100);

  const CommandVerdict replay = auth.check(c, kT0 + 1'000);
  REQUIRE_FALSE(replay.accepted);
  REQUIRE(replay.reason == command_status_t::REASON_STALE_SEQUENCE);

  operator_command_t older = goal(7, kT0 + 99);
  sign_command(older, key);
  REQUIRE(auth.check(older, kT0 + 1'000).reason == command_status_t::REASON_STALE_SEQUENCE);

  operator_command_t newer = goal(7, kT0 + 101);
  newer.kind = operator_command_t::KIND_ACKNOWLEDGE;
  newer.num_joints = 0;
  newer.alert_id = 12;
  sign_command(newer, key);
  REQUIRE(auth.check(newer, kT0 + 1'000).accepted);
  REQUIRE(auth.last_sequence(7) == kT0 + 101);

  // Counters are per sender: another sender may use a lower sequence.
  operator_command_t other = goal(8, kT0 + 5);
  sign_command(other, key);
  REQUIRE(auth.check(other, kT0 + 1'000).accepted);
  REQUIRE(auth.last_sequence(7) == kT0 + 101);
}

TEST_CASE("a tampered byte anywhere in the command is refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  operator_command_t c = goal(7, kT0);
  sign_command(c, key);
  const std::vector<std::uint8_t> bytes = encode(c);
  int refused = 0;
  int bad_mac = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    CommandAuthenticator auth(key);  // fresh counters: only the flipped byte can be the reason
    std::vector<std::uint8_t> tampered = bytes;
    tampered[i] ^= 0x01;
    operator_command_t decoded{};
    const CommandVerdict v = auth.check_bytes(tampered, decoded, kT0);
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
  REQUIRE(auth.check_bytes(bytes, decoded, kT0).accepted);
}

TEST_CASE("a goal signed with another key, or unsigned, is refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  const CommandKey wrong(key_bytes(2));
  CommandAuthenticator auth(key);
  operator_command_t c = goal(7, kT0);
  sign_command(c, wrong);
  REQUIRE(auth.check(c, kT0).reason == command_status_t::REASON_BAD_MAC);
  operator_command_t unsigned_goal = goal(7, kT0 + 1);
  REQUIRE(auth.check(unsigned_goal, kT0).reason == command_status_t::REASON_BAD_MAC);
  // A refused command does not move the counter.
  REQUIRE(auth.last_sequence(7) == 0);
}

TEST_CASE("a stop is accepted from anyone, without a MAC, and leaves the counters alone", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  operator_command_t stop{};
  stop.kind = operator_command_t::KIND_STOP;
  stop.sender_id = 99;
  stop.sequence = 1'000'000;  // far outside the clock window: a stop is obeyed all the same
  REQUIRE(auth.check(stop, kT0).accepted);
  REQUIRE(auth.check(stop, kT0).accepted);  // repeated stops too
  REQUIRE(auth.last_sequence(99) == 0);
}

TEST_CASE("unknown kinds, malformed bytes and bad fields are refused with their reason", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  operator_command_t odd = goal(7, kT0 + 1);
  odd.kind = 42;
  sign_command(odd, key);
  REQUIRE(auth.check(odd, kT0).reason == command_status_t::REASON_UNKNOWN_KIND);

  operator_command_t decoded{};
  const std::vector<std::uint8_t> junk = {1, 2, 3};
  REQUIRE(auth.check_bytes(junk, decoded, kT0).reason == command_status_t::REASON_MALFORMED);
  operator_command_t whole = goal(7, kT0 + 2);
  sign_command(whole, key);
  std::vector<std::uint8_t> longer = encode(whole);
  longer.push_back(0);
  REQUIRE(auth.check_bytes(longer, decoded, kT0).reason == command_status_t::REASON_MALFORMED);

  operator_command_t too_many = goal(7, kT0 + 3);
  too_many.num_joints = 9;
  sign_command(too_many, key);
  REQUIRE(auth.check(too_many, kT0).reason == command_status_t::REASON_MALFORMED);
  operator_command_t nan_goal = goal(7, kT0 + 4);
  nan_goal.goal_position[1] = std::numeric_limits<double>::quiet_NaN();
  sign_command(nan_goal, key);
  REQUIRE(auth.check(nan_goal, kT0).reason == command_status_t::REASON_MALFORMED);
  // None of them moved the counter.
  REQUIRE(auth.last_sequence(7) == 0);
}

TEST_CASE("the sequence floor refuses commands from before a restart", "[unit]") {
  const CommandKey key(key_bytes(1));
  // The controller started at kT0 and tolerates 5 s of skew: its floor is kT0 - 5 s.
  CommandAuthenticator auth(key, kT0 - kDefaultCommandSkew_us);
  operator_command_t before = goal(7, kT0 - kDefaultCommandSkew_us - 1);
  sign_command(before, key);
  // Within the window of a clock that reads kT0 - 5 s, but below the floor.
  REQUIRE(auth.check(before, kT0 - kDefaultCommandSkew_us).reason == command_status_t::REASON_STALE_SEQUENCE);
  operator_command_t after = goal(7, kT0 - kDefaultCommandSkew_us + 1);
  sign_command(after, key);
  REQUIRE(auth.check(after, kT0).accepted);
}

TEST_CASE("the replay table has a fixed size, further senders are refused", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key);
  for (std::int32_t s = 0; s < static_cast<std::int32_t>(CommandAuthenticator::kMaxSenders); ++s) {
    operator_command_t c = goal(s, kT0);
    sign_command(c, key);
    REQUIRE(auth.check(c, kT0).accepted);
  }
  operator_command_t extra = goal(1000, kT0);
  sign_command(extra, key);
  REQUIRE(auth.check(extra, kT0).reason == command_status_t::REASON_TOO_MANY_SENDERS);
}

TEST_CASE("sequences outside the clock window are refused either way, at the bound exactly accepted", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key, 0, 5'000'000);
  const std::int64_t now = kT0;
  const auto verdict = [&](std::int32_t sender, std::int64_t sequence) {
    operator_command_t c = goal(sender, sequence);
    sign_command(c, key);
    return auth.check(c, now);
  };
  CHECK(verdict(1, now + 5'000'001).reason == command_status_t::REASON_FUTURE_SEQUENCE);
  CHECK(verdict(1, now + 3'600'000'000).reason == command_status_t::REASON_FUTURE_SEQUENCE);
  CHECK(verdict(2, now - 5'000'001).reason == command_status_t::REASON_OLD_SEQUENCE);
  CHECK(verdict(2, 1).reason == command_status_t::REASON_OLD_SEQUENCE);
  CHECK(verdict(2, std::numeric_limits<std::int64_t>::min()).reason == command_status_t::REASON_OLD_SEQUENCE);
  // Refusals leave the counters where they were.
  CHECK(auth.last_sequence(1) == 0);
  CHECK(auth.last_sequence(2) == 0);
  CHECK(verdict(1, now + 5'000'000).accepted);
  CHECK(verdict(2, now - 5'000'000).accepted);
  REQUIRE_THROWS_AS(CommandAuthenticator(key, 0, 0), std::invalid_argument);
}

TEST_CASE("a signed INT64_MAX sequence is refused and the real station is still accepted", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key, kT0 - kDefaultCommandSkew_us);
  operator_command_t real = goal(1, kT0 + 10);
  sign_command(real, key);
  REQUIRE(auth.check(real, kT0 + 10).accepted);

  // Signed with the key (a leaked key or a faulty station), sent as the real station.
  operator_command_t lockout = goal(1, std::numeric_limits<std::int64_t>::max());
  sign_command(lockout, key);
  REQUIRE(auth.check(lockout, kT0 + 20).reason == command_status_t::REASON_FUTURE_SEQUENCE);
  REQUIRE(auth.last_sequence(1) == kT0 + 10);

  operator_command_t next = goal(1, kT0 + 30);
  sign_command(next, key);
  REQUIRE(auth.check(next, kT0 + 30).accepted);
  REQUIRE(auth.last_sequence(1) == kT0 + 30);
}

TEST_CASE("a goal replayed into a restarted controller is refused: the counters survive in the state file", "[unit]") {
  const CommandKey key(key_bytes(1));
  const std::string path = temp_path("restart.state");
  std::remove(path.c_str());
  operator_command_t recorded = goal(4, kT0 + 1'000);
  sign_command(recorded, key);
  operator_command_t other = goal(9, kT0 + 2'000);
  sign_command(other, key);
  {
    CommandAuthenticator auth(key, kT0 - kDefaultCommandSkew_us);
    auth.restore(load_command_state(path));  // missing file: the first start
    REQUIRE(auth.senders().empty());
    REQUIRE(auth.check(recorded, kT0 + 1'000).accepted);
    REQUIRE(auth.check(other, kT0 + 2'000).accepted);
    REQUIRE(save_command_state(path, auth.senders()) == 0);
  }
  // The controller restarts 2 s later: the recording is still inside the clock window and above
  // the new floor (start - 5 s), so only the saved counter can refuse it.
  const std::int64_t restart = kT0 + 2'000'000;
  CommandAuthenticator fresh(key, restart - kDefaultCommandSkew_us);
  const std::vector<SenderCounter> saved = load_command_state(path);
  REQUIRE(saved.size() == 2);
  fresh.restore(saved);
  REQUIRE(fresh.last_sequence(4) == kT0 + 1'000);
  REQUIRE(fresh.last_sequence(9) == kT0 + 2'000);
  REQUIRE(fresh.check(recorded, restart + 10).reason == command_status_t::REASON_STALE_SEQUENCE);
  REQUIRE(fresh.check(other, restart + 10).reason == command_status_t::REASON_STALE_SEQUENCE);
  // Without the state file the same replay would have been accepted: the file is what refuses it.
  CommandAuthenticator forgetful(key, restart - kDefaultCommandSkew_us);
  REQUIRE(forgetful.check(recorded, restart + 10).accepted);
  // The station's next command, signed after the restart, is accepted.
  operator_command_t next = goal(4, restart + 20);
  sign_command(next, key);
  REQUIRE(fresh.check(next, restart + 20).accepted);
  std::remove(path.c_str());
}

TEST_CASE("restored counters below the floor are raised to it", "[unit]") {
  const CommandKey key(key_bytes(1));
  CommandAuthenticator auth(key, kT0);
  const std::array<SenderCounter, 2> saved{{{1, kT0 - 1'000}, {2, kT0 + 1'000}}};
  const std::uint64_t before = auth.revision();
  auth.restore(saved);
  CHECK(auth.revision() != before);
  CHECK(auth.last_sequence(1) == kT0);
  CHECK(auth.last_sequence(2) == kT0 + 1'000);
  const std::array<SenderCounter, 2> twice{{{1, kT0}, {1, kT0 + 1}}};
  CHECK_THROWS_AS(auth.restore(twice), std::invalid_argument);
}

TEST_CASE("state file: written atomically and read back, malformed files fail with file, line and field", "[unit]") {
  const std::string path = temp_path("io.state");
  const std::array<SenderCounter, 3> counters{{{1, kT0}, {-5, kT0 + 1}, {2147483647, 0}}};
  REQUIRE(save_command_state(path, counters) == 0);
  // Only the file itself: the temporary was renamed over it.
  std::FILE* tmp = std::fopen((path + ".tmp").c_str(), "r");
  CHECK(tmp == nullptr);
  if (tmp != nullptr) std::fclose(tmp);
  const std::vector<SenderCounter> back = load_command_state(path);
  REQUIRE(back.size() == 3);
  for (std::size_t i = 0; i < back.size(); ++i) {
    CHECK(back[i].sender_id == counters[i].sender_id);
    CHECK(back[i].last_sequence == counters[i].last_sequence);
  }

  const auto write_text = [&](const std::string& text) {
    write_file(path, std::vector<std::uint8_t>(text.begin(), text.end()));
  };
  write_text("mgc-command-state 1\nsender 3 12x\n");
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains(path) && Catch::Contains("line 2") &&
                                                    Catch::Contains("sequence \"12x\""));
  write_text("mgc-command-state 1\nsender 99999999999 12\n");
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains("line 2") && Catch::Contains("sender id"));
  write_text("mgc-command-state 1\nsender 3 12\nsender 3 13\n");
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains("line 3") && Catch::Contains("twice"));
  write_text("mgc-command-state 1\nsender 3 12 7\n");
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains("trailing \"7\""));
  write_text("something else\n");
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains("line 1") && Catch::Contains("header"));
  write_text("");
  REQUIRE_THROWS_AS(load_command_state(path), CommandStateError);
  std::string many = "mgc-command-state 1\n";
  for (int i = 0; i <= static_cast<int>(CommandAuthenticator::kMaxSenders); ++i) many += "sender " + std::to_string(i) + " 1\n";
  write_text(many);
  REQUIRE_THROWS_WITH(load_command_state(path), Catch::Contains("more than 16 senders"));
  // Comments and blank lines are allowed.
  write_text("# saved by mgc\n\nmgc-command-state 1\n# sender 1\nsender 1 5\n");
  REQUIRE(load_command_state(path).size() == 1);
  std::remove(path.c_str());

  // A directory that does not exist: the save reports errno and leaves nothing behind.
  const std::string nowhere = temp_path("no-such-dir") + "/x.state";
  CHECK(save_command_state(nowhere, counters) == ENOENT);
}
