// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/supervisor.hpp"

#include <algorithm>
#include <utility>
#include <stdexcept>
#include <string>

namespace mgc::guidance {
namespace {

using planning::PlannerStatus;

//! Writes text, then " <index>" when index >= 0, truncated to the array, always NUL-terminated.
void write_detail(std::array<char, kTransitionDetailChars>& out, const char* text, std::int32_t index) noexcept {
  std::size_t n = 0;
  constexpr std::size_t kLast = kTransitionDetailChars - 1;
  for (const char* p = text; p != nullptr && *p != '\0' && n < kLast; ++p) out[n++] = *p;
  if (index >= 0 && n + 1 < kLast) {
    out[n++] = ' ';
    char digits[12];
    std::size_t d = 0;
    auto v = static_cast<std::uint32_t>(index);
    do {
      digits[d++] = static_cast<char>('0' + v % 10U);
      v /= 10U;
    } while (v != 0U);
    while (d > 0 && n < kLast) out[n++] = digits[--d];
  }
  out[n] = '\0';
}

//! The device a sensing reason names, for the detail text.
const char* device_text(TransitionReason reason) noexcept {
  switch (reason) {
    case TransitionReason::EncoderMissing:
    case TransitionReason::EncoderStale:
    case TransitionReason::EncoderFaulted: return "joint";
    case TransitionReason::ValveHeartbeatLost:
    case TransitionReason::ValveFailSafe:
    case TransitionReason::ValveFaulted:
    case TransitionReason::ValveNotActive:
    case TransitionReason::ValveStatusStale:
    case TransitionReason::ValveNotObeying: return "valve";
    case TransitionReason::EncoderStuck:
    case TransitionReason::EncoderImplausible:
    case TransitionReason::JointNotFollowing:
    case TransitionReason::JointRunaway:
    case TransitionReason::AngleDisagrees: return "joint";
    case TransitionReason::CutoffLost:
    case TransitionReason::CutoffFailed:
    case TransitionReason::CutoffNotReady: return "cut-off";
    case TransitionReason::BusOff: return "can bus";
    case TransitionReason::UwbGatewayLost: return "uwb gateway";
    case TransitionReason::UwbSilent: return "uwb tags";
    case TransitionReason::PoseDisagrees: return "uwb tag";
    case TransitionReason::WatchdogTripped: return "loop watchdog";
    default: return "";
  }
}

//! Short planner status names that fit the detail (planning's to_string is a sentence).
const char* planner_text(PlannerStatus status) noexcept {
  switch (status) {
    case PlannerStatus::Running: return "Running";
    case PlannerStatus::Solved: return "Solved";
    case PlannerStatus::InvalidStart: return "InvalidStart";
    case PlannerStatus::InvalidGoal: return "InvalidGoal";
    case PlannerStatus::IterationLimit: return "IterationLimit";
    case PlannerStatus::PoolExhausted: return "PoolExhausted";
    case PlannerStatus::NotReset: return "NotReset";
    case PlannerStatus::GoalOccupied: return "GoalOccupied";
  }
  return "unknown";
}

bool is_planner_failure(PlannerStatus status) noexcept {
  return status != PlannerStatus::Running && status != PlannerStatus::Solved;
}

TransitionReason valve_reason(ValveHealth valve) noexcept {
  switch (valve) {
    case ValveHealth::Missing: return TransitionReason::ValveHeartbeatLost;
    case ValveHealth::NotStarted: return TransitionReason::ValveNotActive;
    case ValveHealth::FailSafe: return TransitionReason::ValveFailSafe;
    case ValveHealth::Faulted: return TransitionReason::ValveFaulted;
    case ValveHealth::StatusStale: return TransitionReason::ValveStatusStale;
    case ValveHealth::Active: break;
  }
  return TransitionReason::None;
}

TransitionReason cutoff_reason(CutoffHealth cutoff) noexcept {
  switch (cutoff) {
    case CutoffHealth::Missing: return TransitionReason::CutoffLost;
    case CutoffHealth::Failed: return TransitionReason::CutoffFailed;
    case CutoffHealth::NotReady:
    case CutoffHealth::Cut: return TransitionReason::CutoffNotReady;
    case CutoffHealth::Ready: break;
  }
  return TransitionReason::None;
}

TransitionReason plausibility_reason(PlausibilityFault fault) noexcept {
  switch (fault) {
    case PlausibilityFault::None: break;
    case PlausibilityFault::EncoderOutOfRange:
    case PlausibilityFault::EncoderStep: return TransitionReason::EncoderImplausible;
    case PlausibilityFault::EncoderStuck: return TransitionReason::EncoderStuck;
    case PlausibilityFault::JointNotFollowing: return TransitionReason::JointNotFollowing;
    case PlausibilityFault::JointRunaway: return TransitionReason::JointRunaway;
    case PlausibilityFault::ValveNotObeying: return TransitionReason::ValveNotObeying;
    case PlausibilityFault::PoseDisagrees: return TransitionReason::PoseDisagrees;
    case PlausibilityFault::AngleDisagrees: return TransitionReason::AngleDisagrees;
  }
  return TransitionReason::None;
}

TransitionReason encoder_reason(DeviceHealth joint) noexcept {
  switch (joint) {
    case DeviceHealth::Missing: return TransitionReason::EncoderMissing;
    case DeviceHealth::Stale: return TransitionReason::EncoderStale;
    case DeviceHealth::Faulted: return TransitionReason::EncoderFaulted;
    case DeviceHealth::Alive: break;
  }
  return TransitionReason::None;
}

}  // namespace

const char* to_string(SupervisorState state) noexcept {
  switch (state) {
    case SupervisorState::Init: return "INIT";
    case SupervisorState::Hold: return "HOLD";
    case SupervisorState::Planning: return "PLANNING";
    case SupervisorState::Executing: return "EXECUTING";
    case SupervisorState::Stopping: return "STOPPING";
    case SupervisorState::Replanning: return "REPLANNING";
    case SupervisorState::Fault: return "FAULT";
    case SupervisorState::Estop: return "ESTOP";
  }
  return "unknown";
}

const char* to_string(TransitionReason reason) noexcept {
  switch (reason) {
    case TransitionReason::None: return "None";
    case TransitionReason::StartupComplete: return "StartupComplete";
    case TransitionReason::StartupTimeout: return "StartupTimeout";
    case TransitionReason::GoalRequested: return "GoalRequested";
    case TransitionReason::PlanSolved: return "PlanSolved";
    case TransitionReason::PlanFailed: return "PlanFailed";
    case TransitionReason::PlanTimeout: return "PlanTimeout";
    case TransitionReason::GoalReached: return "GoalReached";
    case TransitionReason::SafetyStopZone: return "SafetyStopZone";
    case TransitionReason::SafetyCheckError: return "SafetyCheckError";
    case TransitionReason::EnvelopeViolated: return "EnvelopeViolated";
    case TransitionReason::RatedCapacityCut: return "RatedCapacityCut";
    case TransitionReason::AtRestReplan: return "AtRestReplan";
    case TransitionReason::ReplanSolved: return "ReplanSolved";
    case TransitionReason::ReplanFailed: return "ReplanFailed";
    case TransitionReason::GoalOccupied: return "GoalOccupied";
    case TransitionReason::ReplanRetry: return "ReplanRetry";
    case TransitionReason::RetryLimitReached: return "RetryLimitReached";
    case TransitionReason::StopTimeout: return "StopTimeout";
    case TransitionReason::OperatorStop: return "OperatorStop";
    case TransitionReason::OperatorAcknowledge: return "OperatorAcknowledge";
    case TransitionReason::EncoderMissing: return "EncoderMissing";
    case TransitionReason::EncoderStale: return "EncoderStale";
    case TransitionReason::EncoderFaulted: return "EncoderFaulted";
    case TransitionReason::ValveHeartbeatLost: return "ValveHeartbeatLost";
    case TransitionReason::ValveFailSafe: return "ValveFailSafe";
    case TransitionReason::ValveFaulted: return "ValveFaulted";
    case TransitionReason::ValveNotActive: return "ValveNotActive";
    case TransitionReason::ValveStatusStale: return "ValveStatusStale";
    case TransitionReason::BusOff: return "BusOff";
    case TransitionReason::UwbGatewayLost: return "UwbGatewayLost";
    case TransitionReason::UwbSilent: return "UwbSilent";
    case TransitionReason::WatchdogTripped: return "WatchdogTripped";
    case TransitionReason::StartBlocked: return "StartBlocked";
    case TransitionReason::EncoderStuck: return "EncoderStuck";
    case TransitionReason::EncoderImplausible: return "EncoderImplausible";
    case TransitionReason::JointNotFollowing: return "JointNotFollowing";
    case TransitionReason::JointRunaway: return "JointRunaway";
    case TransitionReason::ValveNotObeying: return "ValveNotObeying";
    case TransitionReason::CutoffLost: return "CutoffLost";
    case TransitionReason::CutoffFailed: return "CutoffFailed";
    case TransitionReason::CutoffNotReady: return "CutoffNotReady";
    case TransitionReason::PoseDisagrees: return "PoseDisagrees";
    case TransitionReason::AngleDisagrees: return "AngleDisagrees";
    case TransitionReason::PlanRetry: return "PlanRetry";
  }
  return "unknown";
}

const char* to_string(CommandOutcome outcome) noexcept {
  switch (outcome) {
    case CommandOutcome::None: return "None";
    case CommandOutcome::Accepted: return "Accepted";
    case CommandOutcome::RejectedBusy: return "RejectedBusy";
    case CommandOutcome::RejectedLatched: return "RejectedLatched";
    case CommandOutcome::RejectedCauseActive: return "RejectedCauseActive";
    case CommandOutcome::RejectedNothingToAcknowledge: return "RejectedNothingToAcknowledge";
  }
  return "unknown";
}

// --- TransitionLog ---------------------------------------------------------------------------

void TransitionLog::push(const TransitionRecord& record) noexcept {
  if (size_ == kCapacity) {
    // Full: the oldest record gives way, and the count says so.
    ring_[head_] = record;
    head_ = (head_ + 1) % kCapacity;
    ++overwritten_;
    return;
  }
  ring_[(head_ + size_) % kCapacity] = record;
  ++size_;
}

bool TransitionLog::pop(TransitionRecord& out) noexcept {
  if (size_ == 0) return false;
  out = ring_[head_];
  head_ = (head_ + 1) % kCapacity;
  --size_;
  return true;
}

std::size_t TransitionLog::drain(std::span<TransitionRecord> out) noexcept {
  std::size_t n = 0;
  while (n < out.size() && pop(out[n])) ++n;
  return n;
}

// --- Supervisor ------------------------------------------------------------------------------

Supervisor::Supervisor(const SupervisorConfig& config) : config_(config) {
  const auto fail = [](const char* field, const std::string& expected) {
    std::string message = "SupervisorConfig.";
    message += field;
    message += ": expected ";
    message += expected;
    throw std::invalid_argument(message);
  };
  if (config.num_joints < 1 || config.num_joints > kMaxJoints) {
    fail("num_joints", "1.." + std::to_string(kMaxJoints) + ", got " + std::to_string(config.num_joints));
  }
  const std::pair<const char*, std::int64_t> timeouts[] = {
      {"uwb_silence_timeout_us", config.uwb_silence_timeout_us},
      {"init_timeout_us", config.init_timeout_us},
      {"nmt_start_retry_us", config.nmt_start_retry_us},
      {"stop_timeout_us", config.stop_timeout_us},
      {"plan_timeout_us", config.plan_timeout_us},
      {"replan_retry_interval_us", config.replan_retry_interval_us},
  };
  for (const auto& [field, value] : timeouts) {
    if (value <= 0) fail(field, "> 0 us, got " + std::to_string(value));
  }
  if (config.max_replan_retries < 0) {
    fail("max_replan_retries", ">= 0, got " + std::to_string(config.max_replan_retries));
  }
}

Supervisor::Cause Supervisor::running_fault(const SupervisorInputs& in) const noexcept {
  const SensingInputs& s = in.sensing;
  // Bus-off first: it explains every other loss at once.
  if (s.bus_off) return {TransitionReason::BusOff, -1};
  if (const TransitionReason r = valve_reason(s.valve); r != TransitionReason::None) return {r, -1};
  if (const TransitionReason r = cutoff_reason(s.cutoff); r != TransitionReason::None) return {r, -1};
  for (int j = 0; j < config_.num_joints; ++j) {
    const TransitionReason r = encoder_reason(s.joint[static_cast<std::size_t>(j)]);
    if (r != TransitionReason::None) return {r, j};
  }
  if (const TransitionReason r = plausibility_reason(s.plausibility); r != TransitionReason::None) {
    return {r, s.plausibility_joint};
  }
  if (config_.uwb_required) {
    if (s.uwb_gateway != DeviceHealth::Alive) return {TransitionReason::UwbGatewayLost, -1};
    if (s.uwb_last_fix_us <= 0 || in.now_us - s.uwb_last_fix_us > config_.uwb_silence_timeout_us) {
      return {TransitionReason::UwbSilent, -1};
    }
  }
  if (in.watchdog_tripped) return {TransitionReason::WatchdogTripped, -1};
  return {};
}

Supervisor::Cause Supervisor::ack_blocker(const SupervisorInputs& in) const noexcept {
  // Recovery goes through INIT, which restarts the nodes and checks their data: here only what a
  // restart cannot clear blocks the acknowledgement (no communication, a device's own fault).
  const SensingInputs& s = in.sensing;
  if (s.bus_off) return {TransitionReason::BusOff, -1};
  if (s.valve == ValveHealth::Missing) return {TransitionReason::ValveHeartbeatLost, -1};
  if (s.valve == ValveHealth::Faulted) return {TransitionReason::ValveFaulted, -1};
  // A cut-off that does not cut must be repaired first: with it the machine has one channel left.
  if (s.cutoff == CutoffHealth::Missing) return {TransitionReason::CutoffLost, -1};
  if (s.cutoff == CutoffHealth::Failed) return {TransitionReason::CutoffFailed, -1};
  for (int j = 0; j < config_.num_joints; ++j) {
    const DeviceHealth h = s.joint[static_cast<std::size_t>(j)];
    if (h == DeviceHealth::Missing) return {TransitionReason::EncoderMissing, j};
    if (h == DeviceHealth::Faulted) return {TransitionReason::EncoderFaulted, j};
  }
  if (config_.uwb_required && (s.uwb_gateway == DeviceHealth::Missing || s.uwb_gateway == DeviceHealth::Faulted)) {
    return {TransitionReason::UwbGatewayLost, -1};
  }
  return {};
}

Supervisor::Cause Supervisor::init_blocker(const SupervisorInputs& in) const noexcept {
  // Every device alive is exactly "no running fault".
  return running_fault(in);
}

bool Supervisor::all_nodes_heard(const SupervisorInputs& in) const noexcept {
  const SensingInputs& s = in.sensing;
  if (s.bus_off || s.valve == ValveHealth::Missing || s.cutoff == CutoffHealth::Missing) return false;
  for (int j = 0; j < config_.num_joints; ++j) {
    if (s.joint[static_cast<std::size_t>(j)] == DeviceHealth::Missing) return false;
  }
  return !config_.uwb_required || s.uwb_gateway != DeviceHealth::Missing;
}

void Supervisor::transition(SupervisorState to, TransitionReason reason, std::int32_t value, std::int64_t now_us,
                            SupervisorOutput& out, const char* detail) noexcept {
  TransitionRecord record;
  record.sequence = next_sequence_++;
  record.t_us = now_us;
  record.from = state_;
  record.to = to;
  record.reason = reason;
  record.value = value;
  switch (detail != nullptr ? TransitionReason::None : reason) {
    case TransitionReason::None:
      write_detail(record.detail, detail, value);
      break;
    case TransitionReason::PlanFailed:
    case TransitionReason::ReplanFailed:
    case TransitionReason::GoalOccupied:
    case TransitionReason::StartBlocked:
      // value is the planner status code: name it instead of a number.
      write_detail(record.detail, planner_text(static_cast<PlannerStatus>(value)), -1);
      break;
    case TransitionReason::ReplanRetry:
    case TransitionReason::PlanRetry:
      write_detail(record.detail, "retry", value);
      break;
    default:
      write_detail(record.detail, device_text(reason), value);
      break;
  }
  log_.push(record);

  if (to != state_) entered_us_ = now_us;
  state_ = to;
  reason_ = reason;
  fault_value_ = value;
  out.transitioned = true;
}

SupervisorOutput Supervisor::update(const SupervisorInputs& in) noexcept {
  if (!clock_started_) {
    // The time of the first update is the start of INIT (time is never read here).
    entered_us_ = in.now_us;
    clock_started_ = true;
  }
  SupervisorOutput out;
  const OperatorCommands& cmd = in.commands;

  if (cmd.stop) {
    // Obeyed from every state. FAULT is already a latched stop with a stricter recovery: it stays.
    out.stop_outcome = CommandOutcome::Accepted;
    if (state_ != SupervisorState::Fault && state_ != SupervisorState::Estop) {
      transition(SupervisorState::Estop, TransitionReason::OperatorStop, -1, in.now_us, out);
      stopping_to_fault_ = false;
      retry_pending_ = false;
    }
    // Whatever else came with the stop waits for the operator to send it again.
    if (cmd.goal_request) out.goal_outcome = CommandOutcome::RejectedBusy;
    if (cmd.acknowledge) out.acknowledge_outcome = CommandOutcome::RejectedBusy;
  } else {
    step_state(in, out);
  }

  if (cmd.goal_request && out.goal_outcome == CommandOutcome::None) {
    const bool latched = state_ == SupervisorState::Fault || state_ == SupervisorState::Estop;
    out.goal_outcome = latched ? CommandOutcome::RejectedLatched : CommandOutcome::RejectedBusy;
  }
  if (cmd.acknowledge && out.acknowledge_outcome == CommandOutcome::None) {
    out.acknowledge_outcome = CommandOutcome::RejectedNothingToAcknowledge;
  }

  out.state = state_;
  out.reason = reason_;
  out.motion_permitted = state_ == SupervisorState::Executing;
  out.controlled_stop = state_ == SupervisorState::Stopping || state_ == SupervisorState::Fault ||
                        state_ == SupervisorState::Estop;
  if (state_ == SupervisorState::Executing) {
    switch (in.safety.stop_check) {
      case StopCheckStatus::Clear: out.speed_scale = 1.0; break;
      case StopCheckStatus::Warning: {
        // NaN fails both comparisons and so ends at 0, the safe side.
        const double s = in.safety.warning_speed_scale;
        out.speed_scale = s >= 0.0 && s <= 1.0 ? s : (s > 1.0 ? 1.0 : 0.0);
        break;
      }
      case StopCheckStatus::Stop:
      case StopCheckStatus::ErrorInput: out.speed_scale = 0.0; break;
    }
  }
  return out;
}

void Supervisor::step_state(const SupervisorInputs& in, SupervisorOutput& out) noexcept {
  const std::int64_t now = in.now_us;
  // Time that runs backwards is read as no time passed: timeouts only ever fire late, never early.
  const std::int64_t elapsed_us = std::max<std::int64_t>(0, now - entered_us_);
  const OperatorCommands& cmd = in.commands;
  const PlannerStatus planner = in.planner.status;
  const ProgressInputs& progress = in.progress;

  switch (state_) {
    case SupervisorState::Init: {
      if (in.watchdog_tripped) {
        transition(SupervisorState::Fault, TransitionReason::WatchdogTripped, -1, now, out);
        return;
      }
      const Cause blocker = init_blocker(in);
      if (blocker.reason == TransitionReason::None) {
        transition(SupervisorState::Hold, TransitionReason::StartupComplete, -1, now, out);
        return;
      }
      if (elapsed_us >= config_.init_timeout_us) {
        // The detail names what was still not alive ("EncoderStale 2"); value is its joint.
        transition(SupervisorState::Fault, TransitionReason::StartupTimeout, blocker.joint, now, out,
                   to_string(blocker.reason));
        return;
      }
      if (all_nodes_heard(in) && (!nmt_started_ || now - last_nmt_start_us_ >= config_.nmt_start_retry_us)) {
        out.start_nodes = true;
        nmt_started_ = true;
        last_nmt_start_us_ = now;
      }
      return;
    }

    case SupervisorState::Hold: {
      if (const Cause c = running_fault(in); c.reason != TransitionReason::None) {
        transition(SupervisorState::Fault, c.reason, c.joint, now, out);
        return;
      }
      if (cmd.goal_request) {
        out.goal_outcome = CommandOutcome::Accepted;
        retry_pending_ = false;
        retries_done_ = 0;
        out.plan_request = PlanRequest::Plan;
        transition(SupervisorState::Planning, TransitionReason::GoalRequested, -1, now, out);
        return;
      }
      if (retry_pending_ && now >= next_retry_us_) {
        if (retries_done_ < config_.max_replan_retries) {
          ++retries_done_;
          if (retry_first_plan_) {
            out.plan_request = PlanRequest::Plan;
            transition(SupervisorState::Planning, TransitionReason::PlanRetry, retries_done_, now, out);
          } else {
            out.plan_request = PlanRequest::Replan;
            transition(SupervisorState::Replanning, TransitionReason::ReplanRetry, retries_done_, now, out);
          }
        } else {
          retry_pending_ = false;
          transition(SupervisorState::Hold, TransitionReason::RetryLimitReached, retries_done_, now, out);
          retries_done_ = 0;
        }
      }
      return;
    }

    case SupervisorState::Planning:
    case SupervisorState::Replanning: {
      if (const Cause c = running_fault(in); c.reason != TransitionReason::None) {
        transition(SupervisorState::Fault, c.reason, c.joint, now, out);
        return;
      }
      const bool repair = state_ == SupervisorState::Replanning;
      if (planner == PlannerStatus::Solved) {
        retry_pending_ = false;
        retries_done_ = 0;
        transition(SupervisorState::Executing, repair ? TransitionReason::ReplanSolved : TransitionReason::PlanSolved,
                   -1, now, out);
      } else if (planner == PlannerStatus::GoalOccupied ||
                 (planner == PlannerStatus::InvalidStart && (repair || in.planner.start_blocked))) {
        // The obstacle may move off the goal, or away from where the machine stopped: hold at
        // rest and ask again later.
        retry_pending_ = true;
        retry_first_plan_ = !repair;
        next_retry_us_ = now + config_.replan_retry_interval_us;
        transition(SupervisorState::Hold,
                   planner == PlannerStatus::GoalOccupied ? TransitionReason::GoalOccupied : TransitionReason::StartBlocked,
                   static_cast<std::int32_t>(planner), now, out);
      } else if (is_planner_failure(planner)) {
        retry_pending_ = false;
        retries_done_ = 0;
        transition(SupervisorState::Hold, repair ? TransitionReason::ReplanFailed : TransitionReason::PlanFailed,
                   static_cast<std::int32_t>(planner), now, out);
      } else if (elapsed_us >= config_.plan_timeout_us) {
        retry_pending_ = false;
        retries_done_ = 0;
        transition(SupervisorState::Hold, TransitionReason::PlanTimeout, -1, now, out);
      }
      return;
    }

    case SupervisorState::Executing: {
      if (const Cause c = running_fault(in); c.reason != TransitionReason::None) {
        // Moving: stop under control first, then FAULT (the stop's end is judged by the command,
        // since the measurement may be what was lost).
        stopping_to_fault_ = true;
        transition(SupervisorState::Stopping, c.reason, c.joint, now, out);
        return;
      }
      TransitionReason stop = TransitionReason::None;
      if (in.safety.stop_check == StopCheckStatus::Stop) {
        stop = TransitionReason::SafetyStopZone;
      } else if (in.safety.stop_check == StopCheckStatus::ErrorInput) {
        stop = TransitionReason::SafetyCheckError;
      } else if (in.safety.envelope_violated) {
        stop = TransitionReason::EnvelopeViolated;
      } else if ((in.safety.rcl_stage == RclStage::Overload && in.safety.rcl_cuts_path) || in.safety.rcl_stage == RclStage::OutsideChart) {
        stop = TransitionReason::RatedCapacityCut;
      }
      if (stop != TransitionReason::None) {
        stopping_to_fault_ = false;
        transition(SupervisorState::Stopping, stop, -1, now, out);
        return;
      }
      if (progress.path_complete && progress.at_rest) {
        transition(SupervisorState::Hold, TransitionReason::GoalReached, -1, now, out);
      }
      return;
    }

    case SupervisorState::Stopping: {
      if (!stopping_to_fault_) {
        if (const Cause c = running_fault(in); c.reason != TransitionReason::None) {
          // A safety stop becomes a stop toward FAULT: same state, new meaning, logged. The stop
          // timeout keeps counting from the start of the stop.
          stopping_to_fault_ = true;
          transition(SupervisorState::Stopping, c.reason, c.joint, now, out);
          return;
        }
      }
      if (stopping_to_fault_) {
        if (progress.command_at_rest || elapsed_us >= config_.stop_timeout_us) {
          stopping_to_fault_ = false;
          transition(SupervisorState::Fault, reason_, fault_value_, now, out);
        }
        return;
      }
      if (progress.at_rest && progress.command_at_rest) {
        out.plan_request = PlanRequest::Replan;
        transition(SupervisorState::Replanning, TransitionReason::AtRestReplan, -1, now, out);
      } else if (elapsed_us >= config_.stop_timeout_us) {
        transition(SupervisorState::Fault, TransitionReason::StopTimeout, -1, now, out);
      }
      return;
    }

    case SupervisorState::Fault: {
      if (!cmd.acknowledge) return;
      const Cause blocker = ack_blocker(in);
      if (blocker.reason != TransitionReason::None || !progress.command_at_rest) {
        out.acknowledge_outcome = CommandOutcome::RejectedCauseActive;
        out.ack_blocker = blocker.reason;
        return;
      }
      out.acknowledge_outcome = CommandOutcome::Accepted;
      out.reset_latches = true;
      nmt_started_ = false;
      transition(SupervisorState::Init, TransitionReason::OperatorAcknowledge, -1, now, out);
      return;
    }

    case SupervisorState::Estop: {
      if (const Cause c = running_fault(in); c.reason != TransitionReason::None) {
        // The stop is already commanded; FAULT keeps commanding it and names the cause.
        transition(SupervisorState::Fault, c.reason, c.joint, now, out);
        if (cmd.acknowledge) {
          out.acknowledge_outcome = CommandOutcome::RejectedCauseActive;
          out.ack_blocker = c.reason;
        }
        return;
      }
      if (!cmd.acknowledge) return;
      if (!progress.at_rest || !progress.command_at_rest) {
        out.acknowledge_outcome = CommandOutcome::RejectedCauseActive;
        return;
      }
      out.acknowledge_outcome = CommandOutcome::Accepted;
      transition(SupervisorState::Hold, TransitionReason::OperatorAcknowledge, -1, now, out);
      return;
    }
  }
}

}  // namespace mgc::guidance
