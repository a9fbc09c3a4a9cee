// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/cyclic_executive.hpp"

#include <malloc.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace mgc::firmware {

std::int64_t MonotonicLoopClock::now_us() const noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1'000;
}

void MonotonicLoopClock::sleep_until_us(std::int64_t t_us) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_us / 1'000'000);
  ts.tv_nsec = static_cast<long>((t_us % 1'000'000) * 1'000);
  // EINTR: a signal woke us early; sleep on to the same absolute time.
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

void LatencyHistogram::add(std::int64_t value_us) noexcept {
  const std::int64_t v = std::max<std::int64_t>(value_us, 0);
  std::size_t bin = 0;
  if (v < static_cast<std::int64_t>(kFineBins)) {
    bin = static_cast<std::size_t>(v);
  } else {
    bin = std::min(kFineBins + static_cast<std::size_t>((v - 1'000) / 100), kFineBins + kCoarseBins);
  }
  ++bins_[bin];
  ++count_;
  max_us_ = std::max(max_us_, v);
}

std::int64_t LatencyHistogram::percentile_us(double p) const noexcept {
  if (count_ == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(std::clamp(p, 0.0, 1.0) * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < bins_.size(); ++b) {
    seen += bins_[b];
    if (seen >= std::max<std::uint64_t>(rank, 1)) {
      if (b < kFineBins) return static_cast<std::int64_t>(b);
      if (b == kFineBins + kCoarseBins) return max_us_;
      return 1'000 + static_cast<std::int64_t>(b - kFineBins + 1) * 100;
    }
  }
  return max_us_;
}

CyclicExecutive::CyclicExecutive(LoopClock& clock, const ExecutiveConfig& config) noexcept
    : clock_(clock), config_(config) {
  config_.period_us = std::max<std::int64_t>(config_.period_us, 1);
  config_.watchdog_consecutive_misses = std::max(config_.watchdog_consecutive_misses, 1);
}

CycleTiming CyclicExecutive::wait_next() noexcept {
  if (!started_) {
    started_ = true;
    next_slot_us_ = clock_.now_us();
    previous_start_us_ = next_slot_us_;
  }
  std::uint32_t skipped = 0;
  const std::int64_t now = clock_.now_us();
  if (now >= next_slot_us_ + config_.period_us) {
    // Slots that ended while we were still busy are not run late; the next one on the grid is.
    const std::int64_t behind = (now - next_slot_us_) / config_.period_us;
    skipped = static_cast<std::uint32_t>(behind);
    next_slot_us_ += behind * config_.period_us;
  }
  clock_.sleep_until_us(next_slot_us_);
  CycleTiming t;
  t.index = stats_.cycles;
  t.scheduled_us = next_slot_us_;
  t.start_us = clock_.now_us();
  t.lateness_us = t.start_us - t.scheduled_us;
  t.dt_us = stats_.cycles == 0 ? config_.period_us : t.start_us - previous_start_us_;
  t.skipped_periods = skipped;

  stats_.skipped_periods += skipped;
  if (skipped > 0) record_misses(static_cast<int>(skipped));  // a skipped slot missed its deadline too
  stats_.lateness.add(t.lateness_us);
  ++stats_.cycles;
  current_slot_us_ = next_slot_us_;
  current_start_us_ = t.start_us;
  previous_start_us_ = t.start_us;
  next_slot_us_ += config_.period_us;
  return t;
}

void CyclicExecutive::end_cycle() noexcept {
  const std::int64_t end = clock_.now_us();
  stats_.compute.add(end - current_start_us_);
  if (end > current_slot_us_ + config_.period_us) {
    ++stats_.deadline_misses;
    record_misses(1);
  } else {
    stats_.consecutive_misses = 0;
  }
}

void CyclicExecutive::record_misses(int misses) noexcept {
  stats_.consecutive_misses += misses;
  if (stats_.consecutive_misses >= config_.watchdog_consecutive_misses && !watchdog_tripped_) {
    watchdog_tripped_ = true;
    ++stats_.watchdog_trips;
  }
}

void CyclicExecutive::reset_watchdog() noexcept {
  watchdog_tripped_ = false;
  stats_.consecutive_misses = 0;
}

RealtimeReport enable_realtime(int fifo_priority, bool lock_memory) {
  RealtimeReport report;
  if (fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = std::clamp(fifo_priority, 1, 99);
    if (sched_setscheduler(0, SCHED_FIFO, &param) == 0) {
      report.fifo = true;
    } else {
      report.detail += std::string("SCHED_FIFO: ") + std::strerror(errno) + "; ";
    }
  }
  if (lock_memory) {
    // Freed memory stays in the process: a planner's reset that grows its pools, or any later
    // allocation, reuses locked pages rather than faulting in new ones.
    (void)mallopt(M_TRIM_THRESHOLD, -1);
    (void)mallopt(M_MMAP_MAX, 0);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      report.memory_locked = true;
    } else {
      report.detail += std::string("mlockall: ") + std::strerror(errno) + "; ";
    }
  }
  if (report.detail.size() >= 2) report.detail.resize(report.detail.size() - 2);
  return report;
}

}  // namespace mgc::firmware
