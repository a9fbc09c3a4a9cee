// SPDX-License-Identifier: Apache-2.0
#include "sites_bench.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>

#include "json_writer.hpp"
#include "mgc/planning/execution.hpp"
#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/planners/replanner.hpp"
#include "replan_bench.hpp"
#include "site_families.hpp"

namespace mgc::bench {

namespace {

//! The default one-joint-at-a-time planner and re-planner, whose targets the suite checks.
const std::string kDefaultPlannerName{planning::kDefaultPlanner};
const std::string kDefaultReplannerName{planning::kDefaultReplanner};

//! The planners the suite runs: every single-machine planner (multi-rrt lifts with two cranes).
std::vector<std::string> site_planners() {
  std::vector<std::string> names;
  for (const std::string_view n : planning::planner_names()) {
    if (n != "multi-rrt") names.emplace_back(n);
  }
  return names;
}

struct SiteRuns {
  GeneratedSite site;
  std::map<std::string, std::vector<RunRecord>> by_planner;
  std::string endpoint_message;  //!< the loader's first complaint about start or goal, as mgc-plan prints it
};

//! One row of a per-family table.
std::string family_row(const std::string& planner, const std::vector<RunRecord>& runs) {
  const Summary s = summarize(planner, runs);
  const double rate = s.runs > 0 ? 100.0 * s.successes / s.runs : std::numeric_limits<double>::quiet_NaN();
  // summarize() gives means over solved queries; none solved, none to show.
  const double n = s.successes > 0 ? 1.0 : std::numeric_limits<double>::quiet_NaN();
  return "| " + planner + " | " + std::to_string(s.successes) + "/" + std::to_string(s.runs) + " (" + fixed(rate, 1) + " %) | " +
         fixed(percentile(s.times_ms, 0.5), 2) + " | " + fixed(percentile(s.times_ms, 0.95), 2) + " | " + fixed(s.raw.nodes / n, 1) +
         " | " + fixed(s.raw.switches / n, 1) + " | " + fixed(s.raw.exec_s / n, 1) + " | " + fixed(s.simplified.exec_s / n, 1) +
         " | " + std::to_string(s.recheck_failures) + " |\n";
}

constexpr const char* kTableHead =
    "| planner | solved | median [ms] | p95 [ms] | path nodes | DoF switches | exec [s] | exec smoothed [s] | re-check failures |\n"
    "|---|---|---|---|---|---|---|---|---|\n";

//! Mean one-joint-at-a-time execution time of a planner's smoothed paths on one site; NaN if none.
double mean_exec_s(const std::vector<RunRecord>& runs) {
  double sum = 0.0;
  int n = 0;
  for (const RunRecord& r : runs) {
    if (!r.success) continue;
    sum += r.simplified.exec_s;
    ++n;
  }
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

std::filesystem::path sites_folder(const PlanningBenchOptions& options) {
  if (!options.out_dir.empty()) return std::filesystem::path(options.out_dir) / "sites";
  return std::filesystem::temp_directory_path() / ("mgc-bench-sites-" + std::to_string(::getpid()));
}

//! Re-planning figures of one re-planner on one machine's intruder sites.
struct ReplanColumn {
  int lifts = 0, arrived = 0, contact_lifts = 0;
  int events = 0, solved = 0;
  int covered = 0, covered_solved = 0;  //!< events where the intruder covered the machine or its goal
  std::vector<double> repair_ms;        //!< events not covered
};

//! How far ahead the machine sees the intruder (replan_bench.cpp's horizons for the same machines). [s]
double horizon_s(planning::MachineKind kind) {
  switch (kind) {
    case planning::MachineKind::TowerCrane: return 9.0;
    case planning::MachineKind::Excavator: return 3.0;
    default: return 6.0;
  }
}

double wall_clock_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct ReplanTable {
  std::string markdown;
  std::vector<ReplanRow> rows;
};

//! Every re-planner through execute_with_replanning on one intruder site per solvable family.
ReplanTable run_intruder_table(const PlanningBenchOptions& options, int seeds, const std::vector<const SiteFamily*>& families,
                               const std::filesystem::path& folder, const std::filesystem::path& machines) {
  using namespace mgc::planning;
  ReplanTable out;
  const std::vector<std::string_view> names = replanner_names();
  std::vector<GeneratedSite> sites;
  for (const SiteFamily* f : families) {
    if (f->expectation == SiteExpectation::Solvable) sites.push_back(generate_intruder_site(*f, options.first_seed, machines, folder));
  }
  if (sites.empty()) return out;
  constexpr int kMaxRepairs = 10;  // as the replan suite: a lift still blocked after this many counts as stuck
  const char* kinds[] = {"mobile_crane", "tower_crane", "excavator"};
  std::map<std::string, std::map<std::string, ReplanColumn>> table;  // [re-planner][machine]
  {
    Progress progress("sites re-planning", static_cast<int>(sites.size() * names.size()) * seeds);
    for (const GeneratedSite& site : sites) {
      io::LoadedScenario loaded = io::load_and_build(site.file);
      const double horizon = horizon_s(loaded.model->kind());
      loaded.world = build_world(loaded.scenario, *loaded.model, 0.0, static_cast<int>(std::lround(horizon)));
      const std::string machine = to_string(loaded.model->kind());
      ReplanSettings replan;
      replan.max_iterations = loaded.scenario.planner.replan_max_iterations;
      replan.goal_bias = loaded.scenario.planner.replan_goal_bias;
      for (const std::string_view name : names) {
        ReplanColumn& col = table[std::string(name)][machine];
        for (int k = 0; k < seeds; ++k) {
          PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
          problem.seed = options.first_seed + static_cast<std::uint64_t>(k);
          ExecutionSettings execution;
          execution.prediction_horizon_s = horizon;
          execution.max_repairs = kMaxRepairs;
          execution.record_trajectory = false;
          auto replanner = make_replanner(name);
          const ExecutionResult r = execute_with_replanning(loaded.scenario, problem, *replanner, replan, execution, wall_clock_ms);
          ++col.lifts;
          col.arrived += r.outcome == ExecutionResult::Outcome::Arrived ? 1 : 0;
          col.contact_lifts += r.contact_states > 0 ? 1 : 0;
          ReplanRow lift;
          lift.scenario = site.file.filename().string();
          lift.replanner = std::string(name);
          lift.seed = problem.seed;
          lift.outcome = to_string(r.outcome);
          lift.contact_states = r.contact_states;
          lift.first_plan_ms = r.first_plan_ms;
          if (r.repairs.empty()) out.rows.push_back(lift);
          for (std::size_t e = 0; e < r.repairs.size(); ++e) {
            const RepairEvent& ev = r.repairs[e];
            const bool solved = ev.status == PlannerStatus::Solved;
            const bool covered = machine_or_goal_covered(ev);
            ++col.events;
            if (covered) {
              ++col.covered;
              col.covered_solved += solved ? 1 : 0;
            } else {
              col.solved += solved ? 1 : 0;
              col.repair_ms.push_back(ev.compute_ms);
            }
            ReplanRow row = lift;
            row.event = static_cast<int>(e);
            row.event_t_s = ev.t_s;
            row.status = to_string(ev.status);
            row.repair_ms = ev.compute_ms;
            row.iterations = ev.iterations;
            row.invalidated_nodes = ev.invalidated_nodes;
            row.bridge_attempts = ev.bridge_attempts;
            row.path_nodes = ev.path_nodes;
            row.escape_ms = ev.escape_ms;
            row.retreat_s = ev.retreat_s;
            row.escape_joint = ev.escape_joint;
            row.predicted_start_conflict = ev.predicted_start_conflict;
            row.start_in_contact = ev.start_in_contact;
            out.rows.push_back(std::move(row));
          }
          progress.tick(lift.scenario + " " + lift.replanner);
        }
      }
    }
  }
  std::string& md = out.markdown;
  md += "\n#### Re-planning on generated sites with a second machine intruding\n\n"
        "One intruder site per solvable family (site seed " + std::to_string(options.first_seed) +
        ", files `<family>-s" + std::to_string(options.first_seed) +
        "-intruder.yaml`): the site with a second crane (a tipper at the excavator) that drives in from outside the reach "
        "and parks on the bearing halfway between pick and set-down (docs/sites.md). Each lift runs with "
        "`execute_with_replanning` as the replan suite runs it (1/30 s ticks, predicted poses 1 s apart over 6 s for the "
        "mobile crane, 9 s for the tower crane, 3 s for the excavator; at most " + std::to_string(kMaxRepairs) +
        " repairs per lift), " + std::to_string(seeds) +
        " seeds per site. Repair times over the events where the intruder did not cover the machine; those where it did "
        "(run into the stopped machine, its prediction still over it after the retreat, or parked on the goal) are counted apart.\n\n"
        "| re-planner | machine | lifts completed | lifts an obstacle reached | events solved | repair median [ms] | repair p95 [ms] | events with the machine or goal covered (solved) |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const std::string_view name : names) {
    for (const char* kind : kinds) {
      const auto it = table[std::string(name)].find(kind);
      if (it == table[std::string(name)].end()) continue;
      const ReplanColumn& c = it->second;
      md += "| " + std::string(name) + " | " + kind + " | " + std::to_string(c.arrived) + "/" + std::to_string(c.lifts) + " | " +
            std::to_string(c.contact_lifts) + " | " + std::to_string(c.solved) + "/" + std::to_string(c.events - c.covered) + " | " +
            fixed(percentile(c.repair_ms, 0.5), 2) + " | " + fixed(percentile(c.repair_ms, 0.95), 2) + " | " +
            std::to_string(c.covered) + " (" + std::to_string(c.covered_solved) + ") |\n";
    }
  }
  md += "\nTargets of the default re-planner `" + std::string(kDefaultReplannerName) + "`: ";
  const auto def = table.find(kDefaultReplannerName);
  if (def == table.end()) {
    md += "**not met**: it is not among this build's re-planners.\n";
  } else {
    ReplanColumn all;
    for (const auto& [kind, c] : def->second) {
      all.events += c.events;
      all.covered += c.covered;
      all.solved += c.solved;
      all.repair_ms.insert(all.repair_ms.end(), c.repair_ms.begin(), c.repair_ms.end());
    }
    const double median = percentile(all.repair_ms, 0.5), p95 = percentile(all.repair_ms, 0.95);
    md += "repair median " + fixed(median, 3) + " ms (target < 2): " + verdict(median < 2.0) + "; p95 " + fixed(p95, 3) +
          " ms (target < 10): " + verdict(p95 < 10.0) + "; events solved " + std::to_string(all.solved) + "/" +
          std::to_string(all.events - all.covered) + " (target all, the " + std::to_string(all.covered) +
          " covered events apart): " + verdict(all.solved == all.events - all.covered) + ".\n";
  }
  return out;
}
}  // namespace

int run_sites_suite(const PlanningBenchOptions& options, const std::string& command) {
  const std::string suite = "sites";
  const int seeds = options.runs > 0 ? options.runs : kSeedsPerSite;
  std::vector<const SiteFamily*> families;
  for (const std::string& name : options.site_families) {
    const SiteFamily* f = find_site_family(name);
    if (f == nullptr) {
      std::string known;
      for (const SiteFamily& k : site_families()) known += (known.empty() ? "" : ", ") + k.name;
      std::fprintf(stderr, "mgc-bench: --families: expected names among %s, got '%s'\n", known.c_str(), name.c_str());
      return 2;
    }
    families.push_back(f);
  }
  if (families.empty()) {
    for (const SiteFamily& f : site_families()) families.push_back(&f);
  }
  const std::filesystem::path folder = sites_folder(options);
  const std::filesystem::path machines = std::filesystem::path(options.scenarios_dir) / "machines";
  std::filesystem::create_directories(folder);

  std::vector<SiteRuns> sites;
  for (const SiteFamily* f : families) {
    for (int i = 0; i < kSitesPerFamily; ++i) {
      SiteRuns runs;
      try {
        runs.site = generate_site(*f, options.first_seed + static_cast<std::uint64_t>(i), machines, folder);
      } catch (const std::runtime_error& e) {
        // InputError (a machine file missing) passes on to main, which exits 2.
        if (dynamic_cast<const planning::io::InputError*>(&e) != nullptr) throw;
        std::fprintf(stderr, "mgc-bench: %s\n", e.what());
        return 1;
      }
      sites.push_back(std::move(runs));
    }
  }

  const std::vector<std::string> planners = site_planners();
  const auto seeds_for = [&](const SiteRuns& r, const std::string& planner) {
    const int n = r.site.family->expectation == SiteExpectation::Solvable ? seeds : std::min(seeds, kSeedsPerUnsolvableSite);
    return planner == "anytime" ? std::min(n, kAnytimeSeedsPerSite) : n;
  };
  int total = 0;
  for (const SiteRuns& r : sites) {
    for (const std::string& planner : planners) total += seeds_for(r, planner);
  }
  RunLog log;
  int unexpected_paths = 0;
  int chart_rows_named = 0, chart_sites = 0;
  {
    Progress progress(suite, total);
    for (SiteRuns& r : sites) {
      BenchScenario s = load_bench_scenario(folder.string(), r.site.file.filename().string());
      const auto complaints = planning::io::check_endpoints(s.loaded);
      if (!complaints.empty()) r.endpoint_message = complaints.front().what();
      if (r.site.family->expectation == SiteExpectation::ChartInfeasible) {
        ++chart_sites;
        if (r.endpoint_message.find("load-chart row") != std::string::npos) ++chart_rows_named;
      }
      for (const std::string& planner : planners) {
        for (int k = 0; k < seeds_for(r, planner); ++k) {
          RunRecord record = run_ours(s, planner, kSiteMaxIterations, options.first_seed + static_cast<std::uint64_t>(k));
          if (record.success && r.site.family->expectation != SiteExpectation::Solvable) {
            record.error = "returned a path on an unsolvable site";
            std::fprintf(stderr, "\nmgc-bench: ERROR: %s seed %llu on %s: a path on a site that has none\n", planner.c_str(),
                         static_cast<unsigned long long>(record.seed), s.file.c_str());
            ++unexpected_paths;
          }
          log.add(suite, record);
          r.by_planner[planner].push_back(std::move(record));
          progress.tick(s.file + " " + planner);
        }
      }
    }
  }

  std::string md = "### sites\n\nGenerated sites (docs/sites.md): " + std::to_string(families.size()) + " families x " +
                   std::to_string(kSitesPerFamily) + " sites (site seeds " + std::to_string(options.first_seed) + ".." +
                   std::to_string(options.first_seed + kSitesPerFamily - 1) + "), every planner with " + std::to_string(seeds) +
                   " seeds per solvable site and " + std::to_string(std::min(seeds, kSeedsPerUnsolvableSite)) +
                   " per unsolvable one (`anytime` " + std::to_string(kAnytimeSeedsPerSite) +
                   ": each of its queries is seed 000's optimising loop of 51 seeds x 8 runs, 0.1-5 s here), each query capped at " + std::to_string(kSiteMaxIterations) +
                   " iterations (the files' own cap). `--runs " + std::to_string(seeds) + " --seed " +
                   std::to_string(options.first_seed) + "`. The sites are in " + folder.string() +
                   "; replay a query with `mgc-plan --scenario <site> --planner P --seed S`.\n\n"
                   "Times over solved queries; path figures are means over solved queries of the planner's own path "
                   "(exec: one joint at a time at full speed, PathMetrics::exec_time_sequential_s) and, for exec smoothed, "
                   "of the path after smooth_path with single-axis shortcuts. Every path, raw and smoothed, is re-checked "
                   "densely (half the dilation, a quarter of the step).\n";

  // Solvable families, one table each, then all of them pooled.
  std::map<std::string, std::vector<RunRecord>> pooled;
  for (const SiteFamily* f : families) {
    if (f->expectation != SiteExpectation::Solvable) continue;
    md += "\n#### " + f->name + ": " + f->description + " (" + f->machine + ")\n\n" + kTableHead;
    for (const std::string& planner : planners) {
      std::vector<RunRecord> runs;
      for (const SiteRuns& r : sites) {
        if (r.site.family != f) continue;
        const auto& v = r.by_planner.at(planner);
        runs.insert(runs.end(), v.begin(), v.end());
      }
      pooled[planner].insert(pooled[planner].end(), runs.begin(), runs.end());
      md += family_row(planner, runs);
    }
  }
  if (!pooled.empty()) {
    md += "\n#### All solvable sites\n\n" + std::string(kTableHead);
    for (const std::string& planner : planners) md += family_row(planner, pooled[planner]);
  }

  // Unsolvable families: every query must end without a path.
  bool any_unsolvable = false;
  std::string unsolvable = "\n#### Unsolvable sites (counted apart: every query must end without a path)\n\n"
                           "| family | planner | queries | ended without a path | median time to give up [ms] | max [ms] |\n"
                           "|---|---|---|---|---|---|\n";
  for (const SiteFamily* f : families) {
    if (f->expectation == SiteExpectation::Solvable) continue;
    any_unsolvable = true;
    for (const std::string& planner : planners) {
      int queries = 0, failed = 0;
      std::vector<double> times;
      for (const SiteRuns& r : sites) {
        if (r.site.family != f) continue;
        for (const RunRecord& rec : r.by_planner.at(planner)) {
          ++queries;
          if (!rec.success) ++failed;
          times.push_back(rec.time_ms);
        }
      }
      unsolvable += "| " + f->name + " | " + planner + " | " + std::to_string(queries) + " | " + std::to_string(failed) + " | " +
                    fixed(percentile(times, 0.5), 2) + " | " + fixed(times.empty() ? std::numeric_limits<double>::quiet_NaN() : *std::max_element(times.begin(), times.end()), 2) +
                    " |\n";
    }
  }
  if (any_unsolvable) md += unsolvable;
  if (chart_sites > 0) {
    md += "\nChart-infeasible sites whose goal the loader refuses naming the load-chart row (mgc-plan exits 2 with it): " +
          std::to_string(chart_rows_named) + "/" + std::to_string(chart_sites) + ".\n";
  }

  // The default planner's targets.
  const bool have_default = std::find(planners.begin(), planners.end(), kDefaultPlannerName) != planners.end();
  md += "\n#### Targets of the default one-joint-at-a-time planner `" + std::string(kDefaultPlannerName) + "`\n\n";
  bool all_met = false;
  if (!have_default) {
    md += "**not met**: `" + std::string(kDefaultPlannerName) + "` is not among this build's planners.\n";
  } else if (pooled.empty()) {
    md += "**not met**: no solvable family was run.\n";
  } else {
    const Summary d = summarize(kDefaultPlannerName, pooled[kDefaultPlannerName]);
    const double rate = 100.0 * d.successes / std::max(1, d.runs);
    const double median = percentile(d.times_ms, 0.5), p95 = percentile(d.times_ms, 0.95);
    // Per solvable site: the default planner's mean smoothed execution time against the best
    // planner's on that site.
    std::vector<double> ratios;
    for (const SiteRuns& r : sites) {
      if (r.site.family->expectation != SiteExpectation::Solvable) continue;
      const double mine = mean_exec_s(r.by_planner.at(kDefaultPlannerName));
      double best = std::numeric_limits<double>::infinity();
      for (const std::string& planner : planners) {
        const double e = mean_exec_s(r.by_planner.at(planner));
        if (std::isfinite(e)) best = std::min(best, e);
      }
      ratios.push_back(std::isfinite(mine) && std::isfinite(best) && best > 0.0 ? mine / best : std::numeric_limits<double>::infinity());
    }
    const double ratio_median = percentile(ratios, 0.5);
    const double ratio_max = ratios.empty() ? std::numeric_limits<double>::quiet_NaN() : *std::max_element(ratios.begin(), ratios.end());
    const bool rate_met = rate >= 99.5, median_met = median < 2.0, p95_met = p95 < 10.0, exec_met = ratio_median <= 1.2;
    all_met = rate_met && median_met && p95_met && exec_met && d.recheck_failures == 0;
    md += "| target | this run | verdict |\n|---|---|---|\n";
    md += "| solved on solvable sites >= 99.5 % | " + std::to_string(d.successes) + "/" + std::to_string(d.runs) + " (" + fixed(rate, 2) +
          " %) | " + verdict(rate_met) + " |\n";
    md += "| median planning time < 2 ms | " + fixed(median, 3) + " ms | " + verdict(median_met) + " |\n";
    md += "| p95 planning time < 10 ms | " + fixed(p95, 3) + " ms | " + verdict(p95_met) + " |\n";
    md += "| one-joint-at-a-time execution time within 1.2x of the best planner's (per site, smoothed paths; median over sites) | " +
          fixed(ratio_median, 2) + "x (worst site " + fixed(ratio_max, 2) + "x) | " + verdict(exec_met) + " |\n";
    md += "| every path passes the dense re-check | " + std::to_string(d.recheck_failures) + " failing edge(s) | " +
          verdict(d.recheck_failures == 0) + " |\n";
  }
  if (unexpected_paths > 0) md += "\n**" + std::to_string(unexpected_paths) + " path(s) returned on unsolvable sites (see stderr).**\n";
  if (chart_rows_named < chart_sites) md += "\n**A chart-infeasible site's goal was not refused naming the load-chart row.**\n";

  const ReplanTable replanning = run_intruder_table(options, std::min(seeds, kReplanSeedsPerSite), families, folder, machines);
  md += replanning.markdown;

  std::printf("%s\n", md.c_str());
  write_suite_files(options, suite, command, md, log, [&](tools::JsonWriter& json) {
    json.key("replan_events");
    write_replan_json(json, replanning.rows);
    json.key("sites_folder").value(folder.string());
    json.key("default_planner").value(kDefaultPlannerName);
    json.key("default_planner_targets_met").value(all_met);
    json.key("sites").begin_array();
    for (const SiteRuns& r : sites) {
      json.begin_object();
      json.key("family").value(r.site.family->name);
      json.key("expectation").value(to_string(r.site.family->expectation));
      json.key("seed").value(r.site.seed);
      json.key("file").value(r.site.file.filename().string());
      json.key("draws").value(r.site.draws);
      json.key("endpoint_message").value(r.endpoint_message);
      json.end_object();
    }
    json.end_array();
  });
  return log.any_errors() || chart_rows_named < chart_sites ? 1 : 0;
}

}  // namespace mgc::bench
