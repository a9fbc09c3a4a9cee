// SPDX-License-Identifier: Apache-2.0
// send() and receive() run every control cycle, so after warm-up they must not touch the heap.
// tests/support/allocation_counter.cpp counts allocations.
#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "allocation_counter.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/hal.hpp"
#include "transport_support.hpp"

using namespace mgc::hal;

TEST_CASE("send, receive and the codec do not allocate after warm-up", "[unit][transport]") {
  const std::string kind = GENERATE(as<std::string>{}, "loop", "udp");
  CAPTURE(kind);
  ManualClock clock;
  auto bus = mgc::test::open_pair(kind, clock);
  const BusPlan plan = excavator_bus_plan();
  std::array<TimedFrame, 16> buf{};
  CodecCounters codec;

  // One controller-like cycle: SYNC and a valve command out, encoder PDOs back, all decoded.
  const auto cycle = [&](int i) {
    long received = 0;
    const auto sync = canopen::encode_sync({static_cast<std::uint8_t>(1 + i % 240)});
    const auto command = pdo::encode_valve_command({kValveNodeId, 0, {{static_cast<std::int16_t>(i % 100), 0, 0, 0}}});
    if (bus.a->send(sync.value) != Status::Ok || bus.a->send(command.value) != Status::Ok) return -1L;
    for (std::uint8_t j = 0; j < plan.num_joints; ++j) {
      const auto pos = pdo::encode_encoder_position({plan.encoders[j].node_id, i * 10, 0});
      if (bus.b->send(pos.value) != Status::Ok) return -1L;
    }
    for (int attempt = 0; attempt < 100 && received < 4; ++attempt) {
      const ReceiveResult r = bus.a->receive(buf);
      for (std::size_t k = 0; k < r.count; ++k) {
        const Classified c = classify(buf[k].frame, plan);
        codec.record(c.kind == MessageKind::EncoderPosition ? pdo::decode_encoder_position(buf[k].frame).status
                                                            : Status::UnknownId);
      }
      received += static_cast<long>(r.count);
      if (r.count == 0) (void)bus.a->wait_readable(5'000);
    }
    const ReceiveResult rb = bus.b->receive(buf);
    for (std::size_t k = 0; k < rb.count; ++k) {
      if (buf[k].frame.can_id == canopen::kSyncCobId) codec.record(canopen::decode_sync(buf[k].frame).status);
    }
    clock.advance_us(10'000);
    return received;
  };

  for (int i = 0; i < 50; ++i) REQUIRE(cycle(i) == 4);
  const long before = mgc::test::allocation_count();
  long received = 0;
  for (int i = 0; i < 2'000; ++i) received += cycle(i);
  const long allocations = mgc::test::allocation_count() - before;
  CHECK(received == 4 * 2'000);
  CHECK(allocations == 0);
  CHECK(codec.malformed() == 0);
  CHECK(codec.decoded > 8'000);
}

TEST_CASE("Hal::read counts malformed, unknown and implausible frames without allocating", "[unit][hal]") {
  ManualClock clock(1'000'000);
  auto controller = open_can_bus("loop:alloc-hygiene", &clock).bus;
  auto device = open_can_bus("loop:alloc-hygiene", &clock).bus;
  REQUIRE(controller);
  REQUIRE(device);
  const BusPlan plan = mobile_crane_bus_plan();
  Hal hal(*controller, plan, std::vector<double>{0.1, 0.02, 0.1, 0.5});
  hal.set_joint_plausible_range(1, 0.0, 1.0);
  CanFrame short_frame = pdo::encode_encoder_position({plan.encoders[0].node_id, 10, 0}).value;
  short_frame.dlc = 3;
  const CanFrame unknown = CanFrame::standard(0x5B0, 8);
  const CanFrame implausible = pdo::encode_encoder_position({plan.encoders[1].node_id, 170'000, 0}).value;
  const auto cycle = [&] {
    (void)device->send(short_frame);
    (void)device->send(unknown);
    (void)device->send(implausible);
    clock.advance_us(10'000);
    (void)hal.read(clock.now_us());
  };
  for (int i = 0; i < 20; ++i) cycle();
  const long before = mgc::test::allocation_count();
  for (int i = 0; i < 1'000; ++i) cycle();
  const long allocations = mgc::test::allocation_count() - before;
  CHECK(allocations == 0);
  CHECK(hal.snapshot().codec.wrong_length == 1'020);
  CHECK(hal.snapshot().codec.unknown_id == 1'020);
  CHECK(hal.snapshot().codec.implausible == 1'020);
}
