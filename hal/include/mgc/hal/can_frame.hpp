// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace mgc::hal {

// Identifier flags and masks, bit-identical to Linux <linux/can.h> canid_t so that SocketCAN and
// the cannelloni UDP format carry the id word unchanged.
inline constexpr std::uint32_t kCanEffFlag = 0x80000000U;  //!< 29-bit (extended) identifier
inline constexpr std::uint32_t kCanRtrFlag = 0x40000000U;  //!< remote transmission request
inline constexpr std::uint32_t kCanErrFlag = 0x20000000U;  //!< error frame (class bits in the id)
inline constexpr std::uint32_t kCanSffMask = 0x000007FFU;  //!< 11-bit identifier
inline constexpr std::uint32_t kCanEffMask = 0x1FFFFFFFU;  //!< 29-bit identifier
inline constexpr std::uint32_t kCanErrMask = 0x1FFFFFFFU;  //!< error class bits
inline constexpr std::uint8_t kCanMaxDlc = 8;              //!< classic CAN payload [bytes]

// Error frame classes and data[1] controller flags (Linux <linux/can/error.h>).
inline constexpr std::uint32_t kCanErrTxTimeout = 0x001U;
inline constexpr std::uint32_t kCanErrCrtl = 0x004U;
inline constexpr std::uint32_t kCanErrBusOff = 0x040U;
inline constexpr std::uint32_t kCanErrRestarted = 0x100U;
inline constexpr std::uint32_t kCanErrCnt = 0x200U;
inline constexpr std::uint8_t kCanErrCrtlRxOverflow = 0x01;
inline constexpr std::uint8_t kCanErrCrtlTxOverflow = 0x02;
inline constexpr std::uint8_t kCanErrCrtlRxWarning = 0x04;
inline constexpr std::uint8_t kCanErrCrtlTxWarning = 0x08;
inline constexpr std::uint8_t kCanErrCrtlRxPassive = 0x10;
inline constexpr std::uint8_t kCanErrCrtlTxPassive = 0x20;
inline constexpr std::uint8_t kCanErrCrtlActive = 0x40;

//! One classic CAN frame. Plain data, no heap.
struct CanFrame {
  std::uint32_t can_id = 0;             //!< identifier plus kCanEffFlag/kCanRtrFlag/kCanErrFlag
  std::uint8_t dlc = 0;                 //!< payload length 0..8 [bytes]
  std::array<std::uint8_t, 8> data{};   //!< payload; bytes at and beyond dlc are zero by convention

  //! An 11-bit data frame; the caller fills data and dlc.
  [[nodiscard]] static constexpr CanFrame standard(std::uint32_t id11, std::uint8_t length) noexcept {
    CanFrame f;
    f.can_id = id11 & kCanSffMask;
    f.dlc = length;
    return f;
  }

  [[nodiscard]] constexpr bool is_extended() const noexcept { return (can_id & kCanEffFlag) != 0; }
  [[nodiscard]] constexpr bool is_rtr() const noexcept { return (can_id & kCanRtrFlag) != 0; }
  [[nodiscard]] constexpr bool is_error() const noexcept { return (can_id & kCanErrFlag) != 0; }
  //! The 11- or 29-bit identifier without flags.
  [[nodiscard]] constexpr std::uint32_t id() const noexcept {
    return can_id & (is_extended() ? kCanEffMask : kCanSffMask);
  }
  //! dlc within 0..8; a standard id has nothing above bit 10 (flags aside).
  [[nodiscard]] constexpr bool valid() const noexcept {
    if (dlc > kCanMaxDlc) return false;
    if (is_extended() || is_error()) return true;
    return (can_id & kCanEffMask & ~kCanSffMask) == 0;
  }
  [[nodiscard]] std::span<const std::uint8_t> payload() const noexcept {
    return {data.data(), dlc <= kCanMaxDlc ? dlc : kCanMaxDlc};
  }

  friend constexpr bool operator==(const CanFrame&, const CanFrame&) = default;
};

//! A received frame and when it arrived.
struct TimedFrame {
  CanFrame frame;
  std::int64_t t_us = 0;  //!< receive time on the bus's clock (monotonic, never decreasing) [µs]
};

//! Receive filter with SocketCAN's can_filter meaning: a frame passes when
//! (frame.can_id & can_mask) == (can_id & can_mask). Flags take part, so put kCanEffFlag and
//! kCanRtrFlag in the mask to match only standard data frames.
struct CanFilter {
  std::uint32_t can_id = 0;
  std::uint32_t can_mask = 0;  //!< 0 passes everything

  [[nodiscard]] constexpr bool matches(std::uint32_t frame_can_id) const noexcept {
    return (frame_can_id & can_mask) == (can_id & can_mask);
  }
  //! Exactly one 11-bit id, data frames only.
  [[nodiscard]] static constexpr CanFilter exact(std::uint32_t id11) noexcept {
    return {id11 & kCanSffMask, kCanEffFlag | kCanRtrFlag | kCanSffMask};
  }
};

inline constexpr std::size_t kMaxFilters = 16;  //!< receive filters per endpoint

}  // namespace mgc::hal
