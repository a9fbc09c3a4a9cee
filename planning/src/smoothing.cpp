// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/smoothing.hpp"

#include <algorithm>

#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {
namespace {

// Drops a node between two edges that move the same single joint: the merged edge covers the
// same joint interval or part of it, and is re-validated all the same.
void merge_single_joint_runs(CollisionWorld& world, std::vector<JointVector>& path, const JointVector& step) {
  const MachineModel& model = world.model();
  for (std::size_t i = 1; i + 1 < path.size();) {
    const int a = moving_joint(model, path[i - 1], path[i]);
    const int b = moving_joint(model, path[i], path[i + 1]);
    if (a >= 0 && a == b && world.validate_edge(path[i - 1], path[i + 1], step).valid()) {
      path.erase(path.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
  // A node equal to its predecessor adds nothing.
  for (std::size_t i = 1; i < path.size();) {
    if (moving_joint(model, path[i - 1], path[i]) == -1 && path.size() > 2) {
      path.erase(path.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
}

// From path[i] to path[k] one joint at a time, in the order the joints first move along the
// stretch it replaces. Empty if any move is invalid.
std::vector<JointVector> staircase(CollisionWorld& world, const std::vector<JointVector>& path, std::size_t i,
                                   std::size_t k, const JointVector& step) {
  const MachineModel& model = world.model();
  std::vector<int> order;
  for (std::size_t e = i; e < k; ++e) {
    const JointVector d = model.difference(path[e], path[e + 1]);
    for (int j = 0; j < model.dof(); ++j) {
      if (d[j] != 0.0 && std::find(order.begin(), order.end(), j) == order.end()) order.push_back(j);
    }
  }
  std::vector<JointVector> out;
  JointVector current = path[i];
  for (int j : order) {
    if (current[j] == path[k][j]) continue;
    JointVector next = current;
    next[j] = path[k][j];
    if (!world.validate_edge(current, next, step).valid()) return {};
    out.push_back(next);
    current = next;
  }
  return out;
}

}  // namespace

std::vector<JointVector> smooth_path(CollisionWorld& world, const std::vector<JointVector>& path, const JointVector& step,
                                     const SmoothingOptions& options) {
  std::vector<JointVector> out = path;
  if (out.size() < 3) return out;
  if (options.single_axis) merge_single_joint_runs(world, out, step);
  Random random(options.seed);
  for (int attempt = 0; attempt < options.shortcut_attempts && out.size() >= 3; ++attempt) {
    auto i = static_cast<std::size_t>(random.uniform() * static_cast<double>(out.size() - 2));
    auto k = static_cast<std::size_t>(random.uniform() * static_cast<double>(out.size() - i - 2)) + i + 2;
    k = std::min(k, out.size() - 1);
    if (k < i + 2) continue;
    std::vector<JointVector> replacement;
    if (options.single_axis) {
      replacement = staircase(world, out, i, k, step);
      // Fewer edges than the stretch replaced: k - i edges become replacement.size().
      if (replacement.empty() || replacement.size() >= k - i) continue;
    } else {
      if (!world.validate_edge(out[i], out[k], step).valid()) continue;
      replacement = {out[k]};
    }
    // out[k] is the staircase's last node; keep one copy of it.
    out.erase(out.begin() + static_cast<std::ptrdiff_t>(i + 1), out.begin() + static_cast<std::ptrdiff_t>(k + 1));
    out.insert(out.begin() + static_cast<std::ptrdiff_t>(i + 1), replacement.begin(), replacement.end());
    if (options.single_axis) merge_single_joint_runs(world, out, step);
  }
  return out;
}

}  // namespace mgc::planning
