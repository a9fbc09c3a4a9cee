// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <vector>

#include "mgc/planning/planners/problem.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! A tree of configurations in a pool sized once (reset) and never grown: nodes are addressed by
//! index, each knows its parent (-1 for the root). Nearest neighbour is a brute-force scan under
//! the step metric -- the thesis's choice, and exact; trees here hold hundreds to a few thousand
//! nodes.
class NodeTree {
 public:
  //! Empties the tree and reserves room for `capacity` nodes. May allocate.
  void reset(std::size_t capacity);
  //! Adds a node; false (and nothing added) when the pool is full. RT-safe.
  [[nodiscard]] bool add(const JointVector& q, int parent) noexcept;
  [[nodiscard]] int nearest(const PlanningProblem& problem, const JointVector& q) const noexcept;
  //! Appends the configurations from the root down to `node` to `out` (whose capacity the caller
  //! reserved). RT-safe.
  void append_root_to(int node, std::vector<JointVector>& out) const noexcept;
  //! Drops every node flagged in `invalid` (indexed by node, size() entries) and every
  //! descendant of one, keeping the rest in insertion order with parents renumbered; `invalid`
  //! is rewritten to the flags of the removed nodes' old indices and `new_index` (size() entries,
  //! capacity reserved by the caller) receives each old node's new index or -1. Relies on
  //! parents being added before their children. RT-safe.
  void trim(std::vector<unsigned char>& invalid, std::vector<int>& new_index) noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return nodes_.size(); }
  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
  [[nodiscard]] const JointVector& node(int i) const noexcept { return nodes_[static_cast<std::size_t>(i)]; }
  [[nodiscard]] int parent(int i) const noexcept { return parents_[static_cast<std::size_t>(i)]; }
  [[nodiscard]] const std::vector<JointVector>& nodes() const noexcept { return nodes_; }
  [[nodiscard]] const std::vector<int>& parents() const noexcept { return parents_; }

 private:
  std::vector<JointVector> nodes_;
  std::vector<int> parents_;
  std::size_t capacity_ = 0;
};

//! Uniform over the joint ranges.
[[nodiscard]] JointVector uniform_sample(const MachineModel& model, Random& random) noexcept;
//! A uniform sample that satisfies the machine's engineering constraints (seed 000's
//! Random-Node-Satisfy-Eng-Const), by rejection; gives up after a bounded number of draws and
//! returns the last one. RT-safe.
[[nodiscard]] JointVector constrained_sample(const MachineModel& model, Random& random) noexcept;

//! A bidirectional planner's path where its trees meet: `start`'s branch from the root to
//! `start_node`, then `goal`'s from `goal_node`'s parent up to its root (the meeting configuration
//! is in both). `path` is cleared first; its capacity is the caller's. RT-safe.
void join_trees(const NodeTree& start, int start_node, const NodeTree& goal, int goal_node, std::vector<JointVector>& path) noexcept;
//! Both trees as one for drawing, the goal tree's indices after the start tree's. Not RT.
void export_trees(const NodeTree& start, const NodeTree& goal, std::vector<JointVector>& nodes, std::vector<int>& parents);

}  // namespace mgc::planning
