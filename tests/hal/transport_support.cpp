// SPDX-License-Identifier: Apache-2.0
#include "transport_support.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <atomic>

#include "mgc/hal/udp_can_bus.hpp"

namespace mgc::test {

BusPair open_pair(const std::string& kind, const hal::Clock& clock, std::size_t rx_queue) {
  BusPair pair;
  if (kind == "loop") {
    static std::atomic<int> next{0};
    const std::string url = "loop:pair-" + std::to_string(next++) + ",rx_queue=" + std::to_string(rx_queue);
    auto a = hal::open_can_bus(url, &clock);
    auto b = hal::open_can_bus(url, &clock);
    REQUIRE(a);
    REQUIRE(b);
    pair.a = std::move(a.bus);
    pair.b = std::move(b.bus);
  } else if (kind == "socketcan") {
    auto a = hal::open_can_bus("socketcan:vcan0", &clock);
    auto b = hal::open_can_bus("socketcan:vcan0", &clock);
    INFO(a.error << b.error);
    REQUIRE(a);
    REQUIRE(b);
    pair.a = std::move(a.bus);
    pair.b = std::move(b.bus);
  } else {
    REQUIRE(kind == "udp");
    auto a = hal::open_can_bus("udp:127.0.0.1:0", &clock);
    auto b = hal::open_can_bus("udp:127.0.0.1:0", &clock);
    REQUIRE(a);
    REQUIRE(b);
    auto& ua = dynamic_cast<hal::UdpCanBus&>(*a.bus);
    auto& ub = dynamic_cast<hal::UdpCanBus&>(*b.bus);
    REQUIRE(ua.add_peer("127.0.0.1:" + std::to_string(ub.local_port())) == hal::Status::Ok);
    REQUIRE(ub.add_peer("127.0.0.1:" + std::to_string(ua.local_port())) == hal::Status::Ok);
    pair.a = std::move(a.bus);
    pair.b = std::move(b.bus);
  }
  return pair;
}

std::vector<hal::TimedFrame> drain(hal::CanBus& bus, std::size_t expected, std::vector<hal::Status>* statuses,
                                   bool stop_when_idle) {
  std::vector<hal::TimedFrame> got;
  std::array<hal::TimedFrame, 64> buf{};
  // 400 waits of at most 5 ms: a bounded loop that still tolerates a loaded 2-core machine.
  for (int attempt = 0; attempt < 400 && got.size() < expected; ++attempt) {
    const hal::ReceiveResult r = bus.receive(buf);
    if (statuses != nullptr) statuses->push_back(r.status);
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.count));
    if (r.count == 0 && bus.wait_readable(5'000) == hal::Status::Timeout && stop_when_idle) break;
  }
  return got;
}

hal::CanFrame data_frame(std::uint32_t id, std::uint8_t dlc, std::uint8_t seed) {
  hal::CanFrame f = hal::CanFrame::standard(id, dlc);
  for (std::uint8_t i = 0; i < dlc; ++i) f.data[i] = static_cast<std::uint8_t>(seed + i);
  return f;
}

}  // namespace mgc::test
