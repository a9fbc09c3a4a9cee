// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <functional>
#include <vector>

#include "mgc/planning/planners/replanner.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::planning {

//! How the kinematic execution of a lift runs (the seed papers' simulation loop: move one small
//! step, update the obstacles, check the next step, stop and re-plan when it collides).
struct ExecutionSettings {
  double tick_s = 1.0 / 30.0;     //!< the thesis's simulation step: one frame at 30 fps [s]
  double start_time_s = 0.0;      //!< scenario time at which the machine starts [s]
  double time_limit_s = 900.0;    //!< scenario time after which the lift counts as stuck [s]
  double hold_s = 1.0;            //!< after a failed repair, hold this long before looking again [s]
  int max_repairs = 50;           //!< repairs after which the lift counts as stuck
  int iteration_budget = 200;     //!< iterations per step() slice
  bool record_trajectory = true;  //!< keep every executed configuration
  //! With a world built with predicted poses (build_world's predicted_poses = P), copy k of
  //! each dynamic obstacle stands where the scenario puts it k / P of this horizon ahead, so
  //! moves and repairs keep clear of where obstacles are going, not only of where they are. [s]
  double prediction_horizon_s = 0.0;
};

//! One stop and its repair.
struct RepairEvent {
  double t_s = 0.0;      //!< scenario time of the obstacle poses the repair saw [s]
  JointVector at;        //!< where the machine stopped
  int obstacle = -1;     //!< dynamic obstacle the blocked motion hit; -1 if something else
  PlannerStatus status = PlannerStatus::NotReset;  //!< how the repair ended
  double compute_ms = 0.0;  //!< by the caller's clock, from replan() to the end of the repair [ms]
  int iterations = 0;     //!< of the whole repair (ReplanStats::repair_iterations)
  int invalidated_nodes = 0;
  int bridge_attempts = 0;
  int path_nodes = 0;     //!< of the repaired path
  int checked_nodes = 0;  //!< ReplanStats::checked_nodes: the repaired path's leading nodes checked against t_s's poses
  std::vector<JointVector> path;  //!< the repaired path, when the trajectory is recorded
  //! How long the machine moved out of the prediction before the repair, because the prediction
  //! covered where it had stopped: back along its executed motion, or one joint alone. [s]
  double retreat_s = 0.0;
  //! The joint it moved alone to get out; -1 when it backed off along its executed motion or
  //! did not move.
  int escape_joint = -1;
  //! By the caller's clock, choosing the way out of the prediction: simulating every candidate. [ms]
  double escape_ms = 0.0;
  //! The prediction still covered the machine after retreating, so the repair saw the obstacles'
  //! present poses.
  bool predicted_start_conflict = false;
  //! An obstacle at its present pose overlapped the machine where it stopped: it had run into the
  //! machine, and no path could start there until it moved off.
  bool start_in_contact = false;
};

//! Whether an obstacle covered the machine where it stopped (ran into it, or its prediction still
//! over it after the retreat) or the goal (GoalOccupied): no repair can succeed until it moves, so
//! benchmarks count such events apart from the ones a repair must solve.
[[nodiscard]] inline bool machine_or_goal_covered(const RepairEvent& event) noexcept {
  return event.start_in_contact || event.predicted_start_conflict || event.status == PlannerStatus::GoalOccupied;
}

struct ExecutedState {
  double t_s = 0.0;  //!< scenario time [s]
  JointVector q;
};

struct ExecutionResult {
  enum class Outcome : std::uint8_t {
    Arrived,          //!< the machine reached the exact goal
    FirstPlanFailed,  //!< no first path
    Stuck,            //!< time limit or repair limit reached before the goal
  };
  Outcome outcome = Outcome::Stuck;
  PlannerStatus first_plan = PlannerStatus::NotReset;
  double first_plan_ms = 0.0;  //!< by the caller's clock [ms]
  int first_plan_nodes = 0;    //!< path nodes of the first plan
  double end_time_s = 0.0;     //!< scenario time when execution ended [s]
  //! States (moves and holds) at which a dynamic obstacle overlapped the dilated machine: an
  //! obstacle that ran into it. 0 is the only safe result.
  int contact_states = 0;
  std::vector<RepairEvent> repairs;
  std::vector<ExecutedState> trajectory;  //!< start first, then the state after every move or held tick
};

[[nodiscard]] const char* to_string(ExecutionResult::Outcome outcome) noexcept;

//! Plans the problem with `replanner` and moves the machine along the path kinematically: along
//! each edge, the joints at their speed limits scaled to arrive together, at most one tick or up
//! to the next waypoint per move. Before each move the dynamic obstacles go to their scenario
//! poses at the move's end and the move is checked against them (dynamic obstacles only: the
//! planner answers for the static ones); with a prediction, also against the obstacles' copies
//! ahead, and the move's end against their motion a tick at a time up to the first copy ahead (a
//! machine that had to stop there would have no time to get out). When a move collides, the
//! machine stops where it is and the re-planner repairs, time frozen as in the papers (blocked
//! again before any move, the machine waits a tick before the next repair). Whenever the
//! prediction (prediction_horizon_s) covers the machine at rest (stopped for a repair or
//! holding), it first moves out of it: back along its executed motion or one joint alone,
//! whichever way out is clear soonest, simulated against the obstacles' scripted motion over the
//! prediction horizon. For a machine at rest the prediction follows the obstacles a tick at a
//! time, not only at the copies, so it is not left standing in the gap between two copies. After
//! a failed repair the machine holds for `hold_s` and looks again. A repair is told the obstacles
//! stand still (Replanner::replan) when, with a prediction, none moves over its horizon.
//! `world` must be the problem's, built from `scenario` (dynamic obstacles in scenario order).
//! `clock_ms` times the first plan and the repairs; without it those times are 0.
[[nodiscard]] ExecutionResult execute_with_replanning(const Scenario& scenario, const PlanningProblem& problem,
                                                      Replanner& replanner, const ReplanSettings& replan,
                                                      const ExecutionSettings& settings,
                                                      const std::function<double()>& clock_ms = {});

}  // namespace mgc::planning
