// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/axis_connect.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mgc/planning/path_metrics.hpp"

namespace mgc::planning {
namespace {

//! Joint j of q moved by delta, wrapped for a continuous joint. [rad | m]
double moved_value(const MachineModel& model, const JointVector& q, int j, double delta) noexcept {
  const double v = q[j] + delta;
  return model.joints()[static_cast<std::size_t>(j)].continuous ? wrap_angle(v) : v;
}

}  // namespace

AxisConnectPlanner::AxisConnectPlanner(int max_orders, bool shorten) : max_orders_(std::max(max_orders, 1)), shorten_(shorten) {}

PlannerStatus AxisConnectPlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  random_.reseed(problem.seed);
  iterations_ = 0;
  shortening_ = false;
  shortening_chunks_ = 0;
  start_tree_grows_first_ = true;
  checks_at_reset_ = problem.world->collision_checks();
  path_.clear();
  long_way_.clear();
  const int dof = problem.model->dof();
  // An iteration adds at most two corners per joint to a tree (a move and its second pass); the
  // direct staircase of the first one, one per joint.
  const auto per_iteration = static_cast<std::size_t>(2 * dof);
  const auto capacity = problem.node_capacity > 0
                            ? static_cast<std::size_t>(problem.node_capacity)
                            : static_cast<std::size_t>(problem.max_iterations) * per_iteration + static_cast<std::size_t>(dof) + 1;
  start_tree_.reset(capacity);
  goal_tree_.reset(capacity);
  path_.reserve(2 * capacity);
  // The long way round: its halfway node and, at most, a stair per joint before and after it.
  long_way_.reserve(static_cast<std::size_t>(2 * dof + 2));
  for (JointVector& s : stairs_) s = JointVector::Zero(dof);
  // The shortener holds the joined path and the stairs it puts in; a path longer than this (it
  // has never come near) is kept as it is.
  constexpr std::size_t kMaxShortenedNodes = 1024;
  const std::size_t shortener_capacity = std::min(2 * capacity, kMaxShortenedNodes);
  if (shorten_ && (!shortener_ || shortener_capacity_ < shortener_capacity)) {
    shortener_capacity_ = shortener_capacity;
    shortener_.emplace(dof, shortener_capacity_, kShortenerChunkM, kShortenerOrders);
  }

  if (!problem.world->validate(problem.start).valid()) return status_ = PlannerStatus::InvalidStart;
  if (!problem.world->validate(problem.goal).valid()) return status_ = PlannerStatus::InvalidGoal;
  if (!start_tree_.add(problem.start, -1) || !goal_tree_.add(problem.goal, -1)) return status_ = PlannerStatus::PoolExhausted;
  return status_ = PlannerStatus::Running;
}

PlannerStats AxisConnectPlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(start_tree_.size() + goal_tree_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void AxisConnectPlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  export_trees(start_tree_, goal_tree_, nodes, parents);
}

AxisConnectPlanner::Move AxisConnectPlanner::move_joint(const JointVector& from, int joint, double value,
                                                        JointVector& reached) noexcept {
  const MachineModel& model = *problem_->model;
  reached = from;
  reached[joint] = value;
  const double d = model.difference(from, reached)[joint];
  if (d == 0.0) return Move::None;
  JointVector at;
  if (problem_->world->validate_edge(from, reached, problem_->step, &at).valid()) return Move::Full;
  // Back off one step from the first invalid sample; the shorter edge is sampled afresh.
  const double to_invalid = model.difference(from, at)[joint];
  const double back = to_invalid - std::copysign(problem_->step[joint], d);
  if (back * d <= 0.0) return Move::None;
  reached[joint] = moved_value(model, from, joint, back);
  return problem_->world->edge_valid(from, reached, problem_->step) ? Move::Partial : Move::None;
}

