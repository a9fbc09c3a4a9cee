// SPDX-License-Identifier: Apache-2.0
#pragma once

// OMPL side by side: runs OMPL's planners on our PlanningProblem with our validity checks, so a
// comparison measures planners, not collision code. Built only when OMPL is found
// (MGC_BENCH_HAVE_OMPL); this header needs no OMPL headers.

#include <cstdint>
#include <string>
#include <vector>

#include "mgc/planning/planners/problem.hpp"

namespace mgc::bench {

enum class OmplPlanner : std::uint8_t {
  RrtConnect,  //!< ompl::geometric::RRTConnect
  Rrt,         //!< ompl::geometric::RRT
  BitStar,     //!< ompl::geometric::BITstar, stopped at its first solution
};

//! "ompl-rrtconnect", "ompl-rrt", "ompl-bitstar".
[[nodiscard]] constexpr const char* ompl_planner_name(OmplPlanner planner) noexcept {
  switch (planner) {
    case OmplPlanner::RrtConnect: return "ompl-rrtconnect";
    case OmplPlanner::Rrt: return "ompl-rrt";
    case OmplPlanner::BitStar: return "ompl-bitstar";
  }
  return "ompl";
}

struct OmplOptions {
  double time_limit_s = 2.0;  //!< per query; a run that finds no exact solution in it fails [s]
  //! Straight-line extension length, in steps (the step metric); 0: the problem's extend_steps,
  //! the length our bidirectional planners extend by.
  double range_steps = 0.0;
  //! Run the PathSimplifier after solve(); off where only the planning time is wanted.
  bool simplify = true;
};

struct OmplResult {
  bool solved = false;          //!< an exact solution (ends at the goal) within the time limit
  double time_ms = 0.0;         //!< planner setup + solve, wall clock [ms]
  int tree_nodes = 0;           //!< PlannerData vertices joined to a tree (an edge, or a root)
  int planner_data_vertices = 0;  //!< every PlannerData vertex (BIT* also lists unconnected samples)
  //! The world's collision_checks() when solve() returned, before simplification.
  std::uint64_t solve_collision_checks = 0;
  //! The world's body_checks() then.
  std::uint64_t solve_body_checks = 0;
  std::vector<planning::JointVector> path;        //!< raw: exact start to exact goal
  std::vector<planning::JointVector> simplified;  //!< after OMPL's PathSimplifier; empty when not asked for
  double simplify_ms = 0.0;     //!< PathSimplifier wall clock [ms]
  std::string error;            //!< not empty: the adapter found an inconsistency (reported loudly)
};

//! OMPL's global seed is once-only in 1.5.2 (RNG::setSeed after the first RNG exists only logs
//! an error), so the bench seeds it once, before any OMPL object exists. Returns false if OMPL
//! says it was too late.
bool seed_ompl_globally(std::uint32_t seed);

//! One query. The RNGs the adapter can reach -- every state sampler, RRT's and RRTConnect's own,
//! the path simplifier's -- are seeded from `seed`; BIT*'s private graph RNG draws from the
//! global generator, so a BIT* run repeats only within the same sequence of runs.
[[nodiscard]] OmplResult solve_with_ompl(const planning::PlanningProblem& problem, OmplPlanner planner,
                                         const OmplOptions& options, std::uint64_t seed);

//! "1.5.2".
[[nodiscard]] const char* ompl_version() noexcept;

}  // namespace mgc::bench
