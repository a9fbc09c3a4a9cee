// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/single_axis_tree.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace mgc::planning {

const char* to_string(PlannerStatus status) noexcept {
  switch (status) {
    case PlannerStatus::Running: return "running";
    case PlannerStatus::Solved: return "solved";
    case PlannerStatus::InvalidStart: return "invalid start";
    case PlannerStatus::InvalidGoal: return "invalid goal";
    case PlannerStatus::IterationLimit: return "iteration limit reached";
    case PlannerStatus::PoolExhausted: return "node pool exhausted";
    case PlannerStatus::NotReset: return "not reset";
    case PlannerStatus::GoalOccupied: return "goal occupied by an obstacle";
  }
  return "unknown";
}

double step_metric(const MachineModel& model, const JointVector& step, const JointVector& a,
                   const JointVector& b) noexcept {
  const JointVector d = model.difference(a, b);
  double sum = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    const double w = d[i] / step[i];
    sum += w * w;
  }
  return std::sqrt(sum);
}

PlannerStatus SingleAxisTreePlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  random_.reseed(problem.seed);
  iterations_ = 0;
  solved_node_ = -1;
  path_.clear();
  checks_at_reset_ = problem.world->collision_checks();
  const auto capacity = static_cast<std::size_t>(problem.node_capacity > 0 ? problem.node_capacity : problem.max_iterations + 1);
  tree_.reset(capacity);
  path_.reserve(capacity + static_cast<std::size_t>(problem.model->dof()) + 1);

  if (!valid(problem.start)) return status_ = PlannerStatus::InvalidStart;
  if (!valid(problem.goal)) return status_ = PlannerStatus::InvalidGoal;
  if (!tree_.add(problem.start, -1)) return status_ = PlannerStatus::PoolExhausted;
  status_ = PlannerStatus::Running;
  if (near_goal(problem.start) && finish(0)) status_ = PlannerStatus::Solved;
  return status_;
}

PlannerStatus SingleAxisTreePlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  for (int k = 0; k < iteration_budget; ++k) {
    if (iterations_ >= problem_->max_iterations) return status_ = PlannerStatus::IterationLimit;
    ++iterations_;
    const std::size_t before = tree_.size();
    if (!iterate()) return status_ = PlannerStatus::PoolExhausted;
    // Only a new node can be the first to come within the goal tolerance.
    const int newest = static_cast<int>(tree_.size()) - 1;
    if (tree_.size() > before && near_goal(tree_.node(newest)) && finish(newest)) {
      return status_ = PlannerStatus::Solved;
    }
  }
  return status_;
}

PlannerStatus SingleAxisTreePlanner::resume() noexcept {
  iterations_ = 0;
  solved_node_ = -1;
  path_.clear();
  if (tree_.size() == 0) return status_ = PlannerStatus::PoolExhausted;
  status_ = PlannerStatus::Running;
  const int near = nearest(problem_->goal);
  if (near_goal(tree_.node(near)) && finish(near)) status_ = PlannerStatus::Solved;
  return status_;
}

PlannerStats SingleAxisTreePlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(tree_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void SingleAxisTreePlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  nodes = tree_.nodes();
  parents = tree_.parents();
}

JointVector SingleAxisTreePlanner::sample() noexcept {
  if (random_.uniform() < problem_->goal_bias) return problem_->goal;
  return uniform_sample(*problem_->model, random_);
}

JointVector SingleAxisTreePlanner::apply(const JointVector& q, int input) const noexcept {
  JointVector moved = q;
  const int joint = input / 2;
  moved[joint] += (input % 2 == 0 ? 1.0 : -1.0) * problem_->step[joint];
  if (problem_->model->joints()[static_cast<std::size_t>(joint)].continuous) moved[joint] = wrap_angle(moved[joint]);
  return moved;
}

int SingleAxisTreePlanner::select_input(const JointVector& from, const JointVector& target, JointVector& moved) noexcept {
  // Rank the 2n moves by how close they end to the target, then take the first valid one: the
  // same choice as validating all of them, with fewer collision checks.
  const int inputs = 2 * problem_->model->dof();
  std::array<double, 2 * kMaxJoints> distance{};
  std::array<int, 2 * kMaxJoints> order{};
  const double from_distance = metric(from, target);
  for (int u = 0; u < inputs; ++u) {
    distance[static_cast<std::size_t>(u)] = metric(apply(from, u), target);
    order[static_cast<std::size_t>(u)] = u;
  }
  // Insertion sort: stable, and unlike std::stable_sort it needs no heap buffer; n <= 16.
  for (int k = 1; k < inputs; ++k) {
    const int u = order[static_cast<std::size_t>(k)];
    int m = k;
    for (; m > 0 && distance[static_cast<std::size_t>(u)] < distance[static_cast<std::size_t>(order[static_cast<std::size_t>(m - 1)])]; --m) {
      order[static_cast<std::size_t>(m)] = order[static_cast<std::size_t>(m - 1)];
    }
    order[static_cast<std::size_t>(m)] = u;
  }
  for (int k = 0; k < inputs; ++k) {
    const int u = order[static_cast<std::size_t>(k)];
    if (!(distance[static_cast<std::size_t>(u)] < from_distance)) break;
    JointVector candidate = apply(from, u);
    if (valid_step(from, candidate)) {
      moved = candidate;
      return u;
    }
  }
  return -1;
}

