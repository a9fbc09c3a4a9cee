// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/device_pdos.hpp"

#include <cmath>
#include <numbers>

#include "mgc/hal/canopen.hpp"

namespace mgc::hal::pdo {

using canopen::check_frame;
using canopen::get_i16_le;
using canopen::get_u32_le;
using canopen::node_id_of;
using canopen::put_u16_le;
using canopen::put_u32_le;
using canopen::rpdo_cob_id;
using canopen::tpdo_cob_id;

namespace {

bool valid_node(std::uint8_t node) noexcept { return node >= 1 && node <= canopen::kMaxNodeId; }

bool valid_permyriad(std::int16_t v) noexcept { return v >= -kValveFullScale && v <= kValveFullScale; }

// Bank b of the valve maps to PDO number b + 1 (RPDO1/RPDO2 for commands) or b + 2
// (TPDO2/TPDO3 for applied values, TPDO1 being the status).
int bank_of(std::uint32_t cob, std::uint8_t node, int first_pdo, bool rx) noexcept {
  for (int b = 0; b < static_cast<int>(kValveBanks); ++b) {
    const std::uint32_t id = rx ? rpdo_cob_id(first_pdo + b, node) : tpdo_cob_id(first_pdo + b, node);
    if (cob == id) return b;
  }
  return -1;
}

template <class Message>
Result<CanFrame> encode_bank(const Message& m, int first_pdo, bool rx) noexcept {
  if (!valid_node(m.node_id) || m.bank >= kValveBanks) return {Status::OutOfRange, {}};
  for (const std::int16_t v : m.velocity_permyriad) {
    if (!valid_permyriad(v)) return {Status::OutOfRange, {}};
  }
  const int pdo = first_pdo + m.bank;
  CanFrame f = CanFrame::standard(rx ? rpdo_cob_id(pdo, m.node_id) : tpdo_cob_id(pdo, m.node_id), 8);
  for (std::size_t j = 0; j < kJointsPerValveFrame; ++j) {
    put_u16_le(f, 2 * j, static_cast<std::uint16_t>(m.velocity_permyriad[j]));
  }
  return {Status::Ok, f};
}

template <class Message>
Result<Message> decode_bank(const CanFrame& frame, int first_pdo, bool rx) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  const int bank = bank_of(frame.can_id, node, first_pdo, rx);
  // Flagged (extended, RTR, error) ids never equal a PDO's 11-bit id, so they land here too.
  if (bank < 0 || !valid_node(node)) return {Status::WrongId, {}};
  if (const Status s = check_frame(frame, frame.can_id, 8); s != Status::Ok) return {s, {}};
  Message m;
  m.node_id = node;
  m.bank = static_cast<std::uint8_t>(bank);
  for (std::size_t j = 0; j < kJointsPerValveFrame; ++j) {
    m.velocity_permyriad[j] = get_i16_le(frame, 2 * j);
    if (!valid_permyriad(m.velocity_permyriad[j])) return {Status::OutOfRange, {}};
  }
  return {Status::Ok, m};
}

}  // namespace

Result<CanFrame> encode_encoder_position(const EncoderPosition& message) noexcept {
  if (!valid_node(message.node_id) || message.position_counts == kEncoderPositionReserved) {
    return {Status::OutOfRange, {}};
  }
  if ((message.status & kEncoderStatusReservedMask) != 0) return {Status::ReservedBits, {}};
  CanFrame f = CanFrame::standard(tpdo_cob_id(1, message.node_id), 5);
  put_u32_le(f, 0, static_cast<std::uint32_t>(message.position_counts));
  f.data[4] = message.status;
  return {Status::Ok, f};
}

Result<EncoderPosition> decode_encoder_position(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, tpdo_cob_id(1, node), 5); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  EncoderPosition m;
  m.node_id = node;
  m.position_counts = static_cast<std::int32_t>(get_u32_le(frame, 0));
  m.status = frame.data[4];
  if (m.position_counts == kEncoderPositionReserved) return {Status::OutOfRange, {}};
  if ((m.status & kEncoderStatusReservedMask) != 0) return {Status::ReservedBits, {}};
  return {Status::Ok, m};
}

