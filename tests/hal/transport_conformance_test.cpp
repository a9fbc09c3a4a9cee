// SPDX-License-Identifier: Apache-2.0
// One conformance test, run against the transports of conformance_transports(): loop: and udp: in
// mgc_hal_tests on the host, socketcan: in mgc_hal_socketcan_tests inside the vcan VM.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <string>

#include "mgc/hal/can_bus.hpp"
#include "transport_support.hpp"

using namespace mgc::hal;
using mgc::test::data_frame;
using mgc::test::drain;
using mgc::test::open_pair;

namespace {

bool nothing_arrives(CanBus& bus) {
  std::array<TimedFrame, 4> buf{};
  (void)bus.wait_readable(5'000);
  return bus.receive(buf).count == 0;
}

}  // namespace

TEST_CASE("transports keep order both ways and do not echo a sender's own frames", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock(1'000);
  auto bus = open_pair(kind, clock);

  for (std::uint32_t i = 0; i < 100; ++i) {
    REQUIRE(bus.a->send(data_frame(0x100 + i, static_cast<std::uint8_t>(i % 9), static_cast<std::uint8_t>(i))) ==
            Status::Ok);
  }
  const auto at_b = drain(*bus.b, 100);
  REQUIRE(at_b.size() == 100);
  for (std::uint32_t i = 0; i < 100; ++i) {
    CHECK(at_b[i].frame == data_frame(0x100 + i, static_cast<std::uint8_t>(i % 9), static_cast<std::uint8_t>(i)));
  }
  CHECK(nothing_arrives(*bus.a));

  for (std::uint32_t i = 0; i < 50; ++i) REQUIRE(bus.b->send(data_frame(0x500 + i, 8)) == Status::Ok);
  const auto at_a = drain(*bus.a, 50);
  REQUIRE(at_a.size() == 50);
  for (std::uint32_t i = 0; i < 50; ++i) CHECK(at_a[i].frame.id() == 0x500 + i);
  CHECK(nothing_arrives(*bus.b));

  CHECK(bus.a->counters().tx_frames == 100);
  CHECK(bus.a->counters().rx_frames == 50);
  CHECK(bus.b->counters().rx_frames == 100);
  CHECK(bus.b->counters().rx_lost == 0);
}

TEST_CASE("transports carry extended and RTR frames unchanged and refuse invalid ones", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock;
  auto bus = open_pair(kind, clock);
  CanFrame extended = data_frame(0, 3, 7);
  extended.can_id = kCanEffFlag | 0x1ABCDEF0U;
  CanFrame rtr = CanFrame::standard(0x123, 0);
  rtr.can_id |= kCanRtrFlag;
  REQUIRE(bus.a->send(extended) == Status::Ok);
  REQUIRE(bus.a->send(rtr) == Status::Ok);
  const auto got = drain(*bus.b, 2);
  REQUIRE(got.size() == 2);
  CHECK(got[0].frame == extended);
  CHECK(got[0].frame.id() == 0x1ABCDEF0U);
  CHECK(got[1].frame == rtr);

  CanFrame too_long = data_frame(0x10, 8);
  too_long.dlc = 9;
  CanFrame wide_standard = data_frame(0x10, 1);
  wide_standard.can_id = 0x800;
  CHECK(bus.a->send(too_long) == Status::InvalidFrame);
  CHECK(bus.a->send(wide_standard) == Status::InvalidFrame);
  CHECK(bus.a->counters().tx_failed == 2);
}

TEST_CASE("transports apply receive filters like CAN_RAW_FILTER", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock;
  auto bus = open_pair(kind, clock);
  const std::array<CanFilter, 2> filters{CanFilter::exact(0x181), CanFilter{0x200, 0x780}};
  REQUIRE(bus.b->set_filters(filters) == Status::Ok);
  for (const std::uint32_t id : {0x181U, 0x182U, 0x201U, 0x27FU, 0x300U, 0x080U}) {
    REQUIRE(bus.a->send(data_frame(id, 1)) == Status::Ok);
  }
  CanFrame rtr_181 = CanFrame::standard(0x181, 0);
  rtr_181.can_id |= kCanRtrFlag;
  REQUIRE(bus.a->send(rtr_181) == Status::Ok);
  // The marker shows everything before it has been through the filters.
  REQUIRE(bus.a->send(data_frame(0x27E, 0)) == Status::Ok);
  const auto got = drain(*bus.b, 4);
  REQUIRE(got.size() == 4);
  CHECK(got[0].frame.id() == 0x181);
  CHECK(got[1].frame.id() == 0x201);
  CHECK(got[2].frame.id() == 0x27F);
  CHECK(got[3].frame.id() == 0x27E);
  CHECK(nothing_arrives(*bus.b));

  REQUIRE(bus.b->set_filters({}) == Status::Ok);
  REQUIRE(bus.a->send(data_frame(0x181, 1)) == Status::Ok);
  CHECK(nothing_arrives(*bus.b));

  const std::array<CanFilter, kMaxFilters + 1> too_many{};
  CHECK(bus.b->set_filters(too_many) == Status::TooManyFilters);
}

TEST_CASE("transports stamp frames on the injected clock, never going backwards", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock(5'000'000);
  auto bus = open_pair(kind, clock);
  // socketcan dates a frame back from receive() by its real age in the kernel's queue, which a
  // loaded machine or the emulated VM stretches to many ms: 20 steps of 10 ms leave room for it.
  constexpr std::int64_t kStep_us = 10'000;
  for (std::uint32_t i = 0; i < 20; ++i) {
    REQUIRE(bus.a->send(data_frame(0x200 + i, 2)) == Status::Ok);
    clock.advance_us(kStep_us);
  }
  const auto got = drain(*bus.b, 20);
  REQUIRE(got.size() == 20);
  for (std::size_t i = 0; i < got.size(); ++i) {
    CHECK(got[i].t_us >= 5'000'000);
    CHECK(got[i].t_us <= clock.now_us());
    if (i > 0) CHECK(got[i].t_us >= got[i - 1].t_us);
  }
  if (kind == "loop") {
    // The in-process bus stamps on delivery, which is the send: exactly the stepped clock.
    for (std::size_t i = 0; i < got.size(); ++i) CHECK(got[i].t_us == 5'000'000 + kStep_us * static_cast<std::int64_t>(i));
  }
  // A clock stepped backwards does not make timestamps go backwards.
  clock.set_us(1'000);
  REQUIRE(bus.a->send(data_frame(0x300, 0)) == Status::Ok);
  const auto late = drain(*bus.b, 1);
  REQUIRE(late.size() == 1);
  CHECK(late[0].t_us >= got.back().t_us);
}

TEST_CASE("transports report a full receive queue as lost frames, never silently", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock;
  auto bus = open_pair(kind, clock, 64);
  // 5,000 undrained frames overflow a 64-frame loop queue and a default UDP or CAN_RAW socket buffer
  // alike.
  constexpr std::size_t kSent = 5'000;
  std::size_t accepted = 0;
  for (std::size_t i = 0; i < kSent; ++i) accepted += bus.a->send(data_frame(0x400, 2)) == Status::Ok ? 1 : 0;
  CHECK(accepted + bus.a->counters().tx_failed == kSent);
  std::vector<Status> statuses;
  auto got = drain(*bus.b, kSent, &statuses, true);
  // UDP learns of a loss from the next datagram's sequence number, so send a marker after the burst.
  REQUIRE(bus.a->send(data_frame(0x401, 0)) == Status::Ok);
  const auto marker = drain(*bus.b, 1, &statuses);
  REQUIRE(marker.size() == 1);
  CHECK(marker[0].frame.id() == 0x401);
  CHECK(got.size() < kSent);
  CHECK(bus.b->counters().rx_lost > 0);
  CHECK(std::count(statuses.begin(), statuses.end(), Status::RxOverflow) >= 1);
  if (kind == "loop") {
    CHECK(got.size() == 64);
    CHECK(bus.b->counters().rx_lost == kSent - 64);
  }
}

TEST_CASE("transports track bus-off and restart from error frames", "[unit][transport]") {
  const std::string kind = GENERATE(from_range(mgc::test::conformance_transports()));
  CAPTURE(kind);
  ManualClock clock;
  auto bus = open_pair(kind, clock);
  CanFrame passive = CanFrame::standard(0, 8);
  passive.can_id = kCanErrFlag | kCanErrCrtl;
  passive.data[1] = kCanErrCrtlTxPassive;
  CanFrame bus_off = CanFrame::standard(0, 8);
  bus_off.can_id = kCanErrFlag | kCanErrBusOff;
  CanFrame restarted = CanFrame::standard(0, 8);
  restarted.can_id = kCanErrFlag | kCanErrRestarted;

  REQUIRE(bus.b->set_error_mask(kCanErrBusOff) == Status::Ok);
  REQUIRE(bus.a->send(passive) == Status::Ok);
  REQUIRE(bus.a->send(data_frame(0x181, 1)) == Status::Ok);
  REQUIRE(drain(*bus.b, 1).size() == 1);
  CHECK(bus.b->state() == BusState::ErrorPassive);

  REQUIRE(bus.a->send(bus_off) == Status::Ok);
  const auto delivered = drain(*bus.b, 1);
  REQUIRE(delivered.size() == 1);
  CHECK(delivered[0].frame.is_error());
  CHECK(bus.b->state() == BusState::BusOff);
  CHECK(bus.b->send(data_frame(0x181, 1)) == Status::BusOff);
  REQUIRE(bus.a->send(data_frame(0x182, 1)) == Status::Ok);
  CHECK(nothing_arrives(*bus.b));

  REQUIRE(bus.a->send(restarted) == Status::Ok);
  REQUIRE(bus.a->send(data_frame(0x183, 1)) == Status::Ok);
  const auto after = drain(*bus.b, 1);
  REQUIRE(after.size() == 1);
  CHECK(after[0].frame.id() == 0x183);
  CHECK(bus.b->state() == BusState::ErrorActive);
  CHECK(bus.b->send(data_frame(0x181, 1)) == Status::Ok);
  const BusCounters c = bus.b->counters();
  CHECK(c.error_frames == 3);
  CHECK(c.bus_off_events == 1);
  CHECK(c.restarts == 1);
}
