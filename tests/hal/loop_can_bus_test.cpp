// SPDX-License-Identifier: Apache-2.0
// Behaviour of the in-process `loop:` transport that the other transports do not share.
#include <catch2/catch.hpp>

#include <array>

#include "mgc/hal/can_bus.hpp"
#include "transport_support.hpp"

using namespace mgc::hal;
using mgc::test::data_frame;

TEST_CASE("loop buses with the same name share frames, different names do not", "[unit][transport]") {
  ManualClock clock;
  auto a = open_can_bus("loop:shared-site", &clock);
  auto b = open_can_bus("loop:shared-site", &clock);
  auto c = open_can_bus("loop:shared-site", &clock);
  auto other = open_can_bus("loop:other-site", &clock);
  REQUIRE((a && b && c && other));
  REQUIRE(a.bus->send(data_frame(0x80, 0)) == Status::Ok);
  std::array<TimedFrame, 4> buf{};
  CHECK(b.bus->receive(buf).count == 1);
  CHECK(c.bus->receive(buf).count == 1);
  CHECK(a.bus->receive(buf).count == 0);
  CHECK(other.bus->receive(buf).count == 0);
  CHECK(a.bus->url() == "loop:shared-site,rx_queue=1024");
  // A closed endpoint leaves the bus; the others keep talking.
  c.bus.reset();
  REQUIRE(a.bus->send(data_frame(0x81, 0)) == Status::Ok);
  CHECK(b.bus->receive(buf).count == 1);
}
