// SPDX-License-Identifier: Apache-2.0
// The Hal facade against hand-made device frames: health, staleness, malformed and unknown
// frames, tag sequence gaps, command scaling, SYNC and heartbeat production.
#include <catch2/catch.hpp>

#include <stdexcept>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/hal.hpp"

using namespace mgc::hal;

namespace {

struct Bench {
  Bench() : clock(1'000'000) {
    auto a = open_can_bus("loop:facade", &clock);
    auto b = open_can_bus("loop:facade", &clock);
    controller = std::move(a.bus);
    device = std::move(b.bus);
    hal = std::make_unique<Hal>(*controller, plan, std::vector<double>{0.1, 0.02, 0.1, 0.5});
  }

  void send(const Result<CanFrame>& frame) { REQUIRE(device->send(frame.value) == Status::Ok); }
  void send_raw(const CanFrame& frame) { REQUIRE(device->send(frame) == Status::Ok); }

  //! Heartbeats of every node in `state`.
  void beat(canopen::NmtState state = canopen::NmtState::Operational) {
    for (std::size_t j = 0; j < plan.num_joints; ++j) send(canopen::encode_heartbeat({plan.encoders[j].node_id, state}));
    send(canopen::encode_heartbeat({plan.uwb_gateway_node_id, state}));
    send(canopen::encode_heartbeat({plan.valve_node_id, state}));
  }
  void encoders(std::int32_t counts, std::uint8_t status = 0) {
    for (std::size_t j = 0; j < plan.num_joints; ++j) {
      send(pdo::encode_encoder_position({plan.encoders[j].node_id, counts, status}));
    }
  }
  const SensorSnapshot& read_at(std::int64_t t_us) {
    clock.set_us(t_us);
    return hal->read(t_us);
  }
  std::vector<CanFrame> drain_device() {
    std::array<TimedFrame, 64> buf{};
    std::vector<CanFrame> out;
    while (true) {
      const ReceiveResult r = device->receive(buf);
      for (std::size_t k = 0; k < r.count; ++k) out.push_back(buf[k].frame);
      if (r.count < buf.size()) return out;
    }
  }

  BusPlan plan = mobile_crane_bus_plan();
  ManualClock clock;
  std::unique_ptr<CanBus> controller;
  std::unique_ptr<CanBus> device;
  std::unique_ptr<Hal> hal;
};

}  // namespace

