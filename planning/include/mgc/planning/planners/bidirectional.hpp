// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! Kuffner & LaValle's bidirectional RRT (the background of seed 000 §4.2-4.3) and seed 000's
//! RRT-Con-Con-Mod (§4.4). Two trees, rooted at start and goal, grow toward a sample in turn:
//! the first tree toward the sample, the second toward the first's new node; the roles swap every
//! round. Extend takes one straight joint-space step of at most `extend_steps` steps (in the step
//! metric) toward its target, the edge validated at step resolution; Connect repeats Extend until
//! it reaches the target or is trapped. Edges move several joints at once.
class BidirectionalPlanner final : public Planner {
 public:
  enum class Variant : std::uint8_t {
    ExtExt,     //!< both trees Extend
    ExtCon,     //!< the sampled tree Extends, the other Connects (the original RRT-Connect)
    ConCon,     //!< both Connect (seed 000's RRT-Con-Con)
    ConConMod,  //!< ConCon with seed 000's Choose-Better-Node sample filter (Eqs. 5-6)
  };

  //! gamma: Eq. 6's threshold multiplier; k: candidates per round (seed 000: 20).
  explicit BidirectionalPlanner(Variant variant, double gamma = 1.5, int candidates = 20);

  [[nodiscard]] std::string_view name() const noexcept override;
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  void set_gamma(double gamma) noexcept { gamma_ = gamma; }

 private:
  enum class Growth : std::uint8_t { Reached, Advanced, Trapped, PoolFull };

  [[nodiscard]] Growth extend(NodeTree& tree, const JointVector& target, int& added) noexcept;
  [[nodiscard]] Growth connect(NodeTree& tree, const JointVector& target, int& added) noexcept;
  [[nodiscard]] Growth grow(NodeTree& tree, const JointVector& target, bool use_connect, int& added) noexcept;
  //! Seed 000's Choose-Better-Node: the first of k constrained samples inside the ellipsoid of
  //! Eq. 6, else the one with the smallest Eq. 5 roughness.
  [[nodiscard]] JointVector better_sample() noexcept;
  //! Seed 000's Eq. 2: Euclidean distance with joints scaled to [0, 1], hoist left out.
  [[nodiscard]] double roughness(const JointVector& a, const JointVector& b) const noexcept;
  void join(int start_node, int goal_node) noexcept;

  Variant variant_;
  double gamma_;
  int candidates_;
  const PlanningProblem* problem_ = nullptr;
  Random random_;
  NodeTree start_tree_;
  NodeTree goal_tree_;
  bool start_tree_grows_first_ = true;
  PlannerStatus status_ = PlannerStatus::NotReset;
  int iterations_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  std::vector<JointVector> path_;
};

}  // namespace mgc::planning
