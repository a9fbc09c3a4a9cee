// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/realtime_loop.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <stdexcept>
#include <thread>

namespace mgc::sim {

namespace {

//! The longest single wait: a stop (a signal delivered to another thread, or another thread's last
//! iteration) is seen within this. [us]
constexpr std::int64_t kMaxWaitUs = 100'000;

//! A standby thread looks every tick whether the waiting thread is late, and takes over once an
//! event is overdue by the grace: a missed answer goes out within about 3 ms, a tenth of the
//! controller's 30 ms staleness limit, while a waiting thread that is merely a little late (woken
//! on a CPU the controller's higher-priority thread is using) is not raced for every event. [us]
constexpr std::int64_t kStandbyTickUs = 1'000;
constexpr std::int64_t kStandbyGraceUs = 2'000;

double ms(std::int64_t us) noexcept { return static_cast<double>(us) * 1e-3; }

void thread_faults(long& major, long& minor) noexcept {
  rusage usage{};
  if (getrusage(RUSAGE_THREAD, &usage) != 0) return;
  major = usage.ru_majflt;
  minor = usage.ru_minflt;
}

}  // namespace

void IterationGaps::iteration(std::int64_t now_us, double t_s) noexcept {
  ++iterations_;
  if (previous_us_ >= 0) {
    const std::int64_t gap_us = now_us - previous_us_;
    if (gap_us > max_gap_us_) {
      max_gap_us_ = gap_us;
      max_gap_t_s_ = t_s;
    }
    if (gap_us > sync_period_us_) ++gaps_over_sync_;
    if (gap_us > stale_after_us_) ++gaps_over_stale_;
  }
  previous_us_ = now_us;
}

RealtimeLoop::RealtimeLoop(const hal::Clock& clock, hal::CanBus& bus, RealtimeLoopConfig config)
    : RealtimeLoop(clock, std::span<hal::CanBus* const>(std::array<hal::CanBus*, 1>{&bus}), config) {}

RealtimeLoop::RealtimeLoop(const hal::Clock& clock, std::span<hal::CanBus* const> buses, RealtimeLoopConfig config)
    : clock_(clock), buses_(buses.begin(), buses.end()), config_(config), gaps_(config.sync_period_us, config.stale_after_us) {
  if (buses_.empty() || std::find(buses_.begin(), buses_.end(), nullptr) != buses_.end()) {
    throw std::invalid_argument("the loop needs at least one bus, none null");
  }
  if (config_.threads < 1 || config_.threads > kMaxThreads) {
    throw std::invalid_argument("loop threads must be 1.." + std::to_string(kMaxThreads));
  }
  if (config_.sync_period_us <= 0 || config_.stale_after_us <= 0) {
    throw std::invalid_argument("SYNC period and staleness limit must be positive");
  }
  cpus_.fill(-1);
  if (config_.threads == 1) return;  // one thread runs where the scheduler puts it, as any process
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  std::size_t n = 0;
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE && n < config_.threads; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) cpus_[n++] = cpu;
    }
  }
  // Two threads on one CPU would wait for the same CPU: one is all that helps there.
  threads_ = std::max<std::size_t>(n, 1);
  if (threads_ == 1) cpus_[0] = -1;
}

void RealtimeLoop::run(const Iteration& iteration, const std::atomic<bool>& stop) { run(iteration, Observation{}, stop); }

void RealtimeLoop::run(const Iteration& iteration, const Observation& observe, const std::atomic<bool>& stop) {
  start_us_ = clock_.now_us();
  next_due_us_.store(start_us_);
  started_.store(0);
  done_.store(false);
  std::array<std::thread, kMaxThreads> others;
  try {
    for (std::size_t i = 1; i < threads_; ++i) others[i] = std::thread([this, i, &iteration, &observe, &stop] { thread_main(i, iteration, observe, stop); });
  } catch (...) {
    done_.store(true);
    for (std::thread& t : others) {
      if (t.joinable()) t.join();
    }
    throw;
  }
  thread_main(0, iteration, observe, stop);
  for (std::thread& t : others) {
    if (t.joinable()) t.join();
  }
  end_us_ = clock_.now_us();
}

