// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/execution.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace mgc::planning {
namespace {

//! Whether the straight move from -> to hits a dynamic obstacle at its current pose, sampled
//! so that no body point moves more than the dilation between samples. Static obstacles and
//! constraints are the planner's: its edges are valid along their whole continuous motion, and
//! re-sampling a piece of one at other points would only find the dilation margin, not a
//! collision.
bool hits_dynamic_along(CollisionWorld& world, const MachineModel& model, const JointVector& from,
                        const JointVector& to, Contact& contact) {
  const JointVector delta = model.difference(from, to);
  double travel_m = 0.0;
  for (int i = 0; i < model.dof(); ++i) travel_m += model.edge_displacement_bound(from, to, i) * std::abs(delta[i]);
  const int samples = std::max(1, static_cast<int>(std::ceil(travel_m / std::max(world.dilation_m(), 1e-3))));
  for (int k = 0; k <= samples; ++k) {
    if (world.hits_dynamic(model.interpolate(from, to, static_cast<double>(k) / samples), &contact)) return true;
  }
  return false;
}

}  // namespace

const char* to_string(ExecutionResult::Outcome outcome) noexcept {
  switch (outcome) {
    case ExecutionResult::Outcome::Arrived: return "arrived";
    case ExecutionResult::Outcome::FirstPlanFailed: return "first plan failed";
    case ExecutionResult::Outcome::Stuck: return "stuck";
  }
  return "unknown";
}

