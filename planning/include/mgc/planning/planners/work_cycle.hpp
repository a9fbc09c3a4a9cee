// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mgc/planning/planners/nonuniform.hpp"

namespace mgc::planning {

//! Seed 003's free-motion cycle of an excavator (Table 1) as its three subtasks in order, each
//! planned by NonUniformRrtPlanner with that subtask's holds:
//!   move-to-dump  problem.start (dig, bucket full) -> problem.goal (dump), the bucket's ground
//!                 angle held so the soil stays in;
//!   dump          problem.goal -> dumped: swing and boom held, the arm and bucket move (the
//!                 straight line when it is free, the paper's "parametric" dump);
//!   return        dumped -> next_dig, all four joints free.
//! Every subtask takes the problem's seed, step, tolerances and iteration cap. step() stops at
//! each subtask's end (returning Running) so that a caller can time the subtasks; like every
//! planner it allocates nothing there. path() is the whole cycle, subtask_path() one subtask.
class WorkCyclePlanner final : public Planner {
 public:
  static constexpr int kSubtasks = 3;
  static constexpr std::array<ExcavatorSubtask, kSubtasks> kOrder = {
      ExcavatorSubtask::MoveToDump, ExcavatorSubtask::Dump, ExcavatorSubtask::Return};

  //! dumped: the dump pose with the arm and bucket moved; next_dig: where the return ends. [rad]
  WorkCyclePlanner(const JointVector& dumped, const JointVector& next_dig);
  // The subtask planners point into problems_: a copy would plan the original's queries.
  WorkCyclePlanner(const WorkCyclePlanner&) = delete;
  WorkCyclePlanner& operator=(const WorkCyclePlanner&) = delete;

  [[nodiscard]] std::string_view name() const noexcept override { return "nonuniform"; }
  //! Resets all three subtasks. InvalidStart: the dig pose is invalid; InvalidGoal: a later pose
  //! is invalid or breaks its subtask's hold (failed_subtask() says which subtask).
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  //! The whole cycle's counters: sums over the subtasks.
  [[nodiscard]] PlannerStats stats() const noexcept override;
  //! The three subtasks' trees, one after another (each with its root's parent -1).
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  //! The subtask being planned (kSubtasks once the cycle is solved).
  [[nodiscard]] int current_subtask() const noexcept { return current_; }
  //! The subtask whose reset or planning failed, or -1.
  [[nodiscard]] int failed_subtask() const noexcept { return failed_; }
  [[nodiscard]] const PlanningProblem& subtask_problem(int k) const noexcept {
    return problems_[static_cast<std::size_t>(k)];
  }
  [[nodiscard]] PlannerStatus subtask_status(int k) const noexcept { return statuses_[static_cast<std::size_t>(k)]; }
  //! Solved subtasks only; valid until the next reset().
  [[nodiscard]] const std::vector<JointVector>& subtask_path(int k) const noexcept {
    return planners_[static_cast<std::size_t>(k)].path();
  }
  //! Counters of one subtask; collision checks include those of its reset.
  [[nodiscard]] PlannerStats subtask_stats(int k) const noexcept;

 private:
  JointVector dumped_;
  JointVector next_dig_;
  std::array<PlanningProblem, kSubtasks> problems_{};
  std::array<NonUniformRrtPlanner, kSubtasks> planners_{NonUniformRrtPlanner(kOrder[0]),
                                                        NonUniformRrtPlanner(kOrder[1]),
                                                        NonUniformRrtPlanner(kOrder[2])};
  std::array<PlannerStatus, kSubtasks> statuses_{};
  std::array<std::uint64_t, kSubtasks> checks_{};  //!< collision checks per subtask
  CollisionWorld* world_ = nullptr;
  int current_ = 0;
  int failed_ = -1;
  PlannerStatus status_ = PlannerStatus::NotReset;
  std::vector<JointVector> path_;
};

}  // namespace mgc::planning
