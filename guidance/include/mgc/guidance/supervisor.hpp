// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mgc/guidance/diagnostics.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/guidance/safety.hpp"
#include "mgc/limits.hpp"
#include "mgc/planning/planners/planner.hpp"

//! The supervisor state machine of the control loop (docs/supervisor.md): which mode the machine
//! is in, whether it may move, and what the loop must do about planning and stopping. One update()
//! per cycle on a flat input struct with the time passed in; every transition is logged with its
//! reason into a fixed-capacity ring.
namespace mgc::guidance {

enum class SupervisorState : std::uint8_t {
  Init = 0,    //!< start-up: waiting for every device, starting the nodes
  Hold,        //!< at rest, ready for a goal (or waiting to retry a re-plan)
  Planning,    //!< the planner runs toward the operator's goal; no motion
  Executing,   //!< following the plan; the only state that permits motion
  Stopping,    //!< a controlled stop is under way (safety stop zone, or on the way to FAULT)
  Replanning,  //!< at rest after a safety stop; the re-planner repairs the path
  Fault,       //!< latched: loss of sensing, watchdog, stop timeout; needs an operator acknowledgement
  Estop,       //!< latched: operator stop; needs an operator acknowledgement
};
inline constexpr std::size_t kSupervisorStateCount = 8;
[[nodiscard]] const char* to_string(SupervisorState state) noexcept;

//! Why a transition happened. The values are stable (they go into logs).
enum class TransitionReason : std::uint8_t {
  None = 0,              //!< no transition yet (the initial state)
  StartupComplete,       //!< INIT -> HOLD: every device alive
  StartupTimeout,        //!< INIT -> FAULT: a device not alive within init_timeout_us
  GoalRequested,         //!< HOLD -> PLANNING
  PlanSolved,            //!< PLANNING -> EXECUTING
  PlanFailed,            //!< PLANNING -> HOLD (value: the PlannerStatus)
  PlanTimeout,           //!< PLANNING/REPLANNING -> HOLD after plan_timeout_us
  GoalReached,           //!< EXECUTING -> HOLD: path complete and at rest
  SafetyStopZone,        //!< EXECUTING -> STOPPING: the stop check said Stop
  SafetyCheckError,      //!< EXECUTING -> STOPPING: the stop check refused its input (treated as Stop)
  EnvelopeViolated,      //!< EXECUTING -> STOPPING: a monitored point is outside the envelope
  RatedCapacityCut,      //!< EXECUTING -> STOPPING: load chart overload or outside the chart
  AtRestReplan,          //!< STOPPING -> REPLANNING: at rest after a safety stop
  ReplanSolved,          //!< REPLANNING -> EXECUTING
  ReplanFailed,          //!< REPLANNING -> HOLD (value: the PlannerStatus), goal dropped
  GoalOccupied,          //!< PLANNING/REPLANNING -> HOLD: an obstacle covers the goal; a retry is scheduled
  ReplanRetry,           //!< HOLD -> REPLANNING: scheduled retry of a repair after GoalOccupied or StartBlocked
  RetryLimitReached,     //!< HOLD -> HOLD: the retries ran out, goal dropped
  StopTimeout,           //!< STOPPING -> FAULT: not at rest within stop_timeout_us
  OperatorStop,          //!< any state but FAULT -> ESTOP
  OperatorAcknowledge,   //!< FAULT -> INIT, ESTOP -> HOLD
  // Loss of sensing and loop faults: -> STOPPING (when moving), then -> FAULT with the same reason.
  EncoderMissing,        //!< an encoder's heartbeat is lost (value: joint)
  EncoderStale,          //!< an encoder's heartbeat is fresh but its position is stale (value: joint)
  EncoderFaulted,        //!< an encoder reports a fault: EMCY or alarm bit (value: joint)
  ValveHeartbeatLost,    //!< the valve node's heartbeat is lost
  ValveFailSafe,         //!< the valve node neutralised its spools on its own (it lost the controller)
  ValveFaulted,          //!< the valve node reports a fault: EMCY, internal fault, a joint fault bit
  ValveNotActive,        //!< the valve node left Active (disabled, e.g. rebooted) while in use
  BusOff,                //!< the CAN controller is bus-off: every device is lost
  UwbGatewayLost,        //!< the UWB gateway's heartbeat is lost (or it reports a fault)
  UwbSilent,             //!< no tag fix for uwb_silence_timeout_us
  WatchdogTripped,       //!< the cyclic executive's watchdog latched (repeated deadline misses)
  //! REPLANNING -> HOLD: the repair refused where the machine stopped (InvalidStart), e.g. inside
  //! the margin the planner keeps from a moving obstacle; a retry is scheduled as for GoalOccupied.
  //! PLANNING -> HOLD the same, for a first plan whose start a dynamic obstacle blocks.
  StartBlocked,
  //! The valve node's heartbeat says Operational, but its status frames stopped (or the bus holds
  //! them back): whether it still follows the commands is unknown. A loss of sensing.
  ValveStatusStale,
  // Plausibility (guidance::PlausibilityMonitor): devices that talk but cannot be believed.
  EncoderStuck,          //!< an encoder repeats its value while the joint must be moving (value: joint)
  EncoderImplausible,    //!< an encoder value beyond the end stops, or a step no actuator can make (value: joint)
  JointNotFollowing,     //!< a joint moves less than its command allows (value: joint)
  JointRunaway,          //!< a joint moves more than its command allows; pilot pressure is cut (value: joint)
  ValveNotObeying,       //!< the valve's spools or counter do not follow the commands; pilot cut (value: joint, -1: counter)
  // The second shut-off channel (the pilot-pressure cut-off node).
  CutoffLost,            //!< the cut-off node's heartbeat is lost
  CutoffFailed,          //!< it reports a fault, or pilot pressure while it holds the pilot cut
  CutoffNotReady,        //!< no pilot pressure while the machine is in use (not enabled, or it cut on its own)
  //! A tag on the machine disagrees with forward kinematics of the encoders (MachineTagCheck):
  //! one of the encoders it sees is stuck or lies (value: the tag id).
  PoseDisagrees,
  //! The boom inclinometer disagrees with the boom's encoder (InclinometerCheck): one of the two
  //! is stuck or lies (value: the joint).
  AngleDisagrees,
  //! HOLD -> PLANNING: scheduled retry of a first plan after GoalOccupied or StartBlocked (value:
  //! the retry number).
  PlanRetry,
};
[[nodiscard]] const char* to_string(TransitionReason reason) noexcept;

//! Health of a device or of its data, as the Hal reports it (same values and meaning as
//! hal::Health; guidance does not include hal). Zero is Missing, so an input nobody filled in is
//! a fault, never silently healthy.
enum class DeviceHealth : std::uint8_t {
  Missing = 0,  //!< never heard, or heartbeat older than the consumer timeout
  Alive,        //!< heartbeat and data fresh, no fault
  Stale,        //!< heartbeat fresh, data older than the stale limit (or none yet)
  Faulted,      //!< the device reports a fault
};

//! The valve node as the loop sees it (docs/supervisor.md maps the Hal's snapshot onto it).
enum class ValveHealth : std::uint8_t {
  Missing = 0,  //!< heartbeat lost or never heard
  NotStarted,   //!< heartbeat fresh, status Disabled (pre-operational) or no fresh status frame
  Active,       //!< SensorSnapshot::valve_active(): following commands
  FailSafe,     //!< status FailSafe: it neutralised after losing the controller; a restart clears it
  Faulted,      //!< EMCY other than its fail-safe ones, status Fault, or a joint fault bit
  StatusStale,  //!< heartbeat fresh and Operational, but no status frame within the stale limit after earlier ones
};

//! The pilot-pressure cut-off (the second shut-off channel) as the loop sees it.
enum class CutoffHealth : std::uint8_t {
  Missing = 0,  //!< heartbeat lost or never heard
  NotReady,     //!< heartbeat fresh, no fresh status frame (not started, or its reports stopped)
  Ready,        //!< enabled, and its pressure switch reports pilot pressure
  Cut,          //!< no pilot pressure: the machine cannot move
  Failed,       //!< a fault of its own, or pilot pressure although it holds the pilot cut
};

//! Sensing health for one cycle, from the Hal's SensorSnapshot.
struct SensingInputs {
  std::array<DeviceHealth, kMaxJoints> joint{};  //!< JointReading::health per joint (encoder node and data)
  ValveHealth valve = ValveHealth::Missing;
  bool bus_off = false;                          //!< SensorSnapshot::bus_state == BusOff
  DeviceHealth uwb_gateway = DeviceHealth::Missing;  //!< the gateway node's health
  std::int64_t uwb_last_fix_us = 0;              //!< newest tag fix receive time; 0 = none yet [µs]
  CutoffHealth cutoff = CutoffHealth::Missing;
  //! The latched finding of the plausibility monitor (None: none) and the joint it names.
  PlausibilityFault plausibility = PlausibilityFault::None;
  int plausibility_joint = -1;
};

//! The safety functions' verdict for this cycle.
struct SafetyInputs {
  StopCheckStatus stop_check = StopCheckStatus::Clear;  //!< StopCheckResult::status
  double warning_speed_scale = 1.0;  //!< StopCheckResult::speed_scale, used in Warning [0, 1]
  bool envelope_violated = false;    //!< EnvelopeResult::violated
  RclStage rcl_stage = RclStage::Normal;  //!< RatedCapacityResult::stage (cranes; Normal otherwise)
  //! In `Overload`: the load is over the chart, or the limiter cuts a motion the path commands. At
  //! the chart's rating exactly, the planner's boundary, the motions that keep or lower the load
  //! moment go on while the limiter holds the others at zero; only a cut that would stall the path
  //! (or a load over the chart) stops the lift.
  bool rcl_cuts_path = true;
};

//! Operator commands that arrived this cycle, already authenticated upstream (command_auth.hpp).
struct OperatorCommands {
  bool stop = false;          //!< a STOP from anyone
  bool goal_request = false;  //!< an authenticated GOAL; the loop keeps its goal configuration
  bool acknowledge = false;   //!< an authenticated ACKNOWLEDGE with alert_id 0 (all)
};

//! The planner's state for the query the loop ran this cycle (first plan or repair).
struct PlannerInputs {
  planning::PlannerStatus status = planning::PlannerStatus::Running;
  //! A dynamic obstacle stood within the planner's margin of the machine when the query began: an
  //! InvalidStart of a first plan is then one that time may cure, as after a safety stop.
  bool start_blocked = false;
};

//! Where the machine and its command stand.
struct ProgressInputs {
  bool at_rest = false;          //!< measured: every joint's velocity estimate is below the rest threshold
  bool command_at_rest = false;  //!< the rate-limited command is zero on every joint
  bool path_complete = false;    //!< the trajectory reached the end of the plan
};

//! Everything the supervisor reads in one cycle. Plain data.
struct SupervisorInputs {
  std::int64_t now_us = 0;  //!< the cycle's time, monotonic [µs]
  SensingInputs sensing{};
  SafetyInputs safety{};
  OperatorCommands commands{};
  PlannerInputs planner{};
  ProgressInputs progress{};
  bool watchdog_tripped = false;  //!< CyclicExecutive::watchdog_tripped()
};

//! What the supervisor did with an operator command.
enum class CommandOutcome : std::uint8_t {
  None = 0,        //!< no such command this cycle
  Accepted,        //!< it caused the transition (or, for a stop in FAULT, the stop is already latched)
  RejectedBusy,    //!< goal outside HOLD, or together with a stop: stop first / send again in HOLD
  RejectedLatched, //!< goal in FAULT or ESTOP: acknowledge first
  RejectedCauseActive,  //!< acknowledge while the cause is still there (detail in ack_blocker)
  RejectedNothingToAcknowledge,  //!< acknowledge outside FAULT and ESTOP
};
[[nodiscard]] const char* to_string(CommandOutcome outcome) noexcept;

//! What the loop asks the planner to do this cycle (issued once, on entering the state).
enum class PlanRequest : std::uint8_t {
  None = 0,
  Plan,    //!< Planner/Replanner reset() toward the goal the operator requested, from the current state
  Replan,  //!< Replanner::replan() from where the machine stopped
};

struct SupervisorOutput {
  SupervisorState state = SupervisorState::Init;
  bool motion_permitted = false;  //!< EXECUTING only; otherwise the loop commands zero velocity
  //! Scale of the commanded speed: 1 in EXECUTING, the warning scale when the stop check warns, 0 in
  //! every other state. [0, 1]
  double speed_scale = 0.0;
  //! STOPPING, FAULT, ESTOP: the loop brings the command to zero at the deceleration limit
  //! (RateLimiter::stop) and abandons the trajectory.
  bool controlled_stop = false;
  PlanRequest plan_request = PlanRequest::None;
  bool start_nodes = false;       //!< INIT: send NMT start to all nodes now
  bool reset_latches = false;     //!< an acknowledgement was accepted: reset the watchdog
  bool transitioned = false;      //!< a transition was logged this cycle
  TransitionReason reason = TransitionReason::None;  //!< of the transition into the current state
  CommandOutcome stop_outcome = CommandOutcome::None;
  CommandOutcome goal_outcome = CommandOutcome::None;
  CommandOutcome acknowledge_outcome = CommandOutcome::None;
  //! RejectedCauseActive: what still blocks recovery (a sensing reason, or None for "not at rest").
  TransitionReason ack_blocker = TransitionReason::None;
};

inline constexpr std::size_t kTransitionDetailChars = 24;  //!< detail text, NUL included [chars]

//! One logged transition. from == to marks a change of meaning without a change of state (a
//! safety stop that becomes a stop toward FAULT, a dropped retry in HOLD).
struct TransitionRecord {
  std::uint64_t sequence = 0;  //!< 0, 1, 2, ... over the supervisor's life: a gap shows overwritten entries
  std::int64_t t_us = 0;       //!< [µs]
  SupervisorState from = SupervisorState::Init;
  SupervisorState to = SupervisorState::Init;
  TransitionReason reason = TransitionReason::None;
  std::int32_t value = -1;     //!< joint index or PlannerStatus code; -1 = none
  std::array<char, kTransitionDetailChars> detail{};  //!< short text, NUL-terminated ("joint 2", "GoalOccupied")
};

//! Fixed-capacity ring of transition records. When full, a push overwrites the oldest record and
//! counts it: nothing is dropped silently. RT-safe: no allocation, no throw.
class TransitionLog {
 public:
  static constexpr std::size_t kCapacity = 64;  //!< records kept; at one transition per cycle, 0.64 s at 100 Hz

