// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "mgc/planning/path_shortener.hpp"
#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! The default one-joint-at-a-time planner: bidirectional RRT-Connect whose local planner is a
//! staircase, so that every edge of every tree moves exactly one joint (the operator's
//! one-lever-at-a-time rule of the thesis) while the search keeps RRT-Connect's reach on sites
//! nobody tuned it for. docs/plan-json.md ("axis-connect: the default planner") says why it is
//! built so.
//!
//! One iteration: a uniform sample (rejecting those the engineering constraints refuse, as
//! rrt-connect does); the growing tree's nearest node moves toward it joint by joint in a random
//! order, each joint as far as its one-joint edge stays valid, with a node at every corner; then
//! the other tree's nearest node tries to reach that new node exactly by a staircase, in up to
//! max_orders orders of the joints (orders that begin with a blocked stair are skipped whole), and
//! when none is valid it moves toward it as the first tree did. The trees swap roles every
//! iteration. The first iteration tries the staircase from start to goal directly and, when that
//! is blocked and a slewing joint must turn, the same staircase turning the long way round:
//! taken at once when it is at most kLongWayFactor times as slow as the short way's staircase,
//! else kept and returned instead of the search's path if that turns out slower.
//!
//! The joined path then has its consecutive moves of the same joint merged (the merged edge is the
//! union of validated stairs, so it is valid) and is shortened by PathShortener's staircase
//! shortcuts in the same bounded slices; a shortcut never lengthens the one-joint-at-a-time
//! execution time, since a staircase moves each joint straight from one node to another.
//!
//! Every edge is validated by CollisionWorld::validate_edge at the problem's step resolution.
//! Allocation-free after reset(); deterministic for a seed.
class AxisConnectPlanner final : public Planner {
 public:
  //! The long way round is taken at once when its staircase takes at most this many times the
  //! short way's. When the short way's staircase is blocked, the search's paths on the generated
  //! sites took a median 1.73 times that staircase's time, and less than 1.31 times in 1 query of
  //! 10 (docs/plan-json.md). [-]
  static constexpr double kLongWayFactor = 1.3;
  //! Staircase orders the shortener tries per stretch: on the generated sites the first 6 find
  //! the shortcuts that matter (execution time +0.5 % against all 24, 31 % fewer checks). [-]
  static constexpr int kShortenerOrders = 6;
  static constexpr double kShortenerChunkM = 2.0;  //!< PathShortener's chunk of body travel [m]

  //! max_orders: staircase orders tried when one tree reaches for the other's new node (all 24
  //! for 4 joints). shorten: whether the solved path is shortened before Solved is reported.
  explicit AxisConnectPlanner(int max_orders = 24, bool shorten = true);

  [[nodiscard]] std::string_view name() const noexcept override { return "axis-connect"; }
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  //! Staircase chunks PathShortener validated for the last solved path. [-]
  [[nodiscard]] int shortening_chunks() const noexcept { return shortening_chunks_; }

 private:
  enum class Growth : std::uint8_t { Reached, Advanced, Trapped, PoolFull };
  enum class Move : std::uint8_t { None, Partial, Full };

  //! Moves joint `joint` of `from` toward `value` along one straight edge: all the way when that
  //! edge is valid, else to one step short of its first invalid sample when that shorter edge is
  //! valid, else not at all. `reached` receives the end.
  [[nodiscard]] Move move_joint(const JointVector& from, int joint, double value, JointVector& reached) noexcept;
  //! From node `from` of `tree` toward `target`: joint by joint in `order`, each as far as it
  //! stays valid, then once more for the joints that stopped short; a node at every corner.
  //! `last` receives the last node added (or `from`).
  [[nodiscard]] Growth extend(NodeTree& tree, int from, const JointVector& target, const std::array<int, kMaxJoints>& order,
                              int& last) noexcept;
  //! The first valid staircase from node `from` of `tree` that ends exactly at `target`, tried
  //! in up to max_orders orders; its corners are added. Reached, Trapped (nothing added) or
  //! PoolFull.
  [[nodiscard]] Growth connect_exact(NodeTree& tree, int from, const JointVector& target, int& last) noexcept;
  //! The time a staircase from `from` to `to` takes moving one joint at a time at each joint's
  //! maximum velocity. [s]
  [[nodiscard]] double staircase_time_s(const JointVector& from, const JointVector& to) const noexcept;
  //! The direct staircase from start to goal with a continuous joint turning the long way round
  //! (through a node halfway along the long arc). Its corners are added to the start tree; `last`
  //! receives the goal's; at_once: it takes at most kLongWayFactor times the short way's staircase.
  [[nodiscard]] Growth connect_long_way(int& last, bool& at_once) noexcept;
  //! One-joint-at-a-time execution time of a path at each joint's maximum velocity. [s]
  [[nodiscard]] double path_time_s(const std::vector<JointVector>& path) const noexcept;
  //! Solved, with the long way round instead of the path when that is quicker.
  [[nodiscard]] PlannerStatus solved() noexcept;
  //! A random order of all the joints.
  void shuffle(std::array<int, kMaxJoints>& order) noexcept;
  void join(int start_node, int goal_node) noexcept;
  //! Merges consecutive edges that move the same single joint; drops edges that move nothing.
  void merge_collinear() noexcept;
  //! Solved once the path is joined (and shortened when asked for).
  [[nodiscard]] PlannerStatus finish_join() noexcept;

  int max_orders_;
  bool shorten_;
  const PlanningProblem* problem_ = nullptr;
  Random random_;
  NodeTree start_tree_;
  NodeTree goal_tree_;
  bool start_tree_grows_first_ = true;
  PlannerStatus status_ = PlannerStatus::NotReset;
  bool shortening_ = false;
  int iterations_ = 0;
  int shortening_chunks_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  std::vector<JointVector> path_;
  //! The long way round found by the first iteration but slower than kLongWayFactor allows at
  //! once, or empty: the answer if the search's path turns out slower.
  std::vector<JointVector> long_way_;
  std::array<JointVector, kMaxJoints + 1> stairs_{};  //!< the staircase being validated, from its start
  std::optional<PathShortener> shortener_;
  std::size_t shortener_capacity_ = 0;
};

}  // namespace mgc::planning
