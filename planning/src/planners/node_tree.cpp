// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/node_tree.hpp"

#include <limits>

namespace mgc::planning {

void NodeTree::reset(std::size_t capacity) {
  nodes_.clear();
  parents_.clear();
  nodes_.reserve(capacity);
  parents_.reserve(capacity);
  capacity_ = capacity;
}

bool NodeTree::add(const JointVector& q, int parent) noexcept {
  if (nodes_.size() >= capacity_) return false;
  nodes_.push_back(q);
  parents_.push_back(parent);
  return true;
}

int NodeTree::nearest(const PlanningProblem& problem, const JointVector& q) const noexcept {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const double d = step_metric(*problem.model, problem.step, nodes_[i], q);
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(i);
    }
  }
  return best;
}

void NodeTree::append_root_to(int node, std::vector<JointVector>& out) const noexcept {
  const std::size_t first = out.size();
  for (int n = node; n >= 0; n = parents_[static_cast<std::size_t>(n)]) out.push_back(nodes_[static_cast<std::size_t>(n)]);
  // Walked leaf to root; turn that stretch round in place.
  for (std::size_t a = first, b = out.size(); a + 1 < b; ++a, --b) std::swap(out[a], out[b - 1]);
}

void NodeTree::trim(std::vector<unsigned char>& invalid, std::vector<int>& new_index) noexcept {
  const std::size_t n = nodes_.size();
  new_index.resize(n);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int p = parents_[i];
    // Parents precede children, so a parent's flag is final when its child is reached.
    if (p >= 0 && invalid[static_cast<std::size_t>(p)]) invalid[i] = 1;
    if (invalid[i]) {
      new_index[i] = -1;
      continue;
    }
    new_index[i] = static_cast<int>(kept);
    nodes_[kept] = nodes_[i];
    parents_[kept] = p < 0 ? -1 : new_index[static_cast<std::size_t>(p)];
    ++kept;
  }
  nodes_.resize(kept);
  parents_.resize(kept);
}

JointVector uniform_sample(const MachineModel& model, Random& random) noexcept {
  JointVector q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointSpec& j = model.joints()[static_cast<std::size_t>(i)];
    q[i] = random.uniform(j.position_min, j.position_max);
  }
  return q;
}

JointVector constrained_sample(const MachineModel& model, Random& random) noexcept {
  constexpr int kMaxDraws = 100;
  JointVector q = uniform_sample(model, random);
  for (int draw = 1; draw < kMaxDraws && !model.check_constraints(q).ok(); ++draw) q = uniform_sample(model, random);
  return q;
}

void join_trees(const NodeTree& start, int start_node, const NodeTree& goal, int goal_node, std::vector<JointVector>& path) noexcept {
  path.clear();
  start.append_root_to(start_node, path);
  for (int n = goal.parent(goal_node); n >= 0; n = goal.parent(n)) path.push_back(goal.node(n));
}

void export_trees(const NodeTree& start, const NodeTree& goal, std::vector<JointVector>& nodes, std::vector<int>& parents) {
  nodes = start.nodes();
  parents = start.parents();
  const int offset = static_cast<int>(nodes.size());
  for (std::size_t i = 0; i < goal.size(); ++i) {
    nodes.push_back(goal.nodes()[i]);
    const int p = goal.parents()[i];
    parents.push_back(p < 0 ? -1 : p + offset);
  }
}

}  // namespace mgc::planning