  void push(const TransitionRecord& record) noexcept;
  //! Removes the oldest record into `out`; false when empty.
  [[nodiscard]] bool pop(TransitionRecord& out) noexcept;
  //! Moves up to out.size() records, oldest first, into out; returns how many.
  std::size_t drain(std::span<TransitionRecord> out) noexcept;
  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] bool empty() const noexcept { return size_ == 0; }
  //! Records overwritten before anyone drained them, since construction. [-]
  [[nodiscard]] std::uint64_t overwritten() const noexcept { return overwritten_; }

 private:
  std::array<TransitionRecord, kCapacity> ring_{};
  std::size_t head_ = 0;  //!< index of the oldest record
  std::size_t size_ = 0;
  std::uint64_t overwritten_ = 0;
};

//! Timeouts and policies (docs/supervisor.md, with the reasons for each default).
struct SupervisorConfig {
  int num_joints = 0;                          //!< joints of the machine, 1..kMaxJoints [-]
  bool uwb_required = true;                    //!< the site has tagged dynamic obstacles: UWB silence is a fault
  std::int64_t uwb_silence_timeout_us = 1'000'000;  //!< no fix this long: silent (ObstacleTracker's track loss) [µs]
  std::int64_t init_timeout_us = 10'000'000;   //!< INIT -> FAULT when not every device is alive by then [µs]
  std::int64_t nmt_start_retry_us = 1'000'000; //!< INIT: repeat NMT start this often while nodes stay off [µs]
  std::int64_t stop_timeout_us = 10'000'000;   //!< STOPPING -> FAULT when not at rest by then [µs]
  std::int64_t plan_timeout_us = 60'000'000;   //!< PLANNING/REPLANNING -> HOLD when not solved by then [µs]
  std::int64_t replan_retry_interval_us = 1'000'000;  //!< HOLD after GoalOccupied: retry this often [µs]
  int max_replan_retries = 30;                 //!< retries after GoalOccupied before the goal is dropped [-]
};

