// SPDX-License-Identifier: Apache-2.0
// mgc-sim's real-time loop: the gaps between iterations in stepped time, and the loop threads on
// an in-process bus: one iteration at a time, time that never goes backwards, a frame answered, a
// standby that runs the iterations while the first thread is stalled in its observation, a stop
// obeyed; and the ring that hands copies of the true state to the observer.
#include <catch2/catch.hpp>

#include <sched.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/sim/realtime_loop.hpp"
#include "mgc/sim/truth_snapshot.hpp"

using namespace mgc;

namespace {

std::size_t usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 1;
  return static_cast<std::size_t>(CPU_COUNT(&set));
}

}  // namespace

TEST_CASE("iteration gaps: the longest, when it ended, those over the SYNC period and the staleness limit", "[sim][loop]") {
  sim::IterationGaps gaps(10'000, 30'000);
  gaps.iteration(1'000'000, 0.0);
  CHECK(gaps.max_gap_us() == 0);  // one iteration: no gap yet
  gaps.iteration(1'001'000, 0.001);
  gaps.iteration(1'012'000, 0.012);   // 11 ms: over the SYNC period
  gaps.iteration(1'042'000, 0.042);   // 30 ms: over the period, not over the limit
  gaps.iteration(1'072'001, 0.072);   // 30.001 ms: over both
  gaps.iteration(1'073'000, 0.073);
  CHECK(gaps.iterations() == 6);
  CHECK(gaps.max_gap_us() == 30'001);
  CHECK(gaps.max_gap_t_s() == Approx(0.072));
  CHECK(gaps.gaps_over_sync() == 3);
  CHECK(gaps.gaps_over_stale() == 1);
}

TEST_CASE("the loop runs one iteration at a time on every thread, time never going backwards, until told to stop",
          "[sim][loop]") {
  const hal::SteadyClock& clock = hal::SteadyClock::instance();
  auto device = hal::open_can_bus("loop:realtime-loop-test", &clock);
  auto controller = hal::open_can_bus("loop:realtime-loop-test", &clock);
  REQUIRE(device.bus);
  REQUIRE(controller.bus);

  sim::RealtimeLoop loop(clock, *device.bus, {.threads = 2});
  REQUIRE(loop.threads() == std::min<std::size_t>(2, usable_cpus()));

  constexpr std::size_t kIterations = 400;
  std::vector<std::int64_t> times;
  times.reserve(kIterations);
  std::atomic<int> inside{0};
  int most_inside = 0;
  std::size_t frames = 0;
  std::atomic<bool> stop{false};
  // A frame from the controller's side a little into the run: the loop must take it off the bus.
  std::thread peer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    (void)controller.bus->send(hal::CanFrame::standard(0x080, 0));
  });
  loop.run(
      [&](std::int64_t now_us) -> std::int64_t {
        most_inside = std::max(most_inside, ++inside);
        times.push_back(now_us);
        std::array<hal::TimedFrame, 8> in{};
        frames += device.bus->receive(in).count;
        --inside;
        // Ends once it has run kIterations and seen the frame; a frame that never comes ends it
        // after a thousand times as many.
        if ((times.size() >= kIterations && frames > 0) || times.size() >= 1000 * kIterations) return -1;
        return now_us + 200;
      },
      stop);
  peer.join();

  CHECK(most_inside == 1);
  CHECK(frames == 1);
  CHECK(times.size() >= kIterations);
  CHECK(std::is_sorted(times.begin(), times.end()));
  // The first thread waits for the events; a standby runs only what the first is late for.
  CHECK(loop.thread(0).iterations >= 1);
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < loop.threads(); ++i) {
    total += loop.thread(i).iterations;
    if (loop.threads() > 1) CHECK(loop.thread(i).cpu >= 0);
  }
  CHECK(total == times.size());
  CHECK(loop.gaps().iterations() == times.size());
  if (loop.threads() > 1) CHECK(loop.thread(0).cpu != loop.thread(1).cpu);
}

