// SPDX-License-Identifier: Apache-2.0
#pragma once

// A controller's Hal and the simulated machine on one in-process bus with a manual clock: the
// simulator steps every millisecond, the Hal reads and writes every controller period, as mgc and
// mgc-sim do over a real bus. Deterministic and as fast as the host computes, so a lift of minutes
// of simulated time runs in seconds: the tests, the fault campaign and the benchmark suites that
// judge outcomes in the true state run on it.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/sim/simulator.hpp"

namespace mgc::sim {

class SteppedRig {
 public:
  static constexpr std::int64_t kCycleUs = 10'000;
  static constexpr std::int64_t kPhysicsUs = 1'000;
  static constexpr std::int64_t kSimZeroUs = 1'001'000;  //!< clock time of simulation time 0 [µs]

  //! Clock time of a simulation time [µs].
  static constexpr std::int64_t at_sim_s(double t_s) { return kSimZeroUs + static_cast<std::int64_t>(t_s * 1e6); }

  //! bus_name names the in-process loop bus; rigs with different names never hear each other.
  //! Throws std::runtime_error when the loop bus cannot be opened.
  SteppedRig(planning::Scenario scenario, SimConfig config, const std::string& bus_name);

  //! The Hal maps commands past the simulated valves' deadband, as mgc does with its calibration
  //! (docs/protocol.md). Off by default, so that tests of the simulator see its valves as they are.
  void calibrate_valves();

  //! No noise and no dropouts: runs that compare values exactly opt in to noise themselves.
  static SimConfig quiet_config();

  //! Runs for duration_us. controller_alive = false stops the Hal completely (a dead controller).
  void run(std::int64_t duration_us, bool controller_alive = true);

  //! Boots, starts every node and runs until the valve reports active: simulation time 0.25 s.
  //! Throws std::runtime_error when the NMT start cannot be sent.
  void start();

  planning::Scenario scenario;
  hal::ManualClock clock;
  std::unique_ptr<hal::CanBus> controller_bus;
  std::unique_ptr<hal::CanBus> machine_bus;
  std::unique_ptr<hal::CanBus> third_party;  //!< for frames neither side would send
  std::unique_ptr<Simulator> sim;
  std::unique_ptr<hal::Hal> hal;
  std::vector<double> command;
  //! The controller's period: kCycleUs (100 Hz) unless a run is faster; a multiple of kPhysicsUs. [µs]
  std::int64_t cycle_us = kCycleUs;
  bool send_commands = true;
  std::function<void(const hal::SensorSnapshot&)> on_cycle;
  //! Called at each cycle's time before the Hal reads: frames sent here arrive after the machine's
  //! own of the previous millisecond, so an attacker's frame is the last one the Hal sees.
  std::function<void()> before_read;
  const hal::SensorSnapshot* last = nullptr;
  std::int64_t t_us = 1'000'000;
};

//! Each joint's maximum velocity, in the machine's joint order. [rad/s or m/s]
std::vector<double> max_velocities(const planning::Scenario& s);

}  // namespace mgc::sim
