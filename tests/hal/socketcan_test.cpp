// SPDX-License-Identifier: Apache-2.0
// What only a real SocketCAN stack can show: the kernel stamps, filters and masks error frames,
// not our code. Runs inside the vcan VM (scripts/vcan-vm/run-in-vm.sh), which brings up vcan0
// and vcan1; the conformance test cases run against socketcan:vcan0 in the same executable.
#include <linux/can/error.h>

#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <string>
#include <thread>

#include "mgc/hal/can_bus.hpp"
#include "transport_support.hpp"

using namespace mgc::hal;
using mgc::test::data_frame;
using mgc::test::drain;
using mgc::test::open_pair;

namespace {

// Long enough for a frame to cross vcan under software emulation, short enough to wait often.
constexpr std::int64_t kSettle_us = 50'000;

// A protocol-violation error class: the endpoint does not track it, so only an explicit error
// mask lets the kernel deliver it.
constexpr std::uint32_t kUntrackedErrorClass = CAN_ERR_PROT;

}  // namespace

TEST_CASE("socketcan stamps frames when the kernel received them, not when receive() ran",
          "[socketcan][vm]") {
  const SteadyClock& clock = SteadyClock::instance();
  auto bus = open_pair("socketcan", clock);

  const std::int64_t sent_us = clock.now_us();
  REQUIRE(bus.a->send(data_frame(0x181, 2)) == Status::Ok);
  // The frame waits in b's socket while time passes: a stamp taken at receive() would be late.
  constexpr std::int64_t kWaited_us = 200'000;
  std::this_thread::sleep_for(std::chrono::microseconds(kWaited_us));
  const std::int64_t receive_us = clock.now_us();
  const auto first = drain(*bus.b, 1);
  REQUIRE(first.size() == 1);
  CHECK(first[0].t_us >= sent_us);
  CHECK(first[0].t_us <= receive_us - kWaited_us / 2);

  // Frames sent 2 ms apart carry stamps that never go backwards and show the spacing.
  constexpr std::size_t kFrames = 50;
  constexpr std::int64_t kGap_us = 2'000;
  const std::int64_t burst_start_us = clock.now_us();
  for (std::uint32_t i = 0; i < kFrames; ++i) {
    REQUIRE(bus.a->send(data_frame(0x200 + i, 1)) == Status::Ok);
    std::this_thread::sleep_for(std::chrono::microseconds(kGap_us));
  }
  const auto burst = drain(*bus.b, kFrames);
  const std::int64_t burst_end_us = clock.now_us();
  REQUIRE(burst.size() == kFrames);
  CHECK(burst.front().t_us >= burst_start_us);
  CHECK(burst.back().t_us <= burst_end_us);
  for (std::size_t i = 1; i < burst.size(); ++i) CHECK(burst[i].t_us >= burst[i - 1].t_us);
  // sleep_for never wakes early, so the span is at least the sum of the gaps.
  CHECK(burst.back().t_us - burst.front().t_us >= static_cast<std::int64_t>(kFrames - 1) * kGap_us);
}

TEST_CASE("socketcan filters in the kernel with CAN_RAW_FILTER, per socket", "[socketcan][vm]") {
  ManualClock clock;
  auto bus = open_pair("socketcan", clock);
  auto unfiltered = open_can_bus("socketcan:vcan0", &clock);
  REQUIRE(unfiltered);
  const std::array<CanFilter, 1> filters{CanFilter::exact(0x181)};
  REQUIRE(bus.b->set_filters(filters) == Status::Ok);

  CanFrame extended_181 = data_frame(0, 1);
  extended_181.can_id = kCanEffFlag | 0x181U;
  REQUIRE(bus.a->send(data_frame(0x182, 1)) == Status::Ok);
  REQUIRE(bus.a->send(extended_181) == Status::Ok);
  // Rejected frames never reach the socket, so it does not even become readable; a filter applied
  // after the kernel had queued them would leave it readable.
  CHECK(bus.b->wait_readable(kSettle_us) == Status::Timeout);
  // Another socket on the same interface has no filter and sees both.
  CHECK(drain(*unfiltered.bus, 2).size() == 2);

  REQUIRE(bus.a->send(data_frame(0x181, 1)) == Status::Ok);
  CHECK(bus.b->wait_readable(kSettle_us) == Status::Ok);
  const auto got = drain(*bus.b, 1);
  REQUIRE(got.size() == 1);
  CHECK(got[0].frame == data_frame(0x181, 1));
}

TEST_CASE("socketcan accepts an error-frame mask and the kernel delivers exactly those classes",
          "[socketcan][vm]") {
  ManualClock clock;
  auto bus = open_pair("socketcan", clock);
  CanFrame protocol_error = CanFrame::standard(0, 8);
  protocol_error.can_id = kCanErrFlag | kUntrackedErrorClass;

  REQUIRE(bus.a->send(protocol_error) == Status::Ok);
  CHECK(bus.b->wait_readable(kSettle_us) == Status::Timeout);
  CHECK(bus.b->counters().error_frames == 0);

  REQUIRE(bus.b->set_error_mask(kUntrackedErrorClass) == Status::Ok);
  REQUIRE(bus.a->send(protocol_error) == Status::Ok);
  const auto got = drain(*bus.b, 1);
  REQUIRE(got.size() == 1);
  CHECK(got[0].frame.can_id == protocol_error.can_id);
  CHECK(bus.b->counters().error_frames == 1);
  CHECK(bus.b->state() == BusState::ErrorActive);

  CHECK(bus.b->set_error_mask(kCanErrMask) == Status::Ok);
  CHECK(bus.b->set_error_mask(0) == Status::Ok);
}

TEST_CASE("socketcan keeps interfaces apart and names a missing one", "[socketcan][vm]") {
  ManualClock clock;
  auto vcan0 = open_can_bus("socketcan:vcan0", &clock);
  auto vcan1 = open_can_bus("socketcan:vcan1", &clock);
  auto vcan1_peer = open_can_bus("socketcan:vcan1", &clock);
  REQUIRE((vcan0 && vcan1 && vcan1_peer));
  CHECK(vcan1.bus->url() == "socketcan:vcan1");
  REQUIRE(vcan0.bus->send(data_frame(0x123, 3)) == Status::Ok);
  CHECK(vcan1.bus->wait_readable(kSettle_us) == Status::Timeout);
  REQUIRE(vcan1_peer.bus->send(data_frame(0x124, 3)) == Status::Ok);
  const auto got = drain(*vcan1.bus, 1);
  REQUIRE(got.size() == 1);
  CHECK(got[0].frame.id() == 0x124);

  const auto missing = open_can_bus("socketcan:vcan9", &clock);
  CHECK_FALSE(missing);
  CHECK(missing.status == Status::OsError);
  CHECK(missing.error.find("vcan9") != std::string::npos);
  CHECK(missing.error.find("if_nametoindex") != std::string::npos);
}
