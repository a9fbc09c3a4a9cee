// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>

namespace mgc::bench {

struct KimBenchOptions {
  std::string scenarios_dir = "scenarios";
  std::string out_dir;            //!< kim.csv, kim.json and kim.md go here when not empty
  std::string command;            //!< the command line, recorded in kim.json
  int runs = 0;                   //!< seeds per case; 0: 100
  std::uint64_t first_seed = 0;
  int max_iterations = 1000;      //!< the same iteration budget for every planner [-]
  double time_limit_s = 10.0;     //!< per run, checked between slices [s]
};

//! The `kim` suite: seed 004's three scenarios with multi-rrt, rrt and rrt-connect under the same
//! feasibility checker and budget (success, iterations, planning and smoothing time, path length,
//! girder travel, largest tilt), Table 2 beside it, and Table 3's cable-tilt sweep (20/10/5 deg)
//! (docs/benchmarks.md §kim). Prints a markdown report; returns the process exit code.
//! kim.csv and kim.json hold every run.
int run_kim_suite(const KimBenchOptions& options);

}  // namespace mgc::bench
