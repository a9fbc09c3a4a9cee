// SPDX-License-Identifier: Apache-2.0
#include "replan_bench.hpp"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "json_writer.hpp"
#include "mgc/planning/execution.hpp"

namespace mgc::bench {
namespace {

using namespace mgc::planning;

//! Predicted poses are 1 s apart over each case's horizon.
constexpr double kPredictionSpacingS = 1.0;
constexpr int kMaxRepairs = 10;  //!< a lift still blocked after this many repairs counts as stuck

//! What a paper printed for the same kind of event.
struct PaperFigures {
  std::string header;
  std::string mean, min, max, sd, success, nodes, path;
};

struct EventCase {
  const char* scenario;
  const char* what;
  std::vector<double> start_times_s;  //!< phases: scenario time at which the lift starts
  //! How far ahead the machine sees the intruder's motion: long enough to get out of the way of an
  //! intruder that sweeps on (a slewing crane), not so long that one which stops (a truck that
  //! parks) is seen before the lift starts, which would leave no event to repair. [s]
  double horizon_s;
  std::vector<PaperFigures> paper;
};

const std::vector<EventCase>& cases() {
  static const std::vector<EventCase> all = {
      {"thesis-steel-frame.yaml",
       "TMS870 by the steel frame; crane 2 swings 90 deg into the west route from 60 s to 84 s (seed 000 case study 2, "
       "thesis hydraulic case)",
       {0.0, 15.0, 30.0},
       6.0,
       {{"paper: DRRT (seed 000 Table 5)", "5980", "170", "26970", "9630", "12/22", "-", "-"},
        {"paper: DRRT-Con-Con-Mod (seed 000 Table 5)", "1470", "110", "5270", "1400", "23/23", "-", "-"},
        {"paper: DRRT, hydraulic (thesis Table 4.3)", "1736", "-", "-", "3831", "-", "24.2", "4.6"}}},
      {"thesis-steel-frame-tower.yaml", "tower crane by the steel frame; tower crane 2 slews 90 deg from 60 s to 80 s",
       {0.0, 15.0, 30.0},
       // The hook can be 6 s ahead of crane 2's jib and need more than 6 s to leave its sweep.
       9.0,
       {{"paper: DRRT, tower (thesis Table 4.3)", "35", "-", "-", "819", "-", "19.2", "4.1"}}},
      {"excavator-truck.yaml", "Cat 320 loading a truck; truck 2 parks across the bucket's swing at 6.25 s",
       {0.0, 2.0, 4.0},
       3.0,
       {}},
  };
  return all;
}

struct Column {
  std::string replanner;
  int lifts = 0;
  int first_plans = 0;
  int arrived = 0;
  int lifts_with_contact = 0;
  int events = 0;
  int solved = 0;
  int covered = 0;         //!< events with the machine or the goal covered (machine_or_goal_covered)
  int covered_solved = 0;
  std::vector<double> repair_ms;  //!< every event, solved or not
  //! the events not covered: choosing the way out plus the repair, as stop_to_path_ms
  std::vector<double> uncovered_stop_to_path_ms;
  //! every event: choosing the way out of the prediction (if any) plus the repair
  std::vector<double> stop_to_path_ms;
  std::vector<double> solved_ms;
  int escapes_back = 0;      //!< repairs after backing off along the executed motion
  int escapes_by_joint = 0;  //!< repairs after moving one joint alone out of the prediction
  std::vector<double> escape_ms;
  double iterations = 0.0;
  double path_nodes = 0.0;
};

std::string fmt(double v, int decimals = 2) {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

double min_of(const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::min_element(v.begin(), v.end()); }
double max_of(const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end()); }

double wall_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

ReplanTables run_replanning_tables(const PlanningBenchOptions& options, int runs) {
  ReplanTables out;
  std::string& md = out.markdown;
  md += "#### Re-planning: seed 000 Table 5 and thesis Table 4.3\n\n";
  md += "Each lift runs with `execute_with_replanning` (docs/replanning.md): the machine moves along its path in 1/30 s "
        "ticks at full joint speed, the dynamic obstacles follow their scripted motion with predicted poses " +
        fmt(kPredictionSpacingS, 0) +
        " s apart over each site's horizon, and every blocked move stops the machine and calls the re-planner. Seeds " +
        std::to_string(options.first_seed) + ".." + std::to_string(options.first_seed + static_cast<std::uint64_t>(runs) - 1) +
        ", each started at several scenario times so the intrusion meets the lift at different phases; at most " +
        std::to_string(kMaxRepairs) +
        " repairs per lift. Repair time: wall clock from the stop to a valid new path (or to the failure), over every "
        "event. The papers' figures are seconds on 1.83 GHz dual-core laptops (seed 000: Pentium dual-core; thesis: "
        "Core2Duo T5550), shown here in ms.\n\n";
  bool con_con_mod_ok = true;
  std::string target_lines;
  for (const EventCase& c : cases()) {
    io::LoadedScenario loaded;
    try {
      loaded = io::load_and_build(std::filesystem::path(options.scenarios_dir) / c.scenario);
    } catch (const io::InputError& e) {
      std::fprintf(stderr, "mgc-bench: %s\n", e.what());
      out.markdown.clear();
      return out;
    }
    const int predicted_poses = static_cast<int>(std::lround(c.horizon_s / kPredictionSpacingS));
    loaded.world = build_world(loaded.scenario, *loaded.model, 0.0, predicted_poses);
    ReplanSettings replan;
    replan.max_iterations = loaded.scenario.planner.replan_max_iterations;
    replan.goal_bias = loaded.scenario.planner.replan_goal_bias;
    std::vector<Column> columns;
    const std::vector<std::string_view> names = replanner_names();
    Progress progress(std::string("replan ") + c.scenario,
                      static_cast<int>(names.size()) * runs * static_cast<int>(c.start_times_s.size()));
    for (std::string_view name : names) {
      Column col;
      col.replanner = std::string(name);
      for (int i = 0; i < runs; ++i) {
        const std::uint64_t seed = options.first_seed + static_cast<std::uint64_t>(i);
        for (double start_s : c.start_times_s) {
          PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
          problem.seed = seed;
          ExecutionSettings execution;
          execution.prediction_horizon_s = c.horizon_s;
          execution.start_time_s = start_s;
          execution.max_repairs = kMaxRepairs;
          execution.record_trajectory = false;
          auto replanner = make_replanner(name);
          const ExecutionResult r = execute_with_replanning(loaded.scenario, problem, *replanner, replan, execution, wall_ms);
          ++col.lifts;
          col.first_plans += r.first_plan == PlannerStatus::Solved ? 1 : 0;
          col.arrived += r.outcome == ExecutionResult::Outcome::Arrived ? 1 : 0;
          col.lifts_with_contact += r.contact_states > 0 ? 1 : 0;
          ReplanRow lift;
          lift.scenario = c.scenario;
          lift.replanner = std::string(name);
          lift.seed = seed;
          lift.start_time_s = start_s;
          lift.outcome = to_string(r.outcome);
          lift.contact_states = r.contact_states;
          lift.first_plan_ms = r.first_plan_ms;
          if (r.repairs.empty()) out.rows.push_back(lift);
          for (std::size_t k = 0; k < r.repairs.size(); ++k) {
            const RepairEvent& e = r.repairs[k];
            ++col.events;
            col.repair_ms.push_back(e.compute_ms);
            col.stop_to_path_ms.push_back(e.escape_ms + e.compute_ms);
            col.iterations += e.iterations;
            if (e.retreat_s > 0.0) {
              ++(e.escape_joint >= 0 ? col.escapes_by_joint : col.escapes_back);
              col.escape_ms.push_back(e.escape_ms);
            }
            if (machine_or_goal_covered(e)) {
              ++col.covered;
              col.covered_solved += e.status == PlannerStatus::Solved ? 1 : 0;
            } else {
              col.uncovered_stop_to_path_ms.push_back(e.escape_ms + e.compute_ms);
            }
            if (e.status == PlannerStatus::Solved) {
              ++col.solved;
              col.solved_ms.push_back(e.compute_ms);
              col.path_nodes += e.path_nodes;
            }
            ReplanRow row = lift;
            row.event = static_cast<int>(k);
            row.event_t_s = e.t_s;
            row.status = to_string(e.status);
            row.repair_ms = e.compute_ms;
            row.iterations = e.iterations;
            row.invalidated_nodes = e.invalidated_nodes;
            row.bridge_attempts = e.bridge_attempts;
            row.path_nodes = e.path_nodes;
            row.escape_ms = e.escape_ms;
            row.retreat_s = e.retreat_s;
            row.escape_joint = e.escape_joint;
            row.predicted_start_conflict = e.predicted_start_conflict;
            row.start_in_contact = e.start_in_contact;
            out.rows.push_back(std::move(row));
          }
          progress.tick(std::string(name) + " seed " + std::to_string(seed));
        }
      }
      columns.push_back(std::move(col));
    }

    md += std::string("**") + c.scenario + "**: " + c.what + "; horizon " + fmt(c.horizon_s, 0) + " s.\n\n| | ";
    for (const Column& col : columns) md += col.replanner + " | ";
    for (const PaperFigures& p : c.paper) md += p.header + " | ";
    md += "\n|---|";
    for (std::size_t k = 0; k < columns.size() + c.paper.size(); ++k) md += "---|";
    md += "\n";
    const auto row = [&](const std::string& label, const auto& ours, const auto& paper) {
      md += "| " + label + " | ";
      for (const Column& col : columns) md += ours(col) + " | ";
      for (const PaperFigures& p : c.paper) md += paper(p) + " | ";
      md += "\n";
    };
    const auto none = [](const PaperFigures&) { return std::string("-"); };
    row("lifts (seeds x phases)", [](const Column& col) { return std::to_string(col.lifts); }, none);
    row("lifts completed", [](const Column& col) { return std::to_string(col.arrived) + "/" + std::to_string(col.lifts); }, none);
    row("lifts where an obstacle reached the machine",
        [](const Column& col) { return std::to_string(col.lifts_with_contact); }, none);
    row("re-planning events solved", [](const Column& col) { return std::to_string(col.solved) + "/" + std::to_string(col.events); },
        [](const PaperFigures& p) { return p.success; });
    row("events with the machine or goal covered (solved)",
        [](const Column& col) { return std::to_string(col.covered) + " (" + std::to_string(col.covered_solved) + ")"; }, none);
    row("repair median ms", [](const Column& col) { return fmt(percentile(col.repair_ms, 0.5)); }, none);
    row("repair p95 ms", [](const Column& col) { return fmt(percentile(col.repair_ms, 0.95)); }, none);
    row("repair p99 ms", [](const Column& col) { return fmt(percentile(col.repair_ms, 0.99)); }, none);
    row("repair mean ms", [](const Column& col) { return fmt(mean(col.repair_ms)); }, [](const PaperFigures& p) { return p.mean; });
    row("repair min ms", [](const Column& col) { return fmt(min_of(col.repair_ms)); }, [](const PaperFigures& p) { return p.min; });
    row("repair max ms", [](const Column& col) { return fmt(max_of(col.repair_ms)); }, [](const PaperFigures& p) { return p.max; });
    row("repair sd ms", [](const Column& col) { return fmt(standard_deviation(col.repair_ms)); },
        [](const PaperFigures& p) { return p.sd; });
    row("repairs after moving out of the prediction: back / one joint",
        [](const Column& col) { return std::to_string(col.escapes_back) + " / " + std::to_string(col.escapes_by_joint); },
        none);
    row("choosing the way out, median / max ms",
        [](const Column& col) { return fmt(percentile(col.escape_ms, 0.5)) + " / " + fmt(max_of(col.escape_ms)); }, none);
    row("stop to new path with choosing the way out, median / p95 / p99 ms",
        [](const Column& col) {
          return fmt(percentile(col.stop_to_path_ms, 0.5)) + " / " + fmt(percentile(col.stop_to_path_ms, 0.95)) + " / " +
                 fmt(percentile(col.stop_to_path_ms, 0.99));
        },
        none);
    row("iterations per repair (mean)",
        [](const Column& col) { return col.events ? fmt(col.iterations / col.events, 1) : std::string("-"); },
        [](const PaperFigures& p) { return p.nodes; });
    row("repaired path nodes (mean)",
        [](const Column& col) { return col.solved ? fmt(col.path_nodes / col.solved, 1) : std::string("-"); },
        [](const PaperFigures& p) { return p.path; });
    md += "\n";

    for (const Column& col : columns) {
      // Seed 000's repair, and the controller's default with its one-joint bridges.
      if (col.replanner != "drrt-con-con-mod" && col.replanner != kDefaultReplanner) continue;
      // From the stop to the new path: choosing the way out of the prediction counts too. Events
      // with the machine or the goal covered are counted apart: no repair can solve them.
      const double median = percentile(col.uncovered_stop_to_path_ms, 0.5);
      const double p95 = percentile(col.uncovered_stop_to_path_ms, 0.95);
      const int must_solve = col.events - col.covered;
      const int solved = col.solved - col.covered_solved;
      const bool ok = col.events > 0 && solved == must_solve && median < 2.0 && p95 < 10.0 && col.lifts_with_contact == 0;
      con_con_mod_ok = con_con_mod_ok && ok;
      // A short run (the demo's two seeds) may meet no event on a site: nothing to judge there.
      const char* verdict = ok ? "**met**" : "**not met**";
      if (col.events == 0 && col.lifts_with_contact == 0) verdict = "no re-planning event in these lifts, so not measured";
      target_lines += std::string("- ") + c.scenario + ": " + col.replanner + ", stop to new path, median " + fmt(median) +
                      " ms (target < 2), p95 " +
                      fmt(p95) + " ms (target < 10), " + std::to_string(solved) + "/" + std::to_string(must_solve) +
                      " events solved (target all, the " + std::to_string(col.covered) +
                      " with the machine or goal covered apart), lifts an obstacle reached " + std::to_string(col.lifts_with_contact) +
                      " (target 0): " + verdict + ".\n";
    }
  }
  md += "Re-planning targets:\n\n" + target_lines + "\n";
  out.targets_met = con_con_mod_ok;
  return out;
}

void write_replan_csv(std::ostream& out, const std::vector<ReplanRow>& rows) {
  out << "scenario,replanner,seed,start_time_s,outcome,contact_states,first_plan_ms,event,event_t_s,status,repair_ms,"
         "iterations,invalidated_nodes,bridge_attempts,path_nodes,escape_ms,retreat_s,escape_joint,predicted_start_conflict,start_in_contact\n";
  for (const ReplanRow& r : rows) {
    out << r.scenario << ',' << r.replanner << ',' << r.seed << ',' << r.start_time_s << ',' << r.outcome << ','
        << r.contact_states << ',' << r.first_plan_ms << ',';
    if (r.event < 0) {
      out << ",,,,,,,,,,,,\n";
      continue;
    }
    out << r.event << ',' << r.event_t_s << ',' << r.status << ',' << r.repair_ms << ',' << r.iterations << ','
        << r.invalidated_nodes << ',' << r.bridge_attempts << ',' << r.path_nodes << ',' << r.escape_ms << ','
        << r.retreat_s << ',' << r.escape_joint << ',' << (r.predicted_start_conflict ? 1 : 0) << ','
        << (r.start_in_contact ? 1 : 0) << '\n';
  }
}

void write_replan_json(tools::JsonWriter& w, const std::vector<ReplanRow>& rows) {
  w.begin_array();
  for (const ReplanRow& r : rows) {
    w.begin_object();
    w.key("scenario").value(r.scenario).key("replanner").value(r.replanner).key("seed").value(r.seed);
    w.key("start_time_s").value(r.start_time_s).key("outcome").value(r.outcome);
    w.key("contact_states").value(r.contact_states).key("first_plan_ms").value(r.first_plan_ms);
    if (r.event >= 0) {
      w.key("event").value(r.event).key("event_t_s").value(r.event_t_s).key("status").value(r.status);
      w.key("repair_ms").value(r.repair_ms).key("iterations").value(r.iterations);
      w.key("invalidated_nodes").value(r.invalidated_nodes).key("bridge_attempts").value(r.bridge_attempts);
      w.key("path_nodes").value(r.path_nodes);
      w.key("escape_ms").value(r.escape_ms).key("retreat_s").value(r.retreat_s).key("escape_joint").value(r.escape_joint);
      w.key("predicted_start_conflict").value(r.predicted_start_conflict).key("start_in_contact").value(r.start_in_contact);
    }
    w.end_object();
  }
  w.end_array();
}

int run_replan_suite(const PlanningBenchOptions& options, const std::string& command) {
  const int runs = options.runs > 0 ? options.runs : 51;
  const ReplanTables t = run_replanning_tables(options, runs);
  if (t.markdown.empty()) return 2;
  const std::string md = "### replan\n\n`" + command + "`\n\n" + t.markdown;
  std::printf("%s\n", md.c_str());
  if (!options.out_dir.empty()) {
    std::filesystem::create_directories(options.out_dir);
    std::ofstream(options.out_dir + "/replan.md") << md;
    std::ofstream csv(options.out_dir + "/replan.csv");
    write_replan_csv(csv, t.rows);
    std::ofstream json(options.out_dir + "/replan.json");
    tools::JsonWriter w(json);
    w.begin_object().key("suite").value("replan").key("command").value(command).key("markdown").value(md);
    w.key("targets_met").value(t.targets_met).key("events");
    write_replan_json(w, t.rows);
    w.end_object();
    json << '\n';
  }
  return 0;
}

}  // namespace mgc::bench
