// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>
#include <optional>
#include <type_traits>

namespace mgc::firmware {

//! A single-producer/single-consumer ring of fixed capacity: the loop hands snapshots to the LCM
//! I/O thread (and that thread hands commands back) without locks or heap. Storage lives inside
//! the object, so construct it before the first cycle (it may be large: give it static or heap
//! storage, not a small thread stack).
//! Thread-safety: exactly one thread calls try_push(), exactly one other calls try_pop(); any
//! thread may read the counters. RT-safe on both sides: no alloc, no lock, no throw, no wait.
template <class T, std::size_t Capacity>
class SpscQueue {
  static_assert(std::is_trivially_copyable_v<T>, "slots are copied by value across threads");
  static_assert(Capacity >= 1, "a queue holds at least one element");

 public:
  //! Copies value into the queue, or, when it is full, drops value and counts it: the producer is
  //! the control loop, which must never wait for a slow consumer. False when dropped.
  bool try_push(const T& value) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    // The consumer only ever advances tail_, so a stale read can only under-estimate free space.
    if (head - tail_.load(std::memory_order_acquire) >= Capacity) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head % Capacity] = value;
    // Release: the slot's bytes are visible to the consumer before the new head is.
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  //! Copies the oldest element into out and removes it; false when empty (a normal outcome).
  bool try_pop(T& out) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = slots_[tail % Capacity];
    // Release: the copy-out is complete before the producer may reuse the slot.
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  //! Convenience for small T; copies through the return value.
  [[nodiscard]] std::optional<T> try_pop() noexcept {
    T out;
    if (!try_pop(out)) return std::nullopt;
    return out;
  }

  //! Elements waiting; exact only when both sides are quiet. [-]
  [[nodiscard]] std::size_t size() const noexcept {
    return static_cast<std::size_t>(head_.load(std::memory_order_acquire) -
                                    tail_.load(std::memory_order_acquire));
  }
  [[nodiscard]] static constexpr std::size_t capacity() noexcept { return Capacity; }
  //! Elements refused by try_push() because the queue was full, since construction. [-]
  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  //! Elements accepted by try_push() since construction. [-]
  [[nodiscard]] std::uint64_t pushed() const noexcept { return head_.load(std::memory_order_relaxed); }

 private:
  // 64-bit indices never wrap in practice (at 100 Hz: 5e9 years); the slot is index % Capacity.
  // Each index on its own cache line so producer and consumer do not false-share.
  static constexpr std::size_t kCacheLine = 64;
  alignas(kCacheLine) std::atomic<std::uint64_t> head_{0};
  alignas(kCacheLine) std::atomic<std::uint64_t> tail_{0};
  alignas(kCacheLine) std::atomic<std::uint64_t> dropped_{0};
  alignas(kCacheLine) std::array<T, Capacity> slots_{};
};

}  // namespace mgc::firmware
