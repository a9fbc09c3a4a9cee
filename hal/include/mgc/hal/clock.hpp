// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <atomic>
#include <cstdint>

namespace mgc::hal {

//! Where a transport takes receive timestamps from (C7: time is injected). thread-safe.
class Clock {
 public:
  virtual ~Clock() = default;
  //! Monotonic time [µs].
  [[nodiscard]] virtual std::int64_t now_us() const noexcept = 0;
};

//! std::chrono::steady_clock; the default for transports opened without a clock.
class SteadyClock final : public Clock {
 public:
  [[nodiscard]] std::int64_t now_us() const noexcept override;
  //! One shared instance.
  [[nodiscard]] static const SteadyClock& instance() noexcept;
};

//! A clock that moves only when told to: deterministic tests and simulation.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(std::int64_t start_us = 0) noexcept : t_us_(start_us) {}
  [[nodiscard]] std::int64_t now_us() const noexcept override { return t_us_.load(std::memory_order_relaxed); }
  void set_us(std::int64_t t_us) noexcept { t_us_.store(t_us, std::memory_order_relaxed); }
  void advance_us(std::int64_t dt_us) noexcept { t_us_.fetch_add(dt_us, std::memory_order_relaxed); }

 private:
  std::atomic<std::int64_t> t_us_;
};

}  // namespace mgc::hal