void RealtimeLoop::thread_main(std::size_t index, const Iteration& iteration, const Observation& observe,
                               const std::atomic<bool>& stop) noexcept {
  LoopThreadStats& st = stats_[index];
  st.cpu = cpus_[index];
  cpu_set_t previous;
  CPU_ZERO(&previous);
  bool pinned = false;
  if (st.cpu >= 0 && pthread_getaffinity_np(pthread_self(), sizeof previous, &previous) == 0) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(st.cpu, &one);
    pinned = pthread_setaffinity_np(pthread_self(), sizeof one, &one) == 0;
    if (!pinned) st.cpu = -1;
  }
  long major_start = 0;
  long minor_start = 0;
  thread_faults(major_start, minor_start);
  // Thread 0 waits for the events; the others stand by, and run an iteration only when it is late.
  const bool standby = index > 0;
  std::uint64_t seen_started = started_.load(std::memory_order_relaxed);
  while (!stop.load(std::memory_order_relaxed) && !done_.load(std::memory_order_acquire)) {
    if (standby) {
      const std::int64_t tick_due_us = clock_.now_us() + kStandbyTickUs;
      std::this_thread::sleep_for(std::chrono::microseconds(kStandbyTickUs));
      const std::int64_t now_us = clock_.now_us();
      st.max_late_us = std::max(st.max_late_us, now_us - tick_due_us);
      if (now_us - tick_due_us > config_.sync_period_us) ++st.wakeups_over_sync;
      const std::int64_t late_us = now_us - next_due_us_.load(std::memory_order_relaxed);
      // An event overdue by more than the grace, or a frame waiting a whole tick with no iteration
      // begun meanwhile: the thread that waits for them is not being run.
      const std::uint64_t started = started_.load(std::memory_order_relaxed);
      bool waiting_frame = false;
      if (late_us <= kStandbyGraceUs && started == seen_started) {
        for (hal::CanBus* bus : buses_) waiting_frame = waiting_frame || bus->wait_readable(0) == hal::Status::Ok;
      }
      seen_started = started;
      if (late_us <= kStandbyGraceUs && !waiting_frame) continue;
    }
    std::int64_t next_us = 0;
    {
      const std::int64_t before_us = clock_.now_us();
      const std::lock_guard lock(mutex_);
      // Read under the lock: whichever thread runs next, the time it is given is not earlier.
      const std::int64_t now_us = clock_.now_us();
      st.max_lock_wait_us = std::max(st.max_lock_wait_us, now_us - before_us);
      if (done_.load(std::memory_order_relaxed)) break;
      started_.fetch_add(1, std::memory_order_relaxed);
      gaps_.iteration(now_us, static_cast<double>(now_us - start_us_) * 1e-6);
      ++st.iterations;
      next_us = iteration(now_us);
      const std::int64_t held_us = clock_.now_us() - now_us;
      st.lock_held_us += held_us;
      st.max_lock_held_us = std::max(st.max_lock_held_us, held_us);
      if (next_us < 0) {
        done_.store(true, std::memory_order_release);
        break;
      }
      next_due_us_.store(next_us, std::memory_order_relaxed);
    }
    // Outside the iteration's lock: a thread not run while it observes holds up no iteration.
    if (observe && observe_mutex_.try_lock()) {
      observe();
      observe_mutex_.unlock();
    }
    if (standby) continue;
    const std::int64_t waited_from_us = clock_.now_us();
    if (next_us <= waited_from_us) continue;
    const std::int64_t wait_us = std::min(next_us - waited_from_us, kMaxWaitUs);
    const std::int64_t due_us = waited_from_us + wait_us;
    (void)buses_[0]->wait_readable(wait_us);
    // Negative when a frame woke it before the due time.
    const std::int64_t late_us = clock_.now_us() - due_us;
    st.max_late_us = std::max(st.max_late_us, late_us);
    if (late_us > config_.sync_period_us) ++st.wakeups_over_sync;
  }
  long major = 0;
  long minor = 0;
  thread_faults(major, minor);
  st.major_faults = major - major_start;
  st.minor_faults = minor - minor_start;
  if (pinned) (void)pthread_setaffinity_np(pthread_self(), sizeof previous, &previous);
}

std::string RealtimeLoop::line() const {
  char buf[512];
  std::int64_t max_late_us = 0;
  long major = 0;
  long minor = 0;
  for (std::size_t i = 0; i < threads_; ++i) {
    max_late_us = std::max(max_late_us, stats_[i].max_late_us);
    major += stats_[i].major_faults;
    minor += stats_[i].minor_faults;
  }
  std::snprintf(buf, sizeof buf,
                "%" PRIu64 " loop iterations, longest gap between two %.2f ms at %.2f s, %" PRIu64
                " gaps over the %.0f ms SYNC period, %" PRIu64 " over the %.0f ms staleness limit, wake-up lateness max %.2f ms",
                gaps_.iterations(), ms(gaps_.max_gap_us()), gaps_.max_gap_t_s(), gaps_.gaps_over_sync(),
                ms(gaps_.sync_period_us()), gaps_.gaps_over_stale(), ms(gaps_.stale_after_us()), ms(max_late_us));
  std::string line = buf;
  const std::int64_t run_us = end_us_ - start_us_;
  if (threads_ > 1) {
    std::snprintf(buf, sizeof buf, " (%zu threads:", threads_);
    line += buf;
    for (std::size_t i = 0; i < threads_; ++i) {
      const LoopThreadStats& st = stats_[i];
      std::snprintf(buf, sizeof buf,
                    "%s on CPU %d %" PRIu64 " iterations, lateness max %.2f ms, %" PRIu64
                    " wake-ups over the SYNC period, lock wait max %.2f ms, lock held %.2f %% of the run (max %.2f ms)",
                    i == 0 ? "" : ";", st.cpu, st.iterations, ms(st.max_late_us), st.wakeups_over_sync, ms(st.max_lock_wait_us),
                    run_us > 0 ? 100.0 * static_cast<double>(st.lock_held_us) / static_cast<double>(run_us) : 0.0,
                    ms(st.max_lock_held_us));
      line += buf;
    }
    line += ')';
  }
  std::snprintf(buf, sizeof buf, "; %ld major and %ld minor page faults in the loop", major, minor);
  line += buf;
  return line;
}

}  // namespace mgc::sim
