// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mgc/planning/collision_world.hpp"

namespace mgc::planning {

//! Shortens a valid path inside the control loop: the in-loop counterpart of smooth_path's
//! staircase shortcuts (smoothing.hpp), time-sliced and allocation-free after construction.
//!
//! Deterministic, no random pairs. From each node in turn it takes the farthest later node that a
//! staircase reaches in fewer edges than the stretch it replaces. A staircase moves one joint at a
//! time: first in the order the joints first move along the stretch, and where that is blocked in
//! the other orders of the same joints (up to max_orders in all), since a way round an obstacle
//! often needs a hoist or a boom move before the slew rather than after; every order takes the
//! same one-joint-at-a-time time. Then each edge that still moves more than one joint becomes a
//! staircase where one is valid: the largest move first, as the one-joint-at-a-time follower
//! would take it, then the other orders. So the machine moves what was checked. Every stair is
//! validated in `world` at the planner's step resolution. The check runs in chunks of at most
//! chunk_m of body travel, one chunk per unit of budget, so that a slice costs the same whatever
//! an edge's length. An order blocked at a stair rules out every order that begins the same way up
//! to that stair, and the next order is validated from its first stair that differs.
//!
//! Each node remembers which input node it is (source()), or -1 for a staircase corner, so that
//! a re-planner can still be told which of its own nodes the machine was heading for.
class PathShortener {
 public:
  enum class Status : std::int8_t { Idle = 0, Running, Done };

  //! Allocates room for `capacity` nodes of `dof` joints. max_orders: staircase orders tried per
  //! stretch or edge (all of them for 4 joints at 24). [-]
  PathShortener(int dof, std::size_t capacity, double chunk_m = 2.0, int max_orders = 24);

  //! Copies `prefix` (if not null) and then `path`, and starts shortening from node `first` on in
  //! `world` (which must stay posed as the path was planned until Done) at `step`. With shorten
  //! false, or a path longer than the capacity (then cut to it: check truncated()), it is Done at
  //! once.
  Status begin(CollisionWorld& world, const JointVector* prefix, const std::vector<JointVector>& path, const JointVector& step,
               std::size_t first, bool shorten) noexcept;
  //! Validates at most `budget` chunks.
  [[nodiscard]] Status step(int budget) noexcept;

  [[nodiscard]] Status status() const noexcept { return status_; }
  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] const JointVector& operator[](std::size_t i) const noexcept { return nodes_[i]; }
  //! The index in begin()'s `path` of node i, or -1 (the prefix, a staircase corner).
  [[nodiscard]] int source(std::size_t i) const noexcept { return source_[i]; }
  //! The input did not fit and was not taken.
  [[nodiscard]] bool truncated() const noexcept { return truncated_; }
  //! Chunks validated since begin().
  [[nodiscard]] int chunks() const noexcept { return chunks_; }

 private:
  enum class Phase : std::int8_t { Shortcut, Stairs };
  //! Chooses the next (i, k) pair or edge to try and plans its staircase; false when the phase
  //! has nothing left.
  bool next_candidate() noexcept;
  //! The joints that differ from node i_ to node k_, in the phase's first order, into base_ /
  //! order_count_, and that order's stairs.
  void plan_stairs() noexcept;
  //! order_ and stairs_ from base_ permuted by perm_.
  void build_stairs() noexcept;
  //! The next order that does not begin as the blocked one does up to stair `blocked`; false when
  //! none is left or max_orders have been tried. Sets stair_ and at_ to its first new stair.
  bool next_order(int blocked) noexcept;
  //! Replaces nodes i_+1 .. k_ by the validated stairs, the last of which is node k_.
  void apply() noexcept;
  //! to - from of joint j, the short way round for a continuous joint. [rad | m]
  [[nodiscard]] double delta(int j, const JointVector& from, const JointVector& to) const noexcept;

  CollisionWorld* world_ = nullptr;
  JointVector step_;
  double chunk_m_;
  std::vector<JointVector> nodes_;
  std::vector<int> source_;
  std::vector<JointVector> stairs_;  //!< the staircase being validated, one node per joint
  std::size_t size_ = 0;
  std::size_t capacity_;
  Status status_ = Status::Idle;
  Phase phase_ = Phase::Shortcut;
  bool truncated_ = false;
  int chunks_ = 0;

  std::size_t first_ = 0;  //!< nodes before this are kept as they are
  std::size_t i_ = 0;  //!< the stretch or edge being replaced: nodes i_ .. k_
  std::size_t k_ = 0;
  bool trying_ = false;        //!< a staircase is being validated
  std::array<int, 16> base_{};   //!< the joints to move, in the phase's first order
  std::array<int, 16> perm_{};   //!< the order being tried, as positions in base_
  std::array<int, 16> order_{};  //!< the joints in the order being tried
  int order_count_ = 0;
  int orders_tried_ = 0;
  int max_orders_;
  int stair_ = 0;              //!< the stair being validated
  JointVector at_;             //!< how far along the stair the chunks have validated
  JointVector chunk_to_;
  JointVector end_;            //!< node k_ while the nodes shift
};

}  // namespace mgc::planning
