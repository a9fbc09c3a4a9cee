// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/status.hpp"

//! The CiA 301 subset we speak: COB-IDs of the pre-defined connection set, NMT, SYNC, heartbeat
//! and EMCY (DOMAIN-FACTS §1.1-1.5). Encoders validate their input, decoders their frame; both
//! return a Result and touch nothing else. All RT-safe: no alloc, no throw.
namespace mgc::hal::canopen {

inline constexpr std::uint8_t kMaxNodeId = 127;  //!< node ids are 1..127; 0 addresses all nodes

//! The 4-bit function code of an 11-bit COB-ID (COB-ID = code << 7 | node id).
enum class FunctionCode : std::uint8_t {
  Nmt = 0x0,
  SyncOrEmcy = 0x1,  //!< SYNC is exactly 0x080, EMCY is 0x080 + node id
  Time = 0x2,
  Tpdo1 = 0x3,
  Rpdo1 = 0x4,
  Tpdo2 = 0x5,
  Rpdo2 = 0x6,
  Tpdo3 = 0x7,
  Rpdo3 = 0x8,
  Tpdo4 = 0x9,
  Rpdo4 = 0xA,
  SdoTx = 0xB,
  SdoRx = 0xC,
  Heartbeat = 0xE,
};

[[nodiscard]] constexpr std::uint32_t cob_id(FunctionCode code, std::uint8_t node_id) noexcept {
  return (static_cast<std::uint32_t>(code) << 7) | (node_id & 0x7FU);
}
[[nodiscard]] constexpr FunctionCode function_code(std::uint32_t cob) noexcept {
  return static_cast<FunctionCode>((cob >> 7) & 0xFU);
}
[[nodiscard]] constexpr std::uint8_t node_id_of(std::uint32_t cob) noexcept {
  return static_cast<std::uint8_t>(cob & 0x7FU);
}

inline constexpr std::uint32_t kNmtCobId = 0x000;
inline constexpr std::uint32_t kSyncCobId = 0x080;
[[nodiscard]] constexpr std::uint32_t emcy_cob_id(std::uint8_t node) noexcept { return cob_id(FunctionCode::SyncOrEmcy, node); }
[[nodiscard]] constexpr std::uint32_t heartbeat_cob_id(std::uint8_t node) noexcept { return cob_id(FunctionCode::Heartbeat, node); }
//! TPDO n (1..4) of a node: 0x180/0x280/0x380/0x480 + node.
[[nodiscard]] constexpr std::uint32_t tpdo_cob_id(int n, std::uint8_t node) noexcept {
  return 0x080U + 0x100U * static_cast<std::uint32_t>(n) + (node & 0x7FU);
}
//! RPDO n (1..4) of a node: 0x200/0x300/0x400/0x500 + node.
[[nodiscard]] constexpr std::uint32_t rpdo_cob_id(int n, std::uint8_t node) noexcept {
  return 0x100U + 0x100U * static_cast<std::uint32_t>(n) + (node & 0x7FU);
}

//! NMT command specifiers (byte 0 of the NMT frame).
enum class NmtCommand : std::uint8_t {
  Start = 0x01,
  Stop = 0x02,
  EnterPreOperational = 0x80,
  ResetNode = 0x81,
  ResetCommunication = 0x82,
};

//! NMT states as the heartbeat byte carries them.
enum class NmtState : std::uint8_t { BootUp = 0x00, Stopped = 0x04, Operational = 0x05, PreOperational = 0x7F };

[[nodiscard]] const char* to_string(NmtState state) noexcept;

//! NMT module control: COB-ID 0x000, dlc 2.
struct NmtMessage {
  NmtCommand command = NmtCommand::Start;
  std::uint8_t target_node_id = 0;  //!< 0 = all nodes
};
[[nodiscard]] Result<CanFrame> encode_nmt(const NmtMessage& message) noexcept;
[[nodiscard]] Result<NmtMessage> decode_nmt(const CanFrame& frame) noexcept;

inline constexpr std::uint8_t kSyncCounterMax = 240;  //!< largest counter overflow value (0x1019)

//! SYNC: COB-ID 0x080, dlc 0 (no counter) or 1 (counter 1..240).
struct SyncMessage {
  std::uint8_t counter = 0;  //!< 0 = no counter byte, else 1..kSyncCounterMax
};
[[nodiscard]] Result<CanFrame> encode_sync(const SyncMessage& message) noexcept;
[[nodiscard]] Result<SyncMessage> decode_sync(const CanFrame& frame) noexcept;
//! The counter after `counter` for a counter overflow value `overflow` (2..240): 1, 2, ..., overflow, 1.
[[nodiscard]] constexpr std::uint8_t next_sync_counter(std::uint8_t counter, std::uint8_t overflow) noexcept {
  return counter >= overflow ? std::uint8_t{1} : static_cast<std::uint8_t>(counter + 1);
}

//! Heartbeat (and boot-up, state BootUp): COB-ID 0x700 + node, dlc 1.
struct HeartbeatMessage {
  std::uint8_t node_id = 1;
  NmtState state = NmtState::BootUp;
};
[[nodiscard]] Result<CanFrame> encode_heartbeat(const HeartbeatMessage& message) noexcept;
[[nodiscard]] Result<HeartbeatMessage> decode_heartbeat(const CanFrame& frame) noexcept;

//! Emergency codes we send or react to (CiA 301 via CANopenNode CO_EM_errorCode_t).
inline constexpr std::uint16_t kEmcyNoError = 0x0000;
inline constexpr std::uint16_t kEmcyGeneric = 0x1000;
inline constexpr std::uint16_t kEmcyCanOverrun = 0x8110;
inline constexpr std::uint16_t kEmcyHeartbeat = 0x8130;
inline constexpr std::uint16_t kEmcyBusOffRecovered = 0x8140;
inline constexpr std::uint16_t kEmcyPdoLength = 0x8210;
inline constexpr std::uint16_t kEmcyRpdoTimeout = 0x8250;
inline constexpr std::uint16_t kEmcyDeviceSpecific = 0xFF00;
//! Error register bit 6 is reserved and always 0 (CO_errorRegister_t).
inline constexpr std::uint8_t kErrorRegisterReserved = 0x40;

//! EMCY: COB-ID 0x080 + node, dlc 8: error code (LE u16), error register, 5 manufacturer bytes.
struct EmcyMessage {
  std::uint8_t node_id = 1;
  std::uint16_t error_code = kEmcyNoError;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> manufacturer{};
};
[[nodiscard]] Result<CanFrame> encode_emcy(const EmcyMessage& message) noexcept;
[[nodiscard]] Result<EmcyMessage> decode_emcy(const CanFrame& frame) noexcept;

// Little-endian field access (CANopen is little-endian, DOMAIN-FACTS §2.1).
[[nodiscard]] constexpr std::uint16_t get_u16_le(const CanFrame& f, std::size_t at) noexcept {
  return static_cast<std::uint16_t>(f.data[at] | (f.data[at + 1] << 8));
}
[[nodiscard]] constexpr std::int16_t get_i16_le(const CanFrame& f, std::size_t at) noexcept {
  return static_cast<std::int16_t>(get_u16_le(f, at));
}
[[nodiscard]] constexpr std::uint32_t get_u32_le(const CanFrame& f, std::size_t at) noexcept {
  return static_cast<std::uint32_t>(f.data[at]) | (static_cast<std::uint32_t>(f.data[at + 1]) << 8) |
         (static_cast<std::uint32_t>(f.data[at + 2]) << 16) | (static_cast<std::uint32_t>(f.data[at + 3]) << 24);
}
constexpr void put_u16_le(CanFrame& f, std::size_t at, std::uint16_t v) noexcept {
  f.data[at] = static_cast<std::uint8_t>(v & 0xFFU);
  f.data[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
constexpr void put_u32_le(CanFrame& f, std::size_t at, std::uint32_t v) noexcept {
  for (std::size_t i = 0; i < 4; ++i) f.data[at + i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFU);
}

//! Shared decoder guard: a standard data frame (no EFF/RTR/ERR flags) with exactly this id and
//! dlc, else WrongId or WrongLength.
[[nodiscard]] Status check_frame(const CanFrame& frame, std::uint32_t expected_id, std::uint8_t expected_dlc) noexcept;

}  // namespace mgc::hal::canopen
