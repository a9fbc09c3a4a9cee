// SPDX-License-Identifier: Apache-2.0
// Kim suite: seed 004's dual-crane scenarios. The planner reads no clock; this harness slices its
// work, times the slices and stops a run at the time limit.
#include "kim_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "json_writer.hpp"
#include "planning_bench.hpp"
#include "mgc/planning/dual_crane.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/multi_rrt.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/smoothing.hpp"

namespace mgc::bench {
namespace {

using namespace mgc::planning;
using Clock = std::chrono::steady_clock;

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
constexpr int kSliceIterations = 10;
constexpr int kSmoothingPasses = 20;  // seed 004's n_smooth, for every planner

struct Run {
  bool success = false;
  int iterations = 0;
  int trees = 0;
  double plan_ms = 0.0;
  double smooth_ms = 0.0;
  double raw_length = 0.0;       //!< seed 004's C-space metric: Euclidean over (deg, m) [-]
  double length = 0.0;           //!< the same after smoothing [-]
  double girder_travel_m = 0.0;  //!< girder centre's path after smoothing [m]
  double max_cable_tilt_deg = 0.0;
  double max_girder_tilt_deg = 0.0;
};

double paper_length(const MachineModel& model, const std::vector<JointVector>& path) {
  double sum = 0.0;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const JointVector d = model.difference(path[e], path[e + 1]);
    double sq = 0.0;
    for (int j = 0; j < model.dof(); ++j) {
      const double v = model.joints()[static_cast<std::size_t>(j)].type == JointType::Revolute ? d[j] * kRadToDeg : d[j];
      sq += v * v;
    }
    sum += std::sqrt(sq);
  }
  return sum;
}

// Girder travel and the largest tilts along the path, four samples per anchor step.
void measure_path(const DualCraneModel& model, const std::vector<JointVector>& path, Run& r) {
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  bool first = true;
  for (std::size_t e = 0; e + 1 < path.size(); ++e) {
    const int n = 4 * model.edge_min_samples(path[e], path[e + 1]);
    for (int k = (e == 0 ? 0 : 1); k <= n; ++k) {
      const Suspension s = model.suspension(model.interpolate(path[e], path[e + 1], static_cast<double>(k) / n));
      if (!s.ok()) continue;
      const Eigen::Vector3d centre = 0.5 * (s.anchor_1_m + s.anchor_2_m);
      if (!first) r.girder_travel_m += (centre - previous).norm();
      previous = centre;
      first = false;
      r.max_cable_tilt_deg = std::max({r.max_cable_tilt_deg, std::abs(s.cable_tilt_1_rad) * kRadToDeg,
                                       std::abs(s.cable_tilt_2_rad) * kRadToDeg});
      r.max_girder_tilt_deg = std::max(r.max_girder_tilt_deg, std::abs(s.girder_tilt_rad) * kRadToDeg);
    }
  }
}

Run run_once(io::LoadedScenario& loaded, const std::string& planner_name, const KimBenchOptions& options,
             std::uint64_t seed) {
  PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
  problem.max_iterations = options.max_iterations;
  problem.seed = seed;
  auto planner = make_planner(planner_name);
  auto* multi = dynamic_cast<MultiRrtPlanner*>(planner.get());
  Run r;
  const auto t0 = Clock::now();
  const auto elapsed_ms = [&] { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); };
  PlannerStatus status = planner->reset(problem);
  while (status == PlannerStatus::Running && (!multi || multi->phase() == MultiRrtPlanner::Phase::Growing) &&
         elapsed_ms() < 1000.0 * options.time_limit_s) {
    status = planner->step(kSliceIterations);
  }
  r.plan_ms = elapsed_ms();
  r.iterations = planner->stats().iterations;
  if (multi) r.trees = multi->trees_created();
  std::vector<JointVector> raw;
  std::vector<JointVector> path;
  if (multi && multi->phase() != MultiRrtPlanner::Phase::Growing) {
    // Seed 004's Fig. 8 smoothing, inside the planner.
    const auto ts = Clock::now();
    while (status == PlannerStatus::Running) status = planner->step(kSmoothingPasses);
    r.smooth_ms = std::chrono::duration<double, std::milli>(Clock::now() - ts).count();
    raw = multi->raw_path();
    path = planner->path();
  } else if (status == PlannerStatus::Solved) {
    // The baselines' paths get the same number of shortcut attempts (node to node, straight).
    raw = planner->path();
    SmoothingOptions smoothing;
    smoothing.single_axis = false;
    smoothing.shortcut_attempts = kSmoothingPasses;
    smoothing.seed = seed;
    const auto ts = Clock::now();
    path = smooth_path(*loaded.world, raw, problem.step, smoothing);
    r.smooth_ms = std::chrono::duration<double, std::milli>(Clock::now() - ts).count();
  }
  r.success = status == PlannerStatus::Solved;
  if (r.success) {
    r.raw_length = paper_length(*loaded.model, raw);
    r.length = paper_length(*loaded.model, path);
    measure_path(static_cast<const DualCraneModel&>(*loaded.model), path, r);
  }
  return r;
}

