// SPDX-License-Identifier: Apache-2.0
// The supervisor state machine (docs/supervisor.md): start-up, every transition with its reason,
// the acknowledgement rules, the operator stop from every state, the fault path of each loss of
// sensing, the re-plan retry policy, the transition log, and a whole lift with a re-plan.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/guidance/supervisor.hpp"

using namespace mgc::guidance;
using mgc::planning::PlannerStatus;

namespace {

constexpr std::int64_t kCycleUs = 10'000;  // the controller's 10 ms cycle
constexpr int kJoints = 4;

SupervisorConfig test_config() {
  SupervisorConfig c;
  c.num_joints = kJoints;
  return c;
}

//! Every device alive, the machine and its command at rest, a fresh UWB fix.
SupervisorInputs healthy(std::int64_t now_us) {
  SupervisorInputs in;
  in.now_us = now_us;
  for (int j = 0; j < kJoints; ++j) in.sensing.joint[static_cast<std::size_t>(j)] = DeviceHealth::Alive;
  in.sensing.valve = ValveHealth::Active;
  in.sensing.cutoff = CutoffHealth::Ready;
  in.sensing.uwb_gateway = DeviceHealth::Alive;
  in.sensing.uwb_last_fix_us = now_us;
  in.progress.at_rest = true;
  in.progress.command_at_rest = true;
  return in;
}

//! A supervisor stepped through time: each step is one 10 ms cycle on `base` inputs plus a change.
struct Machine {
  Supervisor sup;
  std::int64_t now_us = 1'000'000;
  explicit Machine(const SupervisorConfig& config = test_config()) : sup(config) {}

  SupervisorOutput step(const std::function<void(SupervisorInputs&)>& change = {}) {
    now_us += kCycleUs;
    SupervisorInputs in = healthy(now_us);
    if (change) change(in);
    return sup.update(in);
  }
  //! Steps until the time has advanced by dt_us (at least one step), returns the last output.
  SupervisorOutput step_for(std::int64_t dt_us, const std::function<void(SupervisorInputs&)>& change = {}) {
    SupervisorOutput out = step(change);
    for (std::int64_t t = kCycleUs; t < dt_us; t += kCycleUs) out = step(change);
    return out;
  }
  std::vector<TransitionRecord> drain() {
    std::vector<TransitionRecord> records(TransitionLog::kCapacity);
    records.resize(sup.log().drain(records));
    return records;
  }
};

void moving(SupervisorInputs& in) {
  in.progress.at_rest = false;
  in.progress.command_at_rest = false;
}

//! Brings a fresh machine into `state` along the normal paths.
void drive_to(Machine& m, SupervisorState state) {
  if (state == SupervisorState::Init) return;
  REQUIRE(m.step().state == SupervisorState::Hold);
  switch (state) {
    case SupervisorState::Hold: break;
    case SupervisorState::Planning:
      REQUIRE(m.step([](SupervisorInputs& in) { in.commands.goal_request = true; }).state == SupervisorState::Planning);
      break;
    case SupervisorState::Executing:
    case SupervisorState::Stopping:
    case SupervisorState::Replanning:
      REQUIRE(m.step([](SupervisorInputs& in) { in.commands.goal_request = true; }).state == SupervisorState::Planning);
      REQUIRE(m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::Solved; }).state ==
              SupervisorState::Executing);
      REQUIRE(m.step(moving).state == SupervisorState::Executing);
      if (state == SupervisorState::Executing) break;
      REQUIRE(m.step([](SupervisorInputs& in) {
                 moving(in);
                 in.safety.stop_check = StopCheckStatus::Stop;
               }).state == SupervisorState::Stopping);
      if (state == SupervisorState::Stopping) break;
      REQUIRE(m.step().state == SupervisorState::Replanning);
      break;
    case SupervisorState::Fault:
      REQUIRE(m.step([](SupervisorInputs& in) { in.sensing.joint[1] = DeviceHealth::Stale; }).state ==
              SupervisorState::Fault);
      break;
    case SupervisorState::Estop:
      REQUIRE(m.step([](SupervisorInputs& in) { in.commands.stop = true; }).state == SupervisorState::Estop);
      break;
    case SupervisorState::Init: break;
  }
}

constexpr std::array<SupervisorState, kSupervisorStateCount> kAllStates = {
    SupervisorState::Init,      SupervisorState::Hold,       SupervisorState::Planning, SupervisorState::Executing,
    SupervisorState::Stopping,  SupervisorState::Replanning, SupervisorState::Fault,    SupervisorState::Estop};

std::string detail(const TransitionRecord& r) { return std::string(r.detail.data()); }

}  // namespace

TEST_CASE("INIT waits for every device, starts the nodes once all are heard, then HOLD", "[unit]") {
  Machine m;
  const auto nothing_heard = [](SupervisorInputs& in) { in.sensing = SensingInputs{}; };
  SupervisorOutput out = m.step(nothing_heard);
  CHECK(out.state == SupervisorState::Init);
  CHECK_FALSE(out.start_nodes);
  CHECK_FALSE(out.motion_permitted);
  CHECK(out.speed_scale == 0.0);

  // Heartbeats of every node, but pre-operational: no encoder data, valve disabled, no tag fix yet.
  const auto heard = [](SupervisorInputs& in) {
    for (auto& j : in.sensing.joint) j = DeviceHealth::Stale;
    in.sensing.valve = ValveHealth::NotStarted;
    in.sensing.uwb_last_fix_us = 0;
  };
  out = m.step(heard);
  CHECK(out.state == SupervisorState::Init);
  CHECK(out.start_nodes);
  CHECK_FALSE(m.step(heard).start_nodes);  // once, not every cycle
  // Repeated after nmt_start_retry_us while the nodes stay off.
  out = m.step_for(test_config().nmt_start_retry_us - 2 * kCycleUs, heard);
  CHECK_FALSE(out.start_nodes);
  CHECK(m.step(heard).start_nodes);

  CHECK(m.sup.log().empty());
  out = m.step();
  CHECK(out.state == SupervisorState::Hold);
  CHECK(out.reason == TransitionReason::StartupComplete);
  CHECK(out.transitioned);
  const auto log = m.drain();
  REQUIRE(log.size() == 1);
  CHECK(log[0].from == SupervisorState::Init);
  CHECK(log[0].to == SupervisorState::Hold);
  CHECK(log[0].reason == TransitionReason::StartupComplete);
  CHECK(log[0].t_us == m.now_us);
  CHECK(log[0].sequence == 0);
}

TEST_CASE("INIT without every device alive by init_timeout_us is a FAULT naming the device", "[unit]") {
  Machine m;
  const auto joint2_stale = [](SupervisorInputs& in) { in.sensing.joint[2] = DeviceHealth::Stale; };
  // The first update starts INIT's clock: init_timeout_us / period cycles later it is still INIT.
  SupervisorOutput out = m.step_for(test_config().init_timeout_us, joint2_stale);
  CHECK(out.state == SupervisorState::Init);
  out = m.step(joint2_stale);
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.reason == TransitionReason::StartupTimeout);
  CHECK(out.controlled_stop);
  const auto log = m.drain();
  REQUIRE(log.size() == 1);
  CHECK(log[0].value == 2);
  CHECK(detail(log[0]) == "EncoderStale 2");
}

TEST_CASE("a latched watchdog in INIT is a FAULT at once", "[unit]") {
  Machine m;
  const SupervisorOutput out = m.step([](SupervisorInputs& in) { in.watchdog_tripped = true; });
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.reason == TransitionReason::WatchdogTripped);
}

namespace {

struct TransitionRow {
  const char* name;
  SupervisorState from;
  std::function<void(SupervisorInputs&)> change;
  std::int64_t after_us;  // inputs held this long (0: one cycle)
  SupervisorState to;
  TransitionReason reason;
  PlanRequest plan_request;
  std::int32_t value;
  const char* detail;
};

}  // namespace

