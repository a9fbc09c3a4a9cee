// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! The shared pieces of the thesis's single-tree planners (ICE-Planner, after MSL): a node pool
//! sized at reset, a goal-biased sampler, brute-force nearest neighbour under the step metric,
//! and MSL's single-axis input set -- 2n inputs, each moving exactly one joint by one step -- so
//! every edge moves one joint ("rules of action", thesis §3.4). Subclasses differ only in how
//! an iteration extends the tree.
class SingleAxisTreePlanner : public Planner {
 public:
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

 protected:
  //! One iteration: sample, extend, add at most one node to tree_. Returns false when the pool
  //! is full.
  [[nodiscard]] virtual bool iterate() noexcept = 0;

  //! Goal with probability goal_bias, else uniform over the joint ranges.
  [[nodiscard]] JointVector sample() noexcept;
  [[nodiscard]] int nearest(const JointVector& q) const noexcept { return tree_.nearest(*problem_, q); }
  [[nodiscard]] double metric(const JointVector& a, const JointVector& b) const noexcept {
    return step_metric(*problem_->model, problem_->step, a, b);
  }
  //! q moved by one step of `input` (input = 2 * joint + (negative ? 1 : 0)); continuous joints
  //! wrap.
  [[nodiscard]] JointVector apply(const JointVector& q, int input) const noexcept;
  //! MSL's SelectInput: the valid one-step move from `from` that ends closest to `target`; -1
  //! when no valid move gets closer than `from` is.
  [[nodiscard]] int select_input(const JointVector& from, const JointVector& target, JointVector& moved) noexcept;
  [[nodiscard]] bool valid(const JointVector& q) noexcept { return problem_->world->validate(q).valid(); }
  //! The one-step edge from -> to, checked as every edge is (CollisionWorld::validate_edge).
  [[nodiscard]] bool valid_step(const JointVector& from, const JointVector& to) noexcept {
    return problem_->world->validate_edge(from, to, problem_->step).valid();
  }
  //! The thesis's Limited Greedy Connect iteration (App. E), shared by limcon and the DRRT.
  [[nodiscard]] bool limited_connect() noexcept;
  //! The goal-biased RRT iteration: one step toward the sample.
  [[nodiscard]] bool single_step() noexcept;
  //! Starts a new query on the tree as it stands -- the problem's goal, cap or bias may have
  //! changed (re-planning): resets the iteration count and solves at once when a node already
  //! lies within the goal tolerance. RT-safe.
  [[nodiscard]] PlannerStatus resume() noexcept;
  //! The tree node the solved path leaves the tree at, before the closing moves; -1 unsolved.
  [[nodiscard]] int solved_node() const noexcept { return solved_node_; }

  const PlanningProblem* problem_ = nullptr;
  Random random_;
  NodeTree tree_;

 private:
  //! MSL's GapSatisfied: every joint within error_tolerance steps of the goal.
  [[nodiscard]] bool near_goal(const JointVector& q) const noexcept;
  //! From the node nearest the goal, close the remaining gap one joint at a time with validated
  //! moves and write the path. False if a closing move is invalid.
  [[nodiscard]] bool finish(int node) noexcept;
  //! Steps of one joint summed in floating point can leave it a rounding error (1e-13 rad) from
  //! the goal, and closing that gap would be an edge of no length. Instead the joint takes the
  //! goal's value from the end of the last edge of `path` that moved it, the edges from there on
  //! re-validated; a gap the start already has is closed as any other. False when a re-validated
  //! edge is invalid. RT-safe.
  [[nodiscard]] bool absorb_rounding(std::vector<JointVector>& path, const JointVector& goal) noexcept;

  PlannerStatus status_ = PlannerStatus::NotReset;
  int solved_node_ = -1;
  int iterations_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  std::vector<JointVector> path_;
};

//! The thesis's RRTBiasedLimCon (App. E): from the node nearest a goal-biased sample, pick the
//! best single-axis input and repeat it while the state stays valid, does not move away from the
//! sample, and -- when the first step approached the goal -- keeps approaching the goal (Limited
//! Greedy Connect). One node per iteration, at the last state of that run.
class LimConPlanner final : public SingleAxisTreePlanner {
 public:
  [[nodiscard]] std::string_view name() const noexcept override { return "limcon"; }

 protected:
  [[nodiscard]] bool iterate() noexcept override;
};

//! The thesis's RRTGoalBiased baseline: the same sampler and input set, one step per iteration.
class GoalBiasedRrtPlanner final : public SingleAxisTreePlanner {
 public:
  [[nodiscard]] std::string_view name() const noexcept override { return "rrt"; }

 protected:
  [[nodiscard]] bool iterate() noexcept override;
};

}  // namespace mgc::planning
