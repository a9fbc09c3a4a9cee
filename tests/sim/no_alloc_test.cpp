// SPDX-License-Identifier: Apache-2.0
// The Hal's read() and write() run every control cycle: after construction they must not touch
// the heap, whatever the devices send. The simulator is held to the same rule so that mgc-sim's
// timing is not disturbed by the allocator, and so is its truth monitor, which samples in the same
// loop. tests/support/allocation_counter.cpp counts.
#include <catch2/catch.hpp>


#include "allocation_counter.hpp"
#include "mgc/sim/truth_monitor.hpp"
#include "mgc/sim/truth_snapshot.hpp"
#include "sim_rig.hpp"

using namespace mgc;

TEST_CASE("Hal read/write and the simulator do not allocate, faults and fail-safe included", "[unit][sim]") {
  sim::SimConfig config;  // noise and dropouts on
  config.faults.push_back(sim::parse_fault("encoder-dropout:swing@1+0.5", std::vector<std::string>{"swing"}));
  config.faults.push_back(sim::parse_fault("bus-off@2+0.3", {}));
  config.faults.push_back(sim::parse_fault("frame-delay@3+0.5,delay_ms=40", {}));
  test::SimRig rig("thesis-steel-frame.yaml", config, "alloc");
  rig.start();
  rig.command[0] = 0.05;
  rig.command[3] = -0.1;
  rig.run(500'000);  // warm-up: every path once

  const long before = test::allocation_count();
  rig.run(4'000'000);  // dropout, bus-off with fail-safe, delays
  REQUIRE(rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0) == hal::Status::Ok);
  rig.run(500'000);
  CHECK(test::allocation_count() == before);
  CHECK(rig.sim->counters().fail_safe_events >= 1);
  CHECK(rig.last->all_joints_valid());
  CHECK(rig.last->num_tags == 3);
}

TEST_CASE("the truth monitor's samples do not allocate", "[unit][sim][truth]") {
  sim::SimConfig config = test::SimRig::quiet_config();
  config.scenario_time_offset_s = 60.0;  // crane 2 swinging
  test::SimRig rig("thesis-steel-frame-road.yaml", config, "alloc-truth");
  sim::TruthMonitor monitor(rig.scenario);
  REQUIRE(monitor.has_envelope());
  rig.start();
  rig.command[0] = -0.2;  // swing toward the road's wall
  rig.run(100'000);
  (void)monitor.sample(*rig.sim);  // warm-up

  const long before = test::allocation_count();
  std::uint64_t taken = 0;
  for (int i = 0; i < 100; ++i) {
    rig.run(10'000);
    taken += monitor.sample(*rig.sim) ? 1U : 0U;
  }
  CHECK(test::allocation_count() == before);
  CHECK(taken == 20);  // 1 s at one sample per 50 ms

  // mgc-sim's way: the state copied into a frame of a ring, measured from the copy.
  sim::TruthFrame prototype;
  prototype.machines.resize(1);
  prototype.machines[0].resize_for(*rig.sim);
  sim::TruthFrameRing frames(4, prototype);
  const long before_frames = test::allocation_count();
  taken = 0;
  for (int i = 0; i < 100; ++i) {
    rig.run(10'000);
    sim::TruthFrame* frame = frames.begin_push();
    REQUIRE(frame != nullptr);
    frame->machines[0].capture(*rig.sim);
    frames.end_push();
    taken += monitor.sample(frames.front()->machines[0]) ? 1U : 0U;
    frames.pop();
  }
  CHECK(test::allocation_count() == before_frames);
  CHECK(taken == 20);
}
