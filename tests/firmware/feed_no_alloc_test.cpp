// SPDX-License-Identifier: Apache-2.0
// What the loop calls every cycle (push a snapshot, write the operator words, pop commands) and
// what the I/O thread calls per command (authentication) never touch the heap.

#include <mgc/firmware/command_auth.hpp>
#include <mgc/firmware/lcm_feed.hpp>
#include <mgc/firmware/operator_words.hpp>

#include "allocation_counter.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

using namespace mgc::firmware;
using mgc::operator_command_t;
using mgc::test::allocation_count;

TEST_CASE("snapshot push/pop and operator words do not allocate", "[unit]") {
  auto snapshots = std::make_unique<SnapshotQueue>();
  auto commands = std::make_unique<CommandQueue>();
  auto s = std::make_unique<GuidanceSnapshot>();
  auto out = std::make_unique<GuidanceSnapshot>();
  s->num_joints = 4;
  s->plan.num_waypoints = 3;
  s->plan.positions[1][0] = 0.5;
  s->plan.positions[2] = {0.5, 0.2, 3.0, 0.0};
  s->num_tracked = kSnapshotMaxObstacles;
  s->num_obstacles = kSnapshotMaxObstacles;
  for (auto& o : s->obstacles) o = {1, true, true, {-30.0, -6.0, 0.0}, 0.5, 0.1, 0.0, 0.0, 1'000};
  AcceptedCommand cmd{};

  const long before = allocation_count();
  std::size_t text_bytes = 0;
  for (int cycle = 0; cycle < 2 * static_cast<int>(kSnapshotQueueCapacity); ++cycle) {
    s->cycle_index = static_cast<std::uint64_t>(cycle);
    text_bytes += next_moves_in_words(mgc::planning::MachineKind::MobileCrane, 4, s->joint_position,
                                      std::span(s->plan.positions.data(), 3), 0, 2, s->instruction_text);
    snapshots->try_push(*s);  // the second half overflows: dropping must not allocate either
    commands->try_pop(cmd);
  }
  while (snapshots->try_pop(*out)) {
  }
  const long after = allocation_count();
  REQUIRE(text_bytes > 0);
  REQUIRE(out->num_obstacles == kSnapshotMaxObstacles);
  REQUIRE(out->obstacles[kSnapshotMaxObstacles - 1].position_m[0] == -30.0);
  REQUIRE(snapshots->dropped() == kSnapshotQueueCapacity);
  REQUIRE(after - before == 0);
}

TEST_CASE("command authentication, refusal counting and saving the counters do not allocate", "[unit]") {
  std::array<std::uint8_t, kCommandKeyBytes> bytes{};
  bytes.fill(9);
  const CommandKey key(bytes);
  CommandAuthenticator auth(key);
  RefusalCounter refusals(1'000'000);
  constexpr std::int64_t kT0 = 1'700'000'000'000'000;
  const std::string state_path = "/tmp/mgc_feed_alloc_test_" + std::to_string(::getpid()) + ".state";
  operator_command_t c{};
  c.kind = operator_command_t::KIND_GOAL;
  c.sender_id = 1;
  c.num_joints = 1;
  const long before = allocation_count();
  int accepted = 0;
  int alerts = 0;
  int save_errors = 0;
  for (std::int64_t seq = 1; seq <= 100; ++seq) {
    c.sequence = kT0 + seq;
    sign_command(c, key);
    accepted += auth.check(c, kT0 + seq).accepted ? 1 : 0;
    const CommandVerdict replay = auth.check(c, kT0 + seq);  // refused
    alerts += refusals.record(replay.reason, seq * 1'000) ? 1 : 0;
    if (seq % 25 == 0) save_errors += save_command_state(state_path, auth.senders()) != 0 ? 1 : 0;
  }
  const long after = allocation_count();
  std::remove(state_path.c_str());
  REQUIRE(accepted == 100);
  REQUIRE(alerts == 1);
  REQUIRE(refusals.total() == 100);
  REQUIRE(save_errors == 0);
  REQUIRE(after - before == 0);
}
