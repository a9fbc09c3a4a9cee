// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/can_bus.hpp"

#include <charconv>
#include <string>
#include <vector>

#include "bus_common.hpp"
#include "mgc/hal/udp_can_bus.hpp"

namespace mgc::hal {

namespace detail {

void apply_error_frame(const CanFrame& frame, BusState& state, BusCounters& counters) noexcept {
  ++counters.error_frames;
  const std::uint32_t classes = frame.can_id & kCanErrMask;
  if (state != BusState::BusOff) {
    if ((classes & kCanErrCrtl) != 0 && frame.dlc >= 2) {
      const std::uint8_t flags = frame.data[1];
      if ((flags & (kCanErrCrtlRxOverflow | kCanErrCrtlTxOverflow)) != 0) ++counters.rx_lost;
      if ((flags & (kCanErrCrtlRxPassive | kCanErrCrtlTxPassive)) != 0) {
        state = BusState::ErrorPassive;
      } else if ((flags & (kCanErrCrtlRxWarning | kCanErrCrtlTxWarning)) != 0) {
        state = BusState::ErrorWarning;
      } else if ((flags & kCanErrCrtlActive) != 0) {
        state = BusState::ErrorActive;
      }
    }
    if ((classes & kCanErrCnt) != 0 && frame.dlc == 8) {
      // Fault confinement thresholds: 0-95 active, 96-127 warning, >= 128 passive.
      const int worst = frame.data[6] > frame.data[7] ? frame.data[6] : frame.data[7];
      state = worst >= 128 ? BusState::ErrorPassive : worst >= 96 ? BusState::ErrorWarning : BusState::ErrorActive;
    }
  }
  if ((classes & kCanErrBusOff) != 0 && state != BusState::BusOff) {
    state = BusState::BusOff;
    ++counters.bus_off_events;
  }
  if ((classes & kCanErrRestarted) != 0) {
    state = BusState::ErrorActive;
    ++counters.restarts;
  }
}

Status RxPolicy::set_filters(std::span<const CanFilter> filters) noexcept {
  if (filters.size() > kMaxFilters) return Status::TooManyFilters;
  num_filters_ = filters.size();
  for (std::size_t i = 0; i < num_filters_; ++i) filters_[i] = filters[i];
  return Status::Ok;
}

bool RxPolicy::admit(const CanFrame& frame, BusState& state, BusCounters& counters) const noexcept {
  if (frame.is_error()) {
    apply_error_frame(frame, state, counters);
    return (frame.can_id & error_mask_) != 0;
  }
  // A bus-off controller takes no part in bus traffic.
  if (state == BusState::BusOff) return false;
  for (std::size_t i = 0; i < num_filters_; ++i) {
    if (filters_[i].matches(frame.can_id)) return true;
  }
  return false;
}

bool parse_ipv4_endpoint(std::string_view text, bool allow_port_zero, Ipv4Endpoint& out, std::string& why) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) {
    why = "expected HOST:PORT, got '" + std::string(text) + "'";
    return false;
  }
  const std::string_view host = text.substr(0, colon);
  const std::string_view port = text.substr(colon + 1);
  Ipv4Endpoint e;
  if (host == "localhost") {
    e.address = 0x7F000001U;
  } else {
    std::string_view rest = host;
    for (int i = 0; i < 4; ++i) {
      unsigned octet = 0;
      const auto [ptr, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), octet);
      const std::size_t used = static_cast<std::size_t>(ptr - rest.data());
      if (ec != std::errc{} || used == 0 || used > 3 || octet > 255) {
        why = "host '" + std::string(host) + "' is not an IPv4 address (A.B.C.D or localhost)";
        return false;
      }
      e.address = (e.address << 8) | octet;
      rest.remove_prefix(used);
      if (i < 3) {
        if (rest.empty() || rest.front() != '.') {
          why = "host '" + std::string(host) + "' is not an IPv4 address (A.B.C.D or localhost)";
          return false;
        }
        rest.remove_prefix(1);
      }
    }
    if (!rest.empty()) {
      why = "host '" + std::string(host) + "' is not an IPv4 address (A.B.C.D or localhost)";
      return false;
    }
  }
  unsigned long value = 0;
  const auto [ptr, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (port.empty() || ec != std::errc{} || ptr != port.data() + port.size() || value > 65535 ||
      (value == 0 && !allow_port_zero)) {
    why = "port '" + std::string(port) + "' is not " + (allow_port_zero ? "0..65535" : "1..65535");
    return false;
  }
  e.port = static_cast<std::uint16_t>(value);
  out = e;
  return true;
}