TEST_CASE("every transition of the table, with its reason, value and detail", "[unit]") {
  const SupervisorConfig config = test_config();
  const auto planner = [](PlannerStatus s) {
    return [s](SupervisorInputs& in) { in.planner.status = s; };
  };
  const auto safety_stop = [](StopCheckStatus s) {
    return [s](SupervisorInputs& in) {
      moving(in);
      in.safety.stop_check = s;
    };
  };
  const std::vector<TransitionRow> rows = {
      {"goal in HOLD", SupervisorState::Hold, [](SupervisorInputs& in) { in.commands.goal_request = true; }, 0,
       SupervisorState::Planning, TransitionReason::GoalRequested, PlanRequest::Plan, -1, ""},
      {"plan solved", SupervisorState::Planning, planner(PlannerStatus::Solved), 0, SupervisorState::Executing,
       TransitionReason::PlanSolved, PlanRequest::None, -1, ""},
      {"plan failed", SupervisorState::Planning, planner(PlannerStatus::IterationLimit), 0, SupervisorState::Hold,
       TransitionReason::PlanFailed, PlanRequest::None, static_cast<std::int32_t>(PlannerStatus::IterationLimit),
       "IterationLimit"},
      {"plan invalid goal", SupervisorState::Planning, planner(PlannerStatus::InvalidGoal), 0, SupervisorState::Hold,
       TransitionReason::PlanFailed, PlanRequest::None, static_cast<std::int32_t>(PlannerStatus::InvalidGoal),
       "InvalidGoal"},
      {"plan invalid start", SupervisorState::Planning, planner(PlannerStatus::InvalidStart), 0, SupervisorState::Hold,
       TransitionReason::PlanFailed, PlanRequest::None, static_cast<std::int32_t>(PlannerStatus::InvalidStart),
       "InvalidStart"},
      {"plan start blocked by an obstacle", SupervisorState::Planning,
       [](SupervisorInputs& in) {
         in.planner.status = PlannerStatus::InvalidStart;
         in.planner.start_blocked = true;
       },
       0, SupervisorState::Hold, TransitionReason::StartBlocked, PlanRequest::None,
       static_cast<std::int32_t>(PlannerStatus::InvalidStart), "InvalidStart"},
      {"plan goal occupied", SupervisorState::Planning, planner(PlannerStatus::GoalOccupied), 0, SupervisorState::Hold,
       TransitionReason::GoalOccupied, PlanRequest::None, static_cast<std::int32_t>(PlannerStatus::GoalOccupied),
       "GoalOccupied"},
      {"plan timeout", SupervisorState::Planning, planner(PlannerStatus::Running), config.plan_timeout_us,
       SupervisorState::Hold, TransitionReason::PlanTimeout, PlanRequest::None, -1, ""},
      {"stop zone", SupervisorState::Executing, safety_stop(StopCheckStatus::Stop), 0, SupervisorState::Stopping,
       TransitionReason::SafetyStopZone, PlanRequest::None, -1, ""},
      {"stop check error", SupervisorState::Executing, safety_stop(StopCheckStatus::ErrorInput), 0,
       SupervisorState::Stopping, TransitionReason::SafetyCheckError, PlanRequest::None, -1, ""},
      {"envelope violated", SupervisorState::Executing,
       [](SupervisorInputs& in) {
         moving(in);
         in.safety.envelope_violated = true;
       },
       0, SupervisorState::Stopping, TransitionReason::EnvelopeViolated, PlanRequest::None, -1, ""},
      {"overload", SupervisorState::Executing,
       [](SupervisorInputs& in) {
         moving(in);
         in.safety.rcl_stage = RclStage::Overload;
       },
       0, SupervisorState::Stopping, TransitionReason::RatedCapacityCut, PlanRequest::None, -1, ""},
      {"outside chart", SupervisorState::Executing,
       [](SupervisorInputs& in) {
         moving(in);
         in.safety.rcl_stage = RclStage::OutsideChart;
       },
       0, SupervisorState::Stopping, TransitionReason::RatedCapacityCut, PlanRequest::None, -1, ""},
      {"goal reached", SupervisorState::Executing, [](SupervisorInputs& in) { in.progress.path_complete = true; }, 0,
       SupervisorState::Hold, TransitionReason::GoalReached, PlanRequest::None, -1, ""},
      {"at rest after a safety stop", SupervisorState::Stopping, {}, 0, SupervisorState::Replanning,
       TransitionReason::AtRestReplan, PlanRequest::Replan, -1, ""},
      {"stop timeout", SupervisorState::Stopping, moving, config.stop_timeout_us, SupervisorState::Fault,
       TransitionReason::StopTimeout, PlanRequest::None, -1, ""},
      {"re-plan solved", SupervisorState::Replanning, planner(PlannerStatus::Solved), 0, SupervisorState::Executing,
       TransitionReason::ReplanSolved, PlanRequest::None, -1, ""},
      {"goal occupied", SupervisorState::Replanning, planner(PlannerStatus::GoalOccupied), 0, SupervisorState::Hold,
       TransitionReason::GoalOccupied, PlanRequest::None, static_cast<std::int32_t>(PlannerStatus::GoalOccupied),
       "GoalOccupied"},
      {"re-plan invalid start", SupervisorState::Replanning, planner(PlannerStatus::InvalidStart), 0,
       SupervisorState::Hold, TransitionReason::StartBlocked, PlanRequest::None,
       static_cast<std::int32_t>(PlannerStatus::InvalidStart), "InvalidStart"},
      {"re-plan pool exhausted", SupervisorState::Replanning, planner(PlannerStatus::PoolExhausted), 0,
       SupervisorState::Hold, TransitionReason::ReplanFailed, PlanRequest::None,
       static_cast<std::int32_t>(PlannerStatus::PoolExhausted), "PoolExhausted"},
      {"re-plan timeout", SupervisorState::Replanning, planner(PlannerStatus::Running), config.plan_timeout_us,
       SupervisorState::Hold, TransitionReason::PlanTimeout, PlanRequest::None, -1, ""},
      {"operator stop", SupervisorState::Executing,
       [](SupervisorInputs& in) {
         moving(in);
         in.commands.stop = true;
       },
       0, SupervisorState::Estop, TransitionReason::OperatorStop, PlanRequest::None, -1, ""},
      {"acknowledge ESTOP at rest", SupervisorState::Estop, [](SupervisorInputs& in) { in.commands.acknowledge = true; },
       0, SupervisorState::Hold, TransitionReason::OperatorAcknowledge, PlanRequest::None, -1, ""},
      {"acknowledge FAULT, cause gone", SupervisorState::Fault,
       [](SupervisorInputs& in) { in.commands.acknowledge = true; }, 0, SupervisorState::Init,
       TransitionReason::OperatorAcknowledge, PlanRequest::None, -1, ""},
      {"lost encoder in HOLD", SupervisorState::Hold, [](SupervisorInputs& in) { in.sensing.joint[3] = DeviceHealth::Missing; },
       0, SupervisorState::Fault, TransitionReason::EncoderMissing, PlanRequest::None, 3, "joint 3"},
      {"lost encoder while planning", SupervisorState::Planning,
       [](SupervisorInputs& in) { in.sensing.joint[0] = DeviceHealth::Stale; }, 0, SupervisorState::Fault,
       TransitionReason::EncoderStale, PlanRequest::None, 0, "joint 0"},
      {"bus-off while re-planning", SupervisorState::Replanning, [](SupervisorInputs& in) { in.sensing.bus_off = true; },
       0, SupervisorState::Fault, TransitionReason::BusOff, PlanRequest::None, -1, "can bus"},
      {"valve fault in ESTOP", SupervisorState::Estop, [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::Faulted; },
       0, SupervisorState::Fault, TransitionReason::ValveFaulted, PlanRequest::None, -1, "valve"},
      {"cut-off lost in ESTOP", SupervisorState::Estop, [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Missing; },
       0, SupervisorState::Fault, TransitionReason::CutoffLost, PlanRequest::None, -1, "cut-off"},
      {"cut-off cut on its own in HOLD", SupervisorState::Hold,
       [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Cut; }, 0, SupervisorState::Fault,
       TransitionReason::CutoffNotReady, PlanRequest::None, -1, "cut-off"},
      {"valve counter not obeying while planning", SupervisorState::Planning,
       [](SupervisorInputs& in) {
         in.sensing.plausibility = PlausibilityFault::ValveNotObeying;
         in.sensing.plausibility_joint = -1;
       },
       0, SupervisorState::Fault, TransitionReason::ValveNotObeying, PlanRequest::None, -1, "valve"},
      {"runaway in ESTOP", SupervisorState::Estop,
       [](SupervisorInputs& in) {
         in.sensing.plausibility = PlausibilityFault::JointRunaway;
         in.sensing.plausibility_joint = 2;
       },
       0, SupervisorState::Fault, TransitionReason::JointRunaway, PlanRequest::None, 2, "joint 2"},
  };
  for (const TransitionRow& row : rows) {
    SECTION(row.name) {
      Machine m;
      drive_to(m, row.from);
      REQUIRE(m.sup.state() == row.from);
      (void)m.drain();
      const SupervisorOutput out =
          row.after_us > 0 ? m.step_for(row.after_us, row.change) : m.step(row.change);
      CHECK(out.state == row.to);
      CHECK(out.reason == row.reason);
      CHECK(out.plan_request == row.plan_request);
      CHECK(out.transitioned);
      const auto log = m.drain();
      REQUIRE(log.size() == 1);
      CHECK(log[0].from == row.from);
      CHECK(log[0].to == row.to);
      CHECK(log[0].reason == row.reason);
      CHECK(log[0].value == row.value);
      CHECK(detail(log[0]) == row.detail);
      CHECK(log[0].t_us == m.now_us);
    }
  }
}

