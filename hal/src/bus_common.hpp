// SPDX-License-Identifier: Apache-2.0
// Pieces every transport shares: receive filtering, error-frame interpretation, URL pieces and
// the per-transport open functions behind open_can_bus.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "mgc/hal/can_bus.hpp"

namespace mgc::hal::detail {

//! Updates state and counters from one error frame, with SocketCAN's meaning of the class bits.
void apply_error_frame(const CanFrame& frame, BusState& state, BusCounters& counters) noexcept;

//! Filters plus error mask: decides whether a received frame reaches receive(). RT-safe.
class RxPolicy {
 public:
  [[nodiscard]] Status set_filters(std::span<const CanFilter> filters) noexcept;
  void set_error_mask(std::uint32_t class_mask) noexcept { error_mask_ = class_mask & kCanErrMask; }
  [[nodiscard]] std::span<const CanFilter> filters() const noexcept { return {filters_.data(), num_filters_}; }
  [[nodiscard]] std::uint32_t error_mask() const noexcept { return error_mask_; }
  //! Error frames update state/counters and pass if their class is in the mask; data frames pass
  //! a filter unless the bus is off.
  [[nodiscard]] bool admit(const CanFrame& frame, BusState& state, BusCounters& counters) const noexcept;

 private:
  std::array<CanFilter, kMaxFilters> filters_{};  // one zero-mask filter: pass everything
  std::size_t num_filters_ = 1;
  std::uint32_t error_mask_ = 0;
};

//! Keeps a stream of timestamps from ever going backwards.
[[nodiscard]] inline std::int64_t monotonic_us(std::int64_t t_us, std::int64_t& last_us) noexcept {
  if (t_us < last_us) t_us = last_us;
  last_us = t_us;
  return t_us;
}

//! IPv4 address and port, host byte order.
struct Ipv4Endpoint {
  std::uint32_t address = 0;
  std::uint16_t port = 0;
};

//! "A.B.C.D:PORT" or "localhost:PORT". On failure returns false and says why.
[[nodiscard]] bool parse_ipv4_endpoint(std::string_view text, bool allow_port_zero, Ipv4Endpoint& out,
                                       std::string& why);
[[nodiscard]] std::string format_ipv4_endpoint(const Ipv4Endpoint& endpoint);

OpenResult open_loop_bus(std::string_view name, std::size_t rx_queue_frames, const Clock& clock);
OpenResult open_udp_bus(const Ipv4Endpoint& local, std::span<const Ipv4Endpoint> peers, const Clock& clock);
OpenResult open_socketcan_bus(std::string_view ifname, const Clock& clock);

}  // namespace mgc::hal::detail
