// SPDX-License-Identifier: Apache-2.0
#include <chrono>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/status.hpp"

namespace mgc::hal {

const char* to_string(Status status) noexcept {
  switch (status) {
    case Status::Ok: return "ok";
    case Status::Timeout: return "timeout";
    case Status::Error: return "error";
    case Status::BadUrl: return "bad url";
    case Status::OsError: return "os error";
    case Status::Unsupported: return "unsupported";
    case Status::InvalidFrame: return "invalid frame";
    case Status::TxQueueFull: return "transmit queue full";
    case Status::RxOverflow: return "receive overflow";
    case Status::BusOff: return "bus off";
    case Status::TooManyFilters: return "too many filters";
    case Status::SendFailed: return "send failed";
    case Status::MalformedDatagram: return "malformed datagram";
    case Status::WrongLength: return "wrong length";
    case Status::WrongId: return "wrong id";
    case Status::OutOfRange: return "out of range";
    case Status::ReservedBits: return "reserved bits set";
    case Status::UnknownId: return "unknown id";
  }
  return "unknown status";
}

const char* to_string(BusState state) noexcept {
  switch (state) {
    case BusState::ErrorActive: return "error-active";
    case BusState::ErrorWarning: return "error-warning";
    case BusState::ErrorPassive: return "error-passive";
    case BusState::BusOff: return "bus-off";
  }
  return "unknown";
}

std::int64_t SteadyClock::now_us() const noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

const SteadyClock& SteadyClock::instance() noexcept {
  static const SteadyClock clock;
  return clock;
}

}  // namespace mgc::hal
