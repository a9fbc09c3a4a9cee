// SPDX-License-Identifier: Apache-2.0
// mgc-plan: offline tool over the planning library. `--check` loads a scenario, validates every
// field, and reports whether start and goal are feasible and, if not, why. `--planner NAME` plans
// the scenario's lift and writes the path and its metrics as JSON (docs/plan-json.md).
//
// Exit status: 0 feasible, 1 the job could not be done, 2 bad input (one line on stderr naming
// the file, the line, the field and what was expected). An infeasible start or goal is bad input for
// --check as for planning (2); a blocked straight line between feasible ones is not (0).

#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>

#include "cycle_plan.hpp"
#include "envelope_rule.hpp"
#include "json_writer.hpp"
#include "plan_json.hpp"
#include "svg_view.hpp"
#include "trace_view.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/anytime.hpp"
#include "mgc/planning/planners/cart_rrt.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/smoothing.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

using mgc::planning::JointType;
using mgc::planning::JointVector;
using mgc::planning::MachineModel;

std::string format_configuration(const MachineModel& model, const JointVector& q) {
  std::ostringstream s;
  s.precision(4);
  for (int i = 0; i < model.dof(); ++i) {
    const auto& j = model.joints()[static_cast<std::size_t>(i)];
    const bool revolute = j.type == JointType::Revolute;
    s << (i > 0 ? ", " : "") << j.name << " " << (revolute ? q[i] * 180.0 / std::numbers::pi : q[i])
      << (revolute ? " deg" : " m");
  }
  return s.str();
}

int run_check(const std::string& scenario_file, double envelope_margin_m) {
  auto loaded = mgc::planning::io::load_and_build(scenario_file);
  const auto envelope = mgc::tools::keep_envelope(loaded, envelope_margin_m);
  const auto& s = loaded.scenario;
  const MachineModel& model = *loaded.model;
  auto& world = *loaded.world;

  std::printf("scenario   %s (%s)\n", s.name.c_str(), s.file.c_str());
  std::printf("machine    %s, %s, %d joints (%s)\n", model.name().c_str(), to_string(model.kind()), model.dof(),
              s.machine.file.c_str());
  if (s.task && model.kind() == mgc::planning::MachineKind::MobileCrane) {
    std::printf("task       load %.0f lb, capacity reduction %.0f %%, rigging %s / %.0f lb counterweight\n",
                s.task->load_lb, s.task->capacity_reduction_pct, s.task->outriggers.c_str(), s.task->counterweight_lb);
  }
  std::printf("obstacles  %d static, %d dynamic; dilation %.2f m\n", world.num_static(), world.num_dynamic(),
              world.dilation_m());
  if (s.envelope) {
    const auto& e = *s.envelope;
    std::string points;
    for (const auto& p : e.points) points += (points.empty() ? "" : ", ") + p;
    std::string limits;
    const auto add = [&limits](const std::string& text) { limits += (limits.empty() ? "" : ", ") + text; };
    char buf[96];
    if (e.height_ceiling_m) add((std::snprintf(buf, sizeof buf, "ceiling %.2f m", *e.height_ceiling_m), buf));
    if (e.depth_floor_m) add((std::snprintf(buf, sizeof buf, "floor %.2f m", *e.depth_floor_m), buf));
    if (e.slew_left_rad) {
      add((std::snprintf(buf, sizeof buf, "slew %.1f..%.1f deg", *e.slew_right_rad * 180.0 / std::numbers::pi,
                         *e.slew_left_rad * 180.0 / std::numbers::pi),
           buf));
    }
    if (e.radius_min_m) add((std::snprintf(buf, sizeof buf, "radius >= %.2f m", *e.radius_min_m), buf));
    if (e.radius_max_m) add((std::snprintf(buf, sizeof buf, "radius <= %.2f m", *e.radius_max_m), buf));
    if (!e.walls.empty()) add(std::to_string(e.walls.size()) + (e.walls.size() == 1 ? " wall" : " walls"));
    std::printf("envelope   %s on %s; kept by %.2f m\n", limits.c_str(), points.c_str(), envelope_margin_m);
  }

  const auto errors = mgc::planning::io::check_endpoints(loaded);
  const auto report = [&](const char* label, const JointVector& q) {
    std::printf("%-10s %s\n", label, format_configuration(model, q).c_str());
    const auto v = world.validate(q);
    if (!v.valid()) {
      std::printf("           infeasible: %s\n", world.describe(v).c_str());
      return;
    }
    const auto c = world.clearance(q);
    const std::string nearest = c.with == mgc::planning::Contact::With::Static    ? world.static_name(c.other)
                                : c.with == mgc::planning::Contact::With::Dynamic ? world.dynamic_name(c.other)
                                                                                  : std::string("-");
    std::printf("           feasible, clearance %.2f m (%s to '%s')\n", c.distance_m,
                c.body >= 0 ? model.bodies()[static_cast<std::size_t>(c.body)].name.c_str() : "-", nearest.c_str());
  };
  report("start", s.start);
  report("goal", s.goal);
  if (s.work_cycle) {
    report("dumped", s.work_cycle->dumped);
    report("next dig", s.work_cycle->next_dig);
  }

  if (errors.empty()) {
    JointVector at;
    const auto steps = mgc::planning::step_sizes(model, s.planner.space_resolution);
    const auto edge = world.validate_edge(s.start, s.goal, steps, &at);
    if (edge.valid()) {
      std::printf("straight   the joint-space line from start to goal is free (no planning needed)\n");
    } else {
      std::printf("straight   the joint-space line from start to goal is blocked at %s: %s\n",
                  format_configuration(model, at).c_str(), world.describe(edge).c_str());
    }
  }
  for (const auto& e : errors) std::fprintf(stderr, "%s\n", e.what());
  return errors.empty() ? 0 : 2;
}

