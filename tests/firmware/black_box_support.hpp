// SPDX-License-Identifier: Apache-2.0
#pragma once

// A controller on the stepped rig with the black box around it, as mgc records: the Hal reads
// through a RecordingBus, accepted commands and each cycle's entry go into the BlackBox.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include <unistd.h>

#include "../sim/sim_rig.hpp"
#include "mgc/firmware/black_box.hpp"
#include "mgc/firmware/controller.hpp"

namespace mgc::test {

//! A scratch folder named for its test program and this process, removed with everything in it
//! when the program ends.
struct ScratchDir {
  std::filesystem::path dir;
  explicit ScratchDir(const std::string& prefix)
      : dir(std::filesystem::temp_directory_path() / (prefix + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

struct RecordedLift {
  SimRig rig;
  firmware::Controller controller;
  firmware::black_box::Identity identity;
  std::unique_ptr<firmware::black_box::BlackBox> box;
  std::unique_ptr<firmware::black_box::RecordingBus> bus;
  std::uint64_t cycles = 0;
  bool goal_sent = false;
  //! Called after each recorded cycle (the allocation count, in the allocation test).
  std::function<void()> after_cycle;

  RecordedLift(const std::string& file, const std::string& bus_name, std::size_t ring_bytes)
      : rig("thesis-steel-frame.yaml", SimRig::quiet_config(), bus_name), controller(rig.scenario, firmware::ControllerConfig{}) {
    identity = firmware::black_box::identity_for(rig.scenario, firmware::ControllerConfig{}.replanner, rig.cycle_us,
                                                 rig.sim->config().valve_deadband);
    box = std::make_unique<firmware::black_box::BlackBox>(file, identity, ring_bytes);
    bus = std::make_unique<firmware::black_box::RecordingBus>(*rig.controller_bus, *box);
    rig.hal = std::make_unique<hal::Hal>(*bus, rig.sim->plan(), sim::max_velocities(rig.scenario));
    firmware::black_box::configure_hal(*rig.hal, identity);
    rig.on_cycle = [this](const hal::SensorSnapshot& s) { cycle(s); };
  }

  void cycle(const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) {
      commands.goal_request = true;
      goal_sent = true;
    }
    const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, commands, false);
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    box->push_cycle(firmware::black_box::make_cycle_entry(cycles, s.t_us, rig.cycle_us, false, s, commands, out, controller.snapshot(), 0));
    ++cycles;
    if (after_cycle) after_cycle();
  }
};

}  // namespace mgc::test
