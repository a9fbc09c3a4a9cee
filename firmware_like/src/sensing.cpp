// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/sensing.hpp"

#include <algorithm>

namespace mgc::firmware {
namespace {

guidance::DeviceHealth device_health(hal::Health health) noexcept {
  switch (health) {
    case hal::Health::Missing: return guidance::DeviceHealth::Missing;
    case hal::Health::Alive: return guidance::DeviceHealth::Alive;
    case hal::Health::Stale: return guidance::DeviceHealth::Stale;
    case hal::Health::Faulted: return guidance::DeviceHealth::Faulted;
  }
  return guidance::DeviceHealth::Missing;
}

guidance::ValveHealth valve_health(const hal::SensorSnapshot& s) noexcept {
  if (s.valve.health == hal::Health::Missing) return guidance::ValveHealth::Missing;
  // The node's own account comes first: fail-safe means it lost us, which a restart clears.
  if (s.valve_status_valid && s.valve_status.state == hal::pdo::ValveState::FailSafe) return guidance::ValveHealth::FailSafe;
  if (s.valve.health == hal::Health::Faulted) return guidance::ValveHealth::Faulted;
  if (s.valve_active()) return guidance::ValveHealth::Active;
  // Operational by its heartbeat and heard from before, but its status is old: not a node that
  // left Active (that one says so in its heartbeat or its status), one whose reports stopped.
  if (s.valve.health == hal::Health::Alive && s.valve.nmt_state == hal::canopen::NmtState::Operational && !s.valve_status_valid &&
      s.valve_status_t_us != 0) {
    return guidance::ValveHealth::StatusStale;
  }
  return guidance::ValveHealth::NotStarted;
}

}  // namespace

guidance::CutoffHealth cutoff_health(const hal::SensorSnapshot& s) noexcept {
  if (s.cutoff.health == hal::Health::Missing) return guidance::CutoffHealth::Missing;
  const bool emcy = s.cutoff.health == hal::Health::Faulted;
  if (!s.cutoff_status_valid) return emcy ? guidance::CutoffHealth::Failed : guidance::CutoffHealth::NotReady;
  const hal::pdo::CutoffStatus& st = s.cutoff_status;
  if (st.state == hal::pdo::CutoffState::Fault) return guidance::CutoffHealth::Failed;
  // The pressure switch is the truth: pressure behind a dump valve that should be open means the
  // second channel does not work.
  if (st.pressure) {
    return st.state == hal::pdo::CutoffState::Enabled && !emcy ? guidance::CutoffHealth::Ready : guidance::CutoffHealth::Failed;
  }
  // No pressure: cut, whether asked for or after a loss the node signalled (a restart clears it).
  return guidance::CutoffHealth::Cut;
}

guidance::PlausibilityInputs plausibility_inputs(const hal::SensorSnapshot& s, std::span<const double> commanded_velocity,
                                                 bool pilot_enabled) noexcept {
  guidance::PlausibilityInputs in;
  in.now_us = s.t_us;
  const std::size_t joints = std::min<std::size_t>(s.num_joints, in.position.size());
  for (std::size_t j = 0; j < joints; ++j) {
    const hal::JointReading& r = s.joints[j];
    in.position[j] = r.position;
    in.valid[j] = r.valid;
    in.updated[j] = r.updated;
    in.commanded_velocity[j] = j < commanded_velocity.size() ? commanded_velocity[j] : 0.0;
    in.valve_applied[j] = s.valve_applied_fraction[j];
    in.valve_commanded[j] = s.valve_command_fraction[j];
  }
  in.valve_active = s.valve_active();
  // The commands move the machine unless pilot pressure is off or the valve says it does not
  // follow them. A valve whose reports are late or missing is taken at its commands: assuming it
  // stopped would read a machine that runs down its commanded stop as a runaway.
  const bool status_idle = s.valve_status_valid && s.valve_status.state != hal::pdo::ValveState::Active;
  const bool heartbeat_idle = s.valve.health != hal::Health::Missing && s.valve.nmt_state != hal::canopen::NmtState::Operational;
  in.drive_enabled = pilot_enabled && !status_idle && !heartbeat_idle;
  in.valve_command_counter = s.valve_status.command_counter;
  in.valve_commands_sent = s.valve_commands_sent;
  return in;
}

guidance::SensingInputs sensing_inputs(const hal::SensorSnapshot& snapshot, std::span<const std::uint8_t> machine_tag_ids) noexcept {
  guidance::SensingInputs in;
  const std::size_t joints = std::min<std::size_t>(snapshot.num_joints, in.joint.size());
  for (std::size_t j = 0; j < joints; ++j) in.joint[j] = device_health(snapshot.joints[j].health);
  in.valve = valve_health(snapshot);
  in.cutoff = cutoff_health(snapshot);
  in.bus_off = snapshot.bus_state == hal::BusState::BusOff;
  in.uwb_gateway = device_health(snapshot.uwb_gateway.health);
  for (std::size_t i = 0; i < snapshot.num_tags; ++i) {
    const hal::TagReading& tag = snapshot.tags[i];
    if (std::find(machine_tag_ids.begin(), machine_tag_ids.end(), tag.tag_id) != machine_tag_ids.end()) continue;
    if (tag.fixes > 0) in.uwb_last_fix_us = std::max(in.uwb_last_fix_us, tag.t_us);
  }
  return in;
}

}  // namespace mgc::firmware
