// SPDX-License-Identifier: Apache-2.0
// mgc-bench: reproduces the seed papers' planning experiments on this machine and prints them
// beside OMPL's planners (when built with OMPL) and the published figures. Timings are wall clock
// on one core; compare ratios measured in one run, not absolute times across runs.

#include <CLI/CLI.hpp>
#include <malloc.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "mgc/planning/io/input_error.hpp"
#include "mgc/tools/cli_checks.hpp"

#include "bus_bench.hpp"
#include "campaign_bench.hpp"
#include "kim_bench.hpp"
#include "loop_bench.hpp"
#include "planning_bench.hpp"
#include "safety_bench.hpp"
#include "site_bench.hpp"
#include "site_scale_bench.hpp"
#include "sites_bench.hpp"
#include "trajectory_bench.hpp"
#include "replan_bench.hpp"
#include "zhang_bench.hpp"

namespace {

using PlanningSuite = int (*)(const mgc::bench::PlanningBenchOptions&, const std::string&);

//! The planning suites, in the order `--suite all` runs them.
const std::vector<std::pair<std::string, PlanningSuite>>& planning_suites() {
  static const std::vector<std::pair<std::string, PlanningSuite>> all = {
      {"thesis", mgc::bench::run_thesis_suite},
      {"zhang", mgc::bench::run_zhang_suite},
      {"replan", mgc::bench::run_replan_suite},
      {"langari", mgc::bench::run_langari_suite},
      {"sites", mgc::bench::run_sites_suite},
  };
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  // Freed memory stays in the process, as in mgc and mgc-sim: a query's allocations reuse pages
  // already mapped instead of faulting in fresh ones, so the times are the planners' and not the
  // kernel's (on this virtual machine a fresh page costs microseconds).
  (void)mallopt(M_TRIM_THRESHOLD, -1);
  (void)mallopt(M_MMAP_MAX, 0);
  CLI::App app{"mgc-bench: the seed papers' planning experiments, with OMPL's planners and the published figures beside ours"};
  std::string suite_name = "all";
  int runs = 0;
  std::uint64_t first_seed = 0;
  std::string out_dir;
  std::string scenarios_dir = "scenarios";
  std::string names;
  std::vector<std::string> site_families;
  int bus_samples = 1500;
  int trajectory_cases = 100000;
  mgc::bench::LoopBenchOptions loop;
  mgc::bench::OmplOptions ompl;
  mgc::bench::CampaignOptions campaign;
  mgc::bench::SiteScaleOptions scale;
  for (const auto& [name, run] : planning_suites()) names += std::string(names.empty() ? "" : ", ") + name;
  app.add_option("--suite", suite_name, "suite to run: " + names + ", kim (dual crane), campaign (randomized lifts judged in the true state), site (two cranes crossing, stepped time), site-scale (2 to 16 machines on a generated site, measured), all (thesis, zhang, langari, sites, kim, campaign, site), bus (fieldbus), trajectory, safety or loop (control cycle)");
  app.add_option("--runs", runs, "runs (seeds) per case; default: the paper's count (thesis, langari 50; zhang 51; kim 100); sites: seeds per site (6)")
      ->check(mgc::tools::positive_number());
  app.add_option("--seed", first_seed, "first seed; runs use seed, seed + 1, ...");
  app.add_option("--out", out_dir, "write <suite>.csv (every run), <suite>.json and <suite>.md (the tables) here");
  app.add_option("--scenarios", scenarios_dir, "folder of the shipped scenarios");
  app.add_option("--families", site_families, "sites suite: only these site families (docs/sites.md), comma-separated")
      ->delimiter(',');
  app.add_option("--bus-samples", bus_samples, "bus suite: SYNC round trips per latency case")->check(mgc::tools::positive_number());
  app.add_option("--trajectory-cases", trajectory_cases, "trajectory suite: calculations per case")->check(mgc::tools::positive_number());
  app.add_option("--loop-cycles", loop.cycles, "loop suite: timed controller cycles at 100 Hz")->check(mgc::tools::positive_number());
  app.add_option("--reaction-runs", loop.reaction_runs, "loop suite: intrusion runs per reaction case (100 Hz and 500 Hz with the tags at 10 Hz, 100 Hz with them at 100 Hz)")
      ->check(mgc::tools::positive_number());
  app.add_option("--loop-seconds", loop.loop_seconds, "loop suite: seconds of the live cyclic executive (0: skip)")
      ->check(mgc::tools::nonnegative_number());
  app.add_option("--sweep-first", loop.sweep_first_s, "loop suite: the intrusion sweep's first script offset of crane 2 [s]");
  app.add_option("--sweep-last", loop.sweep_last_s, "loop suite: the intrusion sweep's last script offset of crane 2 [s]");
  app.add_option("--sweep-step", loop.sweep_step_s, "loop suite: the intrusion sweep's offset step (0: skip the sweep) [s]")
      ->check(mgc::tools::nonnegative_number());
  app.add_option("--sweep-limit", loop.sweep_limit_s, "loop suite: simulated seconds a sweep run may take to reach the goal")
      ->check(mgc::tools::positive_number());
  app.add_option("--campaign-lifts", campaign.lifts,
                 "campaign suite: lifts up to K-1 (default 1500): lifts 0-999 on the shipped sites, from 1000 on generated sites")
      ->check(mgc::tools::positive_number());
  app.add_option("--campaign-first", campaign.first_lift, "campaign suite: the first lift (default 0; 1000: the generated sites' lifts alone)")
      ->check(mgc::tools::nonnegative_number());
  app.add_option("--lift", campaign.lift, "campaign suite: run lift N alone and print its whole record")
      ->check(mgc::tools::nonnegative_number());
  app.add_option("--campaign-threads", campaign.threads, "campaign suite: lifts run on this many threads (the results do not depend on it)")
      ->check(mgc::tools::positive_number());
  app.add_option("--scale-machines", scale.machines, "site-scale suite: the site sizes, comma-separated (default 2,4,8,16)")
      ->delimiter(',')
      ->check(CLI::Range(2, 16));
  app.add_option("--scale-seconds", scale.sim_s, "site-scale suite: simulated seconds per site (default 60)")
      ->check(mgc::tools::positive_number());
  app.add_option("--ompl-time-limit", ompl.time_limit_s, "OMPL: seconds per query before it counts as a failure")
      ->check(mgc::tools::positive_number());
  app.add_option("--ompl-range", ompl.range_steps, "OMPL RRT/RRTConnect extension length in steps; 0: our extend step")
      ->check(mgc::tools::nonnegative_number());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-bench: %s (see --help)\n", e.what());
    return 2;
  }
  std::vector<std::pair<std::string, PlanningSuite>> chosen;
  for (const auto& suite : planning_suites()) {
    // The zhang suite holds the re-planning tables (its Table 5), so `all` does not run them twice.
    if ((suite_name == "all" && suite.first != "replan") || suite_name == suite.first) chosen.push_back(suite);
  }
  const bool other_suite = suite_name == "bus" || suite_name == "trajectory" || suite_name == "safety" ||
                           suite_name == "loop" || suite_name == "kim" || suite_name == "campaign" || suite_name == "site" ||
                           suite_name == "site-scale";
  if (chosen.empty() && !other_suite) {
    std::fprintf(stderr, "mgc-bench: --suite: expected one of %s, kim, campaign, all, site, site-scale, bus, trajectory, safety, loop; got '%s'\n",
                 names.c_str(), suite_name.c_str());
    return 2;
  }
  if (!site_families.empty() && suite_name != "sites") {
    std::fprintf(stderr, "mgc-bench: --families: expected --suite sites, got --suite '%s'\n", suite_name.c_str());
    return 2;
  }
  std::string command = "mgc-bench";
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];
  if (!out_dir.empty()) {
    // Checked before the suites run, so that a long run does not end in a folder it cannot write.
    std::error_code error;
    std::filesystem::create_directories(out_dir, error);
    if (error || !std::filesystem::is_directory(out_dir) || ::access(out_dir.c_str(), W_OK) != 0) {
      std::fprintf(stderr, "mgc-bench: --out: cannot write to the folder '%s': %s\n", out_dir.c_str(),
                   error ? error.message().c_str() : "not a writable folder");
      return 2;
    }
  }
  if ((app.count("--scale-machines") > 0 || app.count("--scale-seconds") > 0) && suite_name != "site-scale") {
    std::fprintf(stderr, "mgc-bench: --scale-machines, --scale-seconds: expected --suite site-scale, got --suite '%s'\n", suite_name.c_str());
    return 2;
  }
  if (campaign.lift >= 0 && suite_name != "campaign") {
    std::fprintf(stderr, "mgc-bench: --lift: expected --suite campaign, got --suite '%s'\n", suite_name.c_str());
    return 2;
  }
  if (campaign.first_lift >= campaign.lifts) {
    std::fprintf(stderr, "mgc-bench: --campaign-first: expected a lift below --campaign-lifts (%d), got %d\n", campaign.lifts, campaign.first_lift);
    return 2;
  }
  if (campaign.lift >= 0 && campaign.lift >= campaign.lifts) {
    std::fprintf(stderr, "mgc-bench: --lift: expected a lift below --campaign-lifts (%d), got %d\n", campaign.lifts, campaign.lift);
    return 2;
  }
  const mgc::bench::KimBenchOptions kim{scenarios_dir, out_dir, command, runs, first_seed};
  campaign.scenarios_dir = scenarios_dir;
  campaign.out_dir = out_dir;
  campaign.command = command;
  campaign.first_seed = first_seed;
  // A suite that meets a scenario file it cannot read says so, like any other bad input.
  try {
    if (suite_name == "bus") return mgc::bench::run_bus_suite({scenarios_dir, out_dir, bus_samples});
    if (suite_name == "trajectory") return mgc::bench::run_trajectory_suite({out_dir, trajectory_cases, first_seed});
    if (suite_name == "safety") return mgc::bench::run_safety_suite({scenarios_dir, out_dir, 2000, first_seed});
    if (suite_name == "loop") {
      loop.scenarios_dir = scenarios_dir;
      loop.out_dir = out_dir;
      loop.first_seed = first_seed;
      return mgc::bench::run_loop_suite(loop);
    }
    if (suite_name == "kim") return mgc::bench::run_kim_suite(kim);
    if (suite_name == "campaign") return mgc::bench::run_campaign_suite(campaign);
    const mgc::bench::SiteBenchOptions site_options{scenarios_dir, out_dir, command};
    if (suite_name == "site") return mgc::bench::run_site_suite(site_options);
    if (suite_name == "site-scale") {
      scale.scenarios_dir = scenarios_dir;
      scale.out_dir = out_dir;
      scale.command = command;
      scale.seed = first_seed;
      return mgc::bench::run_site_scale_suite(scale);
    }
    // OMPL's global seed takes effect only before its first random generator exists: set it now.
    if (!mgc::bench::seed_ompl(static_cast<std::uint32_t>(first_seed))) {
      std::fprintf(stderr, "mgc-bench: OMPL refused the global seed; BIT* runs will not repeat\n");
    }
    const mgc::bench::PlanningBenchOptions options{scenarios_dir, out_dir, runs, first_seed, ompl, site_families};
    const auto t0 = std::chrono::steady_clock::now();
    int exit_code = 0;
    for (const auto& [name, run] : chosen) {
      const int code = run(options, command);
      if (code != 0) exit_code = code;
    }
    // `all` is every seed paper's suite: the dual-crane one too, and the safety campaign.
    if (suite_name == "all") {
      const int code = mgc::bench::run_kim_suite(kim);
      if (code != 0) exit_code = code;
      const int campaign_code = mgc::bench::run_campaign_suite(campaign);
      if (campaign_code != 0) exit_code = campaign_code;
      const int site_code = mgc::bench::run_site_suite(site_options);
      if (site_code != 0) exit_code = site_code;
    }
    if (exit_code == 0) {
      // The tables first, where both streams go to one log.
      std::fflush(stdout);
      std::fprintf(stderr, "mgc-bench: %zu suite(s) in %.1f s\n", chosen.size() + (suite_name == "all" ? 3 : 0),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return exit_code;
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "mgc-bench: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-bench: %s\n", e.what());
    return 1;
  }
}