template <class F>
std::vector<double> successful(const std::vector<Run>& runs, F field) {
  std::vector<double> out;
  for (const Run& r : runs) {
    if (r.success) out.push_back(field(r));
  }
  return out;
}

struct Published {
  const char* iterations;
  const char* iteration_s;
  const char* smoothing_s;
  const char* total_s;
};

// Seed 004 Table 2 (MATLAB, hardware not given), and Table 3's totals per cable-tilt limit.
const Published kTable2[] = {{"5.3", "5.22", "5.95", "11.17"}, {"12.1", "14.21", "8.52", "22.73"}, {"42.9", "53.92", "8.24", "62.16"}};
const char* const kTable3[3][3] = {{"10.59", "17.47", "48.92"}, {"11.17", "22.73", "62.16"}, {"20.53", "38.37", "150.48"}};

io::LoadedScenario load(const KimBenchOptions& options, const char* scenario, double cable_tilt_deg) {
  Scenario s = io::load_scenario(std::filesystem::path(options.scenarios_dir) / scenario);
  if (cable_tilt_deg > 0.0) s.dual_crane->max_cable_tilt_rad = cable_tilt_deg * std::numbers::pi / 180.0;
  io::LoadedScenario loaded;
  loaded.model = build_model(s);
  loaded.world = build_world(s, *loaded.model);
  loaded.scenario = std::move(s);
  return loaded;
}

//! One run as kim.csv and kim.json list it.
struct Record {
  const char* table;  //!< "main" (Table 2's comparison) or "table3" (the cable-tilt sweep)
  const char* scenario;
  const char* planner;
  double cable_tilt_deg;
  std::uint64_t seed;
  Run run;
};

void write_files(const KimBenchOptions& options, const std::string& markdown, const std::vector<Record>& records) {
  std::filesystem::create_directories(options.out_dir);
  std::ofstream(options.out_dir + "/kim.md") << markdown;
  std::ofstream csv(options.out_dir + "/kim.csv");
  csv << "table,scenario,planner,cable_tilt_deg,seed,success,iterations,trees,plan_ms,smooth_ms,raw_length,length,"
         "girder_travel_m,max_cable_tilt_deg,max_girder_tilt_deg\n";
  for (const Record& e : records) {
    const Run& r = e.run;
    csv << e.table << ',' << e.scenario << ',' << e.planner << ',' << e.cable_tilt_deg << ',' << e.seed << ',' << r.success
        << ',' << r.iterations << ',' << r.trees << ',' << r.plan_ms << ',' << r.smooth_ms << ',' << r.raw_length << ','
        << r.length << ',' << r.girder_travel_m << ',' << r.max_cable_tilt_deg << ',' << r.max_girder_tilt_deg << '\n';
  }
  std::ofstream out(options.out_dir + "/kim.json");
  tools::JsonWriter json(out);
  json.begin_object();
  json.key("suite").value("kim");
  json.key("command").value(options.command);
  json.key("markdown").value(markdown);
  json.key("runs").begin_array();
  for (const Record& e : records) {
    const Run& r = e.run;
    json.begin_object();
    json.key("table").value(e.table);
    json.key("scenario").value(e.scenario);
    json.key("planner").value(e.planner);
    json.key("cable_tilt_deg").value(e.cable_tilt_deg);
    json.key("seed").value(e.seed);
    json.key("success").value(r.success);
    json.key("iterations").value(r.iterations);
    json.key("trees").value(r.trees);
    json.key("plan_ms").value(r.plan_ms);
    json.key("smooth_ms").value(r.smooth_ms);
    json.key("raw_length").value(r.raw_length);
    json.key("length").value(r.length);
    json.key("girder_travel_m").value(r.girder_travel_m);
    json.key("max_cable_tilt_deg").value(r.max_cable_tilt_deg);
    json.key("max_girder_tilt_deg").value(r.max_girder_tilt_deg);
    json.end_object();
  }
  json.end_array();
  json.end_object();
  out << '\n';
}

}  // namespace