AxisConnectPlanner::Growth AxisConnectPlanner::extend(NodeTree& tree, int from, const JointVector& target,
                                                      const std::array<int, kMaxJoints>& order, int& last) noexcept {
  const int dof = problem_->model->dof();
  last = from;
  JointVector q = tree.node(from);
  JointVector next;
  bool moved = false;
  // A joint stopped by an obstacle may pass once the others have moved: one more pass for those.
  for (int pass = 0; pass < 2; ++pass) {
    bool short_of_target = false;
    bool moved_this_pass = false;
    for (int k = 0; k < dof; ++k) {
      const int j = order[static_cast<std::size_t>(k)];
      if (q[j] == target[j]) continue;
      const Move m = move_joint(q, j, target[j], next);
      if (m != Move::Full) short_of_target = true;
      if (m == Move::None) continue;
      if (!tree.add(next, last)) return Growth::PoolFull;
      last = static_cast<int>(tree.size()) - 1;
      q = next;
      moved = moved_this_pass = true;
    }
    if (!short_of_target) return Growth::Reached;
    if (!moved_this_pass) break;
  }
  return moved ? Growth::Advanced : Growth::Trapped;
}

AxisConnectPlanner::Growth AxisConnectPlanner::connect_exact(NodeTree& tree, int from, const JointVector& target,
                                                             int& last) noexcept {
  const MachineModel& model = *problem_->model;
  const int dof = model.dof();
  last = from;
  const JointVector& q = tree.node(from);
  // The joints to move, the largest move (in steps) first.
  std::array<int, kMaxJoints> base{};
  std::array<double, kMaxJoints> size{};
  int count = 0;
  const JointVector d = model.difference(q, target);
  for (int j = 0; j < dof; ++j) {
    if (q[j] == target[j]) continue;
    const double s = std::abs(d[j]) / problem_->step[j];
    int at = count++;
    for (; at > 0 && size[static_cast<std::size_t>(at - 1)] < s; --at) {
      base[static_cast<std::size_t>(at)] = base[static_cast<std::size_t>(at - 1)];
      size[static_cast<std::size_t>(at)] = size[static_cast<std::size_t>(at - 1)];
    }
    base[static_cast<std::size_t>(at)] = j;
    size[static_cast<std::size_t>(at)] = s;
  }
  if (count == 0) return Growth::Reached;

  std::array<int, kMaxJoints> perm{};
  for (int s = 0; s < count; ++s) perm[static_cast<std::size_t>(s)] = s;
  stairs_[0] = q;
  int validated = 0;  // stairs of the current order known valid
  for (int tried = 1;; ++tried) {
    int blocked = -1;
    for (int s = validated; s < count; ++s) {
      const auto k = static_cast<std::size_t>(s);
      stairs_[k + 1] = stairs_[k];
      stairs_[k + 1][base[static_cast<std::size_t>(perm[k])]] = target[base[static_cast<std::size_t>(perm[k])]];
      if (!problem_->world->edge_valid(stairs_[k], stairs_[k + 1], problem_->step)) {
        blocked = s;
        break;
      }
      validated = s + 1;
    }
    if (blocked < 0) break;
    if (tried >= max_orders_) return Growth::Trapped;
    // Every order that begins as this one up to the blocked stair is blocked there too: the
    // lexicographically last of them comes next, then the next permutation leaves that prefix.
    const auto begin = perm.begin();
    const auto end = perm.begin() + count;
    // Descending by insertion: n <= 8, and std::sort's introsort here trips GCC 12's
    // -Warray-bounds at -O3.
    for (int a = blocked + 2; a < count; ++a) {
      const int v = perm[static_cast<std::size_t>(a)];
      int b = a;
      for (; b > blocked + 1 && perm[static_cast<std::size_t>(b - 1)] < v; --b) perm[static_cast<std::size_t>(b)] = perm[static_cast<std::size_t>(b - 1)];
      perm[static_cast<std::size_t>(b)] = v;
    }
    const std::array<int, kMaxJoints> before = perm;
    if (!std::next_permutation(begin, end)) return Growth::Trapped;
    int same = 0;
    while (same < count && perm[static_cast<std::size_t>(same)] == before[static_cast<std::size_t>(same)]) ++same;
    validated = std::min(validated, same);
  }
  for (int s = 1; s <= count; ++s) {
    if (!tree.add(stairs_[static_cast<std::size_t>(s)], last)) return Growth::PoolFull;
    last = static_cast<int>(tree.size()) - 1;
  }
  return Growth::Reached;
}

