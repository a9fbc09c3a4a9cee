// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/status.hpp"

//! The cannelloni UDP format, version 2 (github.com/mguentner/cannelloni doc/udp_format.md), for
//! classic CAN frames; docs/protocol.md says where we differ. Big-endian throughout.
namespace mgc::hal::cannelloni {

inline constexpr std::uint8_t kVersion = 2;
inline constexpr std::uint8_t kOpData = 0;  //!< cannelloni's enum op_codes {DATA, ACK, NACK}
inline constexpr std::size_t kHeaderBytes = 5;       //!< version, op code, seq no, count (u16)
inline constexpr std::size_t kFrameHeaderBytes = 5;  //!< can_id (u32), len (u8)
inline constexpr std::uint8_t kCanFdFlag = 0x80;     //!< in len: a CAN FD frame, flags byte follows
inline constexpr std::size_t kMaxDatagramBytes = 1472;  //!< one Ethernet MTU of UDP payload [bytes]
//! The most frames a kMaxDatagramBytes datagram can hold (all with dlc 0) [frames].
inline constexpr std::size_t kMaxFramesPerDatagram = (kMaxDatagramBytes - kHeaderBytes) / kFrameHeaderBytes;

struct Header {
  std::uint8_t version = kVersion;
  std::uint8_t op_code = kOpData;
  std::uint8_t seq_no = 0;  //!< per sender, +1 per datagram, wraps at 256
  std::uint16_t count = 0;  //!< frames that follow [frames]
};

//! Writes a DATA datagram holding frames. Returns the bytes written, or 0 when out is too small or
//! a frame is invalid. RT-safe.
[[nodiscard]] std::size_t encode(std::span<const CanFrame> frames, std::uint8_t seq_no,
                                 std::span<std::uint8_t> out) noexcept;

//! Parses a datagram into header and frames[0..count). Checks the whole datagram before writing
//! anything: WrongLength (short, truncated, trailing bytes), OutOfRange (version != 2, len > 8,
//! count > frames.size()), Unsupported (a CAN FD frame). ACK/NACK datagrams give Ok, count 0.
//! RT-safe.
[[nodiscard]] Status decode(std::span<const std::uint8_t> datagram, Header& header, std::span<CanFrame> frames,
                            std::size_t& count) noexcept;

}  // namespace mgc::hal::cannelloni