TEST_CASE("nothing changes state without its condition", "[unit]") {
  SECTION("EXECUTING: path complete but still moving") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    const SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.progress.path_complete = true;
    });
    CHECK(out.state == SupervisorState::Executing);
    CHECK_FALSE(out.transitioned);
  }
  SECTION("STOPPING: measured at rest but the command not yet zero") {
    Machine m;
    drive_to(m, SupervisorState::Stopping);
    const SupervisorOutput out = m.step([](SupervisorInputs& in) { in.progress.command_at_rest = false; });
    CHECK(out.state == SupervisorState::Stopping);
    CHECK(out.plan_request == PlanRequest::None);
  }
  SECTION("PLANNING: still running just before the timeout") {
    Machine m;
    drive_to(m, SupervisorState::Planning);
    const SupervisorOutput out = m.step_for(test_config().plan_timeout_us - kCycleUs);
    CHECK(out.state == SupervisorState::Planning);
  }
  SECTION("the stop zone in HOLD: the machine is at rest already") {
    Machine m;
    drive_to(m, SupervisorState::Hold);
    const SupervisorOutput out = m.step([](SupervisorInputs& in) { in.safety.stop_check = StopCheckStatus::Stop; });
    CHECK(out.state == SupervisorState::Hold);
  }
  SECTION("the plan request is issued once, on entry") {
    Machine m;
    drive_to(m, SupervisorState::Planning);
    CHECK(m.step().plan_request == PlanRequest::None);
  }
}

TEST_CASE("motion permitted and speed scale per state", "[unit]") {
  for (const SupervisorState state : kAllStates) {
    Machine m;
    drive_to(m, state);
    // The same inputs that keep the state (at rest would end STOPPING, so move).
    const SupervisorOutput out = m.step([state](SupervisorInputs& in) {
      if (state == SupervisorState::Stopping || state == SupervisorState::Executing) moving(in);
      if (state == SupervisorState::Init) in.sensing.valve = ValveHealth::NotStarted;
    });
    CAPTURE(to_string(state));
    REQUIRE(out.state == state);
    CHECK(out.motion_permitted == (state == SupervisorState::Executing));
    CHECK(out.speed_scale == (state == SupervisorState::Executing ? 1.0 : 0.0));
    const bool stop = state == SupervisorState::Stopping || state == SupervisorState::Fault ||
                      state == SupervisorState::Estop;
    CHECK(out.controlled_stop == stop);
  }
  Machine m;
  drive_to(m, SupervisorState::Executing);
  const auto warn = [](double scale) {
    return [scale](SupervisorInputs& in) {
      moving(in);
      in.safety.stop_check = StopCheckStatus::Warning;
      in.safety.warning_speed_scale = scale;
    };
  };
  CHECK(m.step(warn(0.4)).speed_scale == 0.4);
  CHECK(m.step(warn(0.0)).speed_scale == 0.0);
  CHECK(m.step(warn(1.7)).speed_scale == 1.0);
  CHECK(m.step(warn(-0.2)).speed_scale == 0.0);
  CHECK(m.step(warn(std::numeric_limits<double>::quiet_NaN())).speed_scale == 0.0);
  const SupervisorOutput out = m.step(warn(0.25));
  CHECK(out.state == SupervisorState::Executing);
  CHECK(out.motion_permitted);
  CHECK(out.speed_scale == 0.25);
}

TEST_CASE("an operator stop is obeyed from every state", "[unit]") {
  for (const SupervisorState state : kAllStates) {
    Machine m;
    drive_to(m, state);
    (void)m.drain();
    CAPTURE(to_string(state));
    const SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.commands.stop = true;
      in.commands.goal_request = true;
    });
    CHECK(out.stop_outcome == CommandOutcome::Accepted);
    CHECK(out.goal_outcome == CommandOutcome::RejectedBusy);  // sent with a stop: never acted on
    CHECK_FALSE(out.motion_permitted);
    CHECK(out.speed_scale == 0.0);
    CHECK(out.controlled_stop);
    CHECK(out.plan_request == PlanRequest::None);
    const auto log = m.drain();
    if (state == SupervisorState::Fault || state == SupervisorState::Estop) {
      // Already a latched stop: FAULT keeps its cause and its stricter recovery.
      CHECK(out.state == state);
      CHECK(log.empty());
    } else {
      CHECK(out.state == SupervisorState::Estop);
      CHECK(out.reason == TransitionReason::OperatorStop);
      REQUIRE(log.size() == 1);
      CHECK(log[0].from == state);
      CHECK(log[0].reason == TransitionReason::OperatorStop);
    }
    // It stays latched: no goal is taken until an acknowledgement.
    const SupervisorOutput next = m.step([](SupervisorInputs& in) { in.commands.goal_request = true; });
    CHECK(next.state == out.state);
    CHECK(next.goal_outcome == CommandOutcome::RejectedLatched);
  }
}