double AxisConnectPlanner::staircase_time_s(const JointVector& from, const JointVector& to) const noexcept {
  const MachineModel& model = *problem_->model;
  const JointVector d = model.difference(from, to);
  double t_s = 0.0;
  for (int j = 0; j < model.dof(); ++j) t_s += std::abs(d[j]) / model.joints()[static_cast<std::size_t>(j)].max_velocity;
  return t_s;
}

AxisConnectPlanner::Growth AxisConnectPlanner::connect_long_way(int& last, bool& at_once) noexcept {
  const MachineModel& model = *problem_->model;
  const JointVector& start = problem_->start;
  const JointVector& goal = problem_->goal;
  const double short_way_s = staircase_time_s(start, goal);
  const JointVector d = model.difference(start, goal);
  for (int c = 0; c < model.dof(); ++c) {
    const auto& joint = model.joints()[static_cast<std::size_t>(c)];
    if (!joint.continuous || d[c] == 0.0) continue;
    const double long_arc = d[c] > 0.0 ? d[c] - 2.0 * std::numbers::pi : d[c] + 2.0 * std::numbers::pi;
    const double long_way_s = short_way_s + (std::abs(long_arc) - std::abs(d[c])) / joint.max_velocity;
    at_once = long_way_s <= kLongWayFactor * short_way_s;
    const double halfway = wrap_angle(start[c] + 0.5 * long_arc);
    // Half the long arc first and then the staircase to the goal, or the staircase to the goal's
    // other joints with half the arc and then the second half.
    for (int side = 0; side < 2; ++side) {
      JointVector via = side == 0 ? start : goal;
      via[c] = halfway;
      int first = -1;
      Growth g = connect_exact(start_tree_, 0, via, first);
      if (g == Growth::PoolFull) return g;
      if (g != Growth::Reached) continue;
      g = connect_exact(start_tree_, first, goal, last);
      if (g != Growth::Trapped) return g;
    }
  }
  return Growth::Trapped;
}

void AxisConnectPlanner::shuffle(std::array<int, kMaxJoints>& order) noexcept {
  const int dof = problem_->model->dof();
  for (int j = 0; j < dof; ++j) order[static_cast<std::size_t>(j)] = j;
  for (int j = dof - 1; j > 0; --j) {
    const auto k = static_cast<int>(random_.uniform() * (j + 1));
    std::swap(order[static_cast<std::size_t>(j)], order[static_cast<std::size_t>(std::min(k, j))]);
  }
}

void AxisConnectPlanner::join(int start_node, int goal_node) noexcept {
  join_trees(start_tree_, start_node, goal_tree_, goal_node, path_);
}

void AxisConnectPlanner::merge_collinear() noexcept {
  const MachineModel& model = *problem_->model;
  std::size_t kept = 1;
  for (std::size_t i = 1; i < path_.size(); ++i) {
    const JointVector& q = path_[i];
    const int j = moving_joint(model, path_[kept - 1], q);
    if (j == -1) {
      // An edge that moves nothing: the later node stands for both (the goal stays exact), but
      // the start is kept as given.
      if (kept >= 2) path_[kept - 1] = q;
      continue;
    }
    if (kept >= 2 && j >= 0 && moving_joint(model, path_[kept - 2], path_[kept - 1]) == j) {
      // Both edges move joint j only: unless the merged edge goes round the other way, it lies
      // within the two edges already validated.
      const double a = model.difference(path_[kept - 2], path_[kept - 1])[j];
      const double b = model.difference(path_[kept - 1], q)[j];
      const double ab = model.difference(path_[kept - 2], q)[j];
      if (std::abs(ab - (a + b)) <= 1e-12 * (1.0 + std::abs(a) + std::abs(b))) {
        if (ab == 0.0) {
          // There and back: the node before stands for all three.
          --kept;
          if (kept >= 2) path_[kept - 1] = q;
        } else {
          path_[kept - 1] = q;
        }
        continue;
      }
    }
    path_[kept++] = q;
  }
  path_.resize(kept);
}

