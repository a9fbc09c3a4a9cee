// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

namespace mgc::bench {

struct BusBenchOptions {
  std::string scenarios_dir = "scenarios";  //!< where the latency cases find their scenario
  std::string out_dir;                      //!< bus.csv and bus.md go here when not empty
  int latency_samples = 1500;               //!< SYNC round trips per latency case [-]
};

//! The `bus` suite: throughput, Hal::read cost and one-way latency through the loop: and udp:
//! transports on this machine (docs/benchmarks.md §Fieldbus). Prints a markdown report; returns
//! the process exit code.
int run_bus_suite(const BusBenchOptions& options);

}  // namespace mgc::bench
