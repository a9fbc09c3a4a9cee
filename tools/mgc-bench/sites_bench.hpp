// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

#include "planning_bench.hpp"

namespace mgc::bench {

//! Planner seeds per intruder site in the re-planning table at most (one intruder site per solvable
//! family; fewer with a smaller --runs).
inline constexpr int kReplanSeedsPerSite = 2;

//! Sites drawn per family (seeds first_seed, first_seed + 1, ...).
inline constexpr int kSitesPerFamily = 3;
//! Planner seeds per solvable site when --runs is not given.
inline constexpr int kSeedsPerSite = 6;
//! Planner seeds per unsolvable site at most: each run of a slow planner burns its whole cap.
inline constexpr int kSeedsPerUnsolvableSite = 2;
//! `anytime` runs seed 000's whole optimising loop (51 seeds, 8 runs each) per query: 0.1-5 s on
//! a generated site, so it gets this many seeds per site at most to keep the suite in its time.
inline constexpr int kAnytimeSeedsPerSite = 1;

//! The generalization suite (docs/sites.md): generated sites of every family, every single-machine
//! planner on each with a dense re-check of every path; tables per family, the unsolvable
//! families apart, and the default planner's targets. Writes sites.md, sites.csv and sites.json
//! under options.out_dir, the sites themselves under <out_dir>/sites/ (a temporary folder
//! without --out). Returns the exit code.
int run_sites_suite(const PlanningBenchOptions& options, const std::string& command);

}  // namespace mgc::bench
