// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/bidirectional.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "mgc/planning/path_metrics.hpp"

namespace mgc::planning {

BidirectionalPlanner::BidirectionalPlanner(Variant variant, double gamma, int candidates)
    : variant_(variant), gamma_(gamma), candidates_(candidates) {}

std::string_view BidirectionalPlanner::name() const noexcept {
  switch (variant_) {
    case Variant::ExtExt: return "rrt-ext-ext";
    case Variant::ExtCon: return "rrt-ext-con";
    case Variant::ConCon: return "rrt-connect";
    case Variant::ConConMod: return "con-con-mod";
  }
  return "bidirectional";
}

PlannerStatus BidirectionalPlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  random_.reseed(problem.seed);
  iterations_ = 0;
  start_tree_grows_first_ = true;
  checks_at_reset_ = problem.world->collision_checks();
  path_.clear();
  // A Connect adds at most (longest possible edge / epsilon) + 1 nodes: size each tree for that
  // many per round unless told otherwise.
  const MachineModel& model = *problem.model;
  double span_sq = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    const JointSpec& j = model.joints()[static_cast<std::size_t>(i)];
    const double span = (j.continuous ? std::numbers::pi : j.range()) / problem.step[i];
    span_sq += span * span;
  }
  const double per_round = std::ceil(std::sqrt(span_sq) / problem.extend_steps) + 1.0;
  constexpr double kMaxDefaultNodes = 1 << 18;
  const auto capacity = static_cast<std::size_t>(
      problem.node_capacity > 0 ? problem.node_capacity
                                : std::min(kMaxDefaultNodes, (problem.max_iterations + 1.0) * per_round));
  start_tree_.reset(capacity);
  goal_tree_.reset(capacity);
  path_.reserve(2 * capacity);

  if (!problem.world->validate(problem.start).valid()) return status_ = PlannerStatus::InvalidStart;
  if (!problem.world->validate(problem.goal).valid()) return status_ = PlannerStatus::InvalidGoal;
  if (!start_tree_.add(problem.start, -1) || !goal_tree_.add(problem.goal, -1)) {
    return status_ = PlannerStatus::PoolExhausted;
  }
  return status_ = PlannerStatus::Running;
}

PlannerStats BidirectionalPlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(start_tree_.size() + goal_tree_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void BidirectionalPlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  export_trees(start_tree_, goal_tree_, nodes, parents);
}

BidirectionalPlanner::Growth BidirectionalPlanner::extend(NodeTree& tree, const JointVector& target, int& added) noexcept {
  const int near = tree.nearest(*problem_, target);
  const JointVector& from = tree.node(near);
  const double d = step_metric(*problem_->model, problem_->step, from, target);
  if (d == 0.0) {
    added = near;
    return Growth::Reached;
  }
  const bool reaches = d <= problem_->extend_steps;
  const JointVector next = reaches ? target : problem_->model->interpolate(from, target, problem_->extend_steps / d);
  if (!problem_->world->validate_edge(from, next, problem_->step).valid()) return Growth::Trapped;
  if (!tree.add(next, near)) return Growth::PoolFull;
  added = static_cast<int>(tree.size()) - 1;
  return reaches ? Growth::Reached : Growth::Advanced;
}

BidirectionalPlanner::Growth BidirectionalPlanner::connect(NodeTree& tree, const JointVector& target, int& added) noexcept {
  Growth g = Growth::Advanced;
  while (g == Growth::Advanced) g = extend(tree, target, added);
  return g;
}

BidirectionalPlanner::Growth BidirectionalPlanner::grow(NodeTree& tree, const JointVector& target, bool use_connect,
                                                        int& added) noexcept {
  return use_connect ? connect(tree, target, added) : extend(tree, target, added);
}

double BidirectionalPlanner::roughness(const JointVector& a, const JointVector& b) const noexcept {
  return normalized_distance(*problem_->model, a, b, false);
}

JointVector BidirectionalPlanner::better_sample() noexcept {
  const double r0 = roughness(problem_->start, problem_->goal);
  double best = std::numeric_limits<double>::infinity();
  JointVector best_q = problem_->start;
  for (int k = 0; k < candidates_; ++k) {
    const JointVector q = constrained_sample(*problem_->model, random_);
    const double r = roughness(q, problem_->start) + roughness(q, problem_->goal);
    if (r <= gamma_ * r0) return q;
    // Fig. 5 never lowers its running minimum (note 000 §4.4); the text means the minimum.
    if (r <= best) {
      best = r;
      best_q = q;
    }
  }
  return best_q;
}

void BidirectionalPlanner::join(int start_node, int goal_node) noexcept {
  join_trees(start_tree_, start_node, goal_tree_, goal_node, path_);
}

PlannerStatus BidirectionalPlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  const bool first_connects = variant_ == Variant::ConCon || variant_ == Variant::ConConMod;
  const bool second_connects = variant_ != Variant::ExtExt;
  for (int k = 0; k < iteration_budget; ++k) {
    if (iterations_ >= problem_->max_iterations) return status_ = PlannerStatus::IterationLimit;
    ++iterations_;
    NodeTree& a = start_tree_grows_first_ ? start_tree_ : goal_tree_;
    NodeTree& b = start_tree_grows_first_ ? goal_tree_ : start_tree_;
    const JointVector target = variant_ == Variant::ConConMod ? better_sample() : constrained_sample(*problem_->model, random_);
    int a_new = -1;
    const Growth ga = grow(a, target, first_connects, a_new);
    if (ga == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
    // Kuffner & LaValle (and seed 000's Fig. 5): the second tree tries only when the first was
    // not trapped, i.e. an Extend advanced or a Connect reached its sample.
    if (ga != Growth::Trapped) {
      const JointVector meeting = a.node(a_new);
      int b_new = -1;
      const Growth gb = grow(b, meeting, second_connects, b_new);
      if (gb == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
      if (gb == Growth::Reached) {
        if (start_tree_grows_first_) {
          join(a_new, b_new);
        } else {
          join(b_new, a_new);
        }
        return status_ = PlannerStatus::Solved;
      }
    }
    start_tree_grows_first_ = !start_tree_grows_first_;
  }
  return status_;
}

}  // namespace mgc::planning