double counts_to_si(std::int32_t counts, EncoderKind kind) noexcept {
  const double c = static_cast<double>(counts);
  return kind == EncoderKind::Rotary ? c * kRotaryDegPerCount * std::numbers::pi / 180.0 : c * kLinearMmPerCount * 1e-3;
}

Result<std::int32_t> si_to_counts(double value_si, EncoderKind kind) noexcept {
  const double counts = kind == EncoderKind::Rotary ? value_si * 180.0 / std::numbers::pi / kRotaryDegPerCount
                                                    : value_si * 1e3 / kLinearMmPerCount;
  const double rounded = std::round(counts);
  // Strictly above INT32_MIN: that value is reserved for "not available".
  if (!std::isfinite(rounded) || rounded <= static_cast<double>(INT32_MIN) || rounded > static_cast<double>(INT32_MAX)) {
    return {Status::OutOfRange, 0};
  }
  return {Status::Ok, static_cast<std::int32_t>(rounded)};
}

Result<CanFrame> encode_uwb_tag_position(const UwbTagPosition& message) noexcept {
  if (!valid_node(message.node_id) || message.sequence >= kUwbSequenceModulo || message.quality > kUwbQualityUnknown) {
    return {Status::OutOfRange, {}};
  }
  for (const std::int16_t c : message.position_cm) {
    if ((message.quality == kUwbQualityNoFix) != (c == kUwbNoPosition)) return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(tpdo_cob_id(1, message.node_id), 8);
  f.data[0] = message.tag_id;
  for (std::size_t i = 0; i < 3; ++i) put_u16_le(f, 1 + 2 * i, static_cast<std::uint16_t>(message.position_cm[i]));
  f.data[7] = static_cast<std::uint8_t>(message.sequence | (message.quality << 4));
  return {Status::Ok, f};
}

Result<UwbTagPosition> decode_uwb_tag_position(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, tpdo_cob_id(1, node), 8); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  UwbTagPosition m;
  m.node_id = node;
  m.tag_id = frame.data[0];
  for (std::size_t i = 0; i < 3; ++i) m.position_cm[i] = get_i16_le(frame, 1 + 2 * i);
  m.sequence = frame.data[7] & 0x0FU;
  m.quality = static_cast<std::uint8_t>(frame.data[7] >> 4);
  // A fix must carry a position and "no fix" must not: anything else is a confused gateway.
  for (const std::int16_t c : m.position_cm) {
    if ((m.quality == kUwbQualityNoFix) != (c == kUwbNoPosition)) return {Status::OutOfRange, {}};
  }
  return {Status::Ok, m};
}

Result<std::int16_t> metres_to_uwb_counts(double value_m) noexcept {
  const double rounded = std::round(value_m / kUwbMetresPerCount);
  if (!std::isfinite(rounded) || rounded <= static_cast<double>(INT16_MIN) || rounded > static_cast<double>(INT16_MAX)) {
    return {Status::OutOfRange, 0};
  }
  return {Status::Ok, static_cast<std::int16_t>(rounded)};
}

Result<CanFrame> encode_valve_command(const ValveCommand& message) noexcept { return encode_bank(message, 1, true); }
Result<ValveCommand> decode_valve_command(const CanFrame& frame) noexcept {
  return decode_bank<ValveCommand>(frame, 1, true);
}
Result<CanFrame> encode_valve_applied(const ValveApplied& message) noexcept { return encode_bank(message, 2, false); }
Result<ValveApplied> decode_valve_applied(const CanFrame& frame) noexcept {
  return decode_bank<ValveApplied>(frame, 2, false);
}

namespace {

// The combinations a valve node can actually be in: a reason exactly when it is not following
// commands for a cause (FailSafe needs a loss reason, Fault the internal one).
bool consistent(std::uint8_t state, std::uint8_t reason) noexcept {
  switch (static_cast<ValveState>(state)) {
    case ValveState::Disabled:
    case ValveState::Active: return reason == static_cast<std::uint8_t>(ValveReason::None);
    case ValveState::FailSafe:
      return reason == static_cast<std::uint8_t>(ValveReason::ControllerHeartbeatLost) ||
             reason == static_cast<std::uint8_t>(ValveReason::CommandTimeout);
    case ValveState::Fault: return reason == static_cast<std::uint8_t>(ValveReason::InternalFault);
  }
  return false;
}

}  // namespace

