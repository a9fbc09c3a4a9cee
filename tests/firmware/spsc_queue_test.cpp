// SPDX-License-Identifier: Apache-2.0
// The snapshot queue: FIFO order, nothing lost below capacity, drops counted when full, and
// whole elements (never torn ones) across two threads.

#include <mgc/firmware/guidance_snapshot.hpp>
#include <mgc/firmware/spsc_queue.hpp>

#include <catch2/catch.hpp>

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

using mgc::firmware::GuidanceSnapshot;
using mgc::firmware::SpscQueue;

TEST_CASE("queue is FIFO and counts drops when full", "[unit]") {
  SpscQueue<int, 4> q;
  REQUIRE(q.try_pop() == std::nullopt);
  for (int i = 0; i < 4; ++i) REQUIRE(q.try_push(i));
  REQUIRE(q.size() == 4);
  REQUIRE_FALSE(q.try_push(99));
  REQUIRE_FALSE(q.try_push(100));
  REQUIRE(q.dropped() == 2);
  REQUIRE(q.pushed() == 4);
  for (int i = 0; i < 4; ++i) REQUIRE(q.try_pop() == i);
  REQUIRE(q.try_pop() == std::nullopt);
  // The ring wraps: indices keep counting, slots are reused.
  for (int round = 0; round < 10; ++round) {
    REQUIRE(q.try_push(round));
    REQUIRE(q.try_pop() == round);
  }
  REQUIRE(q.dropped() == 2);
}

TEST_CASE("two threads: a producer that retries loses nothing and keeps order", "[unit]") {
  constexpr std::uint64_t kCount = 200'000;
  auto q = std::make_unique<SpscQueue<std::uint64_t, 64>>();
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kCount; ++i) {
      while (!q->try_push(i)) std::this_thread::yield();
    }
  });
  std::uint64_t expected = 1;
  bool in_order = true;
  while (expected <= kCount) {
    std::uint64_t v = 0;
    if (!q->try_pop(v)) {
      std::this_thread::yield();  // both sides spinning on a loaded machine would starve each other
      continue;
    }
    in_order = in_order && v == expected;
    ++expected;
  }
  producer.join();
  REQUIRE(in_order);
  REQUIRE(q->pushed() == kCount);
  REQUIRE(q->try_pop() == std::nullopt);
}

TEST_CASE("two threads: below capacity nothing is dropped", "[unit]") {
  auto q = std::make_unique<SpscQueue<std::uint64_t, 128>>();
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < 128; ++i) q->try_push(i);
  });
  producer.join();
  std::vector<std::uint64_t> got;
  std::thread consumer([&] {
    std::uint64_t v = 0;
    while (q->try_pop(v)) got.push_back(v);
  });
  consumer.join();
  REQUIRE(q->dropped() == 0);
  REQUIRE(got.size() == 128);
  for (std::size_t i = 0; i < got.size(); ++i) REQUIRE(got[i] == i);
}

TEST_CASE("two threads: a producer that never waits drops and counts, the rest arrive in order", "[unit]") {
  constexpr std::uint64_t kCount = 500'000;
  auto q = std::make_unique<SpscQueue<std::uint64_t, 16>>();
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kCount; ++i) q->try_push(i);
    done.store(true);
  });
  std::uint64_t received = 0;
  std::uint64_t last = 0;
  bool increasing = true;
  std::uint64_t v = 0;
  for (;;) {
    if (q->try_pop(v)) {
      increasing = increasing && v > last;
      last = v;
      ++received;
    } else if (done.load() && q->size() == 0) {
      break;
    }
  }
  producer.join();
  REQUIRE(increasing);
  REQUIRE(received + q->dropped() == kCount);
  REQUIRE(received == q->pushed());
}

TEST_CASE("two threads: guidance snapshots arrive whole", "[unit]") {
  // Every field of snapshot i is derived from i, so a slot read while being written shows up as
  // a mismatch between fields.
  constexpr std::uint64_t kCount = 20'000;
  auto q = std::make_unique<SpscQueue<GuidanceSnapshot, 8>>();
  std::thread producer([&] {
    auto s = std::make_unique<GuidanceSnapshot>();
    for (std::uint64_t i = 1; i <= kCount; ++i) {
      s->cycle_index = i;
      s->utime_us = static_cast<std::int64_t>(i) * 10'000;
      s->joint_position.fill(static_cast<double>(i));
      s->plan.positions.back().fill(static_cast<double>(i));
      s->timing.cycles = i;
      while (!q->try_push(*s)) std::this_thread::yield();
    }
  });
  auto s = std::make_unique<GuidanceSnapshot>();
  std::uint64_t expected = 1;
  bool whole = true;
  while (expected <= kCount) {
    if (!q->try_pop(*s)) {
      std::this_thread::yield();
      continue;
    }
    const auto d = static_cast<double>(expected);
    whole = whole && s->cycle_index == expected && s->timing.cycles == expected &&
            s->utime_us == static_cast<std::int64_t>(expected) * 10'000 && s->joint_position[7] == d &&
            s->plan.positions.back()[7] == d;
    ++expected;
  }
  producer.join();
  REQUIRE(whole);
}
