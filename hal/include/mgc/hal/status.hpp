// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

namespace mgc::hal {

//! Outcome of a hal call (C6): 0 ok, positive = normal but noteworthy, negative = error, hal
//! errors in -100..-199 grouped by tens (open, transport, codec).
enum class Status : std::int16_t {
  Ok = 0,
  Timeout = 1,  //!< a bounded wait ended with nothing to read

  Error = -100,        //!< unclassified
  BadUrl = -101,       //!< open_can_bus: the URL does not parse
  OsError = -102,      //!< a system call failed while opening (the reason is in OpenResult::error)
  Unsupported = -103,  //!< the kernel or the peer lacks the feature (no PF_CAN, a CAN FD frame)

  InvalidFrame = -110,        //!< dlc > 8, or an id wider than its format allows
  TxQueueFull = -111,         //!< the OS transmit queue is full; the frame was not sent
  RxOverflow = -112,          //!< received frames were lost (queue full or sequence gap)
  BusOff = -113,              //!< the controller is bus-off; nothing is sent or received
  TooManyFilters = -114,      //!< more than kMaxFilters receive filters
  SendFailed = -115,          //!< the OS refused the frame for another reason
  MalformedDatagram = -116,   //!< a UDP datagram that is not cannelloni format 2 was dropped

  WrongLength = -120,   //!< the frame's dlc (or a datagram's size) is not the message's
  WrongId = -121,       //!< the frame's id or flags are not the message's
  OutOfRange = -122,    //!< a field holds a value the protocol does not allow
  ReservedBits = -123,  //!< a reserved bit is set
  UnknownId = -124,     //!< no message of the bus plan uses this id
};

//! Short English name, e.g. "wrong length". Never null.
[[nodiscard]] const char* to_string(Status status) noexcept;

//! A value or the reason there is none. Decoders return it and leave nothing else changed.
template <class T>
struct Result {
  Status status = Status::Ok;
  T value{};
  [[nodiscard]] bool ok() const noexcept { return status == Status::Ok; }
};

}  // namespace mgc::hal