TEST_CASE("acknowledgement rules", "[unit]") {
  const auto ack = [](SupervisorInputs& in) { in.commands.acknowledge = true; };

  SECTION("ESTOP: refused while moving, accepted at rest, into HOLD") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    REQUIRE(m.step([](SupervisorInputs& in) {
               moving(in);
               in.commands.stop = true;
             }).state == SupervisorState::Estop);
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Estop);
    CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
    CHECK(out.ack_blocker == TransitionReason::None);
    // At rest measured, command not yet zero: still refused.
    out = m.step([](SupervisorInputs& in) {
      in.progress.command_at_rest = false;
      in.commands.acknowledge = true;
    });
    CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
    CHECK(m.step().state == SupervisorState::Estop);  // never recovers by itself
    out = m.step(ack);
    CHECK(out.state == SupervisorState::Hold);
    CHECK(out.acknowledge_outcome == CommandOutcome::Accepted);
    CHECK(out.reason == TransitionReason::OperatorAcknowledge);
    CHECK_FALSE(out.reset_latches);
  }

  SECTION("FAULT: refused while the cause is there, then through INIT with a node restart") {
    Machine m;
    drive_to(m, SupervisorState::Hold);
    const auto encoder_gone = [](SupervisorInputs& in) { in.sensing.joint[2] = DeviceHealth::Missing; };
    REQUIRE(m.step(encoder_gone).state == SupervisorState::Fault);
    // Stays latched with the device back: recovery needs the operator.
    CHECK(m.step_for(5'000'000).state == SupervisorState::Fault);
    SupervisorOutput out = m.step([&](SupervisorInputs& in) {
      encoder_gone(in);
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Fault);
    CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
    CHECK(out.ack_blocker == TransitionReason::EncoderMissing);
    // Heartbeat back, data not yet flowing (rebooted, pre-operational): a restart clears that.
    const auto rebooted = [](SupervisorInputs& in) {
      in.sensing.joint[2] = DeviceHealth::Stale;
      in.sensing.valve = ValveHealth::FailSafe;
    };
    out = m.step([&](SupervisorInputs& in) {
      rebooted(in);
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Init);
    CHECK(out.acknowledge_outcome == CommandOutcome::Accepted);
    CHECK(out.reset_latches);
    CHECK(m.step(rebooted).start_nodes);  // INIT restarts the nodes
    out = m.step();
    CHECK(out.state == SupervisorState::Hold);
    CHECK(out.reason == TransitionReason::StartupComplete);
  }

  SECTION("FAULT: refused while the stop command is still ramping down") {
    Machine m;
    drive_to(m, SupervisorState::Fault);
    const SupervisorOutput out = m.step([](SupervisorInputs& in) {
      in.progress.command_at_rest = false;
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Fault);
    CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
    CHECK(out.ack_blocker == TransitionReason::None);
  }

  SECTION("FAULT: a device's own fault blocks, a fail-safe valve does not") {
    Machine m;
    drive_to(m, SupervisorState::Hold);
    REQUIRE(m.step([](SupervisorInputs& in) { in.sensing.valve = ValveHealth::Faulted; }).state ==
            SupervisorState::Fault);
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      in.sensing.valve = ValveHealth::Faulted;
      in.commands.acknowledge = true;
    });
    CHECK(out.ack_blocker == TransitionReason::ValveFaulted);
    out = m.step([](SupervisorInputs& in) {
      in.sensing.joint[1] = DeviceHealth::Faulted;
      in.sensing.valve = ValveHealth::FailSafe;
      in.commands.acknowledge = true;
    });
    CHECK(out.ack_blocker == TransitionReason::EncoderFaulted);
    out = m.step([](SupervisorInputs& in) {
      in.sensing.valve = ValveHealth::FailSafe;
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Init);
  }

  SECTION("FAULT from the watchdog: the acknowledgement is its reset") {
    Machine m;
    drive_to(m, SupervisorState::Hold);
    const auto tripped = [](SupervisorInputs& in) { in.watchdog_tripped = true; };
    REQUIRE(m.step(tripped).reason == TransitionReason::WatchdogTripped);
    const SupervisorOutput out = m.step([&](SupervisorInputs& in) {
      tripped(in);
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Init);
    CHECK(out.reset_latches);
    CHECK(m.step().state == SupervisorState::Hold);  // the loop reset it
  }

  SECTION("outside FAULT and ESTOP there is nothing to acknowledge") {
    for (const SupervisorState state : {SupervisorState::Hold, SupervisorState::Executing, SupervisorState::Planning}) {
      Machine m;
      drive_to(m, state);
      (void)m.drain();
      const SupervisorOutput out = m.step([state](SupervisorInputs& in) {
        if (state == SupervisorState::Executing) moving(in);
        in.commands.acknowledge = true;
      });
      CHECK(out.state == state);
      CHECK(out.acknowledge_outcome == CommandOutcome::RejectedNothingToAcknowledge);
      CHECK(m.drain().empty());
    }
  }

  SECTION("goals outside HOLD are refused, not queued") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.commands.goal_request = true;
    });
    CHECK(out.state == SupervisorState::Executing);
    CHECK(out.goal_outcome == CommandOutcome::RejectedBusy);
    Machine f;
    drive_to(f, SupervisorState::Fault);
    out = f.step([](SupervisorInputs& in) { in.commands.goal_request = true; });
    CHECK(out.goal_outcome == CommandOutcome::RejectedLatched);
    Machine i;
    out = i.step([](SupervisorInputs& in) {
      in.sensing.valve = ValveHealth::NotStarted;
      in.commands.goal_request = true;
    });
    CHECK(out.state == SupervisorState::Init);
    CHECK(out.goal_outcome == CommandOutcome::RejectedBusy);
  }
}

namespace {

struct SensingLoss {
  const char* name;
  std::function<void(SupervisorInputs&)> lose;
  TransitionReason reason;
  std::int32_t value;
  const char* detail;
};

//! The plausibility monitor's latched finding naming a joint (-1: the valve's counter).
std::function<void(SupervisorInputs&)> plausibility(PlausibilityFault fault, int joint) {
  return [fault, joint](SupervisorInputs& in) {
    in.sensing.plausibility = fault;
    in.sensing.plausibility_joint = joint;
  };
}

std::vector<SensingLoss> sensing_losses(const SupervisorConfig& config) {
  return {
      {"encoder heartbeat lost", [](SupervisorInputs& in) { in.sensing.joint[1] = DeviceHealth::Missing; },
       TransitionReason::EncoderMissing, 1, "joint 1"},
      {"encoder data stale", [](SupervisorInputs& in) { in.sensing.joint[3] = DeviceHealth::Stale; },
       TransitionReason::EncoderStale, 3, "joint 3"},
      {"encoder alarm", [](SupervisorInputs& in) { in.sensing.joint[0] = DeviceHealth::Faulted; },
       TransitionReason::EncoderFaulted, 0, "joint 0"},
      {"valve heartbeat lost", [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::Missing; },
       TransitionReason::ValveHeartbeatLost, -1, "valve"},
      {"valve fail-safe", [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::FailSafe; },
       TransitionReason::ValveFailSafe, -1, "valve"},
      {"valve fault", [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::Faulted; },
       TransitionReason::ValveFaulted, -1, "valve"},
      {"valve disabled", [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::NotStarted; },
       TransitionReason::ValveNotActive, -1, "valve"},
      {"valve status stale", [](SupervisorInputs& in) { in.sensing.valve = ValveHealth::StatusStale; },
       TransitionReason::ValveStatusStale, -1, "valve"},
      {"bus-off", [](SupervisorInputs& in) { in.sensing.bus_off = true; }, TransitionReason::BusOff, -1, "can bus"},
      {"uwb gateway lost", [](SupervisorInputs& in) { in.sensing.uwb_gateway = DeviceHealth::Missing; },
       TransitionReason::UwbGatewayLost, -1, "uwb gateway"},
      {"uwb silence past its timeout",
       [config](SupervisorInputs& in) { in.sensing.uwb_last_fix_us = in.now_us - config.uwb_silence_timeout_us - 1; },
       TransitionReason::UwbSilent, -1, "uwb tags"},
      {"watchdog", [](SupervisorInputs& in) { in.watchdog_tripped = true; }, TransitionReason::WatchdogTripped, -1,
       "loop watchdog"},
      {"cut-off heartbeat lost", [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Missing; },
       TransitionReason::CutoffLost, -1, "cut-off"},
      {"cut-off failed", [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Failed; },
       TransitionReason::CutoffFailed, -1, "cut-off"},
      {"cut-off status stopped", [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::NotReady; },
       TransitionReason::CutoffNotReady, -1, "cut-off"},
      {"pilot cut on its own", [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Cut; },
       TransitionReason::CutoffNotReady, -1, "cut-off"},
      {"encoder stuck", plausibility(PlausibilityFault::EncoderStuck, 2), TransitionReason::EncoderStuck, 2, "joint 2"},
      {"encoder out of range", plausibility(PlausibilityFault::EncoderOutOfRange, 1), TransitionReason::EncoderImplausible,
       1, "joint 1"},
      {"encoder step", plausibility(PlausibilityFault::EncoderStep, 0), TransitionReason::EncoderImplausible, 0,
       "joint 0"},
      {"joint not following", plausibility(PlausibilityFault::JointNotFollowing, 3), TransitionReason::JointNotFollowing,
       3, "joint 3"},
      {"joint runaway", plausibility(PlausibilityFault::JointRunaway, 1), TransitionReason::JointRunaway, 1, "joint 1"},
      {"valve spool not obeying", plausibility(PlausibilityFault::ValveNotObeying, 2), TransitionReason::ValveNotObeying,
       2, "valve 2"},
      {"valve counter not obeying", plausibility(PlausibilityFault::ValveNotObeying, -1),
       TransitionReason::ValveNotObeying, -1, "valve"},
      {"machine tag disagrees", plausibility(PlausibilityFault::PoseDisagrees, 200), TransitionReason::PoseDisagrees, 200,
       "uwb tag 200"},
  };
}

}  // namespace

