// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>

namespace mgc::bench {

struct SafetyBenchOptions {
  std::string scenarios_dir;  //!< folder of the shipped scenarios
  std::string out_dir;  //!< safety.md goes here when not empty
  int repeats = 2000;   //!< timed calls per case; the envelope's configurations per class [-]
  std::uint64_t seed = 0;  //!< the envelope's random configurations
};

//! The `safety` suite: time per call of the per-cycle safety functions on the thesis site, and of
//! the working-envelope limiter on the road site far from, near and beyond its limits
//! (docs/benchmarks.md §Safety). Prints a markdown report; returns the process exit code.
int run_safety_suite(const SafetyBenchOptions& options);

}  // namespace mgc::bench