struct PlanOptions {
  std::string scenario;
  std::string planner;
  std::optional<std::uint64_t> seed;
  std::optional<int> max_iterations;
  double time_limit_s = 60.0;
  std::string json;
  std::string svg;
  bool svg_tree = false;
  bool smooth = true;
  double envelope_margin_m = mgc::tools::kControllerEnvelopeMarginM;
};

int run_plan(const PlanOptions& options) {
  using namespace mgc::planning;
  auto planner = make_planner(options.planner);
  if (!planner) {
    std::string names;
    for (auto n : planner_names()) names += (names.empty() ? "" : ", ") + std::string(n);
    std::fprintf(stderr, "mgc-plan: --planner: expected one of %s, got '%s'\n", names.c_str(), options.planner.c_str());
    return 2;
  }
  auto loaded = io::load_and_build(options.scenario);
  const auto envelope = mgc::tools::keep_envelope(loaded, options.envelope_margin_m);
  const auto errors = io::check_endpoints(loaded);
  if (!errors.empty()) {
    for (const auto& e : errors) std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  const Scenario& s = loaded.scenario;
  PlanningProblem problem = planning_problem(s, *loaded.model, *loaded.world);
  problem.max_iterations = options.max_iterations.value_or(problem.max_iterations);
  problem.seed = options.seed.value_or(problem.seed);

  // The planner reads no clock; the tool slices its work and watches the time.
  constexpr int kIterationsPerSlice = 50;
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed_s = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  PlannerStatus status = planner->reset(problem);
  bool timed_out = false;
  // The anytime planner reports improvements by iteration; the tool stamps them with the time.
  const auto* anytime = dynamic_cast<const AnytimePlanner*>(planner.get());
  std::vector<double> improvement_ms;
  while (status == PlannerStatus::Running) {
    if (elapsed_s() >= options.time_limit_s) {
      timed_out = true;
      break;
    }
    status = planner->step(kIterationsPerSlice);
    if (anytime) {
      while (improvement_ms.size() < anytime->history().size()) improvement_ms.push_back(1000.0 * elapsed_s());
    }
  }
  // Out of time, the anytime planner still has its best path so far.
  const bool anytime_best = anytime && timed_out && anytime->has_path();
  const double planning_time_ms = 1000.0 * elapsed_s();
  const PlannerStats stats = planner->stats();
  const bool success = status == PlannerStatus::Solved || anytime_best;
  std::vector<JointVector> path;
  if (success) path = planner->path();
  const int raw_path_nodes = static_cast<int>(path.size());
  double smoothing_time_ms = 0.0;
  // cart-rrt post-processes its own path (Cartesian shortcuts, then a time-scaled spline whose
  // samples are the path): straight joint-space shortcuts would throw that trajectory away.
  const auto* cart = dynamic_cast<const CartRrtPlanner*>(planner.get());
  const bool smooth = options.smooth && cart == nullptr;
  if (success && smooth) {
    // One joint at a time stays the rule for paths that follow it.
    SmoothingOptions smoothing;
    smoothing.single_axis = compute_path_metrics(*loaded.model, *loaded.world, path, problem.step).multi_joint_edges == 0;
    smoothing.seed = problem.seed;
    const auto t_smooth = std::chrono::steady_clock::now();
    path = smooth_path(*loaded.world, path, problem.step, smoothing);
    smoothing_time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_smooth).count();
  }
  const PathMetrics metrics = compute_path_metrics(*loaded.model, *loaded.world, path, problem.step);
  const std::string status_text = timed_out ? "time limit reached" : to_string(status);

  std::printf("%s %s seed %llu: %s in %.2f ms, %d iterations, %d tree nodes", options.planner.c_str(), s.name.c_str(),
              static_cast<unsigned long long>(problem.seed), status_text.c_str(), planning_time_ms, stats.iterations,
              stats.tree_nodes);
  if (success) {
    std::printf(", %d path nodes (%d raw), %d DoF switches, %.1f s one joint at a time, clearance %.2f m", metrics.path_nodes, raw_path_nodes,
                metrics.dof_switches, metrics.exec_time_sequential_s, metrics.min_clearance_m);
  }
  std::printf("\n");

  if (!options.svg.empty()) {
    mgc::tools::SvgInput view;
    view.scenario = &s;
    view.model = loaded.model.get();
    view.path = path;
    view.step = problem.step;
    if (options.svg_tree) planner->tree(view.tree_nodes, view.tree_parents);
    if (!mgc::tools::write_svg_file(options.svg, view)) return 2;
  }

  if (!options.json.empty()) {
    std::ofstream out(options.json);
    if (!out) {
      std::fprintf(stderr, "%s: cannot write the file\n", options.json.c_str());
      return 2;
    }
    const MachineModel& model = *loaded.model;
    mgc::tools::JsonWriter j(out);
    j.begin_object();
    j.key("success").value(success);
    j.key("status").value(status_text);
    j.key("planner").value(options.planner);
    j.key("scenario").value(s.file);
    j.key("seed").value(problem.seed);
    mgc::tools::write_joints(j, model);
    mgc::tools::write_path(j, model, path);
    j.key("planning_time_ms").value(planning_time_ms);
    j.key("iterations").value(stats.iterations);
    j.key("tree_nodes").value(stats.tree_nodes);
    j.key("collision_checks").value(stats.collision_checks);
    j.key("raw_path_nodes").value(raw_path_nodes);
    j.key("smoothed").value(success && smooth);
    j.key("smoothing_time_ms").value(smoothing_time_ms);
    mgc::tools::write_metrics(j, metrics);
    if (cart && success) {
      const CartRrtPlanner::Report& r = cart->report();
      j.key("cart_rrt").begin_object();
      j.key("trajectory_duration_s").value(r.duration_s);
      j.key("stops_at_vias").value(r.stops_at_vias);
      j.key("vias").value(r.vias);
      j.key("waypoints").value(r.waypoints);
      j.key("shortcuts").value(r.shortcuts);
      j.key("tool_length_m").value(r.tool_length_m);
      j.end_object();
    }
    if (anytime) {
      j.key("anytime_history").begin_array();
      for (std::size_t i = 0; i < anytime->history().size(); ++i) {
        const auto& h = anytime->history()[i];
        j.begin_object();
        j.key("time_ms").value(improvement_ms[i]);
        j.key("iterations").value(h.iterations);
        j.key("seed").value(problem.seed + static_cast<std::uint64_t>(h.seed_index));
        j.key("gamma").value(h.gamma);
        j.key("roughness").value(h.roughness);
        j.key("cost").value(h.cost);
        j.end_object();
      }
      j.end_array();
    }
    j.key("parameters").begin_object();
    j.key("max_iterations").value(problem.max_iterations);
    j.key("time_limit_s").value(options.time_limit_s);
    j.key("goal_bias").value(problem.goal_bias);
    j.key("space_resolution").value(s.planner.space_resolution);
    j.key("error_tolerance").value(problem.error_tolerance);
    j.key("dilation_m").value(s.planner.dilation_m);
    j.end_object();
    j.end_object();
    out << "\n";
  }
  return success ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-plan: load, check and plan crane and excavator lifts on a scenario file"};
  PlanOptions options;
  bool check = false;
  std::uint64_t seed = 0;
  int max_iterations = 0;
  app.add_option("--scenario", options.scenario, "scenario file (YAML, docs/scenario-format.md)")->required();
  app.add_flag("--check", check, "validate the scenario and report whether start and goal are feasible");
  std::string planner_list;
  for (auto n : mgc::planning::planner_names()) planner_list += (planner_list.empty() ? "" : ", ") + std::string(n);
  auto* planner_option = app.add_option("--planner", options.planner, "plan with this planner: " + planner_list + " (default: " + std::string(mgc::planning::kDefaultPlanner) + ")");
  auto* seed_option = app.add_option("--seed", seed, "random seed (default: the scenario's)");
  auto* iterations_option =
      app.add_option("--max-iterations", max_iterations, "iteration cap (default: the scenario's)")->check(mgc::tools::positive_number());
  app.add_option("--time-limit", options.time_limit_s, "wall-clock limit on planning [s] (default 60)")->check(mgc::tools::positive_number());
  app.add_option("--json", options.json, "write the plan and its metrics here (docs/plan-json.md)");
  app.add_option("--svg", options.svg, "draw top and side views of the site, the machine at start and goal, and the path");
  app.add_flag("--svg-tree", options.svg_tree, "also draw the planner's tree in the --svg views");
  bool no_smooth = false;
  app.add_flag("--no-smooth", no_smooth, "keep the planner's raw path (default: shortcut-smoothed)");
  app.add_option("--envelope-margin", options.envelope_margin_m,
                 "keep the scenario's working envelope (its envelope section) by this much [m] (default 1.25, as mgc)")
      ->check(mgc::tools::nonnegative_number());
  std::string trace;
  app.add_option("--trace", trace, "draw a controller run instead of planning: the trace of mgc --trace-csv, into --svg");
  bool cycle = false;
  app.add_flag("--cycle", cycle,
               "plan the scenario's work cycle (move-to-dump, dump, return; needs a work_cycle section and "
               "--planner nonuniform)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::fprintf(stderr, "mgc-plan: %s (see --help)\n", e.what());
    return 2;
  }
  if (*seed_option) options.seed = seed;
  options.smooth = !no_smooth;
  if (*iterations_option) options.max_iterations = max_iterations;
  if (!trace.empty()) {
    if (check || planner_option->count() > 0 || options.svg.empty()) {
      std::fprintf(stderr, "mgc-plan: --trace: expected --svg OUT and neither --check nor --planner\n");
      return 2;
    }
    try {
      return mgc::tools::run_trace_view(options.scenario, trace, options.svg);
    } catch (const mgc::planning::io::InputError& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 2;
    }
  }
  if (check && planner_option->count() > 0) {
    std::fprintf(stderr, "mgc-plan: give either --check or --planner NAME, not both (see --help)\n");
    return 2;
  }
  if (!check && planner_option->count() == 0) options.planner = mgc::planning::kDefaultPlanner;
  if (cycle && (check || options.planner != "nonuniform")) {
    std::fprintf(stderr, "mgc-plan: --cycle: expected --planner nonuniform (seed 003's subtask rules), got %s\n",
                 check ? "--check" : ("--planner " + options.planner).c_str());
    return 2;
  }
  try {
    if (cycle) {
      mgc::tools::CyclePlanOptions cycle_options;
      cycle_options.scenario = options.scenario;
      cycle_options.seed = options.seed;
      cycle_options.max_iterations = options.max_iterations;
      cycle_options.time_limit_s = options.time_limit_s;
      cycle_options.json = options.json;
      cycle_options.svg = options.svg;
      cycle_options.svg_tree = options.svg_tree;
      cycle_options.smooth = options.smooth;
      cycle_options.envelope_margin_m = options.envelope_margin_m;
      return mgc::tools::run_cycle_plan(cycle_options);
    }
    return check ? run_check(options.scenario, options.envelope_margin_m) : run_plan(options);
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
}