TEST_CASE("each loss of sensing while moving: controlled stop, then FAULT with its reason", "[unit]") {
  const SupervisorConfig config = test_config();
  for (const SensingLoss& loss : sensing_losses(config)) {
    SECTION(loss.name) {
      Machine m;
      drive_to(m, SupervisorState::Executing);
      (void)m.drain();
      const auto lost_moving = [&](SupervisorInputs& in) {
        moving(in);
        loss.lose(in);
      };
      SupervisorOutput out = m.step(lost_moving);
      CHECK(out.state == SupervisorState::Stopping);
      CHECK(out.reason == loss.reason);
      CHECK(out.controlled_stop);
      CHECK_FALSE(out.motion_permitted);
      // The stop's end is the command reaching zero: measurements may be what was lost.
      out = m.step_for(500'000, lost_moving);
      CHECK(out.state == SupervisorState::Stopping);
      out = m.step([&](SupervisorInputs& in) {
        loss.lose(in);
        in.progress.at_rest = false;  // unknown: the command alone decides
        in.progress.command_at_rest = true;
      });
      CHECK(out.state == SupervisorState::Fault);
      CHECK(out.reason == loss.reason);
      CHECK(out.controlled_stop);
      const auto log = m.drain();
      REQUIRE(log.size() == 2);
      CHECK(log[0].from == SupervisorState::Executing);
      CHECK(log[0].to == SupervisorState::Stopping);
      CHECK(log[1].from == SupervisorState::Stopping);
      CHECK(log[1].to == SupervisorState::Fault);
      for (const TransitionRecord& r : log) {
        CHECK(r.reason == loss.reason);
        CHECK(r.value == loss.value);
        CHECK(detail(r) == loss.detail);
      }
      CHECK(log[1].sequence == log[0].sequence + 1);
    }
  }
}

TEST_CASE("each loss of sensing at rest is a FAULT at once", "[unit]") {
  for (const SensingLoss& loss : sensing_losses(test_config())) {
    for (const SupervisorState state : {SupervisorState::Hold, SupervisorState::Planning, SupervisorState::Replanning}) {
      Machine m;
      drive_to(m, state);
      CAPTURE(loss.name, to_string(state));
      const SupervisorOutput out = m.step(loss.lose);
      CHECK(out.state == SupervisorState::Fault);
      CHECK(out.reason == loss.reason);
    }
  }
}

TEST_CASE("INIT waits for the cut-off Ready and names it when it never comes", "[unit]") {
  SECTION("Missing: not every node heard, so no start") {
    Machine m;
    const SupervisorOutput out = m.step([](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Missing; });
    CHECK(out.state == SupervisorState::Init);
    CHECK_FALSE(out.start_nodes);
  }
  SECTION("NotReady and Cut keep INIT, with the nodes started; Ready completes it") {
    Machine m;
    SupervisorOutput out = m.step([](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::NotReady; });
    CHECK(out.state == SupervisorState::Init);
    CHECK(out.start_nodes);
    out = m.step_for(500'000, [](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Cut; });
    CHECK(out.state == SupervisorState::Init);
    CHECK_FALSE(out.motion_permitted);
    CHECK(m.sup.log().empty());
    out = m.step();
    CHECK(out.state == SupervisorState::Hold);
    CHECK(out.reason == TransitionReason::StartupComplete);
  }
  struct Never {
    CutoffHealth cutoff;
    const char* detail;
  };
  for (const Never& never : {Never{CutoffHealth::Cut, "CutoffNotReady"}, Never{CutoffHealth::NotReady, "CutoffNotReady"},
                             Never{CutoffHealth::Failed, "CutoffFailed"}, Never{CutoffHealth::Missing, "CutoffLost"}}) {
    CAPTURE(never.detail, static_cast<int>(never.cutoff));
    Machine m;
    const auto stuck = [&](SupervisorInputs& in) { in.sensing.cutoff = never.cutoff; };
    CHECK(m.step_for(test_config().init_timeout_us, stuck).state == SupervisorState::Init);
    const SupervisorOutput out = m.step(stuck);
    CHECK(out.state == SupervisorState::Fault);
    CHECK(out.reason == TransitionReason::StartupTimeout);
    const auto log = m.drain();
    REQUIRE(log.size() == 1);
    CHECK(log[0].value == -1);
    CHECK(detail(log[0]) == never.detail);
  }
}

TEST_CASE("acknowledgement with the cut-off: refused while it is Missing or Failed, accepted when Cut", "[unit]") {
  const auto ack_with = [](CutoffHealth cutoff) {
    return [cutoff](SupervisorInputs& in) {
      in.sensing.cutoff = cutoff;
      in.commands.acknowledge = true;
    };
  };
  Machine m;
  drive_to(m, SupervisorState::Hold);
  REQUIRE(m.step([](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Failed; }).reason ==
          TransitionReason::CutoffFailed);
  SupervisorOutput out = m.step(ack_with(CutoffHealth::Failed));
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
  CHECK(out.ack_blocker == TransitionReason::CutoffFailed);
  out = m.step(ack_with(CutoffHealth::Missing));
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.acknowledge_outcome == CommandOutcome::RejectedCauseActive);
  CHECK(out.ack_blocker == TransitionReason::CutoffLost);
  // The valve's own loss is named before the cut-off's.
  out = m.step([&](SupervisorInputs& in) {
    ack_with(CutoffHealth::Missing)(in);
    in.sensing.valve = ValveHealth::Missing;
  });
  CHECK(out.ack_blocker == TransitionReason::ValveHeartbeatLost);
  // Cut (as the loop leaves it in FAULT): a restart through INIT enables it again.
  out = m.step(ack_with(CutoffHealth::Cut));
  CHECK(out.state == SupervisorState::Init);
  CHECK(out.acknowledge_outcome == CommandOutcome::Accepted);
  CHECK(out.reset_latches);
  CHECK(m.step([](SupervisorInputs& in) { in.sensing.cutoff = CutoffHealth::Cut; }).state == SupervisorState::Init);
  CHECK(m.step().state == SupervisorState::Hold);

  Machine n;
  drive_to(n, SupervisorState::Fault);
  out = n.step(ack_with(CutoffHealth::NotReady));
  CHECK(out.state == SupervisorState::Init);
  CHECK(out.acknowledge_outcome == CommandOutcome::Accepted);
}

TEST_CASE("a plausibility finding does not block its acknowledgement, INIT waits for it to clear", "[unit]") {
  for (const PlausibilityFault fault : {PlausibilityFault::JointRunaway, PlausibilityFault::ValveNotObeying,
                                        PlausibilityFault::EncoderStuck, PlausibilityFault::EncoderStep}) {
    CAPTURE(to_string(fault));
    Machine m;
    drive_to(m, SupervisorState::Hold);
    const auto finding = plausibility(fault, 1);
    REQUIRE(m.step(finding).state == SupervisorState::Fault);
    // The loop keeps the pilot cut in FAULT: the cut-off reports Cut as well.
    const SupervisorOutput out = m.step([&](SupervisorInputs& in) {
      finding(in);
      in.sensing.cutoff = CutoffHealth::Cut;
      in.commands.acknowledge = true;
    });
    CHECK(out.state == SupervisorState::Init);
    CHECK(out.acknowledge_outcome == CommandOutcome::Accepted);
    CHECK(out.ack_blocker == TransitionReason::None);
    CHECK(out.reset_latches);  // the loop resets the monitor with the other latches
    // Were the finding still latched, INIT would not complete.
    CHECK(m.step(finding).state == SupervisorState::Init);
    CHECK(m.step().state == SupervisorState::Hold);
  }
}

TEST_CASE("precedence: a plausibility finding wins over a safety cut of the same cycle", "[unit]") {
  SECTION("with an RCL cut: a stop toward FAULT, not a re-plan") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    (void)m.drain();
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.safety.rcl_stage = RclStage::Overload;
      plausibility(PlausibilityFault::JointRunaway, 1)(in);
    });
    CHECK(out.state == SupervisorState::Stopping);
    CHECK(out.reason == TransitionReason::JointRunaway);
    out = m.step([](SupervisorInputs& in) {
      in.safety.rcl_stage = RclStage::Overload;
      plausibility(PlausibilityFault::JointRunaway, 1)(in);
    });
    CHECK(out.state == SupervisorState::Fault);
    CHECK(out.plan_request == PlanRequest::None);
    CHECK(m.sup.reason_value() == 1);
    const auto log = m.drain();
    REQUIRE(log.size() == 2);
    for (const TransitionRecord& r : log) {
      CHECK(r.reason == TransitionReason::JointRunaway);
      CHECK(r.value == 1);
    }
  }
  SECTION("with the stop zone") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    const SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      in.safety.stop_check = StopCheckStatus::Stop;
      plausibility(PlausibilityFault::ValveNotObeying, -1)(in);
    });
    CHECK(out.state == SupervisorState::Stopping);
    CHECK(out.reason == TransitionReason::ValveNotObeying);
  }
  SECTION("an RCL stop that then finds a plausibility fault becomes a stop toward FAULT") {
    Machine m;
    drive_to(m, SupervisorState::Executing);
    REQUIRE(m.step([](SupervisorInputs& in) {
               moving(in);
               in.safety.rcl_stage = RclStage::OutsideChart;
             }).reason == TransitionReason::RatedCapacityCut);
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      moving(in);
      plausibility(PlausibilityFault::JointNotFollowing, 3)(in);
    });
    CHECK(out.state == SupervisorState::Stopping);
    CHECK(out.reason == TransitionReason::JointNotFollowing);
    out = m.step(plausibility(PlausibilityFault::JointNotFollowing, 3));
    CHECK(out.state == SupervisorState::Fault);
    CHECK(m.sup.reason_value() == 3);
  }
  SECTION("the losses of sensing come first, the cut-off before the encoders, those before the finding") {
    Machine m;
    drive_to(m, SupervisorState::Hold);
    SupervisorOutput out = m.step([](SupervisorInputs& in) {
      in.sensing.valve = ValveHealth::FailSafe;
      in.sensing.cutoff = CutoffHealth::Failed;
      in.sensing.joint[0] = DeviceHealth::Stale;
      plausibility(PlausibilityFault::JointRunaway, 1)(in);
    });
    CHECK(out.reason == TransitionReason::ValveFailSafe);
    Machine c;
    drive_to(c, SupervisorState::Hold);
    out = c.step([](SupervisorInputs& in) {
      in.sensing.cutoff = CutoffHealth::Cut;
      in.sensing.joint[0] = DeviceHealth::Stale;
      plausibility(PlausibilityFault::JointRunaway, 1)(in);
    });
    CHECK(out.reason == TransitionReason::CutoffNotReady);
    Machine e;
    drive_to(e, SupervisorState::Hold);
    out = e.step([](SupervisorInputs& in) {
      in.sensing.joint[2] = DeviceHealth::Faulted;
      plausibility(PlausibilityFault::EncoderStuck, 0)(in);
    });
    CHECK(out.reason == TransitionReason::EncoderFaulted);
    CHECK(e.sup.reason_value() == 2);
    Machine u;
    drive_to(u, SupervisorState::Hold);
    out = u.step([](SupervisorInputs& in) {
      in.sensing.uwb_gateway = DeviceHealth::Missing;
      plausibility(PlausibilityFault::EncoderStuck, 0)(in);
    });
    CHECK(out.reason == TransitionReason::EncoderStuck);
  }
}

