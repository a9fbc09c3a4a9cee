// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/nonuniform.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mgc/planning/excavator.hpp"

namespace mgc::planning {

namespace {
// Start and goal share a held value when they differ by less than this. [rad]
constexpr double kHoldTolerance_rad = 1e-9;
}  // namespace

const char* to_string(ExcavatorSubtask subtask) noexcept {
  switch (subtask) {
    case ExcavatorSubtask::Any: return "any";
    case ExcavatorSubtask::MoveToDump: return "move_to_dump";
    case ExcavatorSubtask::Dump: return "dump";
    case ExcavatorSubtask::Return: return "return";
  }
  return "unknown";
}

double NonUniformRrtPlanner::beta_sample(double mean, double uniform) noexcept {
  // Note 003 §2.2: mean e above 1/2 -> Beta(e / (1 - e), 1), x = U^(1/alpha); below ->
  // Beta(1, (1 - e) / e), x = 1 - U^(1/beta); at 1/2, uniform.
  if (mean > 0.5) return std::pow(uniform, (1.0 - mean) / mean);
  if (mean < 0.5) return 1.0 - std::pow(uniform, mean / (1.0 - mean));
  return uniform;
}

PlannerStatus NonUniformRrtPlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  random_.reseed(problem.seed);
  iterations_ = 0;
  checks_at_reset_ = problem.world->collision_checks();
  path_.clear();
  const auto capacity = static_cast<std::size_t>(problem.node_capacity > 0 ? problem.node_capacity : problem.max_iterations + 1);
  tree_.reset(capacity);
  path_.reserve(capacity + 1);

  const MachineModel& model = *problem.model;
  // A goal exactly on a limit would need an infinite shape parameter (note 003).
  constexpr double kMeanMargin = 0.01;
  for (int i = 0; i < model.dof(); ++i) {
    const JointSpec& j = model.joints()[static_cast<std::size_t>(i)];
    const auto k = static_cast<std::size_t>(i);
    double goal = problem.goal[i];
    if (j.continuous) {
      lower_[k] = problem.start[i] - std::numbers::pi;
      upper_[k] = problem.start[i] + std::numbers::pi;
      goal = problem.start[i] + shorter_turn(problem.goal[i] - problem.start[i]);
    } else {
      lower_[k] = j.position_min;
      upper_[k] = j.position_max;
    }
    mean_[k] = uniform_ ? 0.5 : std::clamp((goal - lower_[k]) / (upper_[k] - lower_[k]), kMeanMargin, 1.0 - kMeanMargin);
  }
  held_.fill(false);
  hold_bucket_ = false;
  try_straight_ = false;
  // Whether start and goal keep what the subtask must hold; a subtask is an excavator's.
  bool holds_kept = subtask_ == ExcavatorSubtask::Any;
  if (model.kind() == MachineKind::Excavator && !uniform_) {
    const double psi_start = bucket_ground_angle_rad(problem.start);
    const bool same_psi = std::abs(wrap_angle(psi_start - bucket_ground_angle_rad(problem.goal))) < kHoldTolerance_rad;
    const auto same = [&](int joint) {
      return std::abs(model.difference(problem.start, problem.goal)[joint]) < kHoldTolerance_rad;
    };
    bucket_ground_angle_rad_ = psi_start;
    switch (subtask_) {
      case ExcavatorSubtask::Any: hold_bucket_ = same_psi; break;
      case ExcavatorSubtask::MoveToDump:
        hold_bucket_ = true;
        holds_kept = same_psi;
        break;
      case ExcavatorSubtask::Dump:
        held_[Excavator::kSwing] = true;
        held_[Excavator::kBoom] = true;
        holds_kept = same(Excavator::kSwing) && same(Excavator::kBoom);
        // Seed 003 plans the dump "parametrically": the straight line when it is free.
        try_straight_ = true;
        break;
      case ExcavatorSubtask::Return: holds_kept = true; break;
    }
  }
  if (hold_bucket_) held_[Excavator::kBucket] = true;

