// SPDX-License-Identifier: Apache-2.0
// mgc-bench: reproduces the seed papers' planning experiments on this machine and prints them
// beside the published figures. Timings are wall clock on one core; compare ratios measured in
// one run, not absolute times across runs.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bus_bench.hpp"
#include "safety_bench.hpp"
#include "trajectory_bench.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/path_metrics.hpp"
#include "mgc/planning/planners/planner.hpp"

namespace {

using namespace mgc::planning;

struct Run {
  std::uint64_t seed = 0;
  bool success = false;
  double time_ms = 0.0;
  int iterations = 0;
  int tree_nodes = 0;
  int path_nodes = 0;
  int dof_switches = 0;
  double exec_time_s = 0.0;
};

//! What the paper printed for the same experiment, for the table's last columns.
struct Published {
  const char* time = "-";
  const char* tree_nodes = "-";
  const char* path_nodes = "-";
  const char* source = "";
};

struct Case {
  const char* scenario;
  const char* planner;
  int max_iterations;  //!< 0: the scenario's
  Published paper;
};

struct Suite {
  const char* name;
  const char* what;
  std::vector<Case> cases;
};

const std::vector<Suite>& suites() {
  static const std::vector<Suite> all = {
      {"thesis",
       "ICE-Planner thesis §4.9 / Table 4.2: RRTBiasedLimCon (limcon) vs RRTGoalBiased (rrt), 50 seeds; paper on a "
       "Core2Duo T5550 1.83 GHz",
       {{"thesis-steel-frame.yaml", "limcon", 0, {"1.0733 s", "36.88", "8.48", "thesis §4.9"}},
        {"thesis-steel-frame.yaml", "rrt", 20000, {"5.1167 s", "1590.5", "187.48", "thesis §4.9"}},
        {"thesis-steel-frame-tower.yaml", "limcon", 0, {"1.071 s", "64.98", "8.42", "thesis Table 4.2"}}}},
      {"langari",
       "Langari & Hammad Table 2: basic (rrt-basic) vs non-uniform RRT, 50 runs; paper on a 3.40 GHz CPU",
       {{"excavator-pipelines.yaml", "rrt-basic", 20000, {"186 ms", "716.2", "-", "seed 003 Table 2"}},
        {"excavator-pipelines.yaml", "nonuniform", 0, {"12 ms", "40.0", "-", "seed 003 Table 2"}}}},
  };
  return all;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(std::min<double>(values.size() - 1, std::ceil(p * values.size()) - 1));
  return values[index];
}

Run run_once(io::LoadedScenario& loaded, const std::string& planner_name, int max_iterations, std::uint64_t seed) {
  PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
  if (max_iterations > 0) problem.max_iterations = max_iterations;
  problem.seed = seed;
  auto planner = make_planner(planner_name);
  Run r;
  r.seed = seed;
  const auto t0 = std::chrono::steady_clock::now();
  PlannerStatus status = planner->reset(problem);
  while (status == PlannerStatus::Running) status = planner->step(100);
  r.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const PlannerStats stats = planner->stats();
  r.success = status == PlannerStatus::Solved;
  r.iterations = stats.iterations;
  r.tree_nodes = stats.tree_nodes;
  if (r.success) {
    const PathMetrics m = compute_path_metrics(*loaded.model, *loaded.world, planner->path(), problem.step);
    r.path_nodes = m.path_nodes;
    r.dof_switches = m.dof_switches;
    r.exec_time_s = m.exec_time_sequential_s;
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-bench: the seed papers' planning experiments, with the published figures beside ours"};
  std::string suite_name = "all";
  int runs = 50;
  std::uint64_t first_seed = 0;
  std::string out_dir;
  std::string scenarios_dir = "scenarios";
  std::string names;
  int bus_samples = 1500;
  int trajectory_cases = 100000;
  for (const Suite& s : suites()) names += std::string(names.empty() ? "" : ", ") + s.name;
  app.add_option("--suite", suite_name, "suite to run: " + names + ", all (the planning suites), bus (fieldbus), trajectory or safety");
  app.add_option("--runs", runs, "runs (seeds) per case")->check(CLI::PositiveNumber);
  app.add_option("--seed", first_seed, "first seed; runs use seed, seed + 1, ...");
  app.add_option("--out", out_dir, "write <suite>.csv (every run) and <suite>.md (the table) here");
  app.add_option("--scenarios", scenarios_dir, "folder of the shipped scenarios");
  app.add_option("--bus-samples", bus_samples, "bus suite: SYNC round trips per latency case")->check(CLI::PositiveNumber);
  app.add_option("--trajectory-cases", trajectory_cases, "trajectory suite: calculations per case")->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-bench: %s (see --help)\n", e.what());
    return 2;
  }
  if (suite_name == "bus") return mgc::bench::run_bus_suite({scenarios_dir, out_dir, bus_samples});
  if (suite_name == "trajectory") return mgc::bench::run_trajectory_suite({out_dir, trajectory_cases, first_seed});
  if (suite_name == "safety") return mgc::bench::run_safety_suite({scenarios_dir, out_dir});
  std::vector<const Suite*> chosen;
  for (const Suite& s : suites()) {
    if (suite_name == "all" || suite_name == s.name) chosen.push_back(&s);
  }
  if (chosen.empty()) {
    std::fprintf(stderr, "mgc-bench: --suite: expected one of %s, all, bus, trajectory, safety; got '%s'\n", names.c_str(), suite_name.c_str());
    return 2;
  }
  if (!out_dir.empty()) std::filesystem::create_directories(out_dir);

  for (const Suite* suite : chosen) {
    std::string table = std::string("### ") + suite->name + "\n\n" + suite->what + ". `--runs " + std::to_string(runs) +
                        " --seed " + std::to_string(first_seed) + "`.\n\n" +
                        "| scenario | planner | success | median ms | p95 ms | p99 ms | tree nodes | path nodes | DoF switches | exec s | paper time | paper tree | paper path |\n"
                        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    std::ofstream csv;
    if (!out_dir.empty()) {
      csv.open(out_dir + "/" + suite->name + ".csv");
      csv << "suite,scenario,planner,seed,success,time_ms,iterations,tree_nodes,path_nodes,dof_switches,exec_time_s\n";
    }
    for (const Case& c : suite->cases) {
      io::LoadedScenario loaded;
      try {
        loaded = io::load_and_build(std::filesystem::path(scenarios_dir) / c.scenario);
      } catch (const io::InputError& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
      }
      std::vector<Run> results;
      for (int i = 0; i < runs; ++i) {
        std::fprintf(stderr, "\r[%s] %s %s %d/%d   ", suite->name, c.scenario, c.planner, i + 1, runs);
        results.push_back(run_once(loaded, c.planner, c.max_iterations, first_seed + static_cast<std::uint64_t>(i)));
        const Run& r = results.back();
        if (csv) {
          csv << suite->name << ',' << c.scenario << ',' << c.planner << ',' << r.seed << ',' << r.success << ',' << r.time_ms
              << ',' << r.iterations << ',' << r.tree_nodes << ',' << r.path_nodes << ',' << r.dof_switches << ','
              << r.exec_time_s << '\n';
        }
      }
      std::fprintf(stderr, "\n");
      std::vector<double> times;
      double tree = 0.0, path = 0.0, switches = 0.0, exec = 0.0;
      for (const Run& r : results) {
        if (!r.success) continue;
        times.push_back(r.time_ms);
        tree += r.tree_nodes;
        path += r.path_nodes;
        switches += r.dof_switches;
        exec += r.exec_time_s;
      }
      const double n = std::max<double>(1.0, static_cast<double>(times.size()));
      char row[512];
      std::snprintf(row, sizeof row, "| %s | %s | %zu/%d | %.2f | %.2f | %.2f | %.1f | %.1f | %.1f | %.1f | %s | %s | %s |\n",
                    c.scenario, c.planner, times.size(), runs, percentile(times, 0.5), percentile(times, 0.95),
                    percentile(times, 0.99), tree / n, path / n, switches / n, exec / n, c.paper.time, c.paper.tree_nodes,
                    c.paper.path_nodes);
      table += row;
    }
    table += "\nTimes over successful runs; nodes, switches and execution time (one joint at a time) are means over "
             "successful runs, raw paths (no smoothing).\n";
    std::printf("%s\n", table.c_str());
    if (!out_dir.empty()) std::ofstream(out_dir + "/" + suite->name + ".md") << table;
  }
  return 0;
}
