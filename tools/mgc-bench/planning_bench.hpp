// SPDX-License-Identifier: Apache-2.0
#pragma once

// The planning suites' shared parts: one run of our planner or of OMPL's on a scenario, its path
// quality raw and simplified, an independent dense re-check of every path, summaries, the
// transposed tables (one column per planner, the paper's figures in the columns beside), the
// CSV/JSON files and a progress bar.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/problem.hpp"
#include "ompl_adapter.hpp"

namespace mgc::tools {
class JsonWriter;
}

namespace mgc::bench {

//! Writes a suite's own extra keys into its JSON object (after "runs").
using JsonExtra = std::function<void(tools::JsonWriter&)>;

struct PlanningBenchOptions {
  std::string scenarios_dir = "scenarios";
  std::string out_dir;  //!< <suite>.csv, <suite>.json and <suite>.md go here when not empty
  int runs = 0;         //!< seeds per case; 0: the suite's own (the paper's count)
  std::uint64_t first_seed = 0;
  OmplOptions ompl;
  std::vector<std::string> site_families;  //!< sites suite: the families to run; empty: all
};

//! Quality of one path by our metrics.
struct PathQuality {
  int nodes = 0;
  int dof_switches = 0;         //!< compute_path_metrics: changes of joint between single-joint edges
  //! Fewest changes of joint when every edge is driven one joint at a time (a multi-joint edge
  //! becomes one move per joint, in the best order): how an operator of the thesis's cranes
  //! would drive it. Equals dof_switches on single-joint paths.
  int sequential_switches = 0;
  int multi_joint_edges = 0;
  double exec_s = 0.0;          //!< one joint at a time at full speed [s]
  double roughness = 0.0;       //!< seed 000 Eq. 3 [-]
  double cost = 0.0;            //!< seed 000 Eq. 4: 0.5 t [min] + 0.5 roughness [-]
};

//! One query.
struct RunRecord {
  std::string scenario;
  std::string planner;
  std::uint64_t seed = 0;
  bool success = false;
  double time_ms = 0.0;         //!< ours: reset + steps; OMPL: setup + solve [ms]
  int iterations = 0;           //!< ours only
  int tree_nodes = 0;
  int planner_data_vertices = 0;  //!< OMPL only: every PlannerData vertex (BIT*: unconnected samples too)
  std::uint64_t collision_checks = 0;  //!< configurations checked for collision by the query
  //! Machine bodies checked against the static site by the query (CollisionWorld::body_checks:
  //! a body at a pose it was already checked at reuses that result).
  std::uint64_t body_checks = 0;
  //! Checks validate_edge makes on the raw path alone at the problem's step: a floor under any
  //! planner's checks for that path.
  std::uint64_t path_checks = 0;
  PathQuality raw;
  PathQuality simplified;       //!< ours: smooth_path (single-axis); OMPL: its PathSimplifier
  //! The raw path through our smooth_path (single-axis): for ours the same as simplified; for
  //! OMPL it separates what the planner gives from what the smoother gives.
  PathQuality our_smoothing;
  double simplify_ms = 0.0;
  int recheck_failures = 0;     //!< edges of the raw or simplified path failing the dense re-check
  std::string error;            //!< not empty: something is wrong with this run (printed loudly)
};

//! A scenario loaded once per case, with a second world for the dense re-check: half the
//! planner's dilation (the clearance validate_edge guarantees along the motion), a quarter of its
//! step -- the check tests/planning/dense_recheck.hpp applies to our planners.
struct BenchScenario {
  std::string file;
  planning::io::LoadedScenario loaded;
  std::unique_ptr<planning::CollisionWorld> recheck_world;
  planning::JointVector recheck_step;
};

//! Throws planning::io::InputError.
[[nodiscard]] BenchScenario load_bench_scenario(const std::string& scenarios_dir, const std::string& file);

//! The scenario's planning query with a seed and, when max_iterations > 0, that cap.
[[nodiscard]] planning::PlanningProblem bench_problem(BenchScenario& s, int max_iterations, std::uint64_t seed);

[[nodiscard]] PathQuality path_quality(BenchScenario& s, const std::vector<planning::JointVector>& path);

//! Collision checks of validating `path` edge by edge at the scenario's step (RunRecord::path_checks).
[[nodiscard]] std::uint64_t path_checks(BenchScenario& s, const std::vector<planning::JointVector>& path);

//! Edges of `path` failing the dense re-check, each printed to stderr.
int dense_recheck(BenchScenario& s, const std::string& what, const std::vector<planning::JointVector>& path);

//! Our planner `planner` (a make_planner name): planning, then smooth_path with single-axis
//! shortcuts (the thesis's rules of action), both paths re-checked.
[[nodiscard]] RunRecord run_ours(BenchScenario& s, const std::string& planner, int max_iterations, std::uint64_t seed);

//! The record of a finished query of ours, for a planner run by hand (run_ours uses it too): the
//! path smoothed, both measured and re-checked.
[[nodiscard]] RunRecord record_ours(BenchScenario& s, const std::string& planner, const planning::PlanningProblem& problem,
                                    bool solved, double time_ms, int iterations, int tree_nodes,
                                    const std::vector<planning::JointVector>& path);

//! OMPL's `planner` through the adapter; its raw path, OMPL's simplification of it and our
//! smooth_path of it measured and re-checked. Without OMPL: a failed record
//! whose error says "OMPL not built".
[[nodiscard]] RunRecord run_ompl(BenchScenario& s, OmplPlanner planner, const OmplOptions& options, int max_iterations,
                                 std::uint64_t seed);

//! Whether mgc-bench was built with OMPL.
[[nodiscard]] bool have_ompl() noexcept;
//! OMPL's version, or "not built".
[[nodiscard]] const char* ompl_build_version() noexcept;
//! seed_ompl_globally() when built with OMPL; true otherwise.
bool seed_ompl(std::uint32_t seed);

//! Means of path quality over successful runs.
struct QualityMean {
  double nodes = 0.0, switches = 0.0, multi_joint_edges = 0.0, exec_s = 0.0, roughness = 0.0, cost = 0.0;
};

//! Summary of one planner's runs on one case.
struct Summary {
  std::string header;            //!< column header
  int runs = 0;
  int successes = 0;
  std::vector<double> times_ms;  //!< successful runs
  double mean_tree_nodes = 0.0;
  double mean_collision_checks = 0.0;
  double mean_body_checks = 0.0;
  double mean_path_checks = 0.0;
  std::vector<double> us_per_check;  //!< planning time per collision check, successful runs [us]
  QualityMean raw;
  QualityMean simplified;
  QualityMean our_smoothing;
  int recheck_failures = 0;
  int errors = 0;
  std::string note;              //!< e.g. "OMPL not built"
};

[[nodiscard]] Summary summarize(const std::string& header, const std::vector<RunRecord>& runs);

//! value to `digits` places; "-" when not finite.
[[nodiscard]] std::string fixed(double value, int digits);
//! numerator / denominator to two places; "n/a" without figures on both sides.
[[nodiscard]] std::string ratio_text(double numerator, double denominator);
//! "**met**" or "**not met**", for the target lines.
[[nodiscard]] const char* verdict(bool met);

//! Nearest-rank percentile p (0..1) of the values; NaN for none. Every suite reports with it.
[[nodiscard]] inline double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(p * static_cast<double>(values.size())) - 1.0;
  const auto index = static_cast<std::size_t>(std::clamp(rank, 0.0, static_cast<double>(values.size() - 1)));
  return values[index];
}
[[nodiscard]] double mean(const std::vector<double>& values);
[[nodiscard]] double standard_deviation(const std::vector<double>& values);