TEST_CASE("Hal: a late read does not make the answer to the previous SYNC stale", "[hal][facade]") {
  Bench b;
  b.beat();
  (void)b.read_at(1'000'000);
  b.encoders(45'000);  // the answer to that SYNC
  REQUIRE(b.read_at(1'010'000).all_joints_valid());
  // The next read comes 45 ms late (a stalled loop): its own SYNC was late too, so the answer to
  // the previous SYNC is the freshest there can be.
  b.beat();
  b.encoders(45'010);
  const SensorSnapshot& late = b.read_at(1'065'000);
  CHECK(late.all_joints_valid());
  // But no answer at all to that SYNC: stale by the next on-time read.
  (void)b.read_at(1'075'000);
  (void)b.read_at(1'085'000);
  (void)b.read_at(1'095'000);
  const SensorSnapshot& silent = b.read_at(1'105'000);
  CHECK(silent.joints[0].health == Health::Stale);
}

TEST_CASE("Hal: a joint is valid only with a fresh heartbeat and a fresh sample", "[hal][facade]") {
  Bench b;
  const SensorSnapshot& s0 = b.read_at(1'000'000);
  CHECK(s0.joints[0].health == Health::Missing);
  b.beat();
  const SensorSnapshot& s1 = b.read_at(1'010'000);
  CHECK(s1.encoders[0].health == Health::Alive);
  CHECK(s1.joints[0].health == Health::Stale);  // no sample yet
  b.encoders(45'000);                            // 45.000 deg rotary, 4.5 m linear
  const SensorSnapshot& s2 = b.read_at(1'020'000);
  REQUIRE(s2.all_joints_valid());
  CHECK(s2.joints[0].position == Approx(45.0 * std::numbers::pi / 180.0));
  CHECK(s2.joints[2].position == Approx(4.5));
  CHECK(s2.joints[0].updated);
  CHECK(s2.joints[0].t_us == 1'010'000);

  // 30 ms after the sample: still valid; one cycle later: stale, value kept but flagged.
  CHECK(b.read_at(1'040'000).joints[0].valid);
  const SensorSnapshot& s3 = b.read_at(1'050'000);
  CHECK(s3.joints[0].health == Health::Stale);
  CHECK_FALSE(s3.joints[0].valid);
  CHECK_FALSE(s3.joints[0].updated);
  CHECK(s3.joints[0].position == Approx(45.0 * std::numbers::pi / 180.0));

  // Heartbeat older than 250 ms: the node is Missing, and so is its joint even with fresh data.
  b.encoders(1);
  const SensorSnapshot& s4 = b.read_at(1'010'000 + 251'000);
  CHECK(s4.encoders[1].health == Health::Missing);
  CHECK(s4.joints[1].health == Health::Missing);
  CHECK_FALSE(s4.joints[1].valid);
}

TEST_CASE("Hal: encoder alarm bits and active EMCYs mark a device Faulted, an EMCY reset clears it", "[hal][facade]") {
  Bench b;
  b.beat();
  b.encoders(0, pdo::kEncoderStatusAlarm);
  const SensorSnapshot& s1 = b.read_at(1'010'000);
  CHECK(s1.joints[0].health == Health::Faulted);
  CHECK_FALSE(s1.joints[0].valid);

  b.encoders(0);
  b.send(canopen::encode_emcy({b.plan.encoders[2].node_id, canopen::kEmcyDeviceSpecific, 0x01, {}}));
  const SensorSnapshot& s2 = b.read_at(1'020'000);
  CHECK(s2.joints[0].valid);
  CHECK(s2.encoders[2].health == Health::Faulted);
  CHECK(s2.encoders[2].emcy_code == canopen::kEmcyDeviceSpecific);
  CHECK_FALSE(s2.joints[2].valid);

  b.encoders(0);
  b.send(canopen::encode_emcy({b.plan.encoders[2].node_id, canopen::kEmcyNoError, 0, {}}));
  const SensorSnapshot& s3 = b.read_at(1'030'000);
  CHECK(s3.encoders[2].health == Health::Alive);
  CHECK(s3.joints[2].valid);
  CHECK(s3.encoders[2].emcy_count == 2);
}

TEST_CASE("Hal: malformed and unknown frames are counted and change nothing", "[hal][facade]") {
  Bench b;
  b.beat();
  b.encoders(10'000);
  const SensorSnapshot& good = b.read_at(1'010'000);
  REQUIRE(good.all_joints_valid());
  const double before = good.joints[0].position;

  CanFrame short_pdo = pdo::encode_encoder_position({0x11, 99'999, 0}).value;
  short_pdo.dlc = 4;
  b.send_raw(short_pdo);
  CanFrame reserved = pdo::encode_encoder_position({0x11, 99'999, 0}).value;
  reserved.data[4] = 0x80;
  b.send_raw(reserved);
  CanFrame not_available = pdo::encode_encoder_position({0x11, 0, 0}).value;
  canopen::put_u32_le(not_available, 0, 0x80000000U);
  b.send_raw(not_available);
  CanFrame bad_heartbeat = canopen::encode_heartbeat({0x12, canopen::NmtState::Operational}).value;
  bad_heartbeat.data[0] = 0x33;
  b.send_raw(bad_heartbeat);
  b.send_raw(CanFrame::standard(0x5FF, 3));  // an SDO of someone else
  b.send_raw(CanFrame::standard(0x19A, 5));  // a TPDO1 of a node not in the plan
  CanFrame ext = CanFrame::standard(0x191, 5);
  ext.can_id = 0x191 | kCanEffFlag;
  b.send_raw(ext);

  const SensorSnapshot& s = b.read_at(1'020'000);
  CHECK(s.codec.wrong_length == 1);
  CHECK(s.codec.reserved_bits == 1);
  CHECK(s.codec.out_of_range == 2);
  CHECK(s.codec.unknown_id == 3);
  CHECK(s.joints[0].position == before);
  CHECK(s.joints[0].samples == 1);
  CHECK_FALSE(s.joints[0].updated);
}

TEST_CASE("Hal: UWB fixes, sequence gaps, 'no fix' and the quality's sigma", "[hal][facade][uwb]") {
  Bench b;
  b.beat();
  const auto fix = [&](std::uint8_t tag, std::uint8_t seq, std::uint8_t quality, std::int16_t x_cm) {
    pdo::UwbTagPosition m{b.plan.uwb_gateway_node_id, tag, {x_cm, 200, 300}, seq, quality};
    if (quality == pdo::kUwbQualityNoFix) m.position_cm.fill(pdo::kUwbNoPosition);
    b.send(pdo::encode_uwb_tag_position(m));
  };
  fix(7, 3, 2, 100);
  fix(9, 0, 15, 500);
  const SensorSnapshot& s1 = b.read_at(1'010'000);
  REQUIRE(s1.num_tags == 2);
  const TagReading* t7 = s1.find_tag(7);
  REQUIRE(t7 != nullptr);
  CHECK(t7->valid);
  CHECK(t7->position_m[0] == Approx(1.0));
  CHECK(t7->position_m[2] == Approx(3.0));
  CHECK(t7->sigma_m == Approx(0.2));
  CHECK(t7->missed == 0);
  CHECK(std::isinf(s1.find_tag(9)->sigma_m));

  fix(7, 6, 2, 110);   // 4 and 5 lost
  fix(7, 7, 0, 0);     // no fix: counted, position kept, not refreshed
  const SensorSnapshot& s2 = b.read_at(1'020'000);
  t7 = s2.find_tag(7);
  CHECK(t7->missed == 2);
  CHECK(t7->no_fix == 1);
  CHECK(t7->fixes == 2);
  CHECK(t7->position_m[0] == Approx(1.1));
  CHECK(t7->t_us == 1'010'000);

  fix(7, 1, 2, 120);   // wraps 7 → 1 (mod 16): 8..15 and 0 lost = 9
  CHECK(b.read_at(1'030'000).find_tag(7)->missed == 11);

  // Stale 500 ms after the last fix (sent at 1.02 s), with the gateway alive throughout.
  b.clock.set_us(1'400'000);
  b.beat();
  CHECK(b.read_at(1'520'000).find_tag(7)->valid);
  CHECK_FALSE(b.read_at(1'530'000).find_tag(7)->valid);
  // Gateway heartbeat lost: its tags are invalid even with fresh fixes.
  fix(7, 2, 2, 130);
  CHECK(b.read_at(1'540'000).find_tag(7)->valid);
  fix(7, 3, 2, 130);
  CHECK_FALSE(b.read_at(1'651'000 + 10'000).find_tag(7)->valid);
}

TEST_CASE("Hal: write scales to permyriad, clamps, refuses NaN as zero, sends the heartbeat every 50 ms", "[hal][facade]") {
  Bench b;
  (void)b.drain_device();
  const std::array<double, 4> v{0.05, -0.04, 0.1, std::numeric_limits<double>::quiet_NaN()};
  const WriteResult w = b.hal->write(v, 1'000'000);
  CHECK(w.status == Status::OutOfRange);
  CHECK(w.clamped_mask == 0b0010);
  CHECK(w.refused_mask == 0b1000);
  const auto frames = b.drain_device();
  REQUIRE(frames.size() == 3);  // command, cut-off command, first heartbeat
  const auto cmd = pdo::decode_valve_command(frames[0]);
  REQUIRE(cmd.ok());
  CHECK(cmd.value.velocity_permyriad == std::array<std::int16_t, 4>{5000, -10000, 10000, 0});
  // Pilot pressure is cut until the harness enables it.
  const auto cut = pdo::decode_cutoff_command(frames[1]);
  REQUIRE(cut.ok());
  CHECK(cut.value.command == pdo::PilotCommand::Cut);
  const auto hb = canopen::decode_heartbeat(frames[2]);
  REQUIRE(hb.ok());
  CHECK(hb.value.node_id == kControllerNodeId);
  CHECK(b.hal->snapshot().valve_commands_sent == 1);  // the frame went out, the NaN sent as 0

  int heartbeats = 0;
  for (std::int64_t t = 1'010'000; t <= 2'000'000; t += 10'000) {
    const std::array<double, 4> zero{};
    CHECK(b.hal->write(zero, t).status == Status::Ok);
    for (const CanFrame& f : b.drain_device()) heartbeats += f.can_id == canopen::heartbeat_cob_id(kControllerNodeId);
  }
  CHECK(heartbeats == 20);  // 1.0 s at 50 ms

  b.hal->set_pilot_enabled(true);
  CHECK(b.hal->write(std::array<double, 4>{}, 2'010'000).status == Status::Ok);
  bool enabled = false;
  for (const CanFrame& f : b.drain_device()) {
    const auto c = pdo::decode_cutoff_command(f);
    enabled = enabled || (c.ok() && c.value.command == pdo::PilotCommand::Enable);
  }
  CHECK(enabled);
  CHECK(b.hal->snapshot().pilot_enable_sent);
}

TEST_CASE("Hal: with a valve deadband a command is mapped past it, zero stays zero", "[hal][facade]") {
  Bench b;
  CHECK_THROWS_AS(b.hal->set_valve_deadband(-0.01), std::invalid_argument);
  CHECK_THROWS_AS(b.hal->set_valve_deadband(0.6), std::invalid_argument);
  b.hal->set_valve_deadband(0.03);
  (void)b.drain_device();
  // Half speed, a full-speed command, a hundredth of full speed, and zero.
  const std::array<double, 4> v{0.05, -0.02, 0.001, 0.0};
  (void)b.hal->write(v, 1'000'000);
  const auto frames = b.drain_device();
  REQUIRE_FALSE(frames.empty());
  const auto cmd = pdo::decode_valve_command(frames[0]);
  REQUIRE(cmd.ok());
  // 3 % + 97 % of the fraction: 0.5 -> 0.515, -1 -> -1, 0.01 -> 0.0397; zero closes the valve.
  CHECK(cmd.value.velocity_permyriad == std::array<std::int16_t, 4>{5150, -10000, 397, 0});
}

TEST_CASE("Hal: read sends SYNC with a counter that runs 1..240", "[hal][facade]") {
  Bench b;
  std::vector<int> counters;
  for (int i = 0; i < 242; ++i) {
    const SensorSnapshot& s = b.read_at(1'000'000 + i * 10'000);
    counters.push_back(s.sync_counter);
  }
  CHECK(counters.front() == 1);
  CHECK(counters[239] == 240);
  CHECK(counters[240] == 1);
  const auto frames = b.drain_device();
  REQUIRE(frames.size() == 242);
  CHECK(canopen::decode_sync(frames[5]).value.counter == 6);
  b.hal->enable_sync(false);
  CHECK(b.read_at(4'000'000).sync_counter == 0);
  CHECK(b.drain_device().empty());
}

TEST_CASE("Hal: construction refuses plans and limits that do not fit", "[hal][facade]") {
  ManualClock clock;
  auto bus = open_can_bus("loop:ctor", &clock);
  const BusPlan plan = mobile_crane_bus_plan();
  CHECK_THROWS_WITH(Hal(*bus.bus, plan, std::vector<double>{1.0, 1.0}), Catch::Contains("one max velocity per joint"));
  CHECK_THROWS_WITH(Hal(*bus.bus, plan, std::vector<double>{1.0, 0.0, 1.0, 1.0}), Catch::Contains("finite and > 0"));
}
