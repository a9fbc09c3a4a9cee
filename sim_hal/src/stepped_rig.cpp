// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/stepped_rig.hpp"

#include <stdexcept>
#include <utility>

namespace mgc::sim {

std::vector<double> max_velocities(const planning::Scenario& s) {
  std::vector<double> v;
  v.reserve(s.machine.joints.size());
  for (const auto& j : s.machine.joints) v.push_back(j.max_velocity);
  return v;
}

SteppedRig::SteppedRig(planning::Scenario scenario_in, SimConfig config, const std::string& bus_name)
    : scenario(std::move(scenario_in)), clock(1'000'000) {
  auto a = hal::open_can_bus("loop:" + bus_name, &clock);
  auto b = hal::open_can_bus("loop:" + bus_name, &clock);
  auto c = hal::open_can_bus("loop:" + bus_name, &clock);
  if (!a || !b || !c) throw std::runtime_error("cannot open the loop bus " + bus_name);
  controller_bus = std::move(a.bus);
  machine_bus = std::move(b.bus);
  third_party = std::move(c.bus);
  (void)controller_bus->set_error_mask(hal::kCanErrBusOff | hal::kCanErrRestarted);
  sim = std::make_unique<Simulator>(scenario, *machine_bus, std::move(config));
  const auto vmax = max_velocities(scenario);
  hal = std::make_unique<hal::Hal>(*controller_bus, sim->plan(), vmax);
  command.assign(vmax.size(), 0.0);
  // The rig's own commands drive the machine; a controller on the rig sets it from its output.
  hal->set_pilot_enabled(true);
}

void SteppedRig::calibrate_valves() { hal->set_valve_deadband(sim->config().valve_deadband); }

SimConfig SteppedRig::quiet_config() {
  SimConfig c;
  c.encoder_noise_counts = 0.0;
  c.uwb.noise_sigma_m = 0.0;
  c.uwb.dropout_probability = 0.0;
  return c;
}

void SteppedRig::run(std::int64_t duration_us, bool controller_alive) {
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

void SteppedRig::start() {
  run(200'000);
  if (hal->send_nmt(hal::canopen::NmtCommand::Start, 0) != hal::Status::Ok) throw std::runtime_error("NMT start failed");
  run(50'000);
}

}  // namespace mgc::sim
