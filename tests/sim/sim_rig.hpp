// SPDX-License-Identifier: Apache-2.0
#pragma once

// A controller's Hal and the simulated machine on one in-process bus with a manual clock: the
// simulator steps every millisecond, the Hal reads and writes every 10 ms, as mgc and mgc-sim do.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/sim/simulator.hpp"

namespace mgc::test {

inline std::string scenario_path(const char* name) { return std::string(MGC_SOURCE_DIR) + "/scenarios/" + name; }

inline std::vector<double> max_velocities(const planning::Scenario& s) {
  std::vector<double> v;
  for (const auto& j : s.machine.joints) v.push_back(j.max_velocity);
  return v;
}

class SimRig {
 public:
  static constexpr std::int64_t kCycleUs = 10'000;
  static constexpr std::int64_t kPhysicsUs = 1'000;
  static constexpr std::int64_t kSimZeroUs = 1'001'000;  //!< clock time of simulation time 0 [µs]

  //! Clock time of a simulation time [µs].
  static constexpr std::int64_t at_sim_s(double t_s) { return kSimZeroUs + static_cast<std::int64_t>(t_s * 1e6); }

  //! edit: changes the scenario before the machine is built (a test's own tags on a shipped site).
  explicit SimRig(const char* scenario_file, sim::SimConfig config = quiet_config(), const std::string& bus_name = "rig",
                  const std::function<void(planning::Scenario&)>& edit = {})
      : scenario(planning::io::load_scenario(scenario_path(scenario_file))), clock(1'000'000) {
    if (edit) edit(scenario);
    auto a = hal::open_can_bus("loop:" + bus_name, &clock);
    auto b = hal::open_can_bus("loop:" + bus_name, &clock);
    auto c = hal::open_can_bus("loop:" + bus_name, &clock);
    if (!a || !b || !c) throw std::runtime_error("cannot open the loop bus");
    controller_bus = std::move(a.bus);
    machine_bus = std::move(b.bus);
    third_party = std::move(c.bus);
    (void)controller_bus->set_error_mask(hal::kCanErrBusOff | hal::kCanErrRestarted);
    sim = std::make_unique<sim::Simulator>(scenario, *machine_bus, std::move(config));
    const auto vmax = max_velocities(scenario);
    hal = std::make_unique<hal::Hal>(*controller_bus, sim->plan(), vmax);
    command.assign(vmax.size(), 0.0);
    // The rig's own commands drive the machine; a controller on the rig sets it from its output.
    hal->set_pilot_enabled(true);
  }

  //! The Hal maps commands past the simulated valves' deadband, as mgc does with its calibration
  //! (docs/protocol.md). Off by default, so that tests of the simulator see its valves as they are.
  void calibrate_valves() { hal->set_valve_deadband(sim->config().valve_deadband); }

  //! No noise and no dropouts: tests that compare values exactly opt in to noise themselves.
  static sim::SimConfig quiet_config() {
    sim::SimConfig c;
    c.encoder_noise_counts = 0.0;
    c.uwb.noise_sigma_m = 0.0;
    c.uwb.dropout_probability = 0.0;
    return c;
  }

  //! Runs for duration_us. controller_alive = false stops the Hal completely (a dead controller).
  void run(std::int64_t duration_us, bool controller_alive = true) {
    const std::int64_t end = t_us + duration_us;
    while (t_us < end) {
      t_us += kPhysicsUs;
      clock.set_us(t_us);
      if (controller_alive && t_us % cycle_us == 0) {
        if (before_read) before_read();
        last = &hal->read(t_us);
        if (on_cycle) on_cycle(*last);
        if (send_commands) (void)hal->write(command, t_us);
        else (void)hal->heartbeat(t_us);
      }
      sim->step(t_us);
    }
  }

  //! Boots, starts every node and runs until the valve reports active: simulation time 0.25 s.
  void start() {
    run(200'000);
    if (hal->send_nmt(hal::canopen::NmtCommand::Start, 0) != hal::Status::Ok) throw std::runtime_error("NMT start failed");
    run(50'000);
  }

  planning::Scenario scenario;
  hal::ManualClock clock;
  std::unique_ptr<hal::CanBus> controller_bus;
  std::unique_ptr<hal::CanBus> machine_bus;
  std::unique_ptr<hal::CanBus> third_party;  //!< for frames neither side would send
  std::unique_ptr<sim::Simulator> sim;
  std::unique_ptr<hal::Hal> hal;
  std::vector<double> command;
  //! The controller's period: kCycleUs (100 Hz) unless a test runs it faster; a multiple of kPhysicsUs. [µs]
  std::int64_t cycle_us = kCycleUs;
  bool send_commands = true;
  std::function<void(const hal::SensorSnapshot&)> on_cycle;
  //! Called at each cycle's time before the Hal reads: frames sent here arrive after the machine's
  //! own of the previous millisecond, so an attacker's frame is the last one the Hal sees.
  std::function<void()> before_read;
  const hal::SensorSnapshot* last = nullptr;
  std::int64_t t_us = 1'000'000;
};

}  // namespace mgc::test
