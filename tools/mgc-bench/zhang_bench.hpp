// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

#include "planning_bench.hpp"

namespace mgc::bench {

//! The `zhang` suite (seed 000, Zhang & Hammad 2012): Table 2 (RRT, RRT-Con-Con, RRT-Con-Con-Mod
//! over seeds 0-50, with OMPL beside them) and the anytime gamma sweep of Tables 3 and 4, on the
//! thesis steel frame (the paper gives no numeric geometry), and the re-planning events of Table 5
//! (replan_bench.hpp). Prints markdown, writes zhang.csv, zhang-anytime.csv, zhang-replan.csv,
//! zhang.json and zhang.md; returns the exit code.
int run_zhang_suite(const PlanningBenchOptions& options, const std::string& command);

}  // namespace mgc::bench