bool SingleAxisTreePlanner::near_goal(const JointVector& q) const noexcept {
  const JointVector d = problem_->model->difference(q, problem_->goal);
  for (int i = 0; i < problem_->model->dof(); ++i) {
    if (std::abs(d[i]) > problem_->error_tolerance * problem_->step[i]) return false;
  }
  return true;
}

bool SingleAxisTreePlanner::finish(int node) noexcept {
  path_.clear();
  tree_.append_root_to(node, path_);
  if (!absorb_rounding(path_, problem_->goal)) {
    path_.clear();
    return false;
  }
  // MSL jumps the last gap in one move; moving the remaining joints one at a time, each move
  // validated at step resolution, keeps every edge single-axis and lands on the exact goal.
  JointVector current = path_.back();
  for (int i = 0; i < problem_->model->dof(); ++i) {
    if (current[i] == problem_->goal[i]) continue;
    JointVector next = current;
    next[i] = problem_->goal[i];
    if (!problem_->world->validate_edge(current, next, problem_->step).valid()) {
      path_.clear();
      return false;
    }
    path_.push_back(next);
    current = next;
  }
  solved_node_ = node;
  return true;
}

bool SingleAxisTreePlanner::absorb_rounding(std::vector<JointVector>& path, const JointVector& goal) noexcept {
  // Far below any step, and far above the rounding of a sum of steps.
  constexpr double kRoundingSteps = 1e-9;
  const MachineModel& model = *problem_->model;
  std::size_t first_changed = path.size();
  for (int i = 0; i < model.dof(); ++i) {
    const double gap = model.difference(path.back(), goal)[i];
    if (gap == 0.0 || std::abs(gap) >= kRoundingSteps * problem_->step[i]) continue;
    std::size_t e = path.size() - 1;
    while (e > 0 && model.difference(path[e - 1], path[e])[i] == 0.0) --e;
    if (e == 0) continue;
    for (std::size_t k = e; k < path.size(); ++k) path[k][i] = goal[i];
    first_changed = std::min(first_changed, e);
  }
  for (std::size_t k = first_changed; k < path.size(); ++k) {
    if (!problem_->world->validate_edge(path[k - 1], path[k], problem_->step).valid()) return false;
  }
  return true;
}

bool SingleAxisTreePlanner::limited_connect() noexcept {
  const JointVector target = sample();
  const int near = nearest(target);
  JointVector next;
  const int input = select_input(tree_.node(near), target, next);
  if (input < 0) return true;
  const JointVector& goal = problem_->goal;
  double d = metric(next, target);
  double d_prev = d;
  JointVector last = next;
  double d_last_goal = metric(tree_.node(near), goal);
  double d_goal = metric(next, goal);
  // App. E limits the run by the goal only when its first step approached the goal.
  const bool track = d_goal < d_last_goal;
  if (!track) {
    d_last_goal = 1.0;
    d_goal = 0.0;
  }
  // The same input repeats; the run is bounded by the joint's range in steps (a continuous
  // joint: half a turn), which the distance test would end anyway.
  const double steps_in_range = problem_->model->joints()[static_cast<std::size_t>(input / 2)].range() /
                                problem_->step[input / 2];
  const int max_run = static_cast<int>(std::ceil(steps_in_range)) + 2;
  // The run is validated step by step, but stored as one edge, which goes the shorter way round: a
  // continuous joint's run must stay short of half a turn, or the edge would turn the other way
  // (through what no step checked).
  const int j = input / 2;
  const bool continuous = problem_->model->joints()[static_cast<std::size_t>(j)].continuous;
  const JointVector& from = tree_.node(near);
  const auto within_half_turn = [&](const JointVector& q) {
    constexpr double kMarginRad = 1e-6;
    return !continuous || std::abs(problem_->model->difference(from, q)[j]) < std::numbers::pi - kMarginRad;
  };
  if (!within_half_turn(next)) return true;
  bool first = true;
  for (int run = 0; run < max_run && d <= d_prev && d_goal < d_last_goal && within_half_turn(next) &&
                    (first || valid_step(last, next));
       ++run) {
    first = false;
    last = next;
    d_prev = d;
    next = apply(last, input);
    d = metric(next, target);
    if (track) {
      d_last_goal = d_goal;
      d_goal = metric(next, goal);
    }
  }
  return tree_.add(last, near);
}

bool SingleAxisTreePlanner::single_step() noexcept {
  const JointVector target = sample();
  const int near = nearest(target);
  JointVector next;
  if (select_input(tree_.node(near), target, next) < 0) return true;
  return tree_.add(next, near);
}

bool LimConPlanner::iterate() noexcept { return limited_connect(); }

bool GoalBiasedRrtPlanner::iterate() noexcept { return single_step(); }

}  // namespace mgc::planning
