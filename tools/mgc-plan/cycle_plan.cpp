// SPDX-License-Identifier: Apache-2.0
// mgc-plan --cycle: seed 003's excavator work cycle, its three subtasks planned in order.

#include "cycle_plan.hpp"

#include <array>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <vector>

#include "envelope_rule.hpp"
#include "plan_json.hpp"
#include "mgc/planning/excavator.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/work_cycle.hpp"
#include "mgc/planning/smoothing.hpp"

namespace mgc::tools {
namespace {

using namespace mgc::planning;

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// What each subtask keeps fixed, as the JSON names it.
std::vector<const char*> held(ExcavatorSubtask subtask) {
  switch (subtask) {
    case ExcavatorSubtask::MoveToDump: return {"bucket_ground_angle"};
    case ExcavatorSubtask::Dump: return {"swing", "boom"};
    default: return {};
  }
}

struct SubtaskResult {
  PlannerStatus status = PlannerStatus::NotReset;
  PlannerStats stats;
  double planning_time_ms = 0.0;   //!< its step() calls; the common reset is in the total only
  double smoothing_time_ms = 0.0;
  int raw_path_nodes = 0;
  std::vector<JointVector> path;   //!< smoothed unless --no-smooth
  PathMetrics metrics;
};

}  // namespace

int run_cycle_plan(const CyclePlanOptions& options) {
  auto loaded = io::load_and_build(options.scenario);
  const auto envelope = keep_envelope(loaded, options.envelope_margin_m);
  const Scenario& s = loaded.scenario;
  if (!s.work_cycle) {
    std::fprintf(stderr, "%s: work_cycle: expected a work_cycle section for --cycle (docs/scenario-format.md), got none\n",
                 s.file.c_str());
    return 2;
  }
  const auto errors = io::check_endpoints(loaded);
  if (!errors.empty()) {
    for (const auto& e : errors) std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  const MachineModel& model = *loaded.model;
  CollisionWorld& world = *loaded.world;
  PlanningProblem problem = planning_problem(s, model, world);
  problem.max_iterations = options.max_iterations.value_or(problem.max_iterations);
  problem.seed = options.seed.value_or(problem.seed);

  WorkCyclePlanner planner(s.work_cycle->dumped, s.work_cycle->next_dig);
  constexpr int kIterationsPerSlice = 50;
  using Clock = std::chrono::steady_clock;
  const auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
  const auto t0 = Clock::now();
  std::array<SubtaskResult, WorkCyclePlanner::kSubtasks> results;
  PlannerStatus status = planner.reset(problem);
  bool timed_out = false;
  while (status == PlannerStatus::Running) {
    if (ms_since(t0) >= 1000.0 * options.time_limit_s) {
      timed_out = true;
      break;
    }
    const int k = planner.current_subtask();
    const auto t_slice = Clock::now();
    status = planner.step(kIterationsPerSlice);
    results[static_cast<std::size_t>(k)].planning_time_ms += ms_since(t_slice);
  }
  const double planning_time_ms = ms_since(t0);
  const bool success = status == PlannerStatus::Solved;

  // Each subtask smoothed on its own, by straight shortcuts between its nodes: they keep every
  // hold that is linear in the joints (a fixed joint, the bucket ground angle), where one-joint
  // staircases would not.
  std::vector<JointVector> path;
  int raw_path_nodes = 0;
  double smoothing_time_ms = 0.0;
  for (int k = 0; k < WorkCyclePlanner::kSubtasks; ++k) {
    SubtaskResult& r = results[static_cast<std::size_t>(k)];
    r.status = planner.subtask_status(k);
    r.stats = planner.subtask_stats(k);
    if (r.status != PlannerStatus::Solved) continue;
    r.path = planner.subtask_path(k);
    r.raw_path_nodes = static_cast<int>(r.path.size());
    raw_path_nodes += r.raw_path_nodes - (k > 0 ? 1 : 0);
    if (options.smooth) {
      SmoothingOptions smoothing;
      smoothing.single_axis = false;
      smoothing.seed = problem.seed;
      const auto t_smooth = Clock::now();
      r.path = smooth_path(world, r.path, problem.step, smoothing);
      r.smoothing_time_ms = ms_since(t_smooth);
      smoothing_time_ms += r.smoothing_time_ms;
    }
    r.metrics = compute_path_metrics(model, world, r.path, problem.step);
    path.insert(path.end(), r.path.begin() + (path.empty() ? 0 : 1), r.path.end());
  }
  if (!success) path.clear();
  const PathMetrics metrics = compute_path_metrics(model, world, path, problem.step);
  const PlannerStats stats = planner.stats();
  // A subtask still Running was cut short by the clock or never reached.
  const auto status_text = [&](int k) {
    const PlannerStatus st = results[static_cast<std::size_t>(k)].status;
    if (st != PlannerStatus::Running) return to_string(st);
    return timed_out && k == planner.current_subtask() ? "time limit reached" : "not planned";
  };

  std::printf("nonuniform %s seed %llu: work cycle %s in %.2f ms (", s.name.c_str(),
              static_cast<unsigned long long>(problem.seed), timed_out ? "time limit reached" : to_string(status),
              planning_time_ms);
  for (int k = 0; k < WorkCyclePlanner::kSubtasks; ++k) {
    const SubtaskResult& r = results[static_cast<std::size_t>(k)];
    std::printf("%s%s %s %.2f ms", k > 0 ? ", " : "", to_string(WorkCyclePlanner::kOrder[static_cast<std::size_t>(k)]),
                status_text(k), r.planning_time_ms);
  }
  std::printf("), %d iterations, %d tree nodes", stats.iterations, stats.tree_nodes);
  if (success) {
    std::printf(", %d path nodes (%d raw), %.1f s all joints together, clearance %.2f m", metrics.path_nodes, raw_path_nodes,
                metrics.exec_time_simultaneous_s, metrics.min_clearance_m);
  }
  std::printf("\n");

  if (!options.svg.empty()) {
    SvgInput view;
    view.scenario = &s;
    view.model = &model;
    view.path = path;
    view.step = problem.step;
    if (options.svg_tree) planner.tree(view.tree_nodes, view.tree_parents);
    if (!write_svg_file(options.svg, view)) return 2;
  }

  if (!options.json.empty()) {
    std::ofstream out(options.json);
    if (!out) {
      std::fprintf(stderr, "%s: cannot write the file\n", options.json.c_str());
      return 2;
    }
    JsonWriter j(out);
    j.begin_object();
    j.key("success").value(success);
    j.key("status").value(timed_out ? "time limit reached" : to_string(status));
    j.key("planner").value("nonuniform");
    j.key("scenario").value(s.file);
    j.key("seed").value(problem.seed);
    j.key("work_cycle").value(true);
    write_joints(j, model);
    write_path(j, model, path);
    j.key("planning_time_ms").value(planning_time_ms);
    j.key("iterations").value(stats.iterations);
    j.key("tree_nodes").value(stats.tree_nodes);
    j.key("collision_checks").value(stats.collision_checks);
    j.key("raw_path_nodes").value(success ? raw_path_nodes : 0);
    j.key("smoothed").value(success && options.smooth);
    j.key("smoothing_time_ms").value(smoothing_time_ms);
    write_metrics(j, metrics);
    j.key("subtasks").begin_array();
    for (int k = 0; k < WorkCyclePlanner::kSubtasks; ++k) {
      const SubtaskResult& r = results[static_cast<std::size_t>(k)];
      const ExcavatorSubtask subtask = WorkCyclePlanner::kOrder[static_cast<std::size_t>(k)];
      const PlanningProblem& p = planner.subtask_problem(k);
      j.begin_object();
      j.key("name").value(to_string(subtask));
      j.key("held").begin_array();
      for (const char* h : held(subtask)) j.value(h);
      j.end_array();
      if (subtask == ExcavatorSubtask::MoveToDump) j.key("bucket_ground_angle_deg").value(bucket_ground_angle_rad(p.start) * kRadToDeg);
      j.key("success").value(r.status == PlannerStatus::Solved);
      j.key("status").value(status_text(k));
      j.key("start");
      write_configuration(j, model, p.start);
      j.key("goal");
      write_configuration(j, model, p.goal);
      write_path(j, model, r.path);
      j.key("planning_time_ms").value(r.planning_time_ms);
      j.key("iterations").value(r.stats.iterations);
      j.key("tree_nodes").value(r.stats.tree_nodes);
      j.key("collision_checks").value(r.stats.collision_checks);
      j.key("raw_path_nodes").value(r.raw_path_nodes);
      j.key("smoothing_time_ms").value(r.smoothing_time_ms);
      write_metrics(j, r.metrics);
      j.end_object();
    }
    j.end_array();
    j.key("parameters").begin_object();
    j.key("max_iterations").value(problem.max_iterations);
    j.key("time_limit_s").value(options.time_limit_s);
    j.key("space_resolution").value(s.planner.space_resolution);
    j.key("error_tolerance").value(problem.error_tolerance);
    j.key("dilation_m").value(s.planner.dilation_m);
    j.end_object();
    j.end_object();
    out << "\n";
  }
  return success ? 0 : 1;
}

}  // namespace mgc::tools
