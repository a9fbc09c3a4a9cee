// SPDX-License-Identifier: Apache-2.0
// The simulator and a Hal client on a real Linux vcan, in real time, inside the VM of
// scripts/vcan-vm/run-in-vm.sh: start-up, encoders, a commanded motion, UWB tags, and the valve's
// fail-safe when the controller falls silent. The VM emulates its CPU, so the bounds here are on
// behaviour, not on timing; timing is measured natively by mgc-bench.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <thread>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/sim/simulator.hpp"

using namespace mgc;

namespace {

//! A small mobile crane scenario built in code: the VM has no scenario files.
planning::Scenario vm_scenario() {
  planning::Scenario s;
  s.name = "vm";
  s.machine.kind = planning::MachineKind::MobileCrane;
  s.machine.name = "test crane";
  const double deg = std::numbers::pi / 180.0;
  s.machine.joints = {
      planning::joint_from_ramps("swing", planning::JointType::Revolute, true, -std::numbers::pi, std::numbers::pi, 3.75 * deg, 1.0, 0.5),
      planning::joint_from_ramps("boom_elevation", planning::JointType::Revolute, false, 0.0, 80 * deg, 1.04 * deg, 1.0, 0.5),
      planning::joint_from_ramps("boom_length", planning::JointType::Prismatic, false, 10.0, 33.5, 0.124, 1.0, 0.5),
      planning::joint_from_ramps("cable_length", planning::JointType::Prismatic, false, 1.0, 36.0, 0.5, 1.0, 0.5),
  };
  s.start = planning::JointVector(4);
  s.start << 0.0, 45 * deg, 20.0, 10.0;
  planning::DynamicObstacleSpec truck;
  truck.obstacle.name = "truck";
  truck.motion = {{0.0, Eigen::Vector3d(0, -30, 0), 0.0}, {10.0, Eigen::Vector3d(0, -10, 0), 0.0}};
  truck.tags = {{5, Eigen::Vector3d(0, 0, 3)}};
  s.dynamic_obstacles.push_back(truck);
  return s;
}

struct RealTimeRig {
  RealTimeRig() : scenario(vm_scenario()) {
    const hal::Clock& clock = hal::SteadyClock::instance();
    auto a = hal::open_can_bus("socketcan:vcan0", &clock);
    auto b = hal::open_can_bus("socketcan:vcan0", &clock);
    INFO(a.error << b.error);
    REQUIRE(a);
    REQUIRE(b);
    controller_bus = std::move(a.bus);
    machine_bus = std::move(b.bus);
    sim::SimConfig config;
    config.uwb.dropout_probability = 0.0;
    sim = std::make_unique<sim::Simulator>(scenario, *machine_bus, config);
    std::vector<double> vmax;
    for (const auto& j : scenario.machine.joints) vmax.push_back(j.max_velocity);
    hal = std::make_unique<hal::Hal>(*controller_bus, sim->plan(), vmax);
    hal->set_pilot_enabled(true);
    command.assign(4, 0.0);
  }

  //! Real time: the simulator every millisecond, the Hal every 10 ms (when alive), until done()
  //! or timeout_s. Returns whether done() became true.
  template <class Done>
  bool run(double timeout_s, bool controller_alive, Done done) {
    const hal::Clock& clock = hal::SteadyClock::instance();
    const std::int64_t end = clock.now_us() + static_cast<std::int64_t>(timeout_s * 1e6);
    std::int64_t next_cycle = clock.now_us();
    while (clock.now_us() < end) {
      const std::int64_t now = clock.now_us();
      if (controller_alive && now >= next_cycle) {
        last = &hal->read(now);
        (void)hal->write(command, now);
        next_cycle += 10'000;
        if (next_cycle <= now) next_cycle = now + 10'000;
      }
      sim->step(clock.now_us());
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return false;
  }

  planning::Scenario scenario;
  std::unique_ptr<hal::CanBus> controller_bus;
  std::unique_ptr<hal::CanBus> machine_bus;
  std::unique_ptr<sim::Simulator> sim;
  std::unique_ptr<hal::Hal> hal;
  std::vector<double> command;
  const hal::SensorSnapshot* last = nullptr;
};

}  // namespace

TEST_CASE("vcan: the Hal starts the simulated crane, reads it, moves it, and the valve fails safe", "[vm][sim]") {
  RealTimeRig rig;
  // Boot-up and heartbeats of all six nodes.
  REQUIRE(rig.run(3.0, true, [&] {
    if (rig.last == nullptr) return false;
    for (std::size_t j = 0; j < 4; ++j) {
      if (!rig.last->encoders[j].heard) return false;
    }
    return rig.last->valve.heard && rig.last->uwb_gateway.heard;
  }));
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0) == hal::Status::Ok);
  REQUIRE(rig.run(3.0, true, [&] { return rig.last->all_joints_valid() && rig.last->valve_active(); }));
  CHECK(rig.last->joints[2].position == Approx(20.0).margin(1e-3));
  CHECK(rig.last->joints[1].position == Approx(45.0 * std::numbers::pi / 180.0).margin(1e-4));
  REQUIRE(rig.run(3.0, true, [&] { return rig.last->find_tag(5) != nullptr && rig.last->find_tag(5)->valid; }));
  CHECK(rig.last->codec.malformed() == 0);
  CHECK(rig.last->codec.unknown_id == 0);

  // Telescope out at full speed for a while: the encoder follows the truth.
  rig.command[2] = 0.124;
  REQUIRE(rig.run(10.0, true, [&] { return rig.sim->truth().position[2] > 20.05; }));
  CHECK(rig.last->joints[2].position > 20.0);
  CHECK(rig.sim->truth().valve_state == hal::pdo::ValveState::Active);

  // The controller falls silent: the valve node blocks every spool by itself.
  REQUIRE(rig.run(5.0, false, [&] { return rig.sim->truth().valve_state == hal::pdo::ValveState::FailSafe; }));
  CHECK(rig.sim->truth().spool[2] == 0.0);
  CHECK(rig.sim->counters().fail_safe_events == 1);
}
