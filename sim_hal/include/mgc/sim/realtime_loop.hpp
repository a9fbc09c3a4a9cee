// SPDX-License-Identifier: Apache-2.0
// mgc-sim's real-time loop: one iteration function run by one or more threads, each pinned to a CPU
// of its own, so that a CPU taken away for tens of milliseconds (a vCPU the hypervisor deschedules,
// a CPU held by another process's work in a kernel without preemption) does not hold up the
// devices' answers. docs/simulator.md, "Real time".
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"

namespace mgc::sim {

//! The gaps between successive iterations, whichever thread ran them: the longest a frame that
//! arrived could have waited for its answer. Plain maxima and counters: no allocation.
class IterationGaps {
 public:
  //! sync_period_us: the bus's SYNC period; stale_after_us: how long the controller waits for a
  //! device's answer before it marks the device stale.
  IterationGaps(std::int64_t sync_period_us, std::int64_t stale_after_us) noexcept
      : sync_period_us_(sync_period_us), stale_after_us_(stale_after_us) {}

  //! An iteration starts at now_us, t_s after the loop's start.
  void iteration(std::int64_t now_us, double t_s) noexcept;

  [[nodiscard]] std::uint64_t iterations() const noexcept { return iterations_; }
  [[nodiscard]] std::int64_t max_gap_us() const noexcept { return max_gap_us_; }
  [[nodiscard]] double max_gap_t_s() const noexcept { return max_gap_t_s_; }  //!< when it ended [s]
  [[nodiscard]] std::uint64_t gaps_over_sync() const noexcept { return gaps_over_sync_; }
  [[nodiscard]] std::uint64_t gaps_over_stale() const noexcept { return gaps_over_stale_; }
  [[nodiscard]] std::int64_t sync_period_us() const noexcept { return sync_period_us_; }
  [[nodiscard]] std::int64_t stale_after_us() const noexcept { return stale_after_us_; }

 private:
  std::int64_t sync_period_us_;
  std::int64_t stale_after_us_;
  std::int64_t previous_us_ = -1;
  std::uint64_t iterations_ = 0;
  std::int64_t max_gap_us_ = 0;
  double max_gap_t_s_ = 0.0;
  std::uint64_t gaps_over_sync_ = 0;
  std::uint64_t gaps_over_stale_ = 0;
};

//! One loop thread's own figures.
struct LoopThreadStats {
  int cpu = -1;                    //!< the CPU it was pinned to; -1 unpinned
  std::uint64_t iterations = 0;    //!< iterations it ran
  std::int64_t max_late_us = 0;    //!< its longest wake-up after the due time [us]
  std::uint64_t wakeups_over_sync = 0;  //!< wake-ups later than a SYNC period
  std::int64_t max_lock_wait_us = 0;    //!< its longest wait for the other thread's iteration [us]
  //! Time it held the lock, in all and at most once: while it holds it, no other thread can answer. [us]
  std::int64_t lock_held_us = 0;
  std::int64_t max_lock_held_us = 0;
  long major_faults = 0;           //!< page faults it took in the loop
  long minor_faults = 0;
};

struct RealtimeLoopConfig {
  //! Threads that run the loop; fewer when the process may run on fewer CPUs. With more than one,
  //! each is pinned to a CPU of its own, the first waits for the events and the others stand by. [-]
  std::size_t threads = 1;
  std::int64_t sync_period_us = 10'000;  //!< the bus's SYNC period [us]
  std::int64_t stale_after_us = 30'000;  //!< the controller's staleness limit for an answer [us]
};

//! Runs an iteration function in real time on a bus, or on several (the machines of a site in one
//! process). The first thread runs an iteration, then waits until the time the iteration asked for
//! or until a frame arrives on the first bus (bus.wait_readable; a frame on another bus is seen at
//! the next due time: the simulator's physics step, 1 ms), and again. Every other thread stands by
//! on a CPU of its own: each millisecond it looks whether an event is overdue by 2 ms, or a frame
//! has waited a whole millisecond with no iteration begun, and if so runs the iteration itself; so a
//! first thread that is not run for a while (its CPU taken away) is covered within about 3 ms, and
//! otherwise the standby takes no lock. The iterations are serialised by one lock, so the function
//! needs no locking of its own, and the clock is read under that lock, so now_us never goes
//! backwards. What is slow and may wait (measuring, formatting) belongs in the observation, which
//! runs outside that lock: a thread stalled there holds up no iteration.
class RealtimeLoop {
 public:
  //! Called under the lock with the time read under it. Returns the time of the next event it
  //! needs [us], or a negative value to stop the loop. Must not block.
  using Iteration = std::function<std::int64_t(std::int64_t now_us)>;
  //! Called after an iteration, outside its lock, by one thread at a time (a thread that finds
  //! another observing goes on without): work on what the iterations handed over (copies of their
  //! state) that must not hold them up. Must not block.
  using Observation = std::function<void()>;
  static constexpr std::size_t kMaxThreads = 8;

