// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <string>

//! The controller's cyclic executive: a fixed period on an absolute time grid, overrun and
//! deadline-miss accounting, a watchdog that latches after repeated misses, and the optional
//! real-time setup (SCHED_FIFO, mlockall) when the OS permits it. docs/control-loop.md.
namespace mgc::firmware {

//! Where the loop reads time and how it waits until a given time.
class LoopClock {
 public:
  virtual ~LoopClock() = default;
  //! Monotonic time [µs].
  [[nodiscard]] virtual std::int64_t now_us() const noexcept = 0;
  //! Returns at or after t_us (at once if t_us has passed).
  virtual void sleep_until_us(std::int64_t t_us) noexcept = 0;
};

//! CLOCK_MONOTONIC with clock_nanosleep(TIMER_ABSTIME): absolute deadlines, so no drift builds up.
//! The same time base as std::chrono::steady_clock and hal::SteadyClock.
class MonotonicLoopClock final : public LoopClock {
 public:
  [[nodiscard]] std::int64_t now_us() const noexcept override;
  void sleep_until_us(std::int64_t t_us) noexcept override;
};

//! A clock for tests: sleeping jumps to the wake time plus an injected lateness; work is
//! simulated with advance_us().
class SteppedClock final : public LoopClock {
 public:
  explicit SteppedClock(std::int64_t start_us = 0) noexcept : t_us_(start_us) {}
  [[nodiscard]] std::int64_t now_us() const noexcept override { return t_us_; }
  void sleep_until_us(std::int64_t t_us) noexcept override {
    if (t_us > t_us_) t_us_ = t_us;
    t_us_ += next_lateness_us_;
    next_lateness_us_ = 0;
  }
  void advance_us(std::int64_t dt_us) noexcept { t_us_ += dt_us; }
  //! The next sleep returns this much late (the OS's wake-up lateness).
  void inject_lateness_us(std::int64_t lateness_us) noexcept { next_lateness_us_ = lateness_us; }

 private:
  std::int64_t t_us_;
  std::int64_t next_lateness_us_ = 0;
};

struct ExecutiveConfig {
  std::int64_t period_us = 10'000;      //!< 100 Hz by default [µs]
  int watchdog_consecutive_misses = 3;  //!< this many missed deadlines in a row latch the watchdog [-]
};

//! What the loop body needs to know about its cycle.
struct CycleTiming {
  std::uint64_t index = 0;          //!< cycles started before this one [-]
  std::int64_t scheduled_us = 0;    //!< this cycle's slot on the period grid [µs]
  std::int64_t start_us = 0;        //!< when it actually woke [µs]
  std::int64_t lateness_us = 0;     //!< start - scheduled [µs]
  std::int64_t dt_us = 0;           //!< true time since the previous cycle's start: integrate with this [µs]
  std::uint32_t skipped_periods = 0;  //!< grid slots passed over since the previous cycle [-]
};

//! Counts in fixed bins: 1 µs up to 1 ms, then 100 µs up to 100 ms, then one overflow bin.
class LatencyHistogram {
 public:
  void add(std::int64_t value_us) noexcept;
  //! The smallest bin upper edge below which fraction p (0..1] of the samples lie [µs]; 0 if empty.
  [[nodiscard]] std::int64_t percentile_us(double p) const noexcept;
  [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
  [[nodiscard]] std::int64_t max_us() const noexcept { return max_us_; }

 private:
  static constexpr std::size_t kFineBins = 1000;    //!< 0..999 µs
  static constexpr std::size_t kCoarseBins = 990;   //!< 1 ms..100 ms in 100 µs
  std::array<std::uint64_t, kFineBins + kCoarseBins + 1> bins_{};
  std::uint64_t count_ = 0;
  std::int64_t max_us_ = 0;
};

struct ExecutiveStats {
  std::uint64_t cycles = 0;
  std::uint64_t deadline_misses = 0;  //!< cycles that ended after their slot's end [-]
  //! Missed deadlines in a row (late ends and skipped slots); a cycle on time resets it [-]
  std::uint64_t skipped_periods = 0;  //!< grid slots never started [-]
  int consecutive_misses = 0;
  std::uint64_t watchdog_trips = 0;
  LatencyHistogram lateness;          //!< wake-up lateness: what the OS adds [µs]
  LatencyHistogram compute;           //!< start to end_cycle(): what the code costs [µs]
};

class CyclicExecutive {
 public:
  CyclicExecutive(LoopClock& clock, const ExecutiveConfig& config) noexcept;

  //! Sleeps until the next slot of the grid and starts a cycle. A slot whose time has already
  //! passed is skipped, so a late loop realigns to the grid instead of running cycles back to back.
  CycleTiming wait_next() noexcept;
  //! Ends the cycle: records its compute time. A cycle ending past its slot, and every slot
  //! skipped, is a missed deadline; watchdog_consecutive_misses of them in a row latch the watchdog.
  void end_cycle() noexcept;

  //! Latched until reset_watchdog(): the loop must bring the machine to a stop.
  [[nodiscard]] bool watchdog_tripped() const noexcept { return watchdog_tripped_; }
  void reset_watchdog() noexcept;
  [[nodiscard]] const ExecutiveStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const ExecutiveConfig& config() const noexcept { return config_; }
  //! The slot the next wait_next() starts (after the first cycle); -1 before it. A standby loop
  //! thread waits for it and runs the cycle when the first thread has not. [µs]
  [[nodiscard]] std::int64_t next_slot_us() const noexcept { return started_ ? next_slot_us_ : -1; }

 private:
  void record_misses(int misses) noexcept;

  LoopClock& clock_;
  ExecutiveConfig config_;
  ExecutiveStats stats_{};
  bool started_ = false;
  std::int64_t next_slot_us_ = 0;
  std::int64_t current_slot_us_ = 0;
  std::int64_t current_start_us_ = 0;
  std::int64_t previous_start_us_ = 0;
  bool watchdog_tripped_ = false;
};

//! What enable_realtime() obtained; the loop runs either way.
struct RealtimeReport {
  bool fifo = false;          //!< SCHED_FIFO at the requested priority
  bool memory_locked = false; //!< mlockall(MCL_CURRENT | MCL_FUTURE)
  std::string detail;         //!< why not, per item (errno text), for the start-up log
};

//! Tries SCHED_FIFO at fifo_priority (1..99; 0 skips it) and mlockall when lock_memory. Never fails:
//! without the privilege the loop runs as a normal process and says so. Start-up only (allocates).
[[nodiscard]] RealtimeReport enable_realtime(int fifo_priority, bool lock_memory);

}  // namespace mgc::firmware
