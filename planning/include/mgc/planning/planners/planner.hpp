// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "mgc/planning/planners/problem.hpp"

namespace mgc::planning {

//! Where a planner stands. Running and Solved are progress; the rest end the query.
enum class PlannerStatus : std::int16_t {
  Running = 1,           //!< step() again
  Solved = 0,            //!< path() holds a valid path from start to the exact goal
  InvalidStart = -320,   //!< the start violates a joint range, a constraint or collides
  InvalidGoal = -321,
  IterationLimit = -322, //!< max_iterations spent without reaching the goal
  PoolExhausted = -323,  //!< the node pool is full: it is sized at reset and never grows
  NotReset = -324,       //!< step() before reset()
  GoalOccupied = -325,   //!< re-planning: an obstacle now covers the goal itself; retry once it moves
};

[[nodiscard]] const char* to_string(PlannerStatus status) noexcept;

//! Counters of one query.
struct PlannerStats {
  int iterations = 0;
  int tree_nodes = 0;             //!< nodes in all trees, roots included
  std::uint64_t collision_checks = 0;
};

//! A sampling-based planner with a resumable, allocation-free core: reset() takes the problem
//! and sizes every buffer; step(budget) runs at most `budget` iterations and allocates nothing,
//! so a control loop can give it a bounded slice of each cycle. Deterministic: the same problem
//! and seed give the same path, bit for bit.
class Planner {
 public:
  virtual ~Planner() = default;

  [[nodiscard]] virtual std::string_view name() const noexcept = 0;
  //! Takes the problem (which must outlive the query) and prepares a fresh query. May allocate.
  virtual PlannerStatus reset(const PlanningProblem& problem) = 0;
  //! Runs at most `iteration_budget` iterations. No heap allocation, no exceptions.
  [[nodiscard]] virtual PlannerStatus step(int iteration_budget) noexcept = 0;
  //! The solution once step() returned Solved: configurations from start to goal, consecutive
  //! ones joined by straight joint-space edges valid at the problem's step resolution.
  [[nodiscard]] virtual const std::vector<JointVector>& path() const noexcept = 0;
  [[nodiscard]] virtual PlannerStats stats() const noexcept = 0;
  //! Tree nodes and their parents (-1 for a root), for drawing. Valid until the next reset().
  virtual void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const = 0;
};

}  // namespace mgc::planning

#include <memory>

namespace mgc::planning {

//! The one-joint-at-a-time planner mgc-plan and the controller use unless told otherwise.
inline constexpr std::string_view kDefaultPlanner = "axis-connect";

//! The planner called `name` on the command line, or nullptr for an unknown name.
[[nodiscard]] std::unique_ptr<Planner> make_planner(std::string_view name);
//! Every name make_planner() knows.
[[nodiscard]] std::vector<std::string_view> planner_names();

}  // namespace mgc::planning
