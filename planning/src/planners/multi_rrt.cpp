// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/multi_rrt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mgc/planning/planners/node_tree.hpp"

namespace mgc::planning {
namespace {

constexpr int kPoolFull = -2;

}  // namespace

PlannerStatus MultiRrtPlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  random_.reseed(problem.seed);
  iterations_ = 0;
  smoothing_done_ = 0;
  shortcuts_ = 0;
  phase_ = Phase::Growing;
  checks_at_reset_ = problem.world->collision_checks();
  // An iteration adds at most one root, or per tree it joins the foot and the sample; joining k
  // trees merges k - 1 of them away, so over n iterations the joins number at most 2 n + 2.
  const std::size_t max_trees = static_cast<std::size_t>(problem.max_iterations) + 2;
  const std::size_t capacity = problem.node_capacity > 0
                                   ? static_cast<std::size_t>(problem.node_capacity)
                                   : 5 * static_cast<std::size_t>(problem.max_iterations) + 8;
  nodes_.clear();
  parents_.clear();
  tree_of_.clear();
  nodes_.reserve(capacity);
  parents_.reserve(capacity);
  tree_of_.reserve(capacity);
  scratch_.clear();
  scratch_.reserve(capacity);
  alive_.clear();
  alive_.reserve(max_trees);
  nearest_.assign(max_trees, Nearest{});
  joined_.assign(max_trees, -1);
  const std::size_t path_capacity = capacity + static_cast<std::size_t>(std::max(0, options_.smoothing_passes)) + 2;
  raw_path_.clear();
  raw_path_.reserve(path_capacity);
  path_.clear();
  path_.reserve(path_capacity);
  path_scratch_.clear();
  path_scratch_.reserve(path_capacity);
  trees_created_ = 0;

  if (!problem.world->validate(problem.start).valid()) return status_ = PlannerStatus::InvalidStart;
  if (!problem.world->validate(problem.goal).valid()) return status_ = PlannerStatus::InvalidGoal;
  if (capacity < 2) return status_ = PlannerStatus::PoolExhausted;
  // Tree 0 holds the start and tree 1 the goal (seed 004 Eqs. 10-11).
  (void)add_node(problem.start, -1, 0);
  (void)add_node(problem.goal, -1, 1);
  alive_.push_back(1);
  alive_.push_back(1);
  trees_created_ = 2;
  return status_ = PlannerStatus::Running;
}

int MultiRrtPlanner::trees_alive() const noexcept {
  return static_cast<int>(std::count(alive_.begin(), alive_.end(), char{1}));
}

PlannerStats MultiRrtPlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(nodes_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void MultiRrtPlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  nodes = nodes_;
  parents = parents_;
}

bool MultiRrtPlanner::valid_edge(const JointVector& a, const JointVector& b) noexcept {
  return problem_->world->validate_edge(a, b, problem_->step).valid();
}

int MultiRrtPlanner::add_node(const JointVector& q, int parent, int tree) noexcept {
  if (nodes_.size() >= nodes_.capacity()) return kPoolFull;
  nodes_.push_back(q);
  parents_.push_back(parent);
  tree_of_.push_back(tree);
  return static_cast<int>(nodes_.size()) - 1;
}

bool MultiRrtPlanner::draw_sample(JointVector& q) noexcept {
  // Seed 004 Step 1: repeat RandomConfig() until it is feasible.
  for (int draw = 0; draw < options_.max_sample_draws; ++draw) {
    q = uniform_sample(*problem_->model, random_);
    if (problem_->world->validate(q).valid()) return true;
  }
  return false;
}

