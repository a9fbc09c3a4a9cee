// SPDX-License-Identifier: Apache-2.0
// The cyclic executive on a stepped clock (exact) and once on the real clock (behaviour only).
#include <catch2/catch.hpp>

#include <vector>

#include "mgc/firmware/cyclic_executive.hpp"

using namespace mgc::firmware;

TEST_CASE("on time: slots on an absolute grid, dt = period, no drift over 10,000 cycles", "[firmware][loop]") {
  SteppedClock clock(5'000'000);
  CyclicExecutive loop(clock, {10'000, 3});
  for (int k = 0; k < 10'000; ++k) {
    const CycleTiming t = loop.wait_next();
    REQUIRE(t.scheduled_us == 5'000'000 + static_cast<std::int64_t>(k) * 10'000);
    REQUIRE(t.dt_us == 10'000);
    REQUIRE(t.lateness_us == 0);
    clock.advance_us(150 + (k % 7) * 100);  // work of varying length
    loop.end_cycle();
  }
  CHECK(loop.stats().cycles == 10'000);
  CHECK(loop.stats().deadline_misses == 0);
  CHECK(loop.stats().skipped_periods == 0);
  CHECK(loop.stats().compute.max_us() == 750);
  CHECK(loop.stats().compute.percentile_us(0.5) == 450);
  CHECK_FALSE(loop.watchdog_tripped());
}

TEST_CASE("wake-up lateness is measured and dt is the true elapsed time", "[firmware][loop]") {
  SteppedClock clock;
  CyclicExecutive loop(clock, {10'000, 3});
  (void)loop.wait_next();
  loop.end_cycle();
  clock.inject_lateness_us(2'500);
  const CycleTiming late = loop.wait_next();
  CHECK(late.lateness_us == 2'500);
  CHECK(late.dt_us == 12'500);
  loop.end_cycle();
  const CycleTiming next = loop.wait_next();
  CHECK(next.scheduled_us == 20'000);  // the grid does not move with a late wake-up
  CHECK(next.dt_us == 7'500);
  CHECK(loop.stats().lateness.max_us() == 2'500);
  CHECK(loop.stats().deadline_misses == 0);
}

TEST_CASE("an overrun is counted, its slots are skipped, the grid is kept", "[firmware][loop]") {
  SteppedClock clock;
  CyclicExecutive loop(clock, {10'000, 3});
  (void)loop.wait_next();
  clock.advance_us(25'000);  // 2.5 periods of work
  loop.end_cycle();
  CHECK(loop.stats().deadline_misses == 1);
  const CycleTiming t = loop.wait_next();
  CHECK(t.skipped_periods == 1);         // the 10..20 ms slot never ran
  CHECK(t.scheduled_us == 20'000);       // the 20..30 ms slot starts at once, 5 ms late
  CHECK(t.lateness_us == 5'000);
  CHECK(t.dt_us == 25'000);              // integrate with the real elapsed time
  CHECK(loop.stats().consecutive_misses == 2);
  CHECK_FALSE(loop.watchdog_tripped());
  loop.end_cycle();                      // on time: the run of misses ends
  CHECK(loop.stats().consecutive_misses == 0);
  CHECK(loop.stats().skipped_periods == 1);
}

TEST_CASE("the watchdog latches after repeated misses, not after one", "[firmware][loop][watchdog]") {
  SteppedClock clock;
  CyclicExecutive loop(clock, {10'000, 3});
  // Two misses, then a good cycle: no trip.
  for (int k = 0; k < 2; ++k) {
    (void)loop.wait_next();
    clock.advance_us(10'500);
    loop.end_cycle();
  }
  // Each 10.5 ms cycle ends late but skips no slot (the next slot is still running).
  CHECK(loop.stats().deadline_misses == 2);
  CHECK(loop.stats().skipped_periods == 0);
  (void)loop.wait_next();
  clock.advance_us(1'000);
  loop.end_cycle();
  CHECK_FALSE(loop.watchdog_tripped());

  // Three in a row: trip, and it stays tripped through good cycles until reset.
  for (int k = 0; k < 3; ++k) {
    (void)loop.wait_next();
    clock.advance_us(10'500);
    loop.end_cycle();
  }
  CHECK(loop.watchdog_tripped());
  for (int k = 0; k < 5; ++k) {
    (void)loop.wait_next();
    clock.advance_us(100);
    loop.end_cycle();
  }
  CHECK(loop.watchdog_tripped());
  CHECK(loop.stats().watchdog_trips == 1);
  loop.reset_watchdog();
  CHECK_FALSE(loop.watchdog_tripped());

  // One long stall spanning several slots trips it by itself.
  (void)loop.wait_next();
  clock.advance_us(45'000);
  loop.end_cycle();
  (void)loop.wait_next();
  CHECK(loop.watchdog_tripped());
  CHECK(loop.stats().watchdog_trips == 2);
}

TEST_CASE("500 Hz works the same way", "[firmware][loop]") {
  SteppedClock clock;
  CyclicExecutive loop(clock, {2'000, 3});
  for (int k = 0; k < 5'000; ++k) {
    const CycleTiming t = loop.wait_next();
    REQUIRE(t.scheduled_us == static_cast<std::int64_t>(k) * 2'000);
    clock.advance_us(300);
    loop.end_cycle();
  }
  CHECK(loop.stats().deadline_misses == 0);
}

TEST_CASE("histogram percentiles: 1 us bins to 1 ms, 100 us bins beyond", "[firmware][loop]") {
  LatencyHistogram h;
  CHECK(h.percentile_us(0.99) == 0);
  for (int i = 0; i < 990; ++i) h.add(100);
  for (int i = 0; i < 9; ++i) h.add(2'345);
  h.add(250'000);
  CHECK(h.count() == 1'000);
  CHECK(h.percentile_us(0.5) == 100);
  CHECK(h.percentile_us(0.99) == 100);
  CHECK(h.percentile_us(0.995) == 2'400);  // the 100 us bin that holds 2345
  CHECK(h.percentile_us(1.0) == 250'000);  // overflow bin: the max
  CHECK(h.max_us() == 250'000);
}

TEST_CASE("the real clock: absolute grid, dt near the period", "[firmware][loop]") {
  MonotonicLoopClock clock;
  CyclicExecutive loop(clock, {2'000, 1'000});
  std::int64_t first = 0;
  std::int64_t previous_start = 0;
  for (int k = 0; k < 50; ++k) {
    const CycleTiming t = loop.wait_next();
    if (k == 0) first = t.scheduled_us;
    CHECK(t.lateness_us >= 0);
    CHECK((t.scheduled_us - first) % 2'000 == 0);
    if (k > 0) CHECK(t.dt_us == t.start_us - previous_start);
    previous_start = t.start_us;
    loop.end_cycle();
  }
  // A shared VM wakes late by milliseconds at times (DOMAIN-FACTS §6): lateness is reported, not bounded.
  CHECK(loop.stats().lateness.count() == 50);
}

TEST_CASE("enable_realtime never fails, it reports what it got", "[firmware]") {
  const RealtimeReport r = enable_realtime(0, false);
  CHECK_FALSE(r.fifo);
  CHECK_FALSE(r.memory_locked);
  CHECK(r.detail.empty());
}

TEST_CASE("next_slot_us names the slot a standby thread waits for, and its late start keeps the grid", "[firmware][loop]") {
  SteppedClock clock(1'000'000);
  CyclicExecutive loop(clock, {10'000, 3});
  CHECK(loop.next_slot_us() == -1);  // no grid before the first cycle
  (void)loop.wait_next();
  loop.end_cycle();
  REQUIRE(loop.next_slot_us() == 1'010'000);
  // The first thread did not wake: the standby wakes 2 ms after the slot and runs that slot's cycle.
  clock.sleep_until_us(loop.next_slot_us() + 2'000);
  const CycleTiming t = loop.wait_next();
  CHECK(t.scheduled_us == 1'010'000);
  CHECK(t.lateness_us == 2'000);
  CHECK(t.skipped_periods == 0);
  loop.end_cycle();
  CHECK(loop.next_slot_us() == 1'020'000);
  CHECK(loop.stats().deadline_misses == 0);
}