ExecutionResult execute_with_replanning(const Scenario& scenario, const PlanningProblem& problem, Replanner& replanner,
                                        const ReplanSettings& replan, const ExecutionSettings& settings,
                                        const std::function<double()>& clock_ms) {
  CollisionWorld& world = *problem.world;
  const MachineModel& model = *problem.model;
  const int copies = scenario.dynamic_obstacles.empty()
                         ? 1
                         : std::max(1, world.num_dynamic() / static_cast<int>(scenario.dynamic_obstacles.size()));
  const int predicted = copies - 1;
  // Each copy where its obstacle is at scenario time t_s. The searches below pose the copies at
  // the same few times again and again (a candidate way out after another, a shift then back):
  // a copy already posed for that time (bit for bit) is left as it stands.
  std::vector<double> posed_for_s(static_cast<std::size_t>(world.num_dynamic()), std::numeric_limits<double>::quiet_NaN());
  const auto pose_copy = [&](int i, double t_s) {
    double& posed_s = posed_for_s[static_cast<std::size_t>(i)];
    if (posed_s == t_s) return;
    world.set_dynamic_pose(i, scenario.dynamic_obstacles[static_cast<std::size_t>(i / copies)].pose_at(t_s));
    posed_s = t_s;
  };
  // Copy k of each obstacle stands where the obstacle will be k / P of the horizon from now.
  const auto pose_obstacles = [&](double t_s, double horizon_s) {
    for (int i = 0; i < world.num_dynamic(); ++i) {
      const int k = i % copies;
      pose_copy(i, t_s + (predicted > 0 ? horizon_s * k / predicted : 0.0));
    }
  };
  const double horizon_s = settings.prediction_horizon_s;
  const auto now_ms = [&] { return clock_ms ? clock_ms() : 0.0; };
  const double spacing_s = predicted > 0 ? horizon_s / predicted : horizon_s;
  const auto any_moves = [&](double from_s, double to_s) {
    for (const DynamicObstacleSpec& obstacle : scenario.dynamic_obstacles) {
      if (obstacle.moves_between(from_s, to_s)) return true;
    }
    return false;
  };
  // The ticks within the spacing between two copies after the first, in bit-reversed order:
  // halves, quarters, eighths. An obstacle that reaches a state does so over a stretch of ticks,
  // which this order finds in a few checks where going tick by tick would take half of them.
  std::vector<double> shifts_s;
  {
    const int ticks = std::max(1, static_cast<int>(std::ceil(spacing_s / settings.tick_s - 1e-9)));
    int bits = 0;
    while ((1 << bits) < ticks) ++bits;
    for (int b = 1; b < (1 << bits); ++b) {
      int j = 0;
      for (int k = 0; k < bits; ++k) j |= ((b >> k) & 1) << (bits - 1 - k);
      if (j < ticks) shifts_s.push_back(j * settings.tick_s);
    }
  }
  // Whether the obstacles reach a machine standing at `state` between their copies, in the first
  // `gaps` gaps after t0_s. The copies alone leave gaps: a jib slewing at 3.5 m/s at the tip moves
  // metres between two copies 1 s apart, and a machine stopped in such a gap is run into before
  // the next copy comes. So the copies of an obstacle that moves in its gap are shifted a tick at a
  // time through it. The copies must stand at t0_s + k spacing (pose_obstacles(t0_s, horizon_s)).
  // A copy whose points all move less over its gap than it stands from the machine cannot reach
  // it there: it is neither shifted nor, standing still, hit. The answer is the one shifting every
  // copy gives, at a fraction of the poses.
  std::vector<unsigned char> sweeps(static_cast<std::size_t>(world.num_dynamic()), 0);
  const auto reached_between_copies = [&](const JointVector& state, double t0_s, int gaps, Contact* contact) {
    if (predicted == 0 || !any_moves(t0_s, t0_s + gaps * spacing_s)) return false;
    bool any_sweeps = false;
    for (int i = 0; i < world.num_dynamic(); ++i) {
      const DynamicObstacleSpec& obstacle = scenario.dynamic_obstacles[static_cast<std::size_t>(i / copies)];
      const double from_s = t0_s + spacing_s * (i % copies);
      // The copy stands at pose_obstacles' time for it, which rounding may put a hair from from_s:
      // the travel is bounded over the gap widened by a tick each side.
      const bool sweeps_here =
          i % copies < gaps && obstacle.moves_between(from_s, from_s + spacing_s) &&
          world.dynamic_may_be_within(
              state, i, obstacle.max_travel_m(from_s - settings.tick_s, from_s + spacing_s + settings.tick_s, world.dynamic_reach_m(i)));
      sweeps[static_cast<std::size_t>(i)] = sweeps_here ? 1 : 0;
      any_sweeps = any_sweeps || sweeps_here;
    }
    if (!any_sweeps) return false;
    for (const double shift_s : shifts_s) {
      for (int i = 0; i < world.num_dynamic(); ++i) {
        if (sweeps[static_cast<std::size_t>(i)] != 0) pose_copy(i, t0_s + spacing_s * (i % copies) + shift_s);
      }
      if (world.hits_dynamic(state, contact)) return true;
    }
    return false;
  };
  // Whether the obstacles, moving on as predicted, reach a machine standing at `state` within the
  // horizon from t0_s, at a copy or between two, or a tick past it: the next move is checked
  // against the copies a tick later, and a machine the farthest of them then reaches cannot start
  // on any path.
  const auto covered_at_rest = [&](const JointVector& state, double t0_s) {
    pose_obstacles(t0_s, horizon_s);
    if (world.hits_dynamic(state) || reached_between_copies(state, t0_s, predicted, nullptr)) return true;
    const double beyond_s = t0_s + horizon_s + settings.tick_s;
    bool moved = false;
    for (int i = predicted; predicted > 0 && i < world.num_dynamic(); i += copies) {
      const DynamicObstacleSpec& obstacle = scenario.dynamic_obstacles[static_cast<std::size_t>(i / copies)];
      if (obstacle.moves_between(t0_s + horizon_s, beyond_s)) {
        pose_copy(i, beyond_s);
        moved = true;
      }
    }
    return moved && world.hits_dynamic(state);
  };

  ExecutionResult result;
  double t_s = settings.start_time_s;
  pose_obstacles(t_s, horizon_s);
  const double plan_start_ms = now_ms();
  PlannerStatus status = replanner.reset(problem, replan);
  while (status == PlannerStatus::Running) status = replanner.step(settings.iteration_budget);
  result.first_plan_ms = now_ms() - plan_start_ms;
  result.first_plan = status;
  if (status != PlannerStatus::Solved) {
    result.outcome = ExecutionResult::Outcome::FirstPlanFailed;
    result.end_time_s = t_s;
    return result;
  }
  result.first_plan_nodes = static_cast<int>(replanner.path().size());
  JointVector q = replanner.path().front();
  std::size_t next = 1;
  // Set while the prediction covers the machine: it then moves away from where the obstacles
  // are, checked against their present poses, until it stands clear of the prediction again.
  bool escaping = false;
  // Corners of the executed motion, which is straight between consecutive ones and from the last
  // one to q: the way back, should the machine need to retreat.
  std::vector<JointVector> came_from{q};
  double last_repair_s = -1.0;
  int repairs_in_place = 0;
  // Every state reached: recorded, and checked against the obstacles' present poses, since an
  // obstacle can run into a machine that has stopped.
  const auto reached = [&](const JointVector& state) {
    if (settings.record_trajectory) result.trajectory.push_back({t_s, state});
    pose_obstacles(t_s, 0.0);
    if (world.hits_dynamic(state)) ++result.contact_states;
    if (escaping) escaping = covered_at_rest(state, t_s);
  };
  // One move toward `target`: the joints at their speed limits, scaled to arrive together, for
  // one tick or up to the target.
  struct Move {
    JointVector to;
    double dt_s = 0.0;
    bool reaches = false;
  };
  const auto move_toward = [&](const JointVector& from, const JointVector& target) {
    const JointVector delta = model.difference(from, target);
    double needed_s = 0.0;
    for (int i = 0; i < model.dof(); ++i) {
      needed_s = std::max(needed_s, std::abs(delta[i]) / model.joints()[static_cast<std::size_t>(i)].max_velocity);
    }
    Move m;
    m.reaches = needed_s <= settings.tick_s;
    m.dt_s = m.reaches ? needed_s : settings.tick_s;
    m.to = m.reaches ? target : model.interpolate(from, target, m.dt_s / needed_s);
    return m;
  };
  const auto inside_prediction = [&] { return covered_at_rest(q, t_s); };
  // Ways out of the prediction: back along the executed motion, or one joint alone at its speed
  // limit either way (2n + 1 candidates). They are simulated before the machine takes one, a move
  // of each in turn, every move checked against the obstacles' scripted poses at its end; a joint
  // move also against the static site and the constraints at the planner's step (the way back is
  // statically valid already). The first to stand clear of the prediction is taken (the soonest
  // of those clear in the same turn); when none does within the horizon, the machine backs off
  // along its executed motion as far as it can, since from inside the prediction no path can keep
  // clear of where the obstacle is going.
  struct Trial {
    std::vector<ExecutedState> states;  //!< scenario time and configuration after each move
    std::vector<JointVector> came_from; //!< the way back (candidate 0 only): its corners as it passes them
    JointVector at;
    double at_s = 0.0;
    bool alive = false;
    bool clear = false;
  };
  std::vector<Trial> trials(static_cast<std::size_t>(2 * model.dof() + 1));
  // One more move of candidate c; false once it is blocked, at a joint limit, back at the start
  // or out of time.
  const auto advance = [&](int c, Trial& trial) {
    if (trial.at_s - t_s >= horizon_s || trial.at_s > settings.time_limit_s) return false;
    Move m;
    if (c == 0) {
      if (trial.came_from.size() == 1 && trial.at == trial.came_from.front()) return false;
      m = move_toward(trial.at, trial.came_from.back());
    } else {
      const int joint = (c - 1) / 2;
      const JointSpec& spec = model.joints()[static_cast<std::size_t>(joint)];
      m.to = trial.at;
      m.to[joint] += (c % 2 == 1 ? 1.0 : -1.0) * spec.max_velocity * settings.tick_s;
      m.to[joint] = spec.continuous ? wrap_angle(m.to[joint]) : std::clamp(m.to[joint], spec.position_min, spec.position_max);
      if (m.to == trial.at) return false;
      m.dt_s = settings.tick_s;
    }
    Contact contact;
    pose_obstacles(trial.at_s + m.dt_s, 0.0);
    if (hits_dynamic_along(world, model, trial.at, m.to, contact)) return false;
    if (c != 0 && !world.validate_edge(trial.at, m.to, problem.step).valid()) return false;
    trial.at = m.to;
    trial.at_s += m.dt_s;
    trial.states.push_back({trial.at_s, trial.at});
    if (c == 0 && m.reaches && trial.came_from.size() > 1) trial.came_from.pop_back();
    return true;
  };
  const auto escape = [&](RepairEvent* event) {
    if (predicted == 0 || !inside_prediction()) return;
    const double search_start_ms = now_ms();
    trials[0].came_from = came_from;
    for (Trial& trial : trials) {
      trial.states.clear();
      trial.at = q;
      trial.at_s = t_s;
      trial.alive = true;
      trial.clear = false;
    }
    int chosen = -1;
    for (bool any = true; any && chosen < 0;) {
      any = false;
      // Every move of the turn first, then whether each stands clear: the moves of a turn mostly
      // end at one time and share the obstacles' present poses, which the prediction's copies
      // would otherwise displace between them.
      for (int c = 0; c < static_cast<int>(trials.size()); ++c) {
        Trial& trial = trials[static_cast<std::size_t>(c)];
        if (trial.alive) trial.alive = advance(c, trial);
      }
      for (int c = 0; c < static_cast<int>(trials.size()); ++c) {
        Trial& trial = trials[static_cast<std::size_t>(c)];
        if (!trial.alive) continue;
        trial.clear = !covered_at_rest(trial.at, trial.at_s);
        trial.alive = !trial.clear;
        any = any || trial.alive;
        if (trial.clear && (chosen < 0 || trial.at_s < trials[static_cast<std::size_t>(chosen)].at_s)) chosen = c;
      }
    }
    if (chosen < 0 && !trials[0].states.empty()) chosen = 0;
    if (event != nullptr) event->escape_ms += now_ms() - search_start_ms;
    if (chosen < 0) return;
    const Trial& way = trials[static_cast<std::size_t>(chosen)];
    const double from_s = t_s;
    const JointVector from_q = q;
    for (const ExecutedState& state : way.states) {
      t_s = state.t_s;
      q = state.q;
      reached(q);
    }
    if (chosen == 0) {
      came_from = way.came_from;
    } else if (came_from.back() != from_q) {
      // The joint move is straight from where it began: a corner of the way back.
      came_from.push_back(from_q);
    }
    if (event != nullptr) {
      event->retreat_s += t_s - from_s;
      if (chosen > 0) event->escape_joint = (chosen - 1) / 2;
    }
  };
  // Holds for hold_s in ticks, keeping clear of the prediction.
  const auto hold = [&](double hold_s) {
    for (double held_s = 0.0; held_s < hold_s; held_s += settings.tick_s) {
      escape(nullptr);
      t_s += settings.tick_s;
      reached(q);
    }
  };
  reached(q);

  for (;;) {
    const std::vector<JointVector>& path = replanner.path();
    if (next >= path.size()) {
      result.outcome = ExecutionResult::Outcome::Arrived;
      break;
    }
    if (t_s > settings.time_limit_s) break;
    const Move m = move_toward(q, path[next]);

    // Update-Environment, then check the move (seed 000 Fig. 8 lines 8-9): the poses at the
    // move's end, which the repair then sees too. Obstacles here move centimetres per tick.
    Contact contact;
    pose_obstacles(t_s + m.dt_s, escaping ? 0.0 : horizon_s);
    // A move may also not end where the obstacles would reach the machine before their next copy,
    // should it have to stop there: it would have no time to get out.
    if (!hits_dynamic_along(world, model, q, m.to, contact) &&
        (escaping || !reached_between_copies(m.to, t_s + m.dt_s, 1, &contact))) {
      q = m.to;
      t_s += m.dt_s;
      if (m.reaches) {
        ++next;
        came_from.push_back(q);
      }
      reached(q);
      continue;
    }

    if (static_cast<int>(result.repairs.size()) >= settings.max_repairs) break;
    // Blocked again and again before moving at all: the obstacles have not moved since the last
    // repairs either, so wait a tick rather than repair against the same poses once more.
    repairs_in_place = t_s == last_repair_s ? repairs_in_place + 1 : 0;
    if (repairs_in_place >= 3) {
      hold(settings.tick_s);
      continue;
    }
    RepairEvent event;
    event.obstacle = contact.with == Contact::With::Dynamic ? contact.other : -1;
    if (!escaping) escape(&event);
    event.t_s = t_s;
    event.at = q;
    pose_obstacles(t_s, 0.0);
    event.start_in_contact = world.hits_dynamic(q);
    pose_obstacles(t_s, escaping ? 0.0 : horizon_s);
    // With a prediction and nothing moving over it, what blocks the path now still will.
    const bool still = predicted > 0 && !escaping && !any_moves(t_s, t_s + horizon_s);
    const double repair_start_ms = now_ms();
    status = replanner.replan(q, static_cast<int>(next), still);
    while (status == PlannerStatus::Running) status = replanner.step(settings.iteration_budget);
    if (status == PlannerStatus::InvalidStart && predicted > 0 && !escaping) {
      // Still inside the prediction after retreating as far as it could: get away from where
      // the obstacle is now.
      pose_obstacles(t_s, 0.0);
      status = replanner.replan(q, static_cast<int>(next));
      while (status == PlannerStatus::Running) status = replanner.step(settings.iteration_budget);
      event.predicted_start_conflict = true;
      escaping = status == PlannerStatus::Solved;
    }
    event.compute_ms = now_ms() - repair_start_ms;
    last_repair_s = t_s;
    event.status = status;
    const ReplanStats stats = replanner.stats();
    event.iterations = stats.repair_iterations;
    event.invalidated_nodes = stats.invalidated_nodes;
    event.bridge_attempts = stats.bridge_attempts;
    if (status == PlannerStatus::Solved) {
      next = 1;
      if (came_from.back() != q) came_from.push_back(q);
      event.path_nodes = static_cast<int>(replanner.path().size());
      event.checked_nodes = stats.checked_nodes;
      if (settings.record_trajectory) event.path = replanner.path();
    } else {
      // Hold, clear of the prediction, and look again once the obstacles have moved on.
      hold(settings.hold_s);
    }
    result.repairs.push_back(event);
  }
  result.end_time_s = t_s;
  return result;
}

}  // namespace mgc::planning
