// SPDX-License-Identifier: Apache-2.0
// The black box on the stepped rig: a lift recorded and replayed against a fresh controller is
// identical in every cycle; an altered decision is named by its cycle and field; a corrupt record
// in the middle is named by its offset; a torn or cut tail is reported and the rest replays.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "black_box_support.hpp"

using namespace mgc;
namespace bb = mgc::firmware::black_box;
using test::RecordedLift;

namespace {

//! A file in this process's scratch folder, removed at exit.
std::string scratch(const char* name) {
  static const test::ScratchDir scratch_dir("mgc-black-box-test-");
  return (scratch_dir.dir / name).string();
}

//! 30 s of the thesis lift, planned and moving: recorded once for all the tests here.
const std::string& recorded_lift() {
  static const std::string file = [] {
    const std::string path = scratch("lift.mgcbb");
    RecordedLift lift(path, "bb-record", bb::ring_bytes_for_minutes(2.0));
    lift.box->start();
    // The rig runs some 30 times faster than real time: a second at a time, then the writer
    // catches up, so that the queue, sized for real time, never fills.
    for (int s = 0; s < 30; ++s) {
      lift.rig.run(1'000'000);
      while (lift.box->pending() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    lift.box->close();
    REQUIRE(lift.box->dropped() == 0);
    REQUIRE(lift.box->io_error() == 0);
    REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
    REQUIRE(lift.cycles == 3000);
    return path;
  }();
  return file;
}

std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

TEST_CASE("a lift recorded on the rig replays identically in every cycle", "[firmware][sim][black-box]") {
  const bb::Recording rec = bb::read_recording(recorded_lift());
  CHECK(rec.ended);
  CHECK_FALSE(rec.wrapped);
  CHECK(rec.torn_tail_bytes == 0);
  CHECK(rec.blocks_used > 1);  // the lift spans blocks: the reader joins them
  CHECK(rec.identity.scenario_name == "thesis-steel-frame");
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  const bb::ReplayResult r = bb::replay(rec, scenario);
  INFO(r.field << " at cycle " << r.first_cycle << ": recorded " << r.recorded << ", replayed " << r.replayed);
  REQUIRE(r.replayable);
  CHECK(r.identical);
  CHECK(r.cycles == 3000);
  CHECK(r.transitions >= 3);  // INIT -> HOLD -> PLANNING -> EXECUTING
  CHECK(r.frames > 3000);

  // The replayed transitions, which mgc-replay prints, are the recorded cycles that transitioned:
  // the same time, state and reason, each from the state before.
  std::vector<bb::CycleEntry> transitioned;
  guidance::SupervisorState before = guidance::SupervisorState::Init;
  std::vector<guidance::SupervisorState> from;
  std::int64_t first_read_us = -1;
  for (const bb::Entry& e : rec.entries) {
    if (e.type != bb::RecordType::Cycle) continue;
    if (first_read_us < 0) first_read_us = e.cycle.read_us;
    if (e.cycle.transitioned) {
      transitioned.push_back(e.cycle);
      from.push_back(before);
    }
    before = e.cycle.state;
  }
  REQUIRE(r.transition_log.size() == transitioned.size());
  REQUIRE(r.transition_log.size() == r.transitions);
  CHECK(r.first_cycle_read_us == first_read_us);
  for (std::size_t i = 0; i < transitioned.size(); ++i) {
    INFO("transition " << i);
    CHECK(r.transition_log[i].t_us == transitioned[i].read_us);
    CHECK(r.transition_log[i].to == transitioned[i].state);
    CHECK(r.transition_log[i].reason == transitioned[i].reason);
    CHECK(r.transition_log[i].from == from[i]);
  }
  CHECK(r.transition_log.back().to == guidance::SupervisorState::Executing);
}

TEST_CASE("an altered decision in the file is named by its cycle and field", "[firmware][sim][black-box]") {
  bb::Recording rec = bb::read_recording(recorded_lift());
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  // The first cycle after 20 s in which joint 0 moves: a velocity one ulp off.
  bb::CycleEntry* target = nullptr;
  std::size_t joint = 0;
  for (bb::Entry& e : rec.entries) {
    if (e.type != bb::RecordType::Cycle || e.cycle.cycle < 2000) continue;
    for (std::size_t j = 0; j < e.cycle.num_joints && target == nullptr; ++j) {
      if (e.cycle.velocity[j] != 0.0) {
        target = &e.cycle;
        joint = j;
      }
    }
    if (target != nullptr) break;
  }
  REQUIRE(target != nullptr);
  const std::uint64_t cycle = target->cycle;

  SECTION("a velocity") {
    target->velocity[joint] = std::nextafter(target->velocity[joint], 1e9);
    const std::string altered = scratch("velocity.mgcbb");
    bb::write_recording(altered, rec, bb::ring_bytes_for_minutes(2.0));
    const bb::ReplayResult r = bb::replay(bb::read_recording(altered), scenario);
    CHECK_FALSE(r.identical);
    CHECK(r.first_cycle == cycle);
    CHECK(r.cycles == cycle);
    CHECK(r.field == "velocity[" + std::to_string(joint) + "]");
  }
  SECTION("the supervisor's state") {
    target->state = guidance::SupervisorState::Stopping;
    const std::string altered = scratch("state.mgcbb");
    bb::write_recording(altered, rec, bb::ring_bytes_for_minutes(2.0));
    const bb::ReplayResult r = bb::replay(bb::read_recording(altered), scenario);
    CHECK_FALSE(r.identical);
    CHECK(r.first_cycle == cycle);
    CHECK(r.field == "supervisor.state");
    CHECK(r.recorded == "STOPPING");
  }
}

TEST_CASE("a corrupt record in the middle is named by its offset, a cut tail is reported", "[firmware][sim][black-box]") {
  const std::vector<std::uint8_t> bytes = read_bytes(recorded_lift());
  const bb::Recording rec = bb::read_recording(recorded_lift());
  REQUIRE(rec.blocks_used >= 3);

  SECTION("a flipped byte in the first block") {
    std::vector<std::uint8_t> bad = bytes;
    const std::size_t offset = bb::kFileHeaderBytes + bb::kBlockHeaderBytes + 1000;
    bad[offset] ^= 0x40u;
    const std::string path = scratch("flipped.mgcbb");
    write_bytes(path, bad);
    try {
      (void)bb::read_recording(path);
      FAIL("a corrupt record was read");
    } catch (const bb::BadRecording& e) {
      // The record that holds the byte starts at or before it, within one record's length.
      const std::string what = e.what();
      INFO(what);
      const auto at = what.find("(offset ");
      REQUIRE(at != std::string::npos);
      const std::size_t named = std::stoul(what.substr(at + 8));
      CHECK(named <= offset);
      CHECK(offset - named < 600);
      CHECK(what.find("CRC mismatch in the middle") != std::string::npos);
    }
  }
  SECTION("a torn last record in the newest block") {
    // The newest block's used length, from its header, and a byte of its last record spoiled.
    std::size_t newest = 0, used = 0;
    std::uint64_t newest_seq = 0;
    for (std::size_t b = 0; b < rec.num_blocks; ++b) {
      const std::size_t off = bb::kFileHeaderBytes + b * bb::kBlockBytes;
      std::uint64_t seq = 0;
      for (int i = 0; i < 8; ++i) seq |= static_cast<std::uint64_t>(bytes[off + 8 + static_cast<std::size_t>(i)]) << (8 * i);
      if (seq > newest_seq) {
        newest_seq = seq;
        newest = off;
        used = static_cast<std::size_t>(bytes[off + 16]) | static_cast<std::size_t>(bytes[off + 17]) << 8 |
               static_cast<std::size_t>(bytes[off + 18]) << 16;
      }
    }
    std::vector<std::uint8_t> torn = bytes;
    torn[newest + used - 3] ^= 0xFFu;
    const std::string path = scratch("torn.mgcbb");
    write_bytes(path, torn);
    const bb::Recording r = bb::read_recording(path);
    CHECK(r.torn_tail_bytes > 0);
    CHECK_FALSE(r.ended);  // the End record was the torn one
    CHECK(r.entries.size() + 1 == rec.entries.size());
  }
  SECTION("a file cut in its second block replays up to the cut") {
    std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(bb::kFileHeaderBytes + bb::kBlockBytes + 100));
    const std::string path = scratch("cut.mgcbb");
    write_bytes(path, cut);
    const bb::Recording r = bb::read_recording(path);
    CHECK(r.blocks_used == 1);
    CHECK(r.torn_tail_bytes == 100);
    CHECK_FALSE(r.ended);
    const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
    const bb::ReplayResult replayed = bb::replay(r, scenario);
    CHECK(replayed.identical);
    CHECK(replayed.cycles > 50);
    CHECK(replayed.cycles < 3000);
  }
  SECTION("not a recording") {
    const std::string path = scratch("not.mgcbb");
    write_bytes(path, std::vector<std::uint8_t>(bb::kFileHeaderBytes, 7));
    CHECK_THROWS_AS(bb::read_recording(path), bb::BadRecording);
  }
}

TEST_CASE("a ring that has wrapped is read but not replayed", "[firmware][sim][black-box]") {
  const bb::Recording rec = bb::read_recording(recorded_lift());
  // Two blocks for a recording of some twenty: the oldest are overwritten.
  const std::string path = scratch("wrapped.mgcbb");
  bb::write_recording(path, rec, bb::kFileHeaderBytes + 2 * bb::kBlockBytes);
  const bb::Recording wrapped = bb::read_recording(path);
  CHECK(wrapped.wrapped);
  CHECK(wrapped.num_blocks == 2);
  CHECK(wrapped.blocks_used == 2);
  CHECK(wrapped.ended);
  REQUIRE(wrapped.entries.size() > 100);
  CHECK(wrapped.entries.size() < rec.entries.size() / 5);
  // What it holds is the newest part of the lift, in order.
  std::uint64_t last = 0;
  for (const bb::Entry& e : wrapped.entries) {
    if (e.type != bb::RecordType::Cycle) continue;
    CHECK(e.cycle.cycle > last);
    last = e.cycle.cycle;
  }
  CHECK(last == 2999);
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  const bb::ReplayResult r = bb::replay(wrapped, scenario);
  CHECK_FALSE(r.replayable);
  CHECK(r.why_not.find("wrapped") != std::string::npos);
}

TEST_CASE("the transitions are read from a recording without replay, a wrapped ring's too", "[firmware][sim][black-box]") {
  const bb::Recording rec = bb::read_recording(recorded_lift());
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  const bb::ReplayResult replayed = bb::replay(rec, scenario);
  REQUIRE(replayed.identical);
  const std::vector<bb::RecordedTransition> read = bb::recorded_transitions(rec);
  REQUIRE(read.size() == replayed.transition_log.size());
  REQUIRE(read.size() >= 3);
  for (std::size_t i = 0; i < read.size(); ++i) {
    INFO("transition " << i);
    CHECK(read[i].t_us == replayed.transition_log[i].t_us);
    CHECK(read[i].from_known);
    CHECK(read[i].from == replayed.transition_log[i].from);
    CHECK(read[i].to == replayed.transition_log[i].to);
    CHECK(read[i].reason == replayed.transition_log[i].reason);
  }

  // The ring as it would be had it wrapped just before the second transition's cycle: that one's
  // previous state is gone, the later ones read as before.
  bb::Recording cut = rec;
  const std::uint64_t keep_from = read[1].cycle;
  const auto first_kept = std::find_if(cut.entries.begin(), cut.entries.end(), [&](const bb::Entry& e) {
    return e.type == bb::RecordType::Cycle && e.cycle.cycle == keep_from;
  });
  REQUIRE(first_kept != cut.entries.end());
  cut.entries.erase(cut.entries.begin(), first_kept);
  cut.wrapped = true;
  CHECK_FALSE(bb::replay(cut, scenario).replayable);
  const std::vector<bb::RecordedTransition> from_cut = bb::recorded_transitions(cut);
  REQUIRE(from_cut.size() == read.size() - 1);
  CHECK(from_cut[0].cycle == keep_from);
  CHECK_FALSE(from_cut[0].from_known);
  CHECK(from_cut[0].to == read[1].to);
  CHECK(from_cut[0].reason == read[1].reason);
  for (std::size_t i = 1; i < from_cut.size(); ++i) {
    CHECK(from_cut[i].from_known);
    CHECK(from_cut[i].from == read[i + 1].from);
    CHECK(from_cut[i].to == read[i + 1].to);
  }
}