//! The supervisor. Construction validates the configuration and throws std::invalid_argument
//! naming the field (start-up only); update() is RT-safe: no allocation, no throw, no clock.
class Supervisor {
 public:
  explicit Supervisor(const SupervisorConfig& config);

  //! One cycle: at most one transition, chosen by the precedence in docs/supervisor.md.
  SupervisorOutput update(const SupervisorInputs& in) noexcept;

  [[nodiscard]] SupervisorState state() const noexcept { return state_; }
  //! The reason of the transition into the current state (for FAULT: the fault's cause).
  [[nodiscard]] TransitionReason reason() const noexcept { return reason_; }
  //! The value of that transition: the joint (or planner status, retry number); -1 for none.
  [[nodiscard]] std::int32_t reason_value() const noexcept { return fault_value_; }
  //! HOLD after GoalOccupied: a re-plan retry is scheduled.
  [[nodiscard]] bool retry_pending() const noexcept { return retry_pending_; }
  [[nodiscard]] int retries_done() const noexcept { return retries_done_; }
  [[nodiscard]] TransitionLog& log() noexcept { return log_; }
  [[nodiscard]] const TransitionLog& log() const noexcept { return log_; }
  [[nodiscard]] const SupervisorConfig& config() const noexcept { return config_; }

 private:
  //! A sensing or loop fault and the joint it concerns (-1: none).
  struct Cause {
    TransitionReason reason = TransitionReason::None;
    std::int32_t joint = -1;
  };
  [[nodiscard]] Cause running_fault(const SupervisorInputs& in) const noexcept;
  [[nodiscard]] Cause ack_blocker(const SupervisorInputs& in) const noexcept;
  [[nodiscard]] Cause init_blocker(const SupervisorInputs& in) const noexcept;
  [[nodiscard]] bool all_nodes_heard(const SupervisorInputs& in) const noexcept;
  //! Logs and enters `to`. detail: the record's text; nullptr derives it from the reason.
  void transition(SupervisorState to, TransitionReason reason, std::int32_t value, std::int64_t now_us,
                  SupervisorOutput& out, const char* detail = nullptr) noexcept;
  void step_state(const SupervisorInputs& in, SupervisorOutput& out) noexcept;

  SupervisorConfig config_;
  SupervisorState state_ = SupervisorState::Init;
  TransitionReason reason_ = TransitionReason::None;
  std::int64_t entered_us_ = 0;           //!< when the current state was entered [µs]
  bool clock_started_ = false;            //!< entered_us_ holds a real time (set by the first update)
  bool stopping_to_fault_ = false;        //!< STOPPING ends in FAULT (reason_) instead of REPLANNING
  std::int32_t fault_value_ = -1;         //!< value of the transition into the current state (the joint)
  bool nmt_started_ = false;
  std::int64_t last_nmt_start_us_ = 0;
  bool retry_pending_ = false;
  bool retry_first_plan_ = false;  //!< the pending retry is of a first plan, not of a repair
  int retries_done_ = 0;
  std::int64_t next_retry_us_ = 0;
  std::uint64_t next_sequence_ = 0;
  TransitionLog log_{};
};

}  // namespace mgc::guidance
