// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/work_cycle.hpp"

namespace mgc::planning {

WorkCyclePlanner::WorkCyclePlanner(const JointVector& dumped, const JointVector& next_dig)
    : dumped_(dumped), next_dig_(next_dig) {}

PlannerStatus WorkCyclePlanner::reset(const PlanningProblem& problem) {
  world_ = problem.world;
  current_ = 0;
  failed_ = -1;
  path_.clear();
  statuses_.fill(PlannerStatus::NotReset);
  checks_.fill(0);
  const std::array<JointVector, kSubtasks + 1> poses = {problem.start, problem.goal, dumped_, next_dig_};
  std::size_t capacity = 0;
  for (int k = 0; k < kSubtasks; ++k) {
    const auto i = static_cast<std::size_t>(k);
    problems_[i] = problem;
    problems_[i].start = poses[i];
    problems_[i].goal = poses[i + 1];
    const std::uint64_t before = world_->collision_checks();
    statuses_[i] = planners_[i].reset(problems_[i]);
    checks_[i] = world_->collision_checks() - before;
    if (statuses_[i] != PlannerStatus::Running) {
      failed_ = k;
      // Only the first subtask's start is the cycle's start; every later failure is a goal's.
      const bool start = k == 0 && statuses_[i] == PlannerStatus::InvalidStart;
      return status_ = start ? PlannerStatus::InvalidStart : PlannerStatus::InvalidGoal;
    }
    capacity += static_cast<std::size_t>(problem.node_capacity > 0 ? problem.node_capacity : problem.max_iterations + 1) + 1;
  }
  path_.reserve(capacity);
  return status_ = PlannerStatus::Running;
}

PlannerStatus WorkCyclePlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  const auto i = static_cast<std::size_t>(current_);
  const std::uint64_t before = world_->collision_checks();
  statuses_[i] = planners_[i].step(iteration_budget);
  checks_[i] += world_->collision_checks() - before;
  switch (statuses_[i]) {
    case PlannerStatus::Running: return status_;
    case PlannerStatus::Solved: {
      const std::vector<JointVector>& piece = planners_[i].path();
      // Each subtask starts where the previous one ended: keep one copy of the junction.
      for (std::size_t n = path_.empty() ? 0 : 1; n < piece.size(); ++n) path_.push_back(piece[n]);
      ++current_;
      return status_ = current_ == kSubtasks ? PlannerStatus::Solved : PlannerStatus::Running;
    }
    default:
      failed_ = current_;
      return status_ = statuses_[i];
  }
}

PlannerStats WorkCyclePlanner::subtask_stats(int k) const noexcept {
  PlannerStats s = planners_[static_cast<std::size_t>(k)].stats();
  s.collision_checks = checks_[static_cast<std::size_t>(k)];
  return s;
}

PlannerStats WorkCyclePlanner::stats() const noexcept {
  PlannerStats total;
  for (int k = 0; k < kSubtasks; ++k) {
    const PlannerStats s = subtask_stats(k);
    total.iterations += s.iterations;
    total.tree_nodes += s.tree_nodes;
    total.collision_checks += s.collision_checks;
  }
  return total;
}

void WorkCyclePlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  nodes.clear();
  parents.clear();
  std::vector<JointVector> sub_nodes;
  std::vector<int> sub_parents;
  // The subtasks reached so far; later ones hold nothing of this query.
  for (int k = 0; k <= current_ && k < kSubtasks; ++k) {
    planners_[static_cast<std::size_t>(k)].tree(sub_nodes, sub_parents);
    const int offset = static_cast<int>(nodes.size());
    nodes.insert(nodes.end(), sub_nodes.begin(), sub_nodes.end());
    for (const int parent : sub_parents) parents.push_back(parent < 0 ? -1 : parent + offset);
  }
}

}  // namespace mgc::planning
