// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>

namespace mgc::bench {

struct LoopBenchOptions {
  std::string scenarios_dir = "scenarios";  //!< folder of the shipped scenarios
  std::string out_dir;                      //!< loop.md and loop.csv go here when not empty
  int cycles = 100'000;                     //!< timed controller cycles at 100 Hz of simulated time [-]
  int reaction_runs = 30;                   //!< intrusion runs per control rate [-]
  double loop_seconds = 30.0;               //!< live CyclicExecutive run; 0 skips it [s]
  std::uint64_t first_seed = 0;             //!< simulator seeds are first_seed + 1, + 2, ...
  //! Intrusion timing sweep: crane 2's script offsets first, first + step, ... up to last; a step
  //! of 0 skips the sweep. [s]
  double sweep_first_s = 14.0;
  double sweep_last_s = 46.0;
  double sweep_step_s = 2.0;
  double sweep_limit_s = 900.0;             //!< a sweep run that has not reached the goal ends here [s]
};

//! The `loop` suite: the controller's whole cycle (Hal::read, Controller::step, Hal::write) timed
//! in-process against the simulated crane on a manual clock, the reaction time from the UWB fix
//! that shows the intruding crane to the stop command on the bus at 100 Hz and 500 Hz, and the
//! OS's wake-up lateness of the cyclic executive (docs/benchmarks.md §Control loop), and the lift's
//! outcome over crane 2's script offsets (the intrusion timing sweep). Prints a markdown report;
//! returns the process exit code.
int run_loop_suite(const LoopBenchOptions& options);

}  // namespace mgc::bench
