// SPDX-License-Identifier: Apache-2.0
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "codec_support.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/device_pdos.hpp"

using namespace mgc::hal;
using namespace mgc::hal::pdo;
using mgc::test::check_malformed_framing;

TEST_CASE("encoder position round trips with its status and stated resolution", "[unit][codec]") {
  for (const std::int32_t counts : {0, 1, -1, 360'000, -90'000, INT32_MAX, INT32_MIN + 1}) {
    for (const std::uint8_t status : {std::uint8_t{0}, kEncoderStatusAlarm, kEncoderStatusWarning}) {
      const auto f = encode_encoder_position({0x12, counts, status});
      REQUIRE(f.ok());
      CHECK(f.value.can_id == 0x192);
      CHECK(f.value.dlc == 5);
      const auto m = decode_encoder_position(f.value);
      REQUIRE(m.ok());
      CHECK(m.value.node_id == 0x12);
      CHECK(m.value.position_counts == counts);
      CHECK(m.value.status == status);
    }
  }
  const CanFrame good = encode_encoder_position({0x11, 12345, 0}).value;
  CHECK(good.data[0] == 0x39);  // 12345 = 0x3039, little-endian
  CHECK(good.data[1] == 0x30);
  check_malformed_framing(good, decode_encoder_position);
  CanFrame reserved = good;
  reserved.data[4] = 0x04;
  CHECK(decode_encoder_position(reserved).status == Status::ReservedBits);
  CanFrame not_available = good;
  not_available.data[0] = 0x00;
  not_available.data[1] = 0x00;
  not_available.data[2] = 0x00;
  not_available.data[3] = 0x80;
  CHECK(decode_encoder_position(not_available).status == Status::OutOfRange);
  CanFrame rpdo = good;
  rpdo.can_id = 0x211;
  CHECK(decode_encoder_position(rpdo).status == Status::WrongId);
  CHECK(encode_encoder_position({0x11, INT32_MIN, 0}).status == Status::OutOfRange);
  CHECK(encode_encoder_position({0x11, 0, 0x80}).status == Status::ReservedBits);

  CHECK(counts_to_si(90'000, EncoderKind::Rotary) == Approx(std::numbers::pi / 2));
  CHECK(counts_to_si(123'456, EncoderKind::Linear) == Approx(12.3456));
  CHECK(si_to_counts(std::numbers::pi, EncoderKind::Rotary).value == 180'000);
  CHECK(si_to_counts(-0.00005, EncoderKind::Linear).value == -1);  // 0.05 mm rounds to one 0.1 mm count
  CHECK(si_to_counts(33.528, EncoderKind::Linear).value == 335'280);
  CHECK(si_to_counts(std::nan(""), EncoderKind::Rotary).status == Status::OutOfRange);
  CHECK(si_to_counts(1e9, EncoderKind::Linear).status == Status::OutOfRange);
}

TEST_CASE("UWB tag position round trips and refuses impossible fixes", "[unit][codec]") {
  const UwbTagPosition in{0x20, 7, {{-1234, 32767, 250}}, 15, 3};
  const auto f = encode_uwb_tag_position(in);
  REQUIRE(f.ok());
  CHECK(f.value.can_id == 0x1A0);
  CHECK(f.value.dlc == 8);
  CHECK(f.value.data[7] == 0x3F);
  const auto m = decode_uwb_tag_position(f.value);
  REQUIRE(m.ok());
  CHECK(m.value.tag_id == 7);
  CHECK(m.value.position_cm == in.position_cm);
  CHECK(m.value.sequence == 15);
  CHECK(m.value.quality == 3);

  const UwbTagPosition no_fix{0x20, 9, {{kUwbNoPosition, kUwbNoPosition, kUwbNoPosition}}, 4, kUwbQualityNoFix};
  const auto nf = encode_uwb_tag_position(no_fix);
  REQUIRE(nf.ok());
  CHECK(decode_uwb_tag_position(nf.value).value.quality == kUwbQualityNoFix);

  check_malformed_framing(f.value, decode_uwb_tag_position);
  CanFrame fix_without_position = f.value;
  fix_without_position.data[3] = 0x00;
  fix_without_position.data[4] = 0x80;  // y = -32768 with quality 3
  CHECK(decode_uwb_tag_position(fix_without_position).status == Status::OutOfRange);
  CanFrame no_fix_with_position = f.value;
  no_fix_with_position.data[7] = 0x05;  // quality 0, coordinates present
  CHECK(decode_uwb_tag_position(no_fix_with_position).status == Status::OutOfRange);
  CHECK(encode_uwb_tag_position({0x20, 1, {{0, 0, 0}}, 16, 1}).status == Status::OutOfRange);
  CHECK(encode_uwb_tag_position({0x20, 1, {{0, 0, 0}}, 0, 16}).status == Status::OutOfRange);

  CHECK(metres_to_uwb_counts(12.345).value == 1235);  // 1 cm resolution
  CHECK(metres_to_uwb_counts(-327.67).value == -32767);
  CHECK(metres_to_uwb_counts(-327.68).status == Status::OutOfRange);
  CHECK(metres_to_uwb_counts(400.0).status == Status::OutOfRange);
  CHECK(metres_to_uwb_counts(std::numeric_limits<double>::infinity()).status == Status::OutOfRange);
}

TEST_CASE("valve commands and applied values round trip per bank and refuse overrange", "[unit][codec]") {
  for (std::uint8_t bank = 0; bank < kValveBanks; ++bank) {
    const ValveCommand in{0x30, bank, {{10000, -10000, 0, -1}}};
    const auto f = encode_valve_command(in);
    REQUIRE(f.ok());
    CHECK(f.value.can_id == (bank == 0 ? 0x230U : 0x330U));
    const auto m = decode_valve_command(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.bank == bank);
    CHECK(m.value.velocity_permyriad == in.velocity_permyriad);
    check_malformed_framing(f.value, decode_valve_command);
    CanFrame over = f.value;
    over.data[2] = 0x11;  // joint 1 = 0x2711 = 10001
    over.data[3] = 0x27;
    CHECK(decode_valve_command(over).status == Status::OutOfRange);

    const ValveApplied applied{0x30, bank, {{1, 2, 3, -4}}};
    const auto a = encode_valve_applied(applied);
    REQUIRE(a.ok());
    CHECK(a.value.can_id == (bank == 0 ? 0x2B0U : 0x3B0U));
    const auto am = decode_valve_applied(a.value);
    REQUIRE(am.ok());
    CHECK(am.value.velocity_permyriad == applied.velocity_permyriad);
    check_malformed_framing(a.value, decode_valve_applied);
  }
  CanFrame status_id = encode_valve_command({0x30, 0, {}}).value;
  status_id.can_id = 0x1B0;
  CHECK(decode_valve_command(status_id).status == Status::WrongId);
  CHECK(encode_valve_command({0x30, 2, {}}).status == Status::OutOfRange);
  CHECK(encode_valve_command({0x30, 0, {{0, 10001, 0, 0}}}).status == Status::OutOfRange);
  CHECK(fraction_to_permyriad(0.5).value == 5000);
  CHECK(fraction_to_permyriad(-1.0).value == -10000);
  CHECK(fraction_to_permyriad(1.0001).status == Status::OutOfRange);
  CHECK(fraction_to_permyriad(std::nan("")).status == Status::OutOfRange);
  CHECK(permyriad_to_fraction(-2500) == Approx(-0.25));
}

TEST_CASE("valve status round trips consistent states and refuses the rest", "[unit][codec]") {
  const ValveStatus cases[] = {
      {0x30, ValveState::Disabled, ValveReason::None, 0, 0},
      {0x30, ValveState::Active, ValveReason::None, 0, 17},
      {0x30, ValveState::FailSafe, ValveReason::ControllerHeartbeatLost, 0, 200},
      {0x30, ValveState::FailSafe, ValveReason::CommandTimeout, 0x02, 255},
      {0x30, ValveState::Fault, ValveReason::InternalFault, 0x09, 1},
  };
  for (const ValveStatus& in : cases) {
    const auto f = encode_valve_status(in);
    REQUIRE(f.ok());
    CHECK(f.value.can_id == 0x1B0);
    CHECK(f.value.dlc == 4);
    const auto m = decode_valve_status(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.state == in.state);
    CHECK(m.value.reason == in.reason);
    CHECK(m.value.joint_fault_mask == in.joint_fault_mask);
    CHECK(m.value.command_counter == in.command_counter);
  }
  const CanFrame good = encode_valve_status(cases[1]).value;
  check_malformed_framing(good, decode_valve_status);
  CanFrame bad_state = good;
  bad_state.data[0] = 4;
  CHECK(decode_valve_status(bad_state).status == Status::OutOfRange);
  CanFrame active_with_reason = good;
  active_with_reason.data[1] = 2;
  CHECK(decode_valve_status(active_with_reason).status == Status::OutOfRange);
  CanFrame failsafe_without_reason = good;
  failsafe_without_reason.data[0] = 2;
  CHECK(decode_valve_status(failsafe_without_reason).status == Status::OutOfRange);
  CHECK(encode_valve_status({0x30, ValveState::Fault, ValveReason::CommandTimeout, 0, 0}).status ==
        Status::OutOfRange);
}

TEST_CASE("cut-off command round trips both patterns and refuses every other byte", "[unit][codec]") {
  for (const PilotCommand command : {PilotCommand::Cut, PilotCommand::Enable}) {
    const auto f = encode_cutoff_command({0x31, command});
    REQUIRE(f.ok());
    CHECK(f.value.can_id == 0x231);
    CHECK(f.value.dlc == 1);
    CHECK(f.value.data[0] == static_cast<std::uint8_t>(command));
    const auto m = decode_cutoff_command(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.node_id == 0x31);
    CHECK(m.value.command == command);
    check_malformed_framing(f.value, decode_cutoff_command);
  }
  CHECK(encode_cutoff_command({0x31, PilotCommand::Enable}).value.data[0] == 0xA5);
  CHECK(encode_cutoff_command({0x31, PilotCommand::Cut}).value.data[0] == 0x00);

  // Only the two patterns decode: one flipped bit of either is refused, never read as enable.
  const CanFrame good = encode_cutoff_command({0x31, PilotCommand::Enable}).value;
  int refused = 0;
  for (int byte = 0; byte <= 0xFF; ++byte) {
    if (byte == 0x00 || byte == 0xA5) continue;
    CanFrame f = good;
    f.data[0] = static_cast<std::uint8_t>(byte);
    CAPTURE(byte);
    CHECK(decode_cutoff_command(f).status == Status::OutOfRange);
    ++refused;
  }
  CHECK(refused == 254);
  CanFrame status_id = good;
  status_id.can_id = 0x1B1;
  CHECK(decode_cutoff_command(status_id).status == Status::WrongId);
  CHECK(encode_cutoff_command({0x31, static_cast<PilotCommand>(0x01)}).status == Status::OutOfRange);
  CHECK(encode_cutoff_command({0, PilotCommand::Cut}).status == Status::OutOfRange);
  CHECK(encode_cutoff_command({128, PilotCommand::Enable}).status == Status::OutOfRange);
}

TEST_CASE("cut-off status round trips consistent state and reason pairs and refuses the rest", "[unit][codec]") {
  const CutoffStatus cases[] = {
      {0x31, CutoffState::Enabled, CutoffReason::None, true},
      {0x31, CutoffState::Enabled, CutoffReason::None, false},
      {0x31, CutoffState::Cut, CutoffReason::Commanded, false},
      {0x31, CutoffState::Cut, CutoffReason::NotOperational, false},
      {0x31, CutoffState::Cut, CutoffReason::ControllerHeartbeatLost, false},
      {0x31, CutoffState::Cut, CutoffReason::CommandTimeout, true},  // a dump valve that failed
      {0x31, CutoffState::Fault, CutoffReason::InternalFault, false},
  };
  for (const CutoffStatus& in : cases) {
    const auto f = encode_cutoff_status(in);
    REQUIRE(f.ok());
    CHECK(f.value.can_id == 0x1B1);
    CHECK(f.value.dlc == 3);
    CHECK(f.value.data[0] == static_cast<std::uint8_t>(in.state));
    CHECK(f.value.data[1] == static_cast<std::uint8_t>(in.reason));
    CHECK(f.value.data[2] == (in.pressure ? 1 : 0));
    const auto m = decode_cutoff_status(f.value);
    REQUIRE(m.ok());
    CHECK(m.value.node_id == 0x31);
    CHECK(m.value.state == in.state);
    CHECK(m.value.reason == in.reason);
    CHECK(m.value.pressure == in.pressure);
  }
  const CanFrame good = encode_cutoff_status(cases[0]).value;
  check_malformed_framing(good, decode_cutoff_status);

  // Every state byte 0..3 against every reason byte 0..6: exactly the documented pairs decode.
  for (int state = 0; state <= 3; ++state) {
    for (int reason = 0; reason <= 6; ++reason) {
      CanFrame f = good;
      f.data[0] = static_cast<std::uint8_t>(state);
      f.data[1] = static_cast<std::uint8_t>(reason);
      const bool consistent = (state == 0 && reason >= 1 && reason <= 4) || (state == 1 && reason == 0) ||
                              (state == 2 && reason == 5);
      CAPTURE(state, reason);
      CHECK(decode_cutoff_status(f).status == (consistent ? Status::Ok : Status::OutOfRange));
    }
  }
  for (const std::uint8_t pressure : {std::uint8_t{0x02}, std::uint8_t{0x03}, std::uint8_t{0x80}, std::uint8_t{0xFF}}) {
    CanFrame f = good;
    f.data[2] = pressure;
    CAPTURE(static_cast<int>(pressure));
    CHECK(decode_cutoff_status(f).status == Status::ReservedBits);
  }
  CanFrame command_id = good;
  command_id.can_id = 0x231;
  CHECK(decode_cutoff_status(command_id).status == Status::WrongId);
  CHECK(encode_cutoff_status({0x31, CutoffState::Enabled, CutoffReason::Commanded, true}).status == Status::OutOfRange);
  CHECK(encode_cutoff_status({0x31, CutoffState::Cut, CutoffReason::None, false}).status == Status::OutOfRange);
  CHECK(encode_cutoff_status({0x31, CutoffState::Cut, CutoffReason::InternalFault, false}).status == Status::OutOfRange);
  CHECK(encode_cutoff_status({0x31, CutoffState::Fault, CutoffReason::CommandTimeout, false}).status ==
        Status::OutOfRange);
  CHECK(encode_cutoff_status({0, CutoffState::Cut, CutoffReason::Commanded, false}).status == Status::OutOfRange);
}

TEST_CASE("bus plans classify the cut-off node's command and status", "[unit][codec]") {
  for (const BusPlan& plan : {mobile_crane_bus_plan(), tower_crane_bus_plan(), excavator_bus_plan()}) {
    CAPTURE(plan.machine);
    CHECK(plan.cutoff_node_id == 0x31);
    const Classified command = classify(CanFrame::standard(0x231, 1), plan);
    CHECK(command.kind == MessageKind::CutoffCommand);
    CHECK(command.node_id == 0x31);
    const Classified status = classify(CanFrame::standard(0x1B1, 3), plan);
    CHECK(status.kind == MessageKind::CutoffStatus);
    CHECK(status.node_id == 0x31);
    CHECK(classify(CanFrame::standard(0x731, 1), plan).kind == MessageKind::Heartbeat);
    CHECK(classify(CanFrame::standard(0x0B1, 8), plan).kind == MessageKind::Emcy);
    // The node has no other PDO: its TPDO2 and RPDO2 are not in the plan.
    CHECK(classify(CanFrame::standard(0x2B1, 8), plan).kind == MessageKind::Unknown);
    CHECK(classify(CanFrame::standard(0x331, 8), plan).kind == MessageKind::Unknown);
    // The valve's PDOs stay the valve's.
    CHECK(classify(CanFrame::standard(0x230, 8), plan).kind == MessageKind::ValveCommand);
    CHECK(classify(CanFrame::standard(0x1B0, 4), plan).kind == MessageKind::ValveStatus);
  }
  CHECK(std::string(to_string(MessageKind::CutoffCommand)) == "cut-off command");
  CHECK(std::string(to_string(MessageKind::CutoffStatus)) == "cut-off status");
}
