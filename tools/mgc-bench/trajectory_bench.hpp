// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>

namespace mgc::bench {

struct TrajectoryBenchOptions {
  std::string out_dir;     //!< trajectory.md goes here when not empty
  int cases = 100000;      //!< random problems per case [-]
  std::uint64_t seed = 0;  //!< seed of the problem generator [-]
};

//! The `trajectory` suite: time per time-optimal 1-DoF calculation from a moving state, and per
//! four such calculations (docs/benchmarks.md §Trajectory). Prints a markdown report; returns the
//! process exit code.
int run_trajectory_suite(const TrajectoryBenchOptions& options);

}  // namespace mgc::bench
