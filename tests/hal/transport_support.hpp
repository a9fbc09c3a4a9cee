// SPDX-License-Identifier: Apache-2.0
// Endpoint pairs for the transport tests, so that one test body runs against every transport.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "mgc/hal/can_bus.hpp"

namespace mgc::test {

struct BusPair {
  std::unique_ptr<hal::CanBus> a;
  std::unique_ptr<hal::CanBus> b;
};

//! The transport kinds the conformance test cases run against in this executable: loop and udp on
//! the host, socketcan in the vcan VM. Each executable that runs them links one definition.
const std::vector<std::string>& conformance_transports();

//! Two endpoints of one bus: kind "loop" (a fresh bus name, rx_queue frames per queue), "udp"
//! (127.0.0.1, OS-chosen ports, each the other's peer) or "socketcan" (two raw sockets on vcan0,
//! which must exist and be up). rx_queue applies to loop only. REQUIREs success.
BusPair open_pair(const std::string& kind, const hal::Clock& clock, std::size_t rx_queue = 1024);

//! Receives until `expected` frames arrived or about 2 s passed (or, with stop_when_idle, until a
//! 5 ms wait brings nothing); every receive() status is appended to statuses when given.
std::vector<hal::TimedFrame> drain(hal::CanBus& bus, std::size_t expected,
                                   std::vector<hal::Status>* statuses = nullptr, bool stop_when_idle = false);

//! A standard data frame with id and dlc, payload bytes = seed + index.
hal::CanFrame data_frame(std::uint32_t id, std::uint8_t dlc, std::uint8_t seed = 0);

}  // namespace mgc::test