TEST_CASE("a thread stalled in the observation holds up no iteration: the standby runs them meanwhile", "[sim][loop]") {
  if (usable_cpus() < 2) {
    WARN("one CPU: no standby thread to test");
    return;
  }
  const hal::SteadyClock& clock = hal::SteadyClock::instance();
  auto device = hal::open_can_bus("loop:realtime-loop-observe", &clock);
  REQUIRE(device.bus);
  sim::RealtimeLoop loop(clock, *device.bus, {.threads = 2});
  REQUIRE(loop.threads() == 2);

  constexpr std::int64_t kStallUs = 150'000;
  std::vector<std::int64_t> times;
  times.reserve(100'000);
  std::atomic<std::int64_t> stall_from_us{-1};
  std::atomic<std::int64_t> stall_to_us{-1};
  std::atomic<int> observing{0};
  int most_observing = 0;
  std::atomic<bool> stop{false};
  loop.run(
      [&](std::int64_t now_us) -> std::int64_t {
        times.push_back(now_us);
        // A millisecond grid, as the simulator's physics steps; done 100 ms after the stall.
        const std::int64_t to_us = stall_to_us.load();
        if (to_us > 0 && now_us > to_us + 100'000) return -1;
        return times.size() > 90'000 ? -1 : now_us + 1'000;
      },
      [&] {
        most_observing = std::max(most_observing, ++observing);
        // Once, after 20 iterations: the observing thread is not run for 150 ms.
        if (times.size() > 20 && stall_from_us.load() < 0) {
          stall_from_us.store(clock.now_us());
          std::this_thread::sleep_for(std::chrono::microseconds(kStallUs));
          stall_to_us.store(clock.now_us());
        }
        --observing;
      },
      stop);
  REQUIRE(stall_from_us.load() > 0);
  CHECK(most_observing == 1);
  // Iterations went on through the stall: no gap near its length, and most of its milliseconds had one.
  std::int64_t longest_gap_us = 0;
  int during = 0;
  for (std::size_t i = 1; i < times.size(); ++i) {
    longest_gap_us = std::max(longest_gap_us, times[i] - times[i - 1]);
    if (times[i] > stall_from_us.load() && times[i] < stall_to_us.load()) ++during;
  }
  CHECK(longest_gap_us < kStallUs / 3);
  // The standby takes an event once it is 2 ms overdue: one at least every 3 ms or so.
  CHECK(during >= 20);
  CHECK(loop.thread(1).iterations >= 20);
}

TEST_CASE("a stop set from outside ends the loop although no iteration asks for it", "[sim][loop]") {
  const hal::SteadyClock& clock = hal::SteadyClock::instance();
  auto device = hal::open_can_bus("loop:realtime-loop-stop", &clock);
  REQUIRE(device.bus);
  sim::RealtimeLoop loop(clock, *device.bus, {.threads = 2});
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> iterations{0};
  std::thread stopper([&] {
    while (iterations.load() < 10) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stop.store(true);
  });
  // Each iteration asks for an event an hour ahead: only the stop ends the waits.
  loop.run(
      [&](std::int64_t now_us) -> std::int64_t {
        ++iterations;
        return now_us + (iterations.load() < 10 ? 100 : 3'600'000'000);
      },
      stop);
  stopper.join();
  CHECK(iterations.load() >= 10);
}

TEST_CASE("a loop of no thread, too many or periods not positive is refused", "[sim][loop]") {
  const hal::SteadyClock& clock = hal::SteadyClock::instance();
  auto device = hal::open_can_bus("loop:realtime-loop-bad", &clock);
  REQUIRE(device.bus);
  CHECK_THROWS_AS(sim::RealtimeLoop(clock, *device.bus, {.threads = 0}), std::invalid_argument);
  CHECK_THROWS_AS(sim::RealtimeLoop(clock, *device.bus, {.threads = sim::RealtimeLoop::kMaxThreads + 1}), std::invalid_argument);
  CHECK_THROWS_AS(sim::RealtimeLoop(clock, *device.bus, {.threads = 1, .sync_period_us = 0}), std::invalid_argument);
  sim::RealtimeLoop one(clock, *device.bus, {.threads = 1});
  CHECK(one.threads() == 1);
}

TEST_CASE("the truth frame ring hands every frame over in order and counts those it has no room for", "[sim][loop]") {
  sim::TruthFrame prototype;
  prototype.machines.resize(2);
  sim::TruthFrameRing ring(3, prototype);
  CHECK(ring.capacity() == 3);
  CHECK(ring.front() == nullptr);
  for (int i = 0; i < 5; ++i) {
    sim::TruthFrame* frame = ring.begin_push();
    if (i >= 3) {
      CHECK(frame == nullptr);  // full: refused, the frames already given kept
      continue;
    }
    REQUIRE(frame != nullptr);
    REQUIRE(frame->machines.size() == 2);
    frame->machines[0].truth.t_s = i;
    frame->log_due = i == 1;
    ring.end_push();
  }
  CHECK(ring.dropped() == 2);
  for (int i = 0; i < 3; ++i) {
    const sim::TruthFrame* frame = ring.front();
    REQUIRE(frame != nullptr);
    CHECK(frame->machines[0].truth.t_s == i);
    CHECK(frame->log_due == (i == 1));
    ring.pop();
  }
  CHECK(ring.front() == nullptr);
  // Room again once consumed, round the end of the storage.
  sim::TruthFrame* again = ring.begin_push();
  REQUIRE(again != nullptr);
  again->machines[0].truth.t_s = 7.0;
  ring.end_push();
  REQUIRE(ring.front() != nullptr);
  CHECK(ring.front()->machines[0].truth.t_s == 7.0);
  CHECK(ring.dropped() == 2);
}
