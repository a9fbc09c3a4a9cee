// SPDX-License-Identifier: Apache-2.0
// The true state copied out of mgc-sim's real-time loop, so that the truth monitor's distance
// queries and the truth log's formatting run outside the loop's lock: a thread that is not run
// while it measures then holds up no device's answer. docs/simulator.md, "Real time".
#pragma once

#include <Eigen/Geometry>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "mgc/sim/simulator.hpp"

namespace mgc::sim {

//! One machine's true state and its scenario's dynamic obstacles at one simulation time.
struct TruthSnapshot {
  TrueState truth{};
  //! Scenario order; sized once (resize_for()), so that capture() does not allocate.
  std::vector<Eigen::Isometry3d> obstacle_poses;

  //! Room for the simulator's obstacles. Allocates: before the loop.
  void resize_for(const Simulator& sim) { obstacle_poses.assign(sim.scenario().dynamic_obstacles.size(), Eigen::Isometry3d::Identity()); }
  //! Copies the simulator's state now. No allocation once sized for it.
  void capture(const Simulator& sim) noexcept {
    truth = sim.truth();
    for (std::size_t i = 0; i < obstacle_poses.size(); ++i) obstacle_poses[i] = sim.obstacle_pose(i);
  }
};

//! The snapshots of every machine (one, or a site's) at one instant, and what is due for them.
struct TruthFrame {
  std::vector<TruthSnapshot> machines;  //!< site order
  bool monitor_due = false;             //!< the truth monitors (and the site's pair referee) sample it
  bool log_due = false;                 //!< the truth log writes a row of it
};

//! A fixed ring of frames from the loop (one producer at a time: under the loop's lock) to the
//! observer (one consumer at a time: under its own lock). A frame the full ring cannot take is
//! counted, never overwritten: the observer sees every frame it was given, in order.
class TruthFrameRing {
 public:
  //! capacity frames, each sized with prototype's machines. Allocates: before the loop.
  TruthFrameRing(std::size_t capacity, const TruthFrame& prototype) : frames_(capacity == 0 ? 1 : capacity, prototype) {}

  //! The frame to fill, or null when the ring is full (counted in dropped()). Producer only.
  [[nodiscard]] TruthFrame* begin_push() noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= frames_.size()) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return nullptr;
    }
    return &frames_[head % frames_.size()];
  }
  //! Hands the frame begin_push() gave over to the consumer. Producer only.
  void end_push() noexcept { head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

  //! The oldest frame not yet consumed, or null. Consumer only.
  [[nodiscard]] const TruthFrame* front() const noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    return tail == head_.load(std::memory_order_acquire) ? nullptr : &frames_[tail % frames_.size()];
  }
  //! Releases front() to the producer. Consumer only.
  void pop() noexcept { tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

  [[nodiscard]] std::size_t capacity() const noexcept { return frames_.size(); }
  //! Frames refused because the ring was full. [-]
  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  std::vector<TruthFrame> frames_;
  std::atomic<std::uint64_t> head_{0};  //!< frames pushed
  std::atomic<std::uint64_t> tail_{0};  //!< frames consumed
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace mgc::sim
