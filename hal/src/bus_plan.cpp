// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/bus_plan.hpp"

#include "mgc/hal/canopen.hpp"

#include <stdexcept>

namespace mgc::hal {

namespace {

using pdo::EncoderKind;

BusPlan make_plan(const char* machine, std::initializer_list<std::pair<const char*, EncoderKind>> joints) noexcept {
  BusPlan plan;
  plan.machine = machine;
  for (const auto& [name, kind] : joints) {
    plan.encoders[plan.num_joints] = {name, static_cast<std::uint8_t>(kFirstEncoderNodeId + plan.num_joints), kind};
    ++plan.num_joints;
  }
  return plan;
}

}  // namespace

//! A boom inclinometer on joint j's link, as load moment limiters carry one.
BusPlan with_inclinometer(BusPlan plan, std::int8_t joint) noexcept {
  plan.inclinometer_node_id = kInclinometerNodeId;
  plan.inclinometer_joint = joint;
  return plan;
}

BusPlan mobile_crane_bus_plan() noexcept {
  return with_inclinometer(make_plan("mobile_crane", {{"swing", EncoderKind::Rotary},
                                                      {"boom_elevation", EncoderKind::Rotary},
                                                      {"boom_length", EncoderKind::Linear},
                                                      {"cable_length", EncoderKind::Linear}}),
                           1);
}

BusPlan tower_crane_bus_plan() noexcept {
  return make_plan("tower_crane", {{"slew", EncoderKind::Rotary},
                                   {"trolley_radius", EncoderKind::Linear},
                                   {"hook_height", EncoderKind::Linear}});
}

BusPlan excavator_bus_plan() noexcept {
  return with_inclinometer(make_plan("excavator", {{"swing", EncoderKind::Rotary},
                                                   {"boom", EncoderKind::Rotary},
                                                   {"arm", EncoderKind::Rotary},
                                                   {"bucket", EncoderKind::Rotary}}),
                           1);
}

const char* to_string(MessageKind kind) noexcept {
  switch (kind) {
    case MessageKind::Unknown: return "unknown";
    case MessageKind::Nmt: return "nmt";
    case MessageKind::Sync: return "sync";
    case MessageKind::Emcy: return "emcy";
    case MessageKind::Heartbeat: return "heartbeat";
    case MessageKind::EncoderPosition: return "encoder position";
    case MessageKind::InclinometerAngle: return "inclinometer angle";
    case MessageKind::UwbTagPosition: return "uwb tag position";
    case MessageKind::ValveCommand: return "valve command";
    case MessageKind::ValveStatus: return "valve status";
    case MessageKind::ValveApplied: return "valve applied";
    case MessageKind::CutoffCommand: return "cut-off command";
    case MessageKind::CutoffStatus: return "cut-off status";
  }
  return "unknown";
}

namespace {

bool in_plan(const BusPlan& plan, std::uint8_t node) noexcept {
  if (node == plan.controller_node_id || node == plan.uwb_gateway_node_id || node == plan.valve_node_id ||
      node == plan.cutoff_node_id || (plan.inclinometer_node_id != 0 && node == plan.inclinometer_node_id)) {
    return true;
  }
  for (std::size_t j = 0; j < plan.num_joints; ++j) {
    if (plan.encoders[j].node_id == node) return true;
  }
  return false;
}

}  // namespace

Classified classify(const CanFrame& frame, const BusPlan& plan) noexcept {
  using canopen::FunctionCode;
  // Flags, or identifier bits above the 11 a standard id has: no COB-ID, however its low bits read.
  if ((frame.can_id & ~kCanSffMask) != 0) return {};
  const std::uint32_t id = frame.can_id;
  if (id == canopen::kNmtCobId) return {MessageKind::Nmt, 0, -1};
  if (id == canopen::kSyncCobId) return {MessageKind::Sync, plan.controller_node_id, -1};
  const std::uint8_t node = canopen::node_id_of(id);
  const FunctionCode code = canopen::function_code(id);
  if (node == 0 || !in_plan(plan, node)) return {};
  if (code == FunctionCode::SyncOrEmcy) return {MessageKind::Emcy, node, -1};
  if (code == FunctionCode::Heartbeat) return {MessageKind::Heartbeat, node, -1};
  if (node == plan.valve_node_id) {
    switch (code) {
      case FunctionCode::Rpdo1: return {MessageKind::ValveCommand, node, 0};
      case FunctionCode::Rpdo2: return {MessageKind::ValveCommand, node, 1};
      case FunctionCode::Tpdo1: return {MessageKind::ValveStatus, node, -1};
      case FunctionCode::Tpdo2: return {MessageKind::ValveApplied, node, 0};
      case FunctionCode::Tpdo3: return {MessageKind::ValveApplied, node, 1};
      default: return {};
    }
  }
  if (node == plan.cutoff_node_id) {
    if (code == FunctionCode::Rpdo1) return {MessageKind::CutoffCommand, node, -1};
    if (code == FunctionCode::Tpdo1) return {MessageKind::CutoffStatus, node, -1};
    return {};
  }
  if (code != FunctionCode::Tpdo1) return {};
  if (node == plan.uwb_gateway_node_id) return {MessageKind::UwbTagPosition, node, -1};
  if (node == plan.inclinometer_node_id) return {MessageKind::InclinometerAngle, node, plan.inclinometer_joint};
  for (std::size_t j = 0; j < plan.num_joints; ++j) {
    if (plan.encoders[j].node_id == node) return {MessageKind::EncoderPosition, node, static_cast<std::int8_t>(j)};
  }
  return {};
}

void CodecCounters::record(Status status) noexcept {
  switch (status) {
    case Status::Ok: ++decoded; break;
    case Status::UnknownId: ++unknown_id; break;
    case Status::WrongLength: ++wrong_length; break;
    case Status::WrongId: ++wrong_id; break;
    case Status::OutOfRange: ++out_of_range; break;
    case Status::ReservedBits: ++reserved_bits; break;
    default: ++other; break;
  }
}

BusPlan bus_plan_for(std::string_view machine_kind, std::span<const std::string> joint_names) {
  BusPlan plan;
  if (machine_kind == "mobile_crane") {
    plan = mobile_crane_bus_plan();
  } else if (machine_kind == "tower_crane") {
    plan = tower_crane_bus_plan();
  } else if (machine_kind == "excavator") {
    plan = excavator_bus_plan();
  } else {
    throw std::invalid_argument("no bus plan for the machine kind \"" + std::string(machine_kind) + "\"");
  }
  if (plan.num_joints != joint_names.size()) {
    throw std::invalid_argument("the machine has " + std::to_string(joint_names.size()) + " joints, its bus plan " +
                                std::to_string(plan.num_joints));
  }
  for (std::size_t j = 0; j < plan.num_joints; ++j) {
    if (joint_names[j] != plan.encoders[j].joint) {
      throw std::invalid_argument("joint " + std::to_string(j) + " is \"" + joint_names[j] + "\", the bus plan expects \"" +
                                  plan.encoders[j].joint + "\"");
    }
  }
  return plan;
}

}  // namespace mgc::hal
