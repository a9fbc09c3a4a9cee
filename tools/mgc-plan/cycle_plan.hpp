// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace mgc::tools {

//! `mgc-plan --cycle`: what to plan and where to write it.
struct CyclePlanOptions {
  std::string scenario;
  std::optional<std::uint64_t> seed;
  std::optional<int> max_iterations;  //!< per subtask
  double time_limit_s = 60.0;         //!< for the whole cycle [s]
  std::string json;
  std::string svg;
  bool svg_tree = false;
  bool smooth = true;
  double envelope_margin_m = 1.25;  //!< the working envelope kept by this much (envelope_rule.hpp) [m]
};

//! Plans the scenario's work cycle (seed 003: move-to-dump, dump, return) with `nonuniform` and
//! reports it as mgc-plan does a single query, plus one entry per subtask (docs/plan-json.md).
//! Returns the exit status: 0 planned, 1 a subtask found no path, 2 bad input (one line on
//! stderr). Throws io::InputError for a bad scenario file.
int run_cycle_plan(const CyclePlanOptions& options);

}  // namespace mgc::tools