  if (!problem.world->validate(problem.start).valid()) return status_ = PlannerStatus::InvalidStart;
  if (!holds_kept || !problem.world->validate(problem.goal).valid()) return status_ = PlannerStatus::InvalidGoal;
  closest_to_goal_ = step_metric(model, problem.step, problem.start, problem.goal);
  if (!tree_.add(problem.start, -1)) return status_ = PlannerStatus::PoolExhausted;
  return status_ = PlannerStatus::Running;
}

PlannerStats NonUniformRrtPlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(tree_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void NonUniformRrtPlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  nodes = tree_.nodes();
  parents = tree_.parents();
}

JointVector NonUniformRrtPlanner::sample() noexcept {
  const MachineModel& model = *problem_->model;
  JointVector q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (held_[k]) {
      q[i] = problem_->start[i];
      continue;
    }
    q[i] = lower_[k] + beta_sample(mean_[k], random_.uniform()) * (upper_[k] - lower_[k]);
    if (model.joints()[k].continuous) q[i] = wrap_angle(q[i]);
  }
  if (hold_bucket_) {
    q[Excavator::kBucket] = bucket_ground_angle_rad_ - q[Excavator::kBoom] - q[Excavator::kArm];
  }
  return q;
}

bool NonUniformRrtPlanner::edge_valid(const JointVector& from, const JointVector& to) noexcept {
  // The far end alone first: most rejected extensions end inside an obstacle, and one check finds
  // that. Then the whole edge as validate_edge samples it (that end included again).
  CollisionWorld& world = *problem_->world;
  return world.validate(to).valid() && world.validate_edge(from, to, problem_->step).valid();
}

PlannerStatus NonUniformRrtPlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  const PlanningProblem& p = *problem_;
  const MachineModel& model = *p.model;
  for (int k = 0; k < iteration_budget; ++k) {
    if (iterations_ >= p.max_iterations) return status_ = PlannerStatus::IterationLimit;
    ++iterations_;
    if (try_straight_) {
      try_straight_ = false;
      if (p.world->validate_edge(p.start, p.goal, p.step).valid()) {
        path_.push_back(p.start);
        path_.push_back(p.goal);
        return status_ = PlannerStatus::Solved;
      }
      continue;
    }
    const JointVector target = sample();
    const int near = tree_.nearest(p, target);
    const JointVector& from = tree_.node(near);
    const double d = step_metric(model, p.step, from, target);
    if (d == 0.0) continue;
    // With the bucket held, bucket = psi - boom - arm is linear in the sampled joints, so the
    // straight edge keeps it held all along.
    const JointVector next = d <= p.extend_steps ? target : model.interpolate(from, target, p.extend_steps / d);
    if (!edge_valid(from, next)) continue;
    if (!tree_.add(next, near)) return status_ = PlannerStatus::PoolExhausted;
    const int added = static_cast<int>(tree_.size()) - 1;
    // Try the straight edge to the exact goal from a node within the goal tolerance, and from
    // the node closest to the goal so far: a goal in a narrow place (a bucket between pipelines)
    // may have no tree node within the tolerance long after a straight edge to it is free.
    const JointVector gap = model.difference(next, p.goal);
    bool close = true;
    for (int i = 0; i < model.dof() && close; ++i) close = std::abs(gap[i]) <= p.error_tolerance * p.extend_steps * p.step[i];
    const double to_goal = step_metric(model, p.step, next, p.goal);
    const bool closest = to_goal < closest_to_goal_;
    closest_to_goal_ = std::min(closest_to_goal_, to_goal);
    if ((close || closest) && p.world->validate_edge(next, p.goal, p.step).valid()) {
      path_.clear();
      tree_.append_root_to(added, path_);
      path_.push_back(p.goal);
      return status_ = PlannerStatus::Solved;
    }
  }
  return status_;
}

}  // namespace mgc::planning