int run_kim_suite(const KimBenchOptions& options) {
  const int runs = options.runs > 0 ? options.runs : 100;
  const char* const scenarios[] = {"kim-s1.yaml", "kim-s2.yaml", "kim-s3.yaml"};
  const char* const planners[] = {"multi-rrt", "rrt-connect", "rrt"};
  // Every site loaded before the first run, so that a bad file ends the suite before it starts.
  std::vector<io::LoadedScenario> sites;
  for (const char* scenario : scenarios) sites.push_back(load(options, scenario, 0.0));
  std::vector<Record> records;
  // Table 2's comparison, then Table 3's sweep: 3 scenarios by 3 planners, 3 by 3 tilts.
  auto progress = std::make_unique<Progress>("kim", 2 * 9 * runs);
  const auto record = [&](const char* table, const char* scenario, const char* planner, double tilt, std::uint64_t seed,
                          const Run& r) { records.push_back({table, scenario, planner, tilt, seed, r}); };
  char line[1024];
  std::string md = "### kim\n\nSeed 004's scenarios (scenarios/kim-s*.yaml), " + std::to_string(runs) +
                   " seeds from " + std::to_string(options.first_seed) + ", iteration budget " +
                   std::to_string(options.max_iterations) + " for every planner, time limit " +
                   std::to_string(static_cast<int>(options.time_limit_s)) +
                   " s per run. Times over successful runs [ms]; plan = growth until start and goal connect, smooth = " +
                   std::to_string(kSmoothingPasses) +
                   " shortcut attempts (multi-rrt: seed 004's edge-point shortcuts; the others: node-to-node). Length: "
                   "seed 004's C-space metric (deg and m mixed), means. Travel: the girder centre's path [m]. Tilt: the "
                   "largest along the smoothed path [deg].\n\n"
                   "| scenario | planner | success | iterations (mean) | plan median | p95 | p99 | smooth median | raw length | "
                   "length | travel m | cable tilt max | girder tilt max |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<std::vector<Run>> multi_results;
  std::vector<double> s3_success(3, 0.0);
  for (int si = 0; si < 3; ++si) {
    io::LoadedScenario& loaded = sites[static_cast<std::size_t>(si)];
    for (int pi = 0; pi < 3; ++pi) {
      std::vector<Run> results;
      for (int i = 0; i < runs; ++i) {
        progress->tick(std::string(scenarios[si]) + " " + planners[pi]);
        const std::uint64_t seed = options.first_seed + static_cast<std::uint64_t>(i);
        results.push_back(run_once(loaded, planners[pi], options, seed));
        record("main", scenarios[si], planners[pi], 10.0, seed, results.back());
      }
      const auto plan = successful(results, [](const Run& r) { return r.plan_ms; });
      const auto smooth = successful(results, [](const Run& r) { return r.smooth_ms; });
      const auto iterations = successful(results, [](const Run& r) { return static_cast<double>(r.iterations); });
      std::snprintf(line, sizeof line, "| %s | %s | %zu/%d | %.1f | %.2f | %.2f | %.2f | %.2f | %.0f | %.0f | %.1f | %.2f | %.2f |\n",
                    scenarios[si], planners[pi], plan.size(), runs, mean(iterations), percentile(plan, 0.5),
                    percentile(plan, 0.95), percentile(plan, 0.99), percentile(smooth, 0.5),
                    mean(successful(results, [](const Run& r) { return r.raw_length; })),
                    mean(successful(results, [](const Run& r) { return r.length; })),
                    mean(successful(results, [](const Run& r) { return r.girder_travel_m; })),
                    percentile(successful(results, [](const Run& r) { return r.max_cable_tilt_deg; }), 1.0),
                    percentile(successful(results, [](const Run& r) { return r.max_girder_tilt_deg; }), 1.0));
      md += line;
      if (si == 2) s3_success[static_cast<std::size_t>(pi)] = static_cast<double>(plan.size()) / runs;
      if (pi == 0) multi_results.push_back(results);
    }
  }

  md += "\nmulti-rrt beside seed 004's Table 2 (MATLAB, mean seconds; ours: mean ms and mean trees rooted):\n\n"
        "| scenario | iterations | trees | plan ms | smooth ms | total ms | paper iterations | paper iteration s | paper "
        "smoothing s | paper total s |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (int si = 0; si < 3; ++si) {
    const auto& results = multi_results[static_cast<std::size_t>(si)];
    const double plan = mean(successful(results, [](const Run& r) { return r.plan_ms; }));
    const double smooth = mean(successful(results, [](const Run& r) { return r.smooth_ms; }));
    std::snprintf(line, sizeof line, "| %s | %.1f | %.1f | %.2f | %.2f | %.2f | %s | %s | %s | %s |\n", scenarios[si],
                  mean(successful(results, [](const Run& r) { return static_cast<double>(r.iterations); })),
                  mean(successful(results, [](const Run& r) { return static_cast<double>(r.trees); })), plan, smooth,
                  plan + smooth, kTable2[si].iterations, kTable2[si].iteration_s, kTable2[si].smoothing_s, kTable2[si].total_s);
    md += line;
  }

  md += "\nTable 3, multi-rrt against the cable-tilt limit phi_h,max (girder tilt limit kept at 10 deg): success, "
        "median / p95 total ms (plan + smooth), mean iterations; the paper's mean total seconds beside.\n\n"
        "| scenario | phi_h,max | success | total median ms | p95 | iterations | paper total s | ratio to 10 deg (ours) | "
        "ratio to 10 deg (paper) |\n|---|---|---|---|---|---|---|---|---|\n";
  for (int si = 0; si < 3; ++si) {
    double at_10_ms = 0.0;
    const double tilts[] = {20.0, 10.0, 5.0};
    double medians[3] = {0, 0, 0};
    std::size_t solved[3] = {0, 0, 0};
    double p95[3] = {0, 0, 0};
    double iterations[3] = {0, 0, 0};
    for (int ti = 0; ti < 3; ++ti) {
      io::LoadedScenario loaded = load(options, scenarios[si], tilts[ti]);
      std::vector<Run> results;
      for (int i = 0; i < runs; ++i) {
        progress->tick("table 3 " + std::string(scenarios[si]) + " " + std::to_string(static_cast<int>(tilts[ti])) + " deg");
        const std::uint64_t seed = options.first_seed + static_cast<std::uint64_t>(i);
        results.push_back(run_once(loaded, "multi-rrt", options, seed));
        record("table3", scenarios[si], "multi-rrt", tilts[ti], seed, results.back());
      }
      const auto total = successful(results, [](const Run& r) { return r.plan_ms + r.smooth_ms; });
      medians[ti] = percentile(total, 0.5);
      p95[ti] = percentile(total, 0.95);
      solved[ti] = total.size();
      iterations[ti] = mean(successful(results, [](const Run& r) { return static_cast<double>(r.iterations); }));
      if (ti == 1) at_10_ms = medians[ti];
    }
    for (int ti = 0; ti < 3; ++ti) {
      const double paper_ratio = std::stod(kTable3[ti][si]) / std::stod(kTable3[1][si]);
      std::snprintf(line, sizeof line, "| %s | %.0f deg | %zu/%d | %.2f | %.2f | %.1f | %s | %.2f | %.2f |\n", scenarios[si],
                    tilts[ti], solved[ti], runs, medians[ti], p95[ti], iterations[ti], kTable3[ti][si],
                    medians[ti] / at_10_ms, paper_ratio);
      md += line;
    }
  }
  std::snprintf(line, sizeof line,
                "\nScenario 3 at the same budget: multi-rrt %.0f %%, rrt-connect %.0f %%, rrt %.0f %% solved.\n",
                100.0 * s3_success[0], 100.0 * s3_success[1], 100.0 * s3_success[2]);
  md += line;
  progress.reset();  // its last line before the tables
  std::printf("%s", md.c_str());
  if (!options.out_dir.empty()) write_files(options, md, records);
  return 0;
}

}  // namespace mgc::bench