TEST_CASE("a safety stop that loses sensing becomes a stop toward FAULT", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Stopping);
  (void)m.drain();
  SupervisorOutput out = m.step([](SupervisorInputs& in) {
    moving(in);
    in.sensing.joint[2] = DeviceHealth::Stale;
  });
  CHECK(out.state == SupervisorState::Stopping);
  CHECK(out.reason == TransitionReason::EncoderStale);
  // At rest now, but it ends in FAULT, not in a re-plan.
  out = m.step([](SupervisorInputs& in) { in.sensing.joint[2] = DeviceHealth::Stale; });
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.plan_request == PlanRequest::None);
  const auto log = m.drain();
  REQUIRE(log.size() == 2);
  CHECK(log[0].from == SupervisorState::Stopping);
  CHECK(log[0].to == SupervisorState::Stopping);
  CHECK(log[0].reason == TransitionReason::EncoderStale);
  CHECK(log[1].reason == TransitionReason::EncoderStale);
}

TEST_CASE("a stop toward FAULT whose command never reaches zero ends in FAULT at the stop timeout", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Executing);
  const auto lost = [](SupervisorInputs& in) {
    moving(in);
    in.sensing.bus_off = true;
  };
  REQUIRE(m.step(lost).state == SupervisorState::Stopping);
  CHECK(m.step_for(test_config().stop_timeout_us - 2 * kCycleUs, lost).state == SupervisorState::Stopping);
  const SupervisorOutput out = m.step_for(2 * kCycleUs, lost);
  CHECK(out.state == SupervisorState::Fault);
  CHECK(out.reason == TransitionReason::BusOff);
}

TEST_CASE("UWB is not monitored on a site without tags", "[unit]") {
  SupervisorConfig config = test_config();
  config.uwb_required = false;
  Machine m(config);
  const auto no_uwb = [](SupervisorInputs& in) {
    in.sensing.uwb_gateway = DeviceHealth::Missing;
    in.sensing.uwb_last_fix_us = 0;
  };
  CHECK(m.step(no_uwb).state == SupervisorState::Hold);
  CHECK(m.step_for(5'000'000, no_uwb).state == SupervisorState::Hold);
  // With UWB required the same inputs never leave INIT.
  Machine r;
  CHECK(r.step(no_uwb).state == SupervisorState::Init);
}