  //! Throws std::invalid_argument for no thread, more than kMaxThreads, or periods not positive.
  RealtimeLoop(const hal::Clock& clock, hal::CanBus& bus, RealtimeLoopConfig config);
  //! The same on several buses (at least one, none null); the iteration serves all of them.
  RealtimeLoop(const hal::Clock& clock, std::span<hal::CanBus* const> buses, RealtimeLoopConfig config);

  //! Runs until an iteration returns a negative time or stop is set. The calling thread is one of
  //! the loop threads; the others are started here and inherit its scheduling policy (chrt).
  //! Starting the threads allocates; the loop does not. Throws std::system_error when a thread
  //! cannot be started.
  void run(const Iteration& iteration, const std::atomic<bool>& stop);
  //! The same with an observation after the iterations (see Observation). After the run the caller
  //! observes what the last iterations left.
  void run(const Iteration& iteration, const Observation& observe, const std::atomic<bool>& stop);

  //! Threads that ran (the configured number, or the CPUs the process may use if fewer).
  [[nodiscard]] std::size_t threads() const noexcept { return threads_; }
  [[nodiscard]] const LoopThreadStats& thread(std::size_t i) const noexcept { return stats_[i]; }
  [[nodiscard]] const IterationGaps& gaps() const noexcept { return gaps_; }

  //! e.g. "140210 loop iterations, longest gap between two 1.31 ms at 12.40 s, 0 gaps over the 10
  //! ms SYNC period, 0 over the 30 ms staleness limit, wake-up lateness max 0.30 ms (2 threads: on
  //! CPU 0 70105 iterations, lateness max 0.30 ms, lock wait max 0.05 ms; on CPU 1 ...); 0 major
  //! and 0 minor page faults in the loop". Allocates: after the run.
  [[nodiscard]] std::string line() const;

 private:
  void thread_main(std::size_t index, const Iteration& iteration, const Observation& observe, const std::atomic<bool>& stop) noexcept;

  const hal::Clock& clock_;
  std::vector<hal::CanBus*> buses_;
  RealtimeLoopConfig config_;
  std::size_t threads_ = 1;
  std::array<int, kMaxThreads> cpus_{};
  std::array<LoopThreadStats, kMaxThreads> stats_{};
  IterationGaps gaps_;
  std::mutex mutex_;  //!< held by the thread running an iteration
  std::mutex observe_mutex_;  //!< held by the thread observing
  std::int64_t start_us_ = 0;
  std::int64_t end_us_ = 0;
  std::atomic<bool> done_{false};
  std::atomic<std::int64_t> next_due_us_{0};  //!< the event the last iteration asked for [us]
  std::atomic<std::uint64_t> started_{0};     //!< iterations begun, by any thread
};

}  // namespace mgc::sim