std::string format_ipv4_endpoint(const Ipv4Endpoint& endpoint) {
  return std::to_string(endpoint.address >> 24) + "." + std::to_string((endpoint.address >> 16) & 0xFFU) + "." +
         std::to_string((endpoint.address >> 8) & 0xFFU) + "." + std::to_string(endpoint.address & 0xFFU) + ":" +
         std::to_string(endpoint.port);
}

}  // namespace detail

namespace {

OpenResult bad_url(std::string_view url, const std::string& why) {
  return {nullptr, Status::BadUrl, "CAN bus URL '" + std::string(url) + "': " + why};
}

std::vector<std::string_view> split_commas(std::string_view text) {
  std::vector<std::string_view> parts;
  while (true) {
    const std::size_t comma = text.find(',');
    parts.push_back(text.substr(0, comma));
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return parts;
}

constexpr std::size_t kDefaultLoopQueueFrames = 1024;
constexpr std::size_t kMaxLoopQueueFrames = 1U << 20;
// Linux IFNAMSIZ is 16 including the terminating NUL.
constexpr std::size_t kMaxIfNameChars = 15;

}  // namespace

OpenResult open_can_bus(std::string_view url, const Clock* clock) {
  const Clock& c = clock != nullptr ? *clock : SteadyClock::instance();
  const std::size_t colon = url.find(':');
  if (colon == std::string_view::npos) {
    return bad_url(url, "expected SCHEME:..., with scheme loop, udp or socketcan");
  }
  const std::string_view scheme = url.substr(0, colon);
  const std::vector<std::string_view> parts = split_commas(url.substr(colon + 1));

  if (scheme == "loop") {
    const std::string_view name = parts[0];
    if (name.empty()) return bad_url(url, "loop: needs a bus name, e.g. loop:crane");
    std::size_t queue = kDefaultLoopQueueFrames;
    for (std::size_t i = 1; i < parts.size(); ++i) {
      const std::string_view opt = parts[i];
      if (!opt.starts_with("rx_queue=")) return bad_url(url, "unknown loop option '" + std::string(opt) + "'");
      const std::string_view v = opt.substr(9);
      const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), queue);
      if (v.empty() || ec != std::errc{} || ptr != v.data() + v.size() || queue == 0 || queue > kMaxLoopQueueFrames) {
        return bad_url(url, "rx_queue must be 1.." + std::to_string(kMaxLoopQueueFrames) + " frames");
      }
    }
    return detail::open_loop_bus(name, queue, c);
  }
  if (scheme == "udp") {
    detail::Ipv4Endpoint local;
    std::string why;
    if (!detail::parse_ipv4_endpoint(parts[0], true, local, why)) return bad_url(url, why);
    std::vector<detail::Ipv4Endpoint> peers;
    for (std::size_t i = 1; i < parts.size(); ++i) {
      const std::string_view opt = parts[i];
      if (!opt.starts_with("peer=")) return bad_url(url, "unknown udp option '" + std::string(opt) + "'");
      detail::Ipv4Endpoint peer;
      if (!detail::parse_ipv4_endpoint(opt.substr(5), false, peer, why)) return bad_url(url, "peer " + why);
      peers.push_back(peer);
    }
    if (peers.size() > kMaxUdpPeers) return bad_url(url, "at most " + std::to_string(kMaxUdpPeers) + " peers");
    return detail::open_udp_bus(local, peers, c);
  }
  if (scheme == "socketcan") {
    const std::string_view ifname = parts[0];
    if (parts.size() != 1) return bad_url(url, "socketcan: takes no options");
    if (ifname.empty() || ifname.size() > kMaxIfNameChars) {
      return bad_url(url, "interface name must be 1.." + std::to_string(kMaxIfNameChars) + " characters");
    }
    return detail::open_socketcan_bus(ifname, c);
  }
  return bad_url(url, "unknown scheme '" + std::string(scheme) + "' (expected loop, udp or socketcan)");
}

}  // namespace mgc::hal
