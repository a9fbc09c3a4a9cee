// SPDX-License-Identifier: Apache-2.0
// Bus hygiene at the decoding edge: the Hal counts malformed frames by kind, frames of COB-ids no
// node of the plan uses, and encoder positions outside a joint's plausible range, and applies
// none of the malformed ones to the snapshot.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/hal.hpp"

using namespace mgc::hal;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Rig {
  explicit Rig(const std::string& name) : clock(1'000'000) {
    controller = std::move(open_can_bus("loop:" + name, &clock).bus);
    device = std::move(open_can_bus("loop:" + name, &clock).bus);
    REQUIRE(controller);
    REQUIRE(device);
    hal = std::make_unique<Hal>(*controller, plan, std::vector<double>{0.1, 0.02, 0.1, 0.5});
  }
  void send(const CanFrame& frame) { REQUIRE(device->send(frame) == Status::Ok); }
  const SensorSnapshot& read() {
    clock.advance_us(10'000);
    return hal->read(clock.now_us());
  }
  //! Joint j's encoder TPDO1 with these counts, status 0.
  CanFrame encoder(std::size_t j, std::int32_t counts) const {
    return pdo::encode_encoder_position({plan.encoders[j].node_id, counts, 0}).value;
  }

  BusPlan plan = mobile_crane_bus_plan();
  ManualClock clock;
  std::unique_ptr<CanBus> controller;
  std::unique_ptr<CanBus> device;
  std::unique_ptr<Hal> hal;
};

}  // namespace

TEST_CASE("Hal counts each kind of malformed frame and applies none of them", "[unit][hal]") {
  Rig rig("hygiene-malformed");
  rig.send(rig.encoder(0, 10'000));
  const SensorSnapshot& first = rig.read();
  REQUIRE(first.codec.decoded == 1);
  REQUIRE(first.joints[0].samples == 1);
  const double position = first.joints[0].position;

  // Wrong DLC: an encoder frame of 4 bytes instead of 5.
  CanFrame short_frame = rig.encoder(0, 20'000);
  short_frame.dlc = 4;
  rig.send(short_frame);
  // One valid frame among the bad ones.
  rig.send(rig.encoder(0, pdo::kEncoderPositionReserved + 1));
  // Bad payload: the reserved "not available" position, and a heartbeat state byte no NMT state has.
  CanFrame reserved_position = rig.encoder(0, 20'000);
  canopen::put_u32_le(reserved_position, 0, static_cast<std::uint32_t>(pdo::kEncoderPositionReserved));
  rig.send(reserved_position);
  CanFrame bad_state = canopen::encode_heartbeat({rig.plan.encoders[1].node_id, canopen::NmtState::Operational}).value;
  bad_state.data[0] = 0x42;
  rig.send(bad_state);
  // Reserved bits: encoder status bits 2..7.
  CanFrame reserved_bits = rig.encoder(0, 20'000);
  reserved_bits.data[4] = 0x80;
  rig.send(reserved_bits);

  const SensorSnapshot& s = rig.read();
  CHECK(s.codec.wrong_length == 1);
  CHECK(s.codec.out_of_range == 2);
  CHECK(s.codec.reserved_bits == 1);
  CHECK(s.codec.wrong_id == 0);
  CHECK(s.codec.unknown_id == 0);
  CHECK(s.codec.malformed() == 4);
  // Only the one valid frame among them was applied.
  CHECK(s.codec.decoded == 2);
  CHECK(s.joints[0].samples == 2);
  CHECK(s.joints[0].position != position);
  CHECK(s.joints[0].position == Approx(pdo::counts_to_si(pdo::kEncoderPositionReserved + 1, pdo::EncoderKind::Rotary)));
  CHECK_FALSE(s.encoders[1].heard);
}

TEST_CASE("Hal counts frames of COB-ids no node of the plan uses", "[unit][hal]") {
  Rig rig("hygiene-unknown");
  rig.send(CanFrame::standard(0x5B0, 8));                       // SDO to the valve node
  rig.send(CanFrame::standard(0x17F, 5));                       // TPDO1 of node 0x7F, not in the plan
  rig.send(CanFrame::standard(canopen::heartbeat_cob_id(0x42), 1));  // a stranger's heartbeat
  CanFrame extended = rig.encoder(0, 1'000);
  extended.can_id |= kCanEffFlag;                               // the encoder's id as a 29-bit id
  rig.send(extended);
  CanFrame remote = rig.encoder(0, 1'000);
  remote.can_id |= kCanRtrFlag;
  rig.send(remote);
  const SensorSnapshot& s = rig.read();
  CHECK(s.codec.unknown_id == 5);
  CHECK(s.codec.malformed() == 0);
  CHECK(s.codec.decoded == 0);
  CHECK(s.joints[0].samples == 0);
}

TEST_CASE("Hal counts encoder positions outside the joint's plausible range, still decoded", "[unit][hal]") {
  Rig rig("hygiene-implausible");
  // Boom elevation (joint 1, rotary): plausible -5..95 deg.
  rig.hal->set_joint_plausible_range(1, -5 * kDeg, 95 * kDeg);
  rig.send(rig.encoder(1, 45'000));    // 45 deg
  rig.send(rig.encoder(1, 95'000));    // 95 deg: the bound itself
  rig.send(rig.encoder(1, 200'000));   // 200 deg: not a boom angle
  rig.send(rig.encoder(1, -90'000));   // -90 deg
  rig.send(rig.encoder(0, 720'000));   // swing, no range set: any value is plausible
  const SensorSnapshot& s = rig.read();
  CHECK(s.codec.decoded == 5);
  CHECK(s.codec.implausible == 2);
  CHECK(s.codec.malformed() == 0);
  CHECK(s.joints[1].samples == 4);
  CHECK(s.joints[1].position == Approx(-90 * kDeg));

  CHECK_THROWS_AS(rig.hal->set_joint_plausible_range(4, 0.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(rig.hal->set_joint_plausible_range(1, 1.0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(rig.hal->set_joint_plausible_range(1, std::numeric_limits<double>::quiet_NaN(), 1.0),
                  std::invalid_argument);
}