TEST_CASE("GoalOccupied: HOLD, retry every interval, give up after max_replan_retries", "[unit]") {
  SupervisorConfig config = test_config();
  config.max_replan_retries = 2;
  Machine m(config);
  drive_to(m, SupervisorState::Replanning);
  const auto occupied = [](SupervisorInputs& in) { in.planner.status = PlannerStatus::GoalOccupied; };
  REQUIRE(m.step(occupied).state == SupervisorState::Hold);
  CHECK(m.sup.retry_pending());
  (void)m.drain();

  // No retry before the interval.
  SupervisorOutput out = m.step_for(config.replan_retry_interval_us - kCycleUs);
  CHECK(out.state == SupervisorState::Hold);
  CHECK_FALSE(out.transitioned);
  out = m.step();
  CHECK(out.state == SupervisorState::Replanning);
  CHECK(out.reason == TransitionReason::ReplanRetry);
  CHECK(out.plan_request == PlanRequest::Replan);
  CHECK(m.sup.retries_done() == 1);
  REQUIRE(m.step(occupied).state == SupervisorState::Hold);

  out = m.step_for(config.replan_retry_interval_us);
  CHECK(out.state == SupervisorState::Replanning);
  CHECK(m.sup.retries_done() == 2);
  REQUIRE(m.step(occupied).state == SupervisorState::Hold);

  // Retries spent: the goal is dropped, and the log says so.
  out = m.step_for(config.replan_retry_interval_us);
  CHECK(out.state == SupervisorState::Hold);
  CHECK(out.reason == TransitionReason::RetryLimitReached);
  CHECK_FALSE(m.sup.retry_pending());
  CHECK(m.step_for(5 * config.replan_retry_interval_us).state == SupervisorState::Hold);

  const auto log = m.drain();
  REQUIRE(log.size() == 5);
  CHECK(log[0].reason == TransitionReason::ReplanRetry);
  CHECK(log[0].value == 1);
  CHECK(detail(log[0]) == "retry 1");
  CHECK(log[2].reason == TransitionReason::ReplanRetry);
  CHECK(log[2].value == 2);
  CHECK(log[4].from == SupervisorState::Hold);
  CHECK(log[4].to == SupervisorState::Hold);
  CHECK(log[4].reason == TransitionReason::RetryLimitReached);
}

TEST_CASE("GoalOccupied then solved: the retry counter starts afresh", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Replanning);
  REQUIRE(m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::GoalOccupied; }).state ==
          SupervisorState::Hold);
  REQUIRE(m.step_for(test_config().replan_retry_interval_us).state == SupervisorState::Replanning);
  const SupervisorOutput out = m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::Solved; });
  CHECK(out.state == SupervisorState::Executing);
  CHECK(out.reason == TransitionReason::ReplanSolved);
  CHECK(m.sup.retries_done() == 0);
  CHECK_FALSE(m.sup.retry_pending());
}

TEST_CASE("a first plan refused for an obstacle is retried as a first plan", "[unit]") {
  for (const bool goal_covered : {true, false}) {
    CAPTURE(goal_covered);
    Machine m;
    drive_to(m, SupervisorState::Planning);
    const auto refused = [goal_covered](SupervisorInputs& in) {
      in.planner.status = goal_covered ? PlannerStatus::GoalOccupied : PlannerStatus::InvalidStart;
      in.planner.start_blocked = !goal_covered;
    };
    SupervisorOutput out = m.step(refused);
    REQUIRE(out.state == SupervisorState::Hold);
    CHECK(out.reason == (goal_covered ? TransitionReason::GoalOccupied : TransitionReason::StartBlocked));
    CHECK(m.sup.retry_pending());
    out = m.step_for(test_config().replan_retry_interval_us);
    CHECK(out.state == SupervisorState::Planning);
    CHECK(out.reason == TransitionReason::PlanRetry);
    CHECK(out.plan_request == PlanRequest::Plan);
    CHECK(m.sup.retries_done() == 1);
    out = m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::Solved; });
    CHECK(out.state == SupervisorState::Executing);
    CHECK(out.reason == TransitionReason::PlanSolved);
    CHECK(m.sup.retries_done() == 0);
    const auto log = m.drain();
    REQUIRE(log.size() >= 2);
    CHECK(detail(log[log.size() - 2]) == "retry 1");
  }
}

TEST_CASE("a new goal while a retry is pending replaces it", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Replanning);
  REQUIRE(m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::GoalOccupied; }).state ==
          SupervisorState::Hold);
  SupervisorOutput out = m.step([](SupervisorInputs& in) { in.commands.goal_request = true; });
  CHECK(out.state == SupervisorState::Planning);
  CHECK(out.plan_request == PlanRequest::Plan);
  CHECK_FALSE(m.sup.retry_pending());
  out = m.step([](SupervisorInputs& in) { in.planner.status = PlannerStatus::IterationLimit; });
  REQUIRE(out.state == SupervisorState::Hold);
  CHECK(m.step_for(3 * test_config().replan_retry_interval_us).state == SupervisorState::Hold);
}

TEST_CASE("time running backwards never fires a timeout early", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Planning);
  SupervisorInputs in = healthy(m.now_us - 500'000);
  CHECK(m.sup.update(in).state == SupervisorState::Planning);
  in.now_us = m.now_us + test_config().plan_timeout_us - kCycleUs;
  in.sensing.uwb_last_fix_us = in.now_us;
  CHECK(m.sup.update(in).state == SupervisorState::Planning);
}

namespace {

//! One cycle of the lift walk: the inputs' change, and what the supervisor must answer.
struct LiftStep {
  const char* what;
  std::function<void(SupervisorInputs&)> change;
  int cycles;  // the change held this many cycles; the expectations hold after each
  SupervisorState state;
  PlanRequest plan_request;  // on the first of the cycles
  bool motion_permitted;
  double speed_scale;
};

}  // namespace

