// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include "codec_support.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/canopen.hpp"

using namespace mgc::hal;
using namespace mgc::hal::canopen;
using mgc::test::check_malformed_framing;

TEST_CASE("COB-IDs follow the pre-defined connection set", "[unit][codec]") {
  CHECK(cob_id(FunctionCode::Tpdo1, 0x11) == 0x191);
  CHECK(tpdo_cob_id(1, 5) == 0x185);
  CHECK(tpdo_cob_id(2, 5) == 0x285);
  CHECK(tpdo_cob_id(4, 5) == 0x485);
  CHECK(rpdo_cob_id(1, 5) == 0x205);
  CHECK(rpdo_cob_id(4, 5) == 0x505);
  CHECK(emcy_cob_id(0x30) == 0x0B0);
  CHECK(heartbeat_cob_id(1) == 0x701);
  CHECK(function_code(0x701) == FunctionCode::Heartbeat);
  CHECK(node_id_of(0x701) == 1);
  CHECK(function_code(kSyncCobId) == FunctionCode::SyncOrEmcy);
}

TEST_CASE("NMT round trips and refuses bad commands and nodes", "[unit][codec]") {
  for (const NmtCommand c : {NmtCommand::Start, NmtCommand::Stop, NmtCommand::EnterPreOperational,
                             NmtCommand::ResetNode, NmtCommand::ResetCommunication}) {
    for (const std::uint8_t node : {0, 1, 0x30, 127}) {
      const auto f = encode_nmt({c, node});
      REQUIRE(f.ok());
      CHECK(f.value.can_id == 0x000);
      CHECK(f.value.dlc == 2);
      const auto m = decode_nmt(f.value);
      REQUIRE(m.ok());
      CHECK(m.value.command == c);
      CHECK(m.value.target_node_id == node);
    }
  }
  const CanFrame good = encode_nmt({NmtCommand::Start, 0}).value;
  check_malformed_framing(good, decode_nmt);
  CanFrame bad_command = good;
  bad_command.data[0] = 0x03;
  CHECK(decode_nmt(bad_command).status == Status::OutOfRange);
  CanFrame bad_node = good;
  bad_node.data[1] = 128;
  CHECK(decode_nmt(bad_node).status == Status::OutOfRange);
  CanFrame wrong_id = good;
  wrong_id.can_id = 0x001;
  CHECK(decode_nmt(wrong_id).status == Status::WrongId);
  CHECK(encode_nmt({NmtCommand::Start, 128}).status == Status::OutOfRange);
  CHECK(encode_nmt({static_cast<NmtCommand>(7), 1}).status == Status::OutOfRange);
}

TEST_CASE("SYNC round trips with and without the counter", "[unit][codec]") {
  const auto plain = encode_sync({0});
  REQUIRE(plain.ok());
  CHECK(plain.value.can_id == 0x080);
  CHECK(plain.value.dlc == 0);
  CHECK(decode_sync(plain.value).value.counter == 0);
  for (const std::uint8_t counter : {1, 2, 120, 240}) {
    const auto f = encode_sync({counter});
    REQUIRE(f.ok());
    CHECK(f.value.dlc == 1);
    const auto m = decode_sync(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.counter == counter);
  }
  CHECK(encode_sync({241}).status == Status::OutOfRange);
  for (std::uint8_t dlc = 2; dlc <= 8; ++dlc) {
    CanFrame f = plain.value;
    f.dlc = dlc;
    CHECK(decode_sync(f).status == Status::WrongLength);
  }
  CanFrame zero = encode_sync({5}).value;
  zero.data[0] = 0;
  CHECK(decode_sync(zero).status == Status::OutOfRange);
  zero.data[0] = 241;
  CHECK(decode_sync(zero).status == Status::OutOfRange);
  CanFrame rtr = plain.value;
  rtr.can_id |= kCanRtrFlag;
  CHECK(decode_sync(rtr).status == Status::WrongId);
  CHECK(next_sync_counter(1, 240) == 2);
  CHECK(next_sync_counter(240, 240) == 1);
  CHECK(next_sync_counter(0, 240) == 1);
}

TEST_CASE("heartbeat round trips every NMT state and refuses others", "[unit][codec]") {
  for (const NmtState s : {NmtState::BootUp, NmtState::Stopped, NmtState::Operational, NmtState::PreOperational}) {
    const auto f = encode_heartbeat({0x11, s});
    REQUIRE(f.ok());
    CHECK(f.value.can_id == 0x711);
    const auto m = decode_heartbeat(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.node_id == 0x11);
    CHECK(m.value.state == s);
  }
  const CanFrame good = encode_heartbeat({0x30, NmtState::Operational}).value;
  check_malformed_framing(good, decode_heartbeat);
  CanFrame bad_state = good;
  bad_state.data[0] = 0x06;
  CHECK(decode_heartbeat(bad_state).status == Status::OutOfRange);
  CanFrame node_zero = good;
  node_zero.can_id = 0x700;
  CHECK(decode_heartbeat(node_zero).status == Status::WrongId);
  CanFrame not_heartbeat = good;
  not_heartbeat.can_id = 0x630;
  CHECK(decode_heartbeat(not_heartbeat).status == Status::WrongId);
  CHECK(encode_heartbeat({0, NmtState::Operational}).status == Status::OutOfRange);
  CHECK(encode_heartbeat({1, static_cast<NmtState>(3)}).status == Status::OutOfRange);
}

