// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "mgc/hal/can_bus.hpp"

namespace mgc::hal {

inline constexpr std::size_t kMaxUdpPeers = 8;  //!< destinations per UDP endpoint

//! The udp: transport's own operations beyond CanBus: wiring endpoints whose ports the OS chose.
//! open_can_bus("udp:...") returns one of these.
class UdpCanBus : public CanBus {
 public:
  //! The bound local port [port].
  [[nodiscard]] virtual std::uint16_t local_port() const noexcept = 0;
  //! Adds a destination "HOST:PORT". Startup only: BadUrl for a bad address, Error when
  //! kMaxUdpPeers are already set.
  [[nodiscard]] virtual Status add_peer(std::string_view host_port) = 0;
};

}  // namespace mgc::hal