Result<CanFrame> encode_valve_status(const ValveStatus& message) noexcept {
  if (!valid_node(message.node_id) ||
      !consistent(static_cast<std::uint8_t>(message.state), static_cast<std::uint8_t>(message.reason))) {
    return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(tpdo_cob_id(1, message.node_id), 4);
  f.data[0] = static_cast<std::uint8_t>(message.state);
  f.data[1] = static_cast<std::uint8_t>(message.reason);
  f.data[2] = message.joint_fault_mask;
  f.data[3] = message.command_counter;
  return {Status::Ok, f};
}

Result<ValveStatus> decode_valve_status(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, tpdo_cob_id(1, node), 4); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  if (!consistent(frame.data[0], frame.data[1])) return {Status::OutOfRange, {}};
  ValveStatus m;
  m.node_id = node;
  m.state = static_cast<ValveState>(frame.data[0]);
  m.reason = static_cast<ValveReason>(frame.data[1]);
  m.joint_fault_mask = frame.data[2];
  m.command_counter = frame.data[3];
  return {Status::Ok, m};
}

Result<CanFrame> encode_cutoff_command(const CutoffCommand& message) noexcept {
  if (!valid_node(message.node_id) ||
      (message.command != PilotCommand::Cut && message.command != PilotCommand::Enable)) {
    return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(rpdo_cob_id(1, message.node_id), 1);
  f.data[0] = static_cast<std::uint8_t>(message.command);
  return {Status::Ok, f};
}

Result<CutoffCommand> decode_cutoff_command(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, rpdo_cob_id(1, node), 1); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  const auto command = static_cast<PilotCommand>(frame.data[0]);
  if (command != PilotCommand::Cut && command != PilotCommand::Enable) return {Status::OutOfRange, {}};
  return {Status::Ok, {node, command}};
}

namespace {

// Enabled exactly when there is no reason to cut; Fault only with the internal reason.
bool cutoff_consistent(std::uint8_t state, std::uint8_t reason) noexcept {
  if (reason > static_cast<std::uint8_t>(CutoffReason::InternalFault)) return false;
  switch (static_cast<CutoffState>(state)) {
    case CutoffState::Enabled: return reason == static_cast<std::uint8_t>(CutoffReason::None);
    case CutoffState::Cut:
      return reason != static_cast<std::uint8_t>(CutoffReason::None) &&
             reason != static_cast<std::uint8_t>(CutoffReason::InternalFault);
    case CutoffState::Fault: return reason == static_cast<std::uint8_t>(CutoffReason::InternalFault);
  }
  return false;
}

}  // namespace

Result<CanFrame> encode_cutoff_status(const CutoffStatus& message) noexcept {
  if (!valid_node(message.node_id) ||
      !cutoff_consistent(static_cast<std::uint8_t>(message.state), static_cast<std::uint8_t>(message.reason))) {
    return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(tpdo_cob_id(1, message.node_id), 3);
  f.data[0] = static_cast<std::uint8_t>(message.state);
  f.data[1] = static_cast<std::uint8_t>(message.reason);
  f.data[2] = message.pressure ? 1 : 0;
  return {Status::Ok, f};
}

Result<CutoffStatus> decode_cutoff_status(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, tpdo_cob_id(1, node), 3); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  if (!cutoff_consistent(frame.data[0], frame.data[1])) return {Status::OutOfRange, {}};
  if ((frame.data[2] & 0xFEU) != 0) return {Status::ReservedBits, {}};
  CutoffStatus m;
  m.node_id = node;
  m.state = static_cast<CutoffState>(frame.data[0]);
  m.reason = static_cast<CutoffReason>(frame.data[1]);
  m.pressure = frame.data[2] != 0;
  return {Status::Ok, m};
}

Result<std::int16_t> fraction_to_permyriad(double fraction) noexcept {
  if (!(fraction >= -1.0 && fraction <= 1.0)) return {Status::OutOfRange, 0};
  return {Status::Ok, static_cast<std::int16_t>(std::lround(fraction * kValveFullScale))};
}

}  // namespace mgc::hal::pdo
