// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/status.hpp"

namespace mgc::hal {

//! CAN controller fault confinement state, as SocketCAN reports it through error frames.
enum class BusState : std::uint8_t { ErrorActive, ErrorWarning, ErrorPassive, BusOff };

[[nodiscard]] const char* to_string(BusState state) noexcept;

//! Monotonic counters since open.
struct BusCounters {
  std::uint64_t tx_frames = 0;            //!< frames handed to the bus [frames]
  std::uint64_t tx_failed = 0;            //!< send() calls that returned an error [frames]
  std::uint64_t rx_frames = 0;            //!< frames returned by receive() [frames]
  std::uint64_t rx_lost = 0;              //!< frames (udp: datagrams) lost before receive() [frames]
  std::uint64_t rx_malformed = 0;         //!< datagrams dropped as not cannelloni format 2 [datagrams]
  std::uint64_t error_frames = 0;         //!< error frames seen, delivered or not [frames]
  std::uint64_t bus_off_events = 0;       //!< transitions into BusOff [events]
  std::uint64_t restarts = 0;             //!< controller restarts after bus-off [events]
};

//! What one receive() call produced.
struct ReceiveResult {
  std::size_t count = 0;      //!< frames written to the front of the span [frames]
  Status status = Status::Ok; //!< RxOverflow if frames were lost since the previous call,
                              //!< MalformedDatagram if a datagram was dropped, BusOff while bus-off
};

//! One endpoint on a classic CAN bus. Endpoints never receive the frames they send themselves
//! (SocketCAN's default), but other endpoints in the same process do.
//!
//! Error frames (kCanErrFlag) received from the bus always update state() and counters(); they are
//! returned by receive() only when their class bits intersect the error mask (default 0), as with
//! CAN_RAW_ERR_FILTER. While BusOff, send() refuses and data frames are not received, until an
//! error frame of class kCanErrRestarted arrives.
//!
//! An endpoint is used by one thread at a time; different endpoints may live in different threads.
class CanBus {
 public:
  virtual ~CanBus() = default;
  CanBus() = default;
  CanBus(const CanBus&) = delete;
  CanBus& operator=(const CanBus&) = delete;

  //! Puts one frame on the bus. RT-safe: no alloc, no throw, never blocks.
  [[nodiscard]] virtual Status send(const CanFrame& frame) noexcept = 0;
  //! Moves up to out.size() received frames, oldest first, into out. RT-safe: no alloc, no throw,
  //! never blocks.
  [[nodiscard]] virtual ReceiveResult receive(std::span<TimedFrame> out) noexcept = 0;
  //! Waits until receive() would return a frame, at most timeout_us: Ok or Timeout. May block;
  //! for the loop harness and tests, not for a control cycle. Any number of threads may
  //! wait while one other thread sends or receives; send() and receive() take one at a time.
  [[nodiscard]] virtual Status wait_readable(std::int64_t timeout_us) noexcept = 0;
  //! Replaces the receive filters; a frame passes when any filter matches. An empty list receives
  //! no data frames (send-only, as CAN_RAW_FILTER with zero filters). Default: pass everything.
  [[nodiscard]] virtual Status set_filters(std::span<const CanFilter> filters) noexcept = 0;
  //! Error frame classes (kCanErr* class bits) that receive() returns. Default 0: none.
  [[nodiscard]] virtual Status set_error_mask(std::uint32_t class_mask) noexcept = 0;

  [[nodiscard]] virtual BusState state() const noexcept = 0;
  [[nodiscard]] virtual BusCounters counters() const noexcept = 0;
  //! The URL this endpoint answers to, with OS-chosen ports filled in. Allocates: edges only.
  [[nodiscard]] virtual std::string url() const = 0;
};

//! open_can_bus's answer: a bus, or the status and a one-line reason naming the URL.
struct OpenResult {
  std::unique_ptr<CanBus> bus;
  Status status = Status::Ok;
  std::string error;
  [[nodiscard]] explicit operator bool() const noexcept { return bus != nullptr; }
};

//! Opens a bus endpoint (startup code; allocates; never throws). URLs:
//!   loop:NAME[,rx_queue=N]              in-process bus NAME; N frames per receive queue (1024)
//!   udp:HOST:PORT[,peer=HOST:PORT]...   cannelloni-format UDP; PORT 0 lets the OS choose;
//!                                        HOST is an IPv4 literal or "localhost"; up to 8 peers
//!   socketcan:IFNAME                    Linux CAN_RAW socket on interface IFNAME
//! Timestamps come from clock (the steady clock when null); it must outlive the bus.
[[nodiscard]] OpenResult open_can_bus(std::string_view url, const Clock* clock = nullptr);

}  // namespace mgc::hal
