// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <vector>

#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! Seed 004's multiple-RRT (after Clifton et al. 2008), Fig. 6. Start and goal each root a tree.
//! Every iteration draws one valid configuration and tries to join it to every tree through the
//! nearer of the tree's nearest node and the foot of the perpendicular on its nearest edge
//! (seed 004 Eq. 17 with the note's |E|^2 fix; the foot joins as a child of the edge's parent,
//! Eqs. 24-27). A sample that joins no tree roots a new one; one that joins several merges them
//! into the oldest, turning the parent links round along each joined branch (Fig. 9). The search
//! ends when start and goal share a tree; then `smoothing_passes` random shortcuts between
//! points inside two path edges (Fig. 8) shorten the path.
//!
//! Distances are the step metric of the other planners (problem.step), every edge is checked by
//! CollisionWorld::validate_edge at problem.step -- so by the model's own edge rule too -- and
//! every edge of path() was validated as it stands. A step() slice spends its budget on growth
//! iterations, then on smoothing passes; the slice in which the trees meet ends there, so a
//! caller can time growth and smoothing apart. No clock is read: a time limit is the caller's.
class MultiRrtPlanner final : public Planner {
 public:
  struct Options {
    int smoothing_passes = 20;    //!< seed 004's n_smooth [-]
    bool nearest_edge = true;     //!< join at an edge's foot when nearer than the nearest node (seed 004 Step 2)
    int max_sample_draws = 2000;  //!< draws per iteration before it is given up without a sample [-]
  };
  enum class Phase : std::uint8_t { Growing, Smoothing, Done };

  MultiRrtPlanner() = default;
  explicit MultiRrtPlanner(const Options& options) : options_(options) {}

  [[nodiscard]] std::string_view name() const noexcept override { return "multi-rrt"; }
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  [[nodiscard]] Phase phase() const noexcept { return phase_; }
  //! The path as the trees gave it, before smoothing (valid from the Smoothing phase on).
  [[nodiscard]] const std::vector<JointVector>& raw_path() const noexcept { return raw_path_; }
  //! Trees rooted so far, start and goal included, and how many are still apart.
  [[nodiscard]] int trees_created() const noexcept { return trees_created_; }
  [[nodiscard]] int trees_alive() const noexcept;
  [[nodiscard]] int shortcuts_taken() const noexcept { return shortcuts_; }
  [[nodiscard]] const Options& options() const noexcept { return options_; }

 private:
  //! Nearest point of one tree to a configuration: a node, or a foot on the edge child -> parent.
  struct Nearest {
    double distance = 0.0;
    int node = -1;       //!< the node, or the edge's child
    double t = -1.0;     //!< < 0: the node itself; else the foot at child + t (parent - child)
  };

  [[nodiscard]] bool grow_once() noexcept;
  [[nodiscard]] bool draw_sample(JointVector& q) noexcept;
  [[nodiscard]] int add_node(const JointVector& q, int parent, int tree) noexcept;
  //! Tries to join q to tree `t`; returns q's node in that tree, -1 if the edge is invalid, -2 if
  //! the pool is full.
  [[nodiscard]] int connect(const JointVector& q, int t, const Nearest& near) noexcept;
  void merge(int into_tree, int into_node, int from_tree, int from_node) noexcept;
  void extract_path() noexcept;
  void smooth_once() noexcept;
  [[nodiscard]] bool valid_edge(const JointVector& a, const JointVector& b) noexcept;

  Options options_;
  const PlanningProblem* problem_ = nullptr;
  Random random_;
  PlannerStatus status_ = PlannerStatus::NotReset;
  Phase phase_ = Phase::Growing;
  int iterations_ = 0;
  int smoothing_done_ = 0;
  int shortcuts_ = 0;
  int trees_created_ = 0;
  std::uint64_t checks_at_reset_ = 0;

  // The node pool: node i holds a configuration, its parent's index (-1 for a root) and its tree.
  std::vector<JointVector> nodes_;
  std::vector<int> parents_;
  std::vector<int> tree_of_;
  std::vector<int> scratch_;  //!< branch being reversed in a merge
  // Per tree (indexed by creation order): alive flag and this iteration's nearest point and join.
  std::vector<char> alive_;
  std::vector<Nearest> nearest_;
  std::vector<int> joined_;  //!< the sample's node in each tree it joined this iteration

  std::vector<JointVector> raw_path_;
  std::vector<JointVector> path_;
  std::vector<JointVector> path_scratch_;
};

}  // namespace mgc::planning
