// SPDX-License-Identifier: Apache-2.0
// The supervisor runs every control cycle: its update and the transition log must not touch the heap.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>

#include "allocation_counter.hpp"
#include "mgc/guidance/supervisor.hpp"

using namespace mgc::guidance;
using mgc::planning::PlannerStatus;

TEST_CASE("the supervisor and its transition log do not allocate", "[unit]") {
  SupervisorConfig config;
  config.num_joints = 4;
  config.max_replan_retries = 1;
  Supervisor sup(config);
  std::array<TransitionRecord, 4> drained{};
  SupervisorInputs in;
  in.now_us = 0;
  in.sensing.valve = ValveHealth::Active;
  in.sensing.cutoff = CutoffHealth::Ready;
  in.sensing.uwb_gateway = DeviceHealth::Alive;
  for (int j = 0; j < 4; ++j) in.sensing.joint[static_cast<std::size_t>(j)] = DeviceHealth::Alive;
  std::uint64_t transitions = 0;
  const long before = mgc::test::allocation_count();
  // 2,000 lifts of 10 phases: every state, re-plans, faults, stops and acknowledgements; drained
  // in small chunks some cycles, left to overwrite in others.
  for (int cycle = 0; cycle < 20'000; ++cycle) {
    in.now_us += 10'000;
    in.sensing.uwb_last_fix_us = in.now_us;
    const int phase = cycle % 10;
    in.commands = {};
    in.commands.goal_request = phase == 1;
    in.commands.stop = phase == 8 && cycle % 20 == 8;
    in.commands.acknowledge = phase == 9;
    in.planner.status = phase == 2 ? PlannerStatus::Solved : phase == 5 ? PlannerStatus::GoalOccupied
                                                                        : PlannerStatus::Running;
    in.safety.stop_check = phase == 3 ? StopCheckStatus::Stop : StopCheckStatus::Warning;
    in.safety.warning_speed_scale = 0.5;
    in.sensing.joint[1] = phase == 7 && cycle % 30 == 7 ? DeviceHealth::Stale : DeviceHealth::Alive;
    in.progress.at_rest = phase >= 4;
    in.progress.command_at_rest = phase >= 4;
    const SupervisorOutput out = sup.update(in);
    transitions += out.transitioned ? 1U : 0U;
    if (cycle % 3 == 0) (void)sup.log().drain(drained);
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(transitions > 2'000);
}