int MultiRrtPlanner::connect(const JointVector& q, int t, const Nearest& near) noexcept {
  if (near.t < 0.0) {
    if (!valid_edge(nodes_[static_cast<std::size_t>(near.node)], q)) return -1;
    return add_node(q, near.node, t);
  }
  const int child = near.node;
  const int parent = parents_[static_cast<std::size_t>(child)];
  const JointVector foot =
      problem_->model->interpolate(nodes_[static_cast<std::size_t>(child)], nodes_[static_cast<std::size_t>(parent)], near.t);
  // The foot becomes a node and parent -> foot an edge of its own: both are checked as they will
  // stand on a path, not only as part of the edge they came from.
  if (!problem_->world->validate(foot).valid() || !valid_edge(foot, q) ||
      !valid_edge(nodes_[static_cast<std::size_t>(parent)], foot)) {
    return -1;
  }
  // Seed 004 Eqs. 24-27: the foot hangs off the edge's parent, the sample off the foot.
  const int h = add_node(foot, parent, t);
  if (h < 0) return h;
  return add_node(q, h, t);
}

void MultiRrtPlanner::merge(int into_tree, int into_node, int from_tree, int from_node) noexcept {
  // Fig. 9: the branch from the sample's copy up to the old root turns round, and the copy hangs
  // off the sample's node in the surviving tree.
  scratch_.clear();
  for (int n = from_node; n >= 0; n = parents_[static_cast<std::size_t>(n)]) scratch_.push_back(n);
  for (std::size_t k = scratch_.size(); k-- > 1;) parents_[static_cast<std::size_t>(scratch_[k])] = scratch_[k - 1];
  parents_[static_cast<std::size_t>(from_node)] = into_node;
  for (int& tree : tree_of_) {
    if (tree == from_tree) tree = into_tree;
  }
  alive_[static_cast<std::size_t>(from_tree)] = 0;
}

bool MultiRrtPlanner::grow_once() noexcept {
  JointVector q;
  if (!draw_sample(q)) return true;
  const MachineModel& model = *problem_->model;
  const JointVector& step = problem_->step;
  const int dof = model.dof();
  const auto trees = static_cast<std::size_t>(trees_created_);
  for (std::size_t t = 0; t < trees; ++t) nearest_[t] = {std::numeric_limits<double>::infinity(), -1, -1.0};

  // Step 2, every tree in one pass over the pool: the nearest node, and the nearest foot of a
  // perpendicular that falls inside its edge (Eq. 17 divided by |E|^2, note 004 §4.3), in the
  // step metric's scaled coordinates.
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const auto t = static_cast<std::size_t>(tree_of_[i]);
    Nearest& best = nearest_[t];
    const JointVector v = model.difference(nodes_[i], q);
    double vv = 0.0;
    for (int j = 0; j < dof; ++j) vv += (v[j] / step[j]) * (v[j] / step[j]);
    if (std::sqrt(vv) < best.distance) best = {std::sqrt(vv), static_cast<int>(i), -1.0};
    const int parent = parents_[i];
    if (!options_.nearest_edge || parent < 0) continue;
    const JointVector e = model.difference(nodes_[i], nodes_[static_cast<std::size_t>(parent)]);
    double ee = 0.0;
    double ev = 0.0;
    for (int j = 0; j < dof; ++j) {
      ee += (e[j] / step[j]) * (e[j] / step[j]);
      ev += (e[j] / step[j]) * (v[j] / step[j]);
    }
    if (!(ee > 0.0)) continue;
    const double s = ev / ee;
    // A foot on the edge's extension is no point of the tree (Eq. 18).
    if (!(s > 0.0 && s < 1.0)) continue;
    const double d = std::sqrt(std::max(0.0, vv - s * ev));
    if (d < best.distance) best = {d, static_cast<int>(i), s};
  }

  // Step 3: try every tree.
  int first = -1;
  int joined = 0;
  for (std::size_t t = 0; t < trees; ++t) {
    joined_[t] = -1;
    if (!alive_[t] || nearest_[t].node < 0) continue;
    const int node = connect(q, static_cast<int>(t), nearest_[t]);
    if (node == kPoolFull) return false;
    if (node < 0) continue;
    joined_[t] = node;
    ++joined;
    if (first < 0) first = static_cast<int>(t);
  }
  if (joined == 0) {
    // Step 3, no tree reached: the sample roots a new one.
    const int tree = trees_created_;
    if (add_node(q, -1, tree) < 0) return false;
    alive_.push_back(1);
    ++trees_created_;
    return true;
  }
  // Step 4: the oldest joined tree absorbs the others, so tree 0 keeps the start as its root.
  for (std::size_t t = static_cast<std::size_t>(first) + 1; t < trees; ++t) {
    if (joined_[t] >= 0) merge(first, joined_[static_cast<std::size_t>(first)], static_cast<int>(t), joined_[t]);
  }
  return true;
}

