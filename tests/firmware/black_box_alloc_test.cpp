// SPDX-License-Identifier: Apache-2.0
// The black box's side of the loop allocates nothing: the frames the Hal receives through the
// RecordingBus, the cycle's entry and the push into the queue, with the writer thread running (the
// count is program-wide, so its steady state is counted too); and a full queue counts its drops.
#include <catch2/catch.hpp>

#include <chrono>
#include <memory>
#include <filesystem>
#include <string>
#include <thread>

#include <unistd.h>

#include "allocation_counter.hpp"
#include "black_box_support.hpp"

using namespace mgc;
namespace bb = mgc::firmware::black_box;

namespace {

//! A file in this process's scratch folder, removed at exit.
std::string scratch(const char* name) {
  static const test::ScratchDir scratch_dir("mgc-black-box-alloc-test-");
  return (scratch_dir.dir / name).string();
}

}  // namespace

TEST_CASE("recording a lift allocates nothing in the loop", "[firmware][sim][black-box][alloc]") {
  test::RecordedLift lift(scratch("alloc.mgcbb"), "bb-alloc", bb::ring_bytes_for_minutes(1.0));
  long before = 0;
  long allocations = 0;
  lift.rig.before_read = [&before] { before = test::allocation_count(); };
  lift.after_cycle = [&] { allocations += test::allocation_count() - before; };
  lift.box->start();
  // Paced as in black_box_test.cpp: the writer catches up after each second of the lift.
  for (int s = 0; s < 20; ++s) {
    lift.rig.run(1'000'000);
    while (lift.box->pending() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  lift.box->close();
  CAPTURE(lift.cycles, lift.box->stats().entries_written);
  REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
  REQUIRE(lift.cycles == 2000);
  REQUIRE(lift.box->dropped() == 0);
  REQUIRE(lift.box->stats().entries_written > 2 * lift.cycles);  // frames and cycles both went through
  CHECK(allocations == 0);
}

TEST_CASE("a full black box queue counts what it drops and does not allocate", "[firmware][black-box][alloc]") {
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  bb::BlackBox box(scratch("full.mgcbb"), bb::identity_for(scenario, "axis-connect", 10'000, 0.0), bb::ring_bytes_for_minutes(0.1));
  hal::TimedFrame frame;
  frame.frame.can_id = 0x181;
  frame.frame.dlc = 8;
  const long before = test::allocation_count();
  for (std::size_t i = 0; i < bb::kQueueCapacity + 100; ++i) {
    frame.t_us = static_cast<std::int64_t>(i);
    box.push_frame(frame);
  }
  const long allocations = test::allocation_count() - before;
  CHECK(allocations == 0);
  CHECK(box.pending() == bb::kQueueCapacity);
  CHECK(box.dropped() == 100);
}

TEST_CASE("recording the site messages the loop takes allocates nothing, and a full plan queue counts its drops", "[firmware][black-box][alloc][site]") {
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  bb::BlackBox box(scratch("site.mgcbb"), bb::identity_for(scenario, "axis-connect", 10'000, 0.0), bb::ring_bytes_for_minutes(0.1));
  const auto inputs = std::make_unique<firmware::SiteInputs>();
  const auto plan = std::make_unique<site_plan_t>();
  plan->machine_id = 2;
  plan->plan_id = 3;
  site_state_t state{};
  state.machine_id = 2;
  constexpr std::size_t kTaken = bb::kPlanQueueCapacity + 5;
  const long before = test::allocation_count();
  for (std::size_t i = 0; i < kTaken; ++i) {
    state.sequence = static_cast<std::int64_t>(i + 1);
    firmware::take_site_state(*inputs, 1, state, static_cast<std::int64_t>(i), &box);
    firmware::take_site_plan(*inputs, 1, *plan, &box);
  }
  box.push_cycle(bb::CycleEntry{});
  const long allocations = test::allocation_count() - before;
  CHECK(allocations == 0);
  // The loop's inputs have them all; the recorder every state, the plans its plan queue held.
  CHECK(inputs->peers[1].state.sequence == static_cast<std::int64_t>(kTaken));
  CHECK(inputs->peers[1].has_plan);
  CHECK(box.site_taken() == 2 * kTaken);
  CHECK(box.site_plans_dropped() == 5);
  CHECK(box.dropped() == 5);
  CHECK(box.pending() == 2 * kTaken - 5 + 1);
}
