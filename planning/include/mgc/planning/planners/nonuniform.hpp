// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"

namespace mgc::planning {

//! The free-motion subtasks of seed 003's excavator cycle (Table 1) and what each one holds.
enum class ExcavatorSubtask : std::uint8_t {
  Any,         //!< decided at reset: the bucket is held when start and goal share its ground angle
  MoveToDump,  //!< bucket ground angle held (the soil stays in); swing, boom and arm sampled
  Dump,        //!< swing and boom held; arm and bucket move, the straight line tried first
  Return,      //!< all four joints sampled
};

[[nodiscard]] const char* to_string(ExcavatorSubtask subtask) noexcept;

//! Seed 003's non-uniform RRT (Langari & Hammad): a single-tree RRT with straight Extend steps
//! whose samples come from a per-joint Beta distribution with its mean on the goal, the smaller
//! shape parameter 1 -- the note's corrected rule (the paper's alpha/beta wording points the bias
//! away from the goal). A continuous joint samples the turn centred on the start. The paper gives
//! no goal test; here the straight edge to the goal is tried from every new node within
//! error_tolerance * extend_steps steps of it on every joint and from every node that is the
//! closest to it yet.
//!
//! For an excavator whose start and goal hold the bucket at the same ground angle (the move-to-
//! dump subtask, seed 003 Table 1), the bucket joint is not sampled: it follows
//! bucket = psi - boom - arm, so every configuration of the path keeps the soil in.
//!
//! Given a subtask, the planner holds what that subtask holds and refuses a query that breaks it
//! (InvalidGoal): move-to-dump needs start and goal at one bucket ground angle, dump one swing and
//! boom. Held joints are not sampled; every edge is straight in the joints, so a hold that is
//! linear in them (a fixed joint, psi = boom + arm + bucket) holds all along every edge.
class NonUniformRrtPlanner final : public Planner {
 public:
  //! uniform: seed 003's baseline "basic RRT" -- the same planner with uniform samples (and no
  //! held bucket).
  explicit NonUniformRrtPlanner(bool uniform = false) : uniform_(uniform) {}
  //! One subtask of an excavator's cycle, with that subtask's holds.
  explicit NonUniformRrtPlanner(ExcavatorSubtask subtask) : subtask_(subtask) {}

  [[nodiscard]] std::string_view name() const noexcept override { return uniform_ ? "rrt-basic" : "nonuniform"; }
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  //! True when the query holds the excavator's bucket ground angle (decided at reset).
  [[nodiscard]] bool holds_bucket() const noexcept { return hold_bucket_; }
  [[nodiscard]] ExcavatorSubtask subtask() const noexcept { return subtask_; }

  //! One draw from Beta(alpha, beta) with min(alpha, beta) = 1 whose mean is `mean` in (0, 1),
  //! by the closed-form inverse CDF. Exposed for tests.
  [[nodiscard]] static double beta_sample(double mean, double uniform) noexcept;

 private:
  [[nodiscard]] JointVector sample() noexcept;
  [[nodiscard]] bool edge_valid(const JointVector& from, const JointVector& to) noexcept;

  bool uniform_ = false;
  ExcavatorSubtask subtask_ = ExcavatorSubtask::Any;
  const PlanningProblem* problem_ = nullptr;
  Random random_;
  NodeTree tree_;
  std::array<double, kMaxJoints> lower_{};  //!< sampling interval per joint [rad | m]
  std::array<double, kMaxJoints> upper_{};
  std::array<double, kMaxJoints> mean_{};   //!< goal's place in the interval, in (0, 1)
  std::array<bool, kMaxJoints> held_{};   //!< not sampled: kept at the start's (= goal's) value
  bool hold_bucket_ = false;
  double bucket_ground_angle_rad_ = 0.0;
  bool try_straight_ = false;
  double closest_to_goal_ = 0.0;          //!< of the tree's nodes, in steps             //!< dump: the straight edge start -> goal comes first
  PlannerStatus status_ = PlannerStatus::NotReset;
  int iterations_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  std::vector<JointVector> path_;
};

}  // namespace mgc::planning