void MultiRrtPlanner::extract_path() noexcept {
  // Step 5: from the goal back to the start, then turned round; a merge leaves the sample twice
  // (once per tree), joined by an empty edge, which the path drops.
  raw_path_.clear();
  for (int n = 1; n >= 0; n = parents_[static_cast<std::size_t>(n)]) {
    const JointVector& q = nodes_[static_cast<std::size_t>(n)];
    if (raw_path_.empty() || raw_path_.back() != q) raw_path_.push_back(q);
  }
  std::reverse(raw_path_.begin(), raw_path_.end());
  path_ = raw_path_;
}

void MultiRrtPlanner::smooth_once() noexcept {
  const auto edges = static_cast<int>(path_.size()) - 1;
  if (edges < 2) return;
  // Fig. 8: two different edges, a random point inside each, joined straight when the joint
  // is valid; the points become path nodes.
  const int first = static_cast<int>(random_.uniform() * edges);
  const int other = (first + 1 + static_cast<int>(random_.uniform() * (edges - 1))) % edges;
  const int a = std::min(first, other);
  const int b = std::max(first, other);
  const MachineModel& model = *problem_->model;
  const auto ua = static_cast<std::size_t>(a);
  const auto ub = static_cast<std::size_t>(b);
  const JointVector pa = model.interpolate(path_[ua], path_[ua + 1], random_.uniform());
  const JointVector pb = model.interpolate(path_[ub], path_[ub + 1], random_.uniform());
  // The shortcut first (it fails most), then the two stubs left of the cut edges.
  if (!valid_edge(pa, pb) || !valid_edge(path_[ua], pa) || !valid_edge(pb, path_[ub + 1])) return;
  path_scratch_.clear();
  const auto push = [&](const JointVector& q) {
    if (path_scratch_.empty() || path_scratch_.back() != q) path_scratch_.push_back(q);
  };
  for (std::size_t i = 0; i <= ua; ++i) push(path_[i]);
  push(pa);
  push(pb);
  for (std::size_t i = ub + 1; i < path_.size(); ++i) push(path_[i]);
  path_.swap(path_scratch_);
  ++shortcuts_;
}

PlannerStatus MultiRrtPlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  if (phase_ == Phase::Growing) {
    for (int k = 0; k < iteration_budget; ++k) {
      if (iterations_ >= problem_->max_iterations) return status_ = PlannerStatus::IterationLimit;
      ++iterations_;
      if (!grow_once()) return status_ = PlannerStatus::PoolExhausted;
      if (tree_of_[0] == tree_of_[1]) {
        extract_path();
        phase_ = Phase::Smoothing;
        break;
      }
    }
    // The slice in which the trees meet ends here: growth and smoothing are timed apart.
    if (phase_ == Phase::Growing || options_.smoothing_passes > 0) return status_;
  } else {
    for (int k = 0; k < iteration_budget && smoothing_done_ < options_.smoothing_passes; ++k) {
      smooth_once();
      ++smoothing_done_;
    }
  }
  if (smoothing_done_ >= options_.smoothing_passes) {
    phase_ = Phase::Done;
    status_ = PlannerStatus::Solved;
  }
  return status_;
}

}  // namespace mgc::planning