//! Rows a planning table can show.
enum class Metric : std::uint8_t {
  Success, MedianMs, P95Ms, P99Ms, MeanMs, MinMs, MaxMs, SdMs, TreeNodes, CollisionChecks, BodyChecks, PathChecks, UsPerCheck,
  PathNodes, Switches, MultiJointEdges, ExecS, Roughness, Cost,
  SimplifiedPathNodes, SimplifiedSwitches, SimplifiedExecS, SimplifiedRoughness, SimplifiedCost,
  OurSmoothingSwitches, OurSmoothingExecS,
};

//! A published figure per row; rows it lacks print "-".
struct PaperColumn {
  std::string header;
  std::map<Metric, std::string> figures;
};

//! Rows are metrics; columns are our planners, OMPL's, then the paper's, left to right.
[[nodiscard]] std::string planning_table(const std::vector<Metric>& rows, const std::vector<Summary>& columns,
                                         const std::vector<PaperColumn>& paper);

//! "median of a / median of b" style ratios need successful runs on both sides; NaN otherwise.
[[nodiscard]] double median_ms(const Summary& s);

//! Every run record of a suite, for <suite>.csv and <suite>.json.
class RunLog {
 public:
  void add(const std::string& suite, const RunRecord& record);
  void write_csv(const std::string& path) const;
  //! Writes {"suite", "command", "ompl", "markdown", "runs": [...], then extra's keys}.
  void write_json(const std::string& path, const std::string& suite, const std::string& command,
                  const std::string& markdown, const JsonExtra& extra) const;
  [[nodiscard]] bool any_errors() const noexcept;

 private:
  std::vector<std::pair<std::string, RunRecord>> records_;
};

//! A progress bar on stderr: redrawn in place on a terminal, every tenth of the way otherwise.
class Progress {
 public:
  Progress(std::string suite, int total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  void tick(const std::string& what);

 private:
  std::string suite_;
  int total_;
  int done_ = 0;
  bool terminal_;
  int last_tenth_ = -1;
  double started_s_;
};

//! One column of a suite: our planner (a make_planner name) or OMPL's.
struct PlannerSpec {
  std::string header;       //!< column header
  std::string name;         //!< make_planner name, or OMPL's planner name
  bool ompl = false;
  OmplPlanner ompl_planner = OmplPlanner::RrtConnect;
  int max_iterations = 0;   //!< ours: 0 = the scenario's cap
};

[[nodiscard]] PlannerSpec ours_spec(std::string header, std::string name, int max_iterations = 0);
[[nodiscard]] PlannerSpec ompl_spec(OmplPlanner planner);

//! `runs` seeds from options.first_seed, each logged under `suite` and ticked on `progress`.
[[nodiscard]] std::vector<RunRecord> run_case(BenchScenario& s, const PlannerSpec& spec, const PlanningBenchOptions& options,
                                              int runs, const std::string& suite, RunLog& log, Progress& progress);

//! The thesis and langari suites (main.cpp dispatches by name); returns the exit code.
int run_thesis_suite(const PlanningBenchOptions& options, const std::string& command);
int run_langari_suite(const PlanningBenchOptions& options, const std::string& command);

//! Writes <suite>.md, .csv and .json under options.out_dir when it is set.
void write_suite_files(const PlanningBenchOptions& options, const std::string& suite, const std::string& command,
                       const std::string& markdown, const RunLog& log, const JsonExtra& extra = {});

}  // namespace mgc::bench
