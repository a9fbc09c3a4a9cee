// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "mgc/planning/planners/planner.hpp"

namespace mgc::planning {

//! The re-planning parameters of the thesis's Table 4.1 (Replan_Max_Nodes,
//! Replan_Biasing_Probability) and its dual-phase switch.
struct ReplanSettings {
  //! Iteration cap of one repair: a bridging re-planner spends it across all its bridges. [-]
  int max_iterations = 2000;
  double goal_bias = 0.15;    //!< goal bias while repairing: high, so the repair heads for the machine
  //! When the first plan hits its cap, keep its tree and go on as a repair (thesis §1.12).
  bool dual_phase = true;
};

//! Counters of a re-planner over its whole life (first plan and every repair).
struct ReplanStats {
  int repairs = 0;             //!< replan() calls
  int iterations = 0;          //!< of the query now running or last finished
  //! Of the last repair in all: summed over its bridges (Con-Con-Mod, axis-connect), its regrowth
  //! (DRRT). At most ReplanSettings::max_iterations for a bridging re-planner.
  int repair_iterations = 0;
  int tree_nodes = 0;          //!< nodes now held (all trees)
  int invalidated_nodes = 0;   //!< removed by the last repair (DRRT: trimmed; Con-Con-Mod: dropped path nodes)
  int bridge_attempts = 0;     //!< Con-Con-Mod: bridges tried by the last repair
  //! Leading nodes of the last repaired path whose edges were checked against the poses that repair
  //! saw: DRRT all of them; Con-Con-Mod its bridge, or the whole path when replan() was told the
  //! obstacles stand still.
  int checked_nodes = 0;
  bool dual_phase_used = false;
  std::uint64_t collision_checks = 0;
};

//! A planner that keeps repairing its path while the machine executes it (seed 001 §1.11,
//! seed 000 §4.8). reset() plans the first path; whenever the next motion of the machine would
//! collide with a dynamic obstacle, the caller stops the machine and calls replan() with where it
//! stopped; step() then runs the repair in bounded slices. Obstacle poses are whatever the
//! problem's CollisionWorld holds: the caller moves them between slices.
//!
//! Allocation: reset() sizes every buffer for the first plan and for the repairs; replan() and
//! step() never allocate and never throw. Deterministic: the same problem, settings, seed and
//! sequence of obstacle poses and replan() calls give the same paths.
class Replanner {
 public:
  virtual ~Replanner() = default;

  [[nodiscard]] virtual std::string_view name() const noexcept = 0;
  //! Takes the problem (which, with its model and world, must outlive the re-planner) and starts
  //! the first plan. May allocate.
  virtual PlannerStatus reset(const PlanningProblem& problem, const ReplanSettings& settings) = 0;
  //! Runs the first plan or the current repair for at most `iteration_budget` iterations.
  [[nodiscard]] virtual PlannerStatus step(int iteration_budget) noexcept = 0;
  //! The path once step() returned Solved: path().front() is where the machine was when it was
  //! planned (the start, or the stop of the latest repair), path().back() the exact goal;
  //! consecutive configurations are joined by straight joint-space edges valid, at the step
  //! resolution, against the obstacle poses the plan or repair saw.
  [[nodiscard]] virtual const std::vector<JointVector>& path() const noexcept = 0;
  //! Starts a repair. The machine is at rest at `q_machine`, on its way from path()[next - 1] to
  //! path()[next] (or exactly at one of them). Returns Running, Solved (repaired at once),
  //! InvalidStart (q_machine itself is invalid now), GoalOccupied (an obstacle covers the goal:
  //! hold and call again once it has moved) or a failure; after a failure the old path stays in
  //! path() and a later replan() may succeed. `obstacles_still`: the caller's prediction has no
  //! dynamic obstacle moving over its horizon, so whatever blocks the rest of the path now will
  //! still block it when the machine gets there (Con-Con-Mod then bridges past the last blocked
  //! edge of its old path, not only past the nodes ahead).
  [[nodiscard]] virtual PlannerStatus replan(const JointVector& q_machine, int next, bool obstacles_still = false) noexcept = 0;
  [[nodiscard]] virtual ReplanStats stats() const noexcept = 0;
};

//! The re-planner the controller uses unless told otherwise: repairs bridged by the default
//! planner, so every edge of the first plan and of every repair moves one joint.
inline constexpr std::string_view kDefaultReplanner = "drrt-axis-connect";

//! The re-planner called `name` on the command line ("drrt-axis-connect", "drrt", "drrt-rrt",
//! "drrt-con-con-mod"), or nullptr for an unknown name.
[[nodiscard]] std::unique_ptr<Replanner> make_replanner(std::string_view name);
//! Every name make_replanner() knows.
[[nodiscard]] std::vector<std::string_view> replanner_names();

}  // namespace mgc::planning