double AxisConnectPlanner::path_time_s(const std::vector<JointVector>& path) const noexcept {
  double t_s = 0.0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) t_s += staircase_time_s(path[i], path[i + 1]);
  return t_s;
}

PlannerStatus AxisConnectPlanner::solved() noexcept {
  if (!long_way_.empty() && path_time_s(long_way_) < path_time_s(path_)) path_ = long_way_;
  return status_ = PlannerStatus::Solved;
}

PlannerStatus AxisConnectPlanner::finish_join() noexcept {
  merge_collinear();
  if (!shorten_ || path_.size() < 3) return solved();
  if (shortener_->begin(*problem_->world, nullptr, path_, problem_->step, 0, true) != PathShortener::Status::Running) {
    return solved();
  }
  shortening_ = true;
  return status_ = PlannerStatus::Running;
}

PlannerStatus AxisConnectPlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  if (shortening_) {
    // One iteration's worth of budget buys a few staircase chunks of the shortener.
    constexpr int kChunksPerIteration = 8;
    const PathShortener::Status s = shortener_->step(std::max(iteration_budget, 1) * kChunksPerIteration);
    if (s == PathShortener::Status::Running) return status_;
    shortening_ = false;
    shortening_chunks_ = shortener_->chunks();
    path_.clear();
    for (std::size_t i = 0; i < shortener_->size(); ++i) path_.push_back((*shortener_)[i]);
    merge_collinear();
    return solved();
  }
  std::array<int, kMaxJoints> order{};
  for (int k = 0; k < iteration_budget; ++k) {
    if (iterations_ >= problem_->max_iterations) {
      // The long way round kept from the first iteration is a valid answer.
      if (long_way_.empty()) return status_ = PlannerStatus::IterationLimit;
      path_ = long_way_;
      return status_ = PlannerStatus::Solved;
    }
    ++iterations_;
    if (iterations_ == 1) {
      // The direct staircase first: an open site needs no tree.
      int last = -1;
      const Growth g = connect_exact(start_tree_, 0, problem_->goal, last);
      if (g == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
      if (g == Growth::Reached) {
        join(last, 0);
        return finish_join();
      }
      if (g == Growth::Trapped) {
        bool at_once = false;
        const Growth gl = connect_long_way(last, at_once);
        if (gl == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
        if (gl == Growth::Reached) {
          join(last, 0);
          if (at_once) return finish_join();
          // Kept to compare with what the search finds the short way.
          merge_collinear();
          long_way_ = path_;
          path_.clear();
        }
      }
      continue;
    }
    NodeTree& a = start_tree_grows_first_ ? start_tree_ : goal_tree_;
    NodeTree& b = start_tree_grows_first_ ? goal_tree_ : start_tree_;
    const JointVector target = constrained_sample(*problem_->model, random_);
    shuffle(order);
    int a_new = -1;
    const Growth ga = extend(a, a.nearest(*problem_, target), target, order, a_new);
    if (ga == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
    if (ga != Growth::Trapped) {
      const JointVector meeting = a.node(a_new);
      const int b_near = b.nearest(*problem_, meeting);
      int b_new = -1;
      Growth gb = connect_exact(b, b_near, meeting, b_new);
      if (gb == Growth::Trapped) {
        shuffle(order);
        gb = extend(b, b_near, meeting, order, b_new);
      }
      if (gb == Growth::PoolFull) return status_ = PlannerStatus::PoolExhausted;
      if (gb == Growth::Reached) {
        if (start_tree_grows_first_) {
          join(a_new, b_new);
        } else {
          join(b_new, a_new);
        }
        return finish_join();
      }
    }
    start_tree_grows_first_ = !start_tree_grows_first_;
  }
  return status_;
}

}  // namespace mgc::planning