TEST_CASE("EMCY round trips and refuses the reserved register bit", "[unit][codec]") {
  const EmcyMessage in{0x30, kEmcyHeartbeat, 0x11, {1, 2, 3, 4, 5}};
  const auto f = encode_emcy(in);
  REQUIRE(f.ok());
  CHECK(f.value.can_id == 0x0B0);
  CHECK(f.value.dlc == 8);
  CHECK(f.value.data[0] == 0x30);  // 0x8130 little-endian
  CHECK(f.value.data[1] == 0x81);
  const auto m = decode_emcy(f.value);
  REQUIRE(m.ok());
  CHECK(m.value.node_id == 0x30);
  CHECK(m.value.error_code == kEmcyHeartbeat);
  CHECK(m.value.error_register == 0x11);
  CHECK(m.value.manufacturer == std::array<std::uint8_t, 5>{1, 2, 3, 4, 5});
  check_malformed_framing(f.value, decode_emcy);
  CanFrame reserved = f.value;
  reserved.data[2] |= kErrorRegisterReserved;
  CHECK(decode_emcy(reserved).status == Status::ReservedBits);
  // 0x080 is SYNC, never an EMCY of node 0.
  CanFrame sync_id = f.value;
  sync_id.can_id = kSyncCobId;
  CHECK(decode_emcy(sync_id).status == Status::WrongId);
  CHECK(encode_emcy({0x30, 0, kErrorRegisterReserved, {}}).status == Status::ReservedBits);
  CHECK(encode_emcy({128, 0, 0, {}}).status == Status::OutOfRange);
}

TEST_CASE("bus plans give each device its own ids and classify frames by them", "[unit][codec]") {
  for (const BusPlan& plan : {mobile_crane_bus_plan(), tower_crane_bus_plan(), excavator_bus_plan()}) {
    CAPTURE(plan.machine);
    CHECK(plan.num_joints >= 3);
    for (std::uint8_t j = 0; j < plan.num_joints; ++j) {
      CHECK(plan.encoders[j].node_id == kFirstEncoderNodeId + j);
      const Classified c = classify(CanFrame::standard(tpdo_cob_id(1, plan.encoders[j].node_id), 5), plan);
      CHECK(c.kind == MessageKind::EncoderPosition);
      CHECK(c.index == static_cast<std::int8_t>(j));
    }
    CHECK(classify(CanFrame::standard(0x000, 2), plan).kind == MessageKind::Nmt);
    CHECK(classify(CanFrame::standard(0x080, 1), plan).kind == MessageKind::Sync);
    CHECK(classify(CanFrame::standard(0x701, 1), plan).kind == MessageKind::Heartbeat);
    CHECK(classify(CanFrame::standard(0x0B0, 8), plan).kind == MessageKind::Emcy);
    CHECK(classify(CanFrame::standard(0x1A0, 8), plan).kind == MessageKind::UwbTagPosition);
    CHECK(classify(CanFrame::standard(0x230, 8), plan).kind == MessageKind::ValveCommand);
    CHECK(classify(CanFrame::standard(0x330, 8), plan).index == 1);
    CHECK(classify(CanFrame::standard(0x1B0, 4), plan).kind == MessageKind::ValveStatus);
    CHECK(classify(CanFrame::standard(0x2B0, 8), plan).kind == MessageKind::ValveApplied);
    CHECK(classify(CanFrame::standard(0x3B0, 8), plan).index == 1);
    // Not in the plan: another node, an unused PDO, an SDO, extended frames.
    CHECK(classify(CanFrame::standard(0x1FF, 8), plan).kind == MessageKind::Unknown);
    CHECK(classify(CanFrame::standard(0x291, 8), plan).kind == MessageKind::Unknown);
    CHECK(classify(CanFrame::standard(0x5B0, 8), plan).kind == MessageKind::Unknown);
    CanFrame extended = CanFrame::standard(0x191, 5);
    extended.can_id |= kCanEffFlag;
    CHECK(classify(extended, plan).kind == MessageKind::Unknown);
    // A standard frame with bits set above its 11-bit id (an invalid frame) is no COB-ID, even
    // when its low 11 bits are one: 0x991 reads as the first encoder's TPDO1 in bits 0-10.
    CanFrame wide = CanFrame::standard(0x191, 5);
    wide.can_id |= 0x800U;
    CHECK(classify(wide, plan).kind == MessageKind::Unknown);
  }
  CodecCounters counters;
  counters.record(Status::Ok);
  counters.record(Status::UnknownId);
  counters.record(Status::WrongLength);
  counters.record(Status::OutOfRange);
  counters.record(Status::ReservedBits);
  CHECK(counters.decoded == 1);
  CHECK(counters.unknown_id == 1);
  CHECK(counters.malformed() == 3);
}
