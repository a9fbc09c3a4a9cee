// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/anytime.hpp"

#include <algorithm>
#include <cmath>

#include "mgc/planning/path_metrics.hpp"

namespace mgc::planning {

AnytimePlanner::AnytimePlanner(int seeds) : seeds_(seeds) {}

PlannerStatus AnytimePlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  run_problem_ = problem;
  iterations_ = 0;
  tree_nodes_ = 0;
  checks_at_reset_ = problem.world->collision_checks();
  best_.clear();
  history_.clear();
  seed_index_ = 0;
  gamma_index_ = -1;
  // Size every buffer now: the inner planners' pools keep their capacity across their own
  // resets, so step() can start run after run without touching the heap.
  status_ = connect_.reset(run_problem_);
  if (status_ != PlannerStatus::Running) return status_;
  if (modified_.reset(run_problem_) != PlannerStatus::Running) return status_ = PlannerStatus::InvalidGoal;
  history_.reserve(static_cast<std::size_t>(seeds_) * (kGammaSteps + 1));
  best_.reserve(connect_.path().capacity());
  start_run();
  return status_ = PlannerStatus::Running;
}

void AnytimePlanner::start_run() noexcept {
  run_problem_.seed = problem_->seed + static_cast<std::uint64_t>(seed_index_);
  if (gamma_index_ < 0) {
    current_ = &connect_;
  } else {
    modified_.set_gamma(gamma_at(gamma_index_));
    current_ = &modified_;
  }
  // Same problem, same pools: a reset that allocates nothing (capacities already reserved).
  (void)current_->reset(run_problem_);
}

bool AnytimePlanner::finish_run(PlannerStatus run_status) noexcept {
  tree_nodes_ += current_->stats().tree_nodes;
  bool next_seed = false;
  if (run_status == PlannerStatus::Solved) {
    const auto& path = current_->path();
    const MachineModel& model = *problem_->model;
    double roughness = 0.0;
    double exec_s = 0.0;
    for (std::size_t e = 0; e + 1 < path.size(); ++e) {
      roughness += normalized_distance(model, path[e], path[e + 1], false);
      const JointVector d = model.difference(path[e], path[e + 1]);
      for (int i = 0; i < model.dof(); ++i) exec_s += std::abs(d[i]) / model.joints()[static_cast<std::size_t>(i)].max_velocity;
    }
    if (best_.empty() || roughness < best_roughness_) {
      best_.assign(path.begin(), path.end());
      best_roughness_ = roughness;
      history_.push_back({iterations_, seed_index_, gamma_index_ < 0 ? 0.0 : gamma_at(gamma_index_), roughness,
                          0.5 * exec_s / 60.0 + 0.5 * roughness});
    }
    // The note's reading of L204: lower gamma while the roughness does not rise.
    if (gamma_index_ >= 0 && roughness > previous_roughness_) next_seed = true;
    previous_roughness_ = roughness;
  } else if (gamma_index_ >= 0) {
    next_seed = true;  // over-constrained: a tighter gamma will not do better
  }
  if (!next_seed && gamma_index_ + 1 < kGammaSteps) {
    ++gamma_index_;
  } else {
    ++seed_index_;
    gamma_index_ = -1;
    if (seed_index_ >= seeds_) return false;
  }
  start_run();
  return true;
}

PlannerStatus AnytimePlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  while (iteration_budget > 0) {
    const int before = current_->stats().iterations;
    const PlannerStatus run = current_->step(iteration_budget);
    const int spent = std::max(1, current_->stats().iterations - before);
    iterations_ += spent;
    iteration_budget -= spent;
    if (run == PlannerStatus::Running) continue;
    if (!finish_run(run)) return status_ = best_.empty() ? PlannerStatus::IterationLimit : PlannerStatus::Solved;
  }
  return status_;
}

PlannerStats AnytimePlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = tree_nodes_;
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void AnytimePlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  if (current_) {
    current_->tree(nodes, parents);
  } else {
    nodes.clear();
    parents.clear();
  }
}

}  // namespace mgc::planning
