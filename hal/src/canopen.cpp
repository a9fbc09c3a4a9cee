// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/canopen.hpp"

namespace mgc::hal::canopen {

const char* to_string(NmtState state) noexcept {
  switch (state) {
    case NmtState::BootUp: return "boot-up";
    case NmtState::Stopped: return "stopped";
    case NmtState::Operational: return "operational";
    case NmtState::PreOperational: return "pre-operational";
  }
  return "unknown";
}

Status check_frame(const CanFrame& frame, std::uint32_t expected_id, std::uint8_t expected_dlc) noexcept {
  if ((frame.can_id & (kCanEffFlag | kCanRtrFlag | kCanErrFlag)) != 0) return Status::WrongId;
  if (frame.can_id != expected_id) return Status::WrongId;
  if (frame.dlc != expected_dlc) return Status::WrongLength;
  return Status::Ok;
}

namespace {

bool valid_node(std::uint8_t node) noexcept { return node >= 1 && node <= kMaxNodeId; }

bool valid_command(std::uint8_t raw) noexcept {
  switch (static_cast<NmtCommand>(raw)) {
    case NmtCommand::Start:
    case NmtCommand::Stop:
    case NmtCommand::EnterPreOperational:
    case NmtCommand::ResetNode:
    case NmtCommand::ResetCommunication: return true;
  }
  return false;
}

bool valid_state(std::uint8_t raw) noexcept {
  switch (static_cast<NmtState>(raw)) {
    case NmtState::BootUp:
    case NmtState::Stopped:
    case NmtState::Operational:
    case NmtState::PreOperational: return true;
  }
  return false;
}

}  // namespace

Result<CanFrame> encode_nmt(const NmtMessage& message) noexcept {
  if (!valid_command(static_cast<std::uint8_t>(message.command)) || message.target_node_id > kMaxNodeId) {
    return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(kNmtCobId, 2);
  f.data[0] = static_cast<std::uint8_t>(message.command);
  f.data[1] = message.target_node_id;
  return {Status::Ok, f};
}

Result<NmtMessage> decode_nmt(const CanFrame& frame) noexcept {
  if (const Status s = check_frame(frame, kNmtCobId, 2); s != Status::Ok) return {s, {}};
  if (!valid_command(frame.data[0]) || frame.data[1] > kMaxNodeId) return {Status::OutOfRange, {}};
  return {Status::Ok, {static_cast<NmtCommand>(frame.data[0]), frame.data[1]}};
}

Result<CanFrame> encode_sync(const SyncMessage& message) noexcept {
  if (message.counter > kSyncCounterMax) return {Status::OutOfRange, {}};
  CanFrame f = CanFrame::standard(kSyncCobId, message.counter == 0 ? 0 : 1);
  f.data[0] = message.counter;
  return {Status::Ok, f};
}

Result<SyncMessage> decode_sync(const CanFrame& frame) noexcept {
  const std::uint8_t dlc = frame.dlc;
  if (dlc > 1) return {check_frame(frame, kSyncCobId, 1), {}};
  if (const Status s = check_frame(frame, kSyncCobId, dlc); s != Status::Ok) return {s, {}};
  if (dlc == 0) return {Status::Ok, {0}};
  // A counter byte of 0 is impossible: the counter starts at 1 (CiA 301 0x1019).
  if (frame.data[0] == 0 || frame.data[0] > kSyncCounterMax) return {Status::OutOfRange, {}};
  return {Status::Ok, {frame.data[0]}};
}

Result<CanFrame> encode_heartbeat(const HeartbeatMessage& message) noexcept {
  if (!valid_node(message.node_id) || !valid_state(static_cast<std::uint8_t>(message.state))) {
    return {Status::OutOfRange, {}};
  }
  CanFrame f = CanFrame::standard(heartbeat_cob_id(message.node_id), 1);
  f.data[0] = static_cast<std::uint8_t>(message.state);
  return {Status::Ok, f};
}

Result<HeartbeatMessage> decode_heartbeat(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, heartbeat_cob_id(node), 1); s != Status::Ok) return {s, {}};
  if (!valid_node(node)) return {Status::WrongId, {}};
  if (!valid_state(frame.data[0])) return {Status::OutOfRange, {}};
  return {Status::Ok, {node, static_cast<NmtState>(frame.data[0])}};
}

Result<CanFrame> encode_emcy(const EmcyMessage& message) noexcept {
  if (!valid_node(message.node_id)) return {Status::OutOfRange, {}};
  if ((message.error_register & kErrorRegisterReserved) != 0) return {Status::ReservedBits, {}};
  CanFrame f = CanFrame::standard(emcy_cob_id(message.node_id), 8);
  put_u16_le(f, 0, message.error_code);
  f.data[2] = message.error_register;
  for (std::size_t i = 0; i < message.manufacturer.size(); ++i) f.data[3 + i] = message.manufacturer[i];
  return {Status::Ok, f};
}

Result<EmcyMessage> decode_emcy(const CanFrame& frame) noexcept {
  const std::uint8_t node = node_id_of(frame.can_id);
  if (const Status s = check_frame(frame, emcy_cob_id(node), 8); s != Status::Ok) return {s, {}};
  // Node 0 would be the SYNC id, which is not an EMCY.
  if (!valid_node(node)) return {Status::WrongId, {}};
  if ((frame.data[2] & kErrorRegisterReserved) != 0) return {Status::ReservedBits, {}};
  EmcyMessage m;
  m.node_id = node;
  m.error_code = get_u16_le(frame, 0);
  m.error_register = frame.data[2];
  for (std::size_t i = 0; i < m.manufacturer.size(); ++i) m.manufacturer[i] = frame.data[3 + i];
  return {Status::Ok, m};
}

}  // namespace mgc::hal::canopen
