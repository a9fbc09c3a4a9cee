// SPDX-License-Identifier: Apache-2.0
// Hal::read (hal/src/hal.cpp) over the in-process loop bus, fed by a device endpoint with whatever
// frames the input holds. The input: one byte picks the machine's bus plan, then operations:
//   0x00-0xBF  a frame: id (u32, flags included), dlc (u8), payload (min(dlc, 8) bytes)
//   0xC0-0xEF  advance the clock by the low bits x 2 ms, then read()
//   0xF0-0xFF  write() one velocity per joint (i16 each, in 1/1000 of a unit; 0x7FFF is NaN)
// Every read() must keep the snapshot's documented invariants, whatever arrived.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "fuzz_support.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"

using namespace mgc::hal;
using mgc::fuzz::require;

namespace {

void check_snapshot(const SensorSnapshot& s, const BusPlan& plan) {
  require(s.num_joints == plan.num_joints, "the snapshot's joint count changed");
  require(s.frames <= kMaxFramesPerRead, "read() drained more than kMaxFramesPerRead frames");
  require(s.num_tags <= kMaxTags, "more tags than kMaxTags");
  for (std::size_t j = 0; j < s.num_joints; ++j) {
    const JointReading& joint = s.joints[j];
    require(joint.valid == (joint.health == Health::Alive), "joint valid differs from health Alive");
    require(!joint.valid || std::isfinite(joint.position), "a valid joint has a position that is not finite");
    require(std::abs(s.valve_applied_fraction[j]) <= 1.0, "an applied spool beyond full scale");
    if (joint.valid) require(s.encoders[j].health == Health::Alive, "a valid joint whose encoder is not alive");
  }
  for (std::size_t i = 0; i < s.num_tags; ++i) {
    const TagReading& tag = s.tags[i];
    require(tag.sequence < 16, "a tag sequence beyond 15");
    if (tag.valid) {
      require(tag.fixes > 0 && tag.quality >= 1 && tag.quality <= 15, "a valid tag without a fix");
      for (const double c : tag.position_m) require(std::abs(c) <= 328.0, "a tag beyond the UWB range");
    }
    require(s.find_tag(tag.tag_id) == &tag, "find_tag() does not find a listed tag");
  }
  require(s.codec.malformed() + s.codec.decoded + s.codec.unknown_id <= s.bus.rx_frames,
          "more frames decoded or refused than received");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mgc::fuzz::Input in(data, size);
  static const std::array<BusPlan, 3> plans{mobile_crane_bus_plan(), tower_crane_bus_plan(), excavator_bus_plan()};
  const BusPlan& plan = plans[in.u8() % plans.size()];

  ManualClock clock(1'000'000);
  // Fresh buses per input (a loop bus lives while an endpoint does), so that runs are repeatable.
  OpenResult controller = open_can_bus("loop:fuzz-hal,rx_queue=128", &clock);
  OpenResult device = open_can_bus("loop:fuzz-hal,rx_queue=128", &clock);
  require(controller && device, "cannot open the loop bus");
  const std::vector<double> max_velocity(plan.num_joints, 0.5);
  Hal hal(*controller.bus, plan, max_velocity);

  std::array<double, kMaxBusJoints> velocity{};
  while (!in.empty()) {
    const std::uint8_t op = in.u8();
    if (op < 0xC0) {
      CanFrame f;
      f.can_id = in.u32();
      f.dlc = in.u8();
      const auto payload = in.bytes(f.dlc < kCanMaxDlc ? f.dlc : kCanMaxDlc);
      for (std::size_t i = 0; i < payload.size(); ++i) f.data[i] = payload[i];
      const Status sent = device.bus->send(f);
      require(sent == Status::Ok || (sent == Status::InvalidFrame && !f.valid()) || sent == Status::BusOff,
              "the loop bus refused a valid frame");
    } else if (op < 0xF0) {
      clock.advance_us(static_cast<std::int64_t>(op - 0xC0) * 2'000);
      check_snapshot(hal.read(clock.now_us()), plan);
    } else {
      for (std::size_t j = 0; j < plan.num_joints; ++j) {
        const auto raw = static_cast<std::int16_t>(in.u16());
        velocity[j] = raw == 0x7FFF ? std::numeric_limits<double>::quiet_NaN() : raw * 1e-3;
      }
      const WriteResult w = hal.write(std::span<const double>(velocity.data(), plan.num_joints), clock.now_us());
      require((w.clamped_mask & w.refused_mask) == 0, "a joint both clamped and refused");
    }
  }
  clock.advance_us(10'000);
  check_snapshot(hal.read(clock.now_us()), plan);
  return 0;
}