TEST_CASE("a whole lift with an intrusion, a stop and a re-plan", "[scenario]") {
  const auto at = [](auto... fns) {
    return [=](SupervisorInputs& in) { (fns(in), ...); };
  };
  const auto pre_op = [](SupervisorInputs& in) {
    for (auto& j : in.sensing.joint) j = DeviceHealth::Stale;
    in.sensing.valve = ValveHealth::NotStarted;
  };
  const auto goal = [](SupervisorInputs& in) { in.commands.goal_request = true; };
  const auto running = [](SupervisorInputs& in) { in.planner.status = PlannerStatus::Running; };
  const auto solved = [](SupervisorInputs& in) { in.planner.status = PlannerStatus::Solved; };
  const auto warn = [](SupervisorInputs& in) {
    in.safety.stop_check = StopCheckStatus::Warning;
    in.safety.warning_speed_scale = 0.5;
  };
  const auto stop_zone = [](SupervisorInputs& in) { in.safety.stop_check = StopCheckStatus::Stop; };
  const auto braking = [](SupervisorInputs& in) {
    in.progress.at_rest = false;
    in.progress.command_at_rest = false;
  };
  const auto command_zero = [](SupervisorInputs& in) { in.progress.command_at_rest = true; };
  const auto occupied = [](SupervisorInputs& in) { in.planner.status = PlannerStatus::GoalOccupied; };
  const auto complete = [](SupervisorInputs& in) { in.progress.path_complete = true; };
  const auto nothing = [](SupervisorInputs&) {};

  const std::vector<LiftStep> walk = {
      {"power on: nodes pre-operational", pre_op, 3, SupervisorState::Init, PlanRequest::None, false, 0.0},
      {"nodes started, data flows", nothing, 1, SupervisorState::Hold, PlanRequest::None, false, 0.0},
      {"idle", nothing, 20, SupervisorState::Hold, PlanRequest::None, false, 0.0},
      {"operator requests the lift", goal, 1, SupervisorState::Planning, PlanRequest::Plan, false, 0.0},
      {"planner slices", running, 30, SupervisorState::Planning, PlanRequest::None, false, 0.0},
      {"plan solved", solved, 1, SupervisorState::Executing, PlanRequest::None, true, 1.0},
      {"swinging", braking, 200, SupervisorState::Executing, PlanRequest::None, true, 1.0},
      {"second crane swings near: warning", at(braking, warn), 50, SupervisorState::Executing, PlanRequest::None,
       true, 0.5},
      {"stop zone", at(braking, stop_zone), 1, SupervisorState::Stopping, PlanRequest::None, false, 0.0},
      {"braking", at(braking, stop_zone), 120, SupervisorState::Stopping, PlanRequest::None, false, 0.0},
      {"command zero, machine settling", at(braking, command_zero, stop_zone), 10, SupervisorState::Stopping,
       PlanRequest::None, false, 0.0},
      {"at rest: re-plan", stop_zone, 1, SupervisorState::Replanning, PlanRequest::Replan, false, 0.0},
      {"intruder parked on the goal", occupied, 1, SupervisorState::Hold, PlanRequest::None, false, 0.0},
      {"hold until the retry", nothing, 99, SupervisorState::Hold, PlanRequest::None, false, 0.0},
      {"retry", nothing, 1, SupervisorState::Replanning, PlanRequest::Replan, false, 0.0},
      {"repair slices", running, 15, SupervisorState::Replanning, PlanRequest::None, false, 0.0},
      {"repaired", solved, 1, SupervisorState::Executing, PlanRequest::None, true, 1.0},
      {"finishing the lift", braking, 300, SupervisorState::Executing, PlanRequest::None, true, 1.0},
      {"path complete, settling", at(braking, complete), 5, SupervisorState::Executing, PlanRequest::None, true, 1.0},
      {"goal reached", complete, 1, SupervisorState::Hold, PlanRequest::None, false, 0.0},
  };

  Machine m;
  for (const LiftStep& s : walk) {
    for (int c = 0; c < s.cycles; ++c) {
      const SupervisorOutput out = m.step(s.change);
      CAPTURE(s.what, c);
      REQUIRE(out.state == s.state);
      CHECK(out.plan_request == (c == 0 ? s.plan_request : PlanRequest::None));
      CHECK(out.motion_permitted == s.motion_permitted);
      CHECK(out.speed_scale == s.speed_scale);
    }
  }

  struct Expected {
    SupervisorState from, to;
    TransitionReason reason;
  };
  const std::vector<Expected> expected = {
      {SupervisorState::Init, SupervisorState::Hold, TransitionReason::StartupComplete},
      {SupervisorState::Hold, SupervisorState::Planning, TransitionReason::GoalRequested},
      {SupervisorState::Planning, SupervisorState::Executing, TransitionReason::PlanSolved},
      {SupervisorState::Executing, SupervisorState::Stopping, TransitionReason::SafetyStopZone},
      {SupervisorState::Stopping, SupervisorState::Replanning, TransitionReason::AtRestReplan},
      {SupervisorState::Replanning, SupervisorState::Hold, TransitionReason::GoalOccupied},
      {SupervisorState::Hold, SupervisorState::Replanning, TransitionReason::ReplanRetry},
      {SupervisorState::Replanning, SupervisorState::Executing, TransitionReason::ReplanSolved},
      {SupervisorState::Executing, SupervisorState::Hold, TransitionReason::GoalReached},
  };
  const auto log = m.drain();
  REQUIRE(log.size() == expected.size());
  for (std::size_t i = 0; i < log.size(); ++i) {
    CAPTURE(i);
    CHECK(log[i].from == expected[i].from);
    CHECK(log[i].to == expected[i].to);
    CHECK(log[i].reason == expected[i].reason);
    CHECK(log[i].sequence == i);
    if (i > 0) CHECK(log[i].t_us > log[i - 1].t_us);
  }
  CHECK(m.sup.log().overwritten() == 0);
}

TEST_CASE("the transition log counts what it overwrites and drains oldest first", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Hold);
  // ESTOP and back, 50 times: 100 transitions plus the start-up one, never drained.
  for (int i = 0; i < 50; ++i) {
    REQUIRE(m.step([](SupervisorInputs& in) { in.commands.stop = true; }).state == SupervisorState::Estop);
    REQUIRE(m.step([](SupervisorInputs& in) { in.commands.acknowledge = true; }).state == SupervisorState::Hold);
  }
  const std::size_t capacity = TransitionLog::kCapacity;
  CHECK(m.sup.log().size() == capacity);
  CHECK(m.sup.log().overwritten() == 101 - capacity);

  std::array<TransitionRecord, 10> chunk{};
  std::vector<TransitionRecord> all;
  while (true) {
    const std::size_t n = m.sup.log().drain(chunk);
    if (n == 0) break;
    all.insert(all.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(n));
  }
  REQUIRE(all.size() == capacity);
  // The newest survive, in order: the first kept one is the first not overwritten.
  CHECK(all.front().sequence == 101 - capacity);
  for (std::size_t i = 1; i < all.size(); ++i) CHECK(all[i].sequence == all[i - 1].sequence + 1);
  CHECK(all.back().reason == TransitionReason::OperatorAcknowledge);
  CHECK(m.sup.log().empty());
  TransitionRecord r;
  CHECK_FALSE(m.sup.log().pop(r));
  // Draining makes room again: nothing more is overwritten.
  REQUIRE(m.step([](SupervisorInputs& in) { in.commands.stop = true; }).state == SupervisorState::Estop);
  CHECK(m.sup.log().size() == 1);
  CHECK(m.sup.log().overwritten() == 101 - capacity);
}

TEST_CASE("a bad configuration is refused at construction, naming the field", "[unit]") {
  const auto message = [](const SupervisorConfig& c) {
    try {
      Supervisor s(c);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  SupervisorConfig c = test_config();
  c.num_joints = 0;
  CHECK(message(c).find("num_joints") != std::string::npos);
  c.num_joints = mgc::kMaxJoints + 1;
  CHECK(message(c).find("num_joints") != std::string::npos);
  c = test_config();
  c.stop_timeout_us = 0;
  CHECK(message(c).find("stop_timeout_us") != std::string::npos);
  c = test_config();
  c.max_replan_retries = -1;
  CHECK(message(c).find("max_replan_retries") != std::string::npos);
  CHECK(message(test_config()).empty());
}

TEST_CASE("names of states, reasons and outcomes", "[unit]") {
  CHECK(std::string(to_string(SupervisorState::Replanning)) == "REPLANNING");
  CHECK(std::string(to_string(TransitionReason::UwbSilent)) == "UwbSilent");
  CHECK(std::string(to_string(CommandOutcome::RejectedLatched)) == "RejectedLatched");
  CHECK(std::string(to_string(TransitionReason::EncoderImplausible)) == "EncoderImplausible");
  CHECK(std::string(to_string(TransitionReason::CutoffNotReady)) == "CutoffNotReady");
  CHECK(std::string(to_string(TransitionReason::PoseDisagrees)) == "PoseDisagrees");
  for (int r = 0; r <= static_cast<int>(TransitionReason::PoseDisagrees); ++r) {
    CAPTURE(r);
    CHECK(std::string(to_string(static_cast<TransitionReason>(r))) != "unknown");
    CHECK(std::strlen(to_string(static_cast<TransitionReason>(r))) < kTransitionDetailChars);
  }
}

TEST_CASE("an overload at the chart's rating exactly stops the lift only when the limiter holds a motion of the path", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Executing);
  // The limiter holds the moment-increasing motions at zero; a slew or a luff up goes on.
  SupervisorOutput out = m.step([](SupervisorInputs& in) {
    moving(in);
    in.safety.rcl_stage = RclStage::Overload;
    in.safety.rcl_cuts_path = false;
  });
  CHECK(out.state == SupervisorState::Executing);
  CHECK_FALSE(out.transitioned);
  // The path asks for a motion the limiter holds (or the load is over the chart): stop, re-plan.
  out = m.step([](SupervisorInputs& in) {
    moving(in);
    in.safety.rcl_stage = RclStage::Overload;
    in.safety.rcl_cuts_path = true;
  });
  CHECK(out.state == SupervisorState::Stopping);
  CHECK(out.reason == TransitionReason::RatedCapacityCut);
}

TEST_CASE("outside the chart stops the lift whatever the limiter cuts", "[unit]") {
  Machine m;
  drive_to(m, SupervisorState::Executing);
  const SupervisorOutput out = m.step([](SupervisorInputs& in) {
    moving(in);
    in.safety.rcl_stage = RclStage::OutsideChart;
    in.safety.rcl_cuts_path = false;
  });
  CHECK(out.state == SupervisorState::Stopping);
  CHECK(out.reason == TransitionReason::RatedCapacityCut);
}
