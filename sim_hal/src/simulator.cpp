// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "mgc/planning/io/input_error.hpp"

namespace mgc::sim {

using hal::CanFrame;
using hal::Classified;
using hal::MessageKind;
using hal::Status;
using hal::canopen::NmtCommand;
using hal::canopen::NmtState;
using hal::pdo::CutoffReason;
using hal::pdo::CutoffState;
using hal::pdo::ValveReason;
using hal::pdo::ValveState;

namespace {

constexpr double kUsPerS = 1e6;

//! Quality nibble for a fix with this 1-sigma error: the smallest q with q × 10 cm >= sigma.
std::uint8_t uwb_quality(double sigma_m) noexcept {
  const double q = std::ceil(sigma_m / 0.1 - 1e-9);
  if (q < 1.0) return 1;
  if (q > 14.0) return hal::pdo::kUwbQualityUnknown;
  return static_cast<std::uint8_t>(q);
}

}  // namespace

std::vector<SimTag> scenario_tags(const planning::Scenario& scenario) {
  std::vector<SimTag> tags;
  for (std::size_t i = 0; i < scenario.dynamic_obstacles.size(); ++i) {
    for (const planning::UwbTagSpec& t : scenario.dynamic_obstacles[i].tags) {
      tags.push_back({static_cast<std::uint8_t>(t.id), i, t.position_m});
    }
  }
  for (const planning::MachineTagSpec& t : scenario.machine_tags) {
    SimTag tag{static_cast<std::uint8_t>(t.id), 0, t.position_m};
    tag.on_machine = true;
    tags.push_back(tag);
  }
  return tags;
}

hal::BusPlan bus_plan_for(const planning::Scenario& scenario) {
  std::vector<std::string> names;
  for (const auto& j : scenario.machine.joints) names.push_back(j.name);
  return hal::bus_plan_for(planning::to_string(scenario.machine.kind), names);
}

Simulator::Simulator(const planning::Scenario& scenario, hal::CanBus& bus, SimConfig config)
    : scenario_(scenario),
      bus_(bus),
      config_(std::move(config)),
      plan_(bus_plan_for(scenario)),
      random_(config_.seed),
      machine_tag_random_(config_.seed ^ 0x6d616368696e65ULL),
      inclinometer_random_(config_.seed ^ 0x696e636c696eULL),
      site_tag_random_(config_.seed ^ 0x73697465746167ULL) {
  if (!(config_.physics_rate_hz >= 100.0 && config_.physics_rate_hz <= 10'000.0)) {
    throw std::invalid_argument("physics rate must be 100..10000 Hz");
  }
  if (!(config_.uwb.rate_hz > 0.0)) throw std::invalid_argument("UWB rate must be > 0 Hz");
  physics_step_us_ = static_cast<std::int64_t>(std::llround(kUsPerS / config_.physics_rate_hz));
  truth_.num_joints = plan_.num_joints;
  for (std::size_t j = 0; j < plan_.num_joints; ++j) {
    const planning::JointSpec& spec = scenario.machine.joints[j];
    ActuatorParams p;
    p.max_velocity = spec.max_velocity;
    p.max_acceleration = spec.max_acceleration;
    p.lag_s = config_.actuator_lag_s;
    p.deadband = config_.valve_deadband;
    p.position_min = spec.position_min;
    p.position_max = spec.position_max;
    p.continuous = spec.continuous;
    const double q0 = scenario.start[static_cast<Eigen::Index>(j)];
    actuators_[j] = HydraulicActuator(p, q0);
    truth_.position[j] = q0;
    nodes_[num_nodes_++].node_id = plan_.encoders[j].node_id;
  }
  nodes_[num_nodes_++].node_id = plan_.uwb_gateway_node_id;
  valve_node_ = num_nodes_;
  nodes_[num_nodes_++].node_id = plan_.valve_node_id;
  cutoff_node_ = num_nodes_;
  nodes_[num_nodes_++].node_id = plan_.cutoff_node_id;
  if (plan_.inclinometer_node_id != 0) {
    inclinometer_node_ = num_nodes_;
    nodes_[num_nodes_++].node_id = plan_.inclinometer_node_id;
    inclinometer_filtered_rad_ = actuators_[static_cast<std::size_t>(plan_.inclinometer_joint)].position();
  }
  tags_ = scenario_tags(scenario);
  if (!scenario.machine_tags.empty()) {
    model_ = planning::build_model(scenario);
    for (SimTag& t : tags_) {
      if (!t.on_machine) continue;
      const auto spec = std::find_if(scenario.machine_tags.begin(), scenario.machine_tags.end(),
                                     [&](const planning::MachineTagSpec& m) { return m.id == t.tag_id; });
      t.mount = planning::resolve_tag_mount(*model_, spec->body);
      if (t.mount.index < 0) throw std::invalid_argument("machine tag " + std::to_string(t.tag_id) + ": no body or frame '" + spec->body + "'");
    }
  }
  next_fix_us_.assign(tags_.size(), 0);
  tag_sequence_.assign(tags_.size(), 0);
}

double Simulator::sim_time_s(std::int64_t now_us) const noexcept {
  return static_cast<double>(now_us - start_us_) / kUsPerS;
}

double Simulator::gaussian(planning::Random& random) noexcept {
  // Box-Muller on the planner's generator, so a seed fixes every noise sample on any libstdc++.
  const double u1 = 1.0 - random.uniform();
  const double u2 = random.uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

Simulator::Node* Simulator::node(std::uint8_t node_id) noexcept {
  for (std::size_t i = 0; i < num_nodes_; ++i) {
    if (nodes_[i].node_id == node_id) return &nodes_[i];
  }
  return nullptr;
}

const Fault* Simulator::find_fault(FaultKind kind, FaultTarget::Kind target, int index) const noexcept {
  const double t = truth_.t_s;
  for (const Fault& f : config_.faults) {
    if (f.kind != kind || !f.active(t)) continue;
    if (target != FaultTarget::Kind::None && (f.target.kind != target || f.target.index != index)) continue;
    return &f;
  }
  return nullptr;
}

bool Simulator::fault_active(FaultKind kind, FaultTarget::Kind target, int index) const noexcept {
  return find_fault(kind, target, index) != nullptr;
}

Eigen::Isometry3d Simulator::obstacle_pose(std::size_t i) const noexcept {
  return scenario_.dynamic_obstacles[i].pose_at(truth_.t_s + config_.scenario_time_offset_s);
}

Eigen::Vector3d Simulator::tag_position(const SimTag& tag) const noexcept {
  if (tag.on_machine) {
    planning::JointVector q(static_cast<Eigen::Index>(plan_.num_joints));
    for (std::size_t j = 0; j < plan_.num_joints; ++j) q[static_cast<Eigen::Index>(j)] = actuators_[j].position();
    model_->forward_kinematics(q, kinematics_);
    return planning::tag_position(kinematics_, tag.mount, tag.position_m);
  }
  return obstacle_pose(tag.obstacle) * tag.position_m;
}

void Simulator::add_site_tags(std::vector<SiteSimTag> tags) {
  if (started_) throw std::logic_error("Simulator::add_site_tags after the first step");
  for (const SiteSimTag& t : tags) {
    if (t.model == nullptr || t.truth == nullptr || t.mount.index < 0) throw std::invalid_argument("site tag " + std::to_string(t.tag_id) + ": no model, truth or mount");
  }
  site_tags_ = std::move(tags);
  next_site_fix_us_.assign(site_tags_.size(), 0);
  site_tag_sequence_.assign(site_tags_.size(), 0);
}

Eigen::Vector3d Simulator::site_tag_position(const SiteSimTag& tag) const noexcept {
  const int n = tag.model->dof();
  planning::JointVector q(n);
  for (int j = 0; j < n; ++j) q[j] = tag.truth->position[static_cast<std::size_t>(j)];
  tag.model->forward_kinematics(q, site_kinematics_);
  return planning::tag_position(site_kinematics_, tag.mount, tag.position_m);
}

std::int64_t Simulator::next_event_us() const noexcept {
  if (!started_) return 0;
  std::int64_t next = physics_us_ + physics_step_us_;
  for (std::size_t i = 0; i < num_nodes_; ++i) next = std::min(next, nodes_[i].next_heartbeat_us);
  for (const std::int64_t t : next_fix_us_) next = std::min(next, t);
  for (std::size_t i = 0; i < num_pending_; ++i) next = std::min(next, pending_[i].release_us);
  return next;
}

void Simulator::boot(Node& n, std::int64_t now_us) noexcept {
  n.state = NmtState::BootUp;
  queue(hal::canopen::encode_heartbeat({n.node_id, NmtState::BootUp}).value, now_us);
  n.state = NmtState::PreOperational;
  n.booted = true;
  // Staggered by node so the heartbeats of all nodes do not arrive as one burst.
  n.next_heartbeat_us = now_us + plan_.timing.device_heartbeat_period_us + 7'000 * (n.node_id % 8);
  if (n.node_id == plan_.valve_node_id) {
    valve_state_ = ValveState::Disabled;
    valve_reason_ = ValveReason::None;
    commanded_.fill(0.0);
    heartbeat_armed_ = false;
    command_armed_ = false;
  }
  if (n.node_id == plan_.cutoff_node_id) {
    set_cutoff(CutoffState::Cut, CutoffReason::NotOperational);
    cutoff_heartbeat_armed_ = false;
    cutoff_command_armed_ = false;
    cutoff_latched_ = false;
  }
}

void Simulator::step(std::int64_t now_us) noexcept {
  if (!started_) {
    started_ = true;
    start_us_ = now_us;
    physics_us_ = now_us;
    // Spread the tags over one period, as a TDMA schedule would: the obstacles' tags as without
    // machine tags (so adding these changes no obstacle fix), the machine's own between them.
    std::size_t obstacle_tags = 0;
    for (const SimTag& tag : tags_) obstacle_tags += tag.on_machine ? 0 : 1;
    const std::size_t machine_tags = tags_.size() - obstacle_tags;
    for (std::size_t t = 0; t < tags_.size(); ++t) {
      const bool machine = tags_[t].on_machine;
      const double slot = machine ? static_cast<double>(t - obstacle_tags) + 0.5 : static_cast<double>(t);
      const double slots = static_cast<double>(machine ? machine_tags : obstacle_tags);
      next_fix_us_[t] = now_us + static_cast<std::int64_t>(kUsPerS / config_.uwb.rate_hz * slot / slots);
    }
    // The other machines' tags a quarter period after the scenario's: none of theirs moves.
    for (std::size_t t = 0; t < site_tags_.size(); ++t) {
      const double slot = static_cast<double>(t) + 0.25;
      next_site_fix_us_[t] = now_us + static_cast<std::int64_t>(kUsPerS / config_.uwb.rate_hz * slot / static_cast<double>(site_tags_.size()));
    }
    for (std::size_t i = 0; i < num_nodes_; ++i) boot(nodes_[i], now_us);
  }
  advance_physics(now_us);
  truth_.t_s = sim_time_s(now_us);

  const bool was_bus_off = bus_off_;
  bus_off_ = fault_active(FaultKind::BusOff);
  if (bus_off_ != was_bus_off) {
    // The error frame goes out before the silence (and after it, the restart), so every other
    // endpoint's controller sees the same bus state.
    CanFrame err;
    err.can_id = hal::kCanErrFlag | (bus_off_ ? hal::kCanErrBusOff : hal::kCanErrRestarted);
    err.dlc = hal::kCanMaxDlc;
    if (bus_.send(err) == Status::Ok) ++counters_.frames_sent;
    if (bus_off_) {
      counters_.frames_dropped += num_pending_;
      num_pending_ = 0;
    }
  }

  while (true) {
    const hal::ReceiveResult r = bus_.receive(rx_);
    for (std::size_t k = 0; k < r.count; ++k) {
      ++counters_.frames_received;
      if (!bus_off_) handle(rx_[k], now_us);
    }
    if (r.count < rx_.size()) break;
  }

  supervise_valve(now_us);  // the node's own timers run on while its CAN controller is bus-off
  supervise_cutoff(now_us);
  if (!bus_off_) {
    emit_heartbeats(now_us);
    emit_uwb(now_us);
  }
  flush(now_us);

  for (std::size_t j = 0; j < plan_.num_joints; ++j) {
    truth_.position[j] = actuators_[j].position();
    truth_.velocity[j] = actuators_[j].velocity();
  }
  truth_.valve_state = valve_state_;
  truth_.valve_reason = valve_reason_;
  truth_.cutoff_state = cutoff_state_;
  truth_.pilot_pressure = pilot_pressure();
}

void Simulator::advance_physics(std::int64_t now_us) noexcept {
  const double dt_s = static_cast<double>(physics_step_us_) / kUsPerS;
  const double ramp = config_.valve_ramp_per_s * dt_s;
  while (physics_us_ + physics_step_us_ <= now_us) {
    // Without pilot pressure the main spools spring to neutral, whatever the valve node drives.
    const bool pilot = pilot_pressure();
    for (std::size_t j = 0; j < plan_.num_joints; ++j) {
      // The node's set-point ramp; fail-safe and disable block the spools at once.
      const double target = valve_state_ == ValveState::Active ? commanded_[j] : 0.0;
      double& spool = truth_.spool[j];
      spool = valve_state_ == ValveState::Active ? std::clamp(target, spool - ramp, spool + ramp) : 0.0;
      actuators_[j].step(pilot ? spool : 0.0, dt_s);
      // A spool that does not quite centre, or a load that drags the joint: only pilot pressure
      // off (all spools sprung to neutral, the brakes set) stops it.
      if (const Fault* creep = find_fault(FaultKind::JointCreep, FaultTarget::Kind::Joint, static_cast<int>(j)); creep && pilot) {
        actuators_[j].displace(creep->offset_rate * dt_s);
      }
    }
    if (inclinometer_node_ != 0) {
      // The link's angle to the horizontal: on a level machine, the joint's angle.
      const double q = actuators_[static_cast<std::size_t>(plan_.inclinometer_joint)].position();
      inclinometer_filtered_rad_ += (q - inclinometer_filtered_rad_) * (1.0 - std::exp(-dt_s / config_.inclinometer.filter_s));
    }
    physics_us_ += physics_step_us_;
  }
}

void Simulator::handle(const hal::TimedFrame& timed, std::int64_t now_us) noexcept {
  const CanFrame& f = timed.frame;
  if (f.is_error()) return;
  const Classified c = hal::classify(f, plan_);
  switch (c.kind) {
    case MessageKind::Nmt: {
      const auto nmt = hal::canopen::decode_nmt(f);
      counters_.codec.record(nmt.status);
      if (nmt.ok()) on_nmt(nmt.value, now_us);
      return;
    }
    case MessageKind::Sync: {
      const auto sync = hal::canopen::decode_sync(f);
      counters_.codec.record(sync.status);
      if (sync.ok()) on_sync(now_us);
      return;
    }
    case MessageKind::Heartbeat: {
      const auto hb = hal::canopen::decode_heartbeat(f);
      counters_.codec.record(hb.status);
      if (hb.ok() && hb.value.node_id == plan_.controller_node_id) {
        // The valve and cut-off nodes consume the controller's heartbeat from the first one they hear.
        heartbeat_armed_ = true;
        last_controller_heartbeat_us_ = timed.t_us;
        cutoff_heartbeat_armed_ = true;
        cutoff_last_heartbeat_us_ = timed.t_us;
      }
      return;
    }
    case MessageKind::ValveCommand: {
      const auto cmd = hal::pdo::decode_valve_command(f);
      counters_.codec.record(cmd.status);
      if (cmd.ok()) on_valve_command(cmd.value, timed.t_us);
      return;
    }
    case MessageKind::CutoffCommand: {
      const auto cmd = hal::pdo::decode_cutoff_command(f);
      counters_.codec.record(cmd.status);
      if (cmd.ok()) on_cutoff_command(cmd.value, timed.t_us);
      return;
    }
    case MessageKind::Unknown: counters_.codec.record(Status::UnknownId); return;
    default: counters_.codec.record(Status::Ok); return;  // our own nodes' messages from another sim
  }
}

void Simulator::on_nmt(const hal::canopen::NmtMessage& nmt, std::int64_t now_us) noexcept {
  for (std::size_t i = 0; i < num_nodes_; ++i) {
    Node& n = nodes_[i];
    if (nmt.target_node_id != 0 && nmt.target_node_id != n.node_id) continue;
    const bool valve = n.node_id == plan_.valve_node_id;
    const bool cutoff = n.node_id == plan_.cutoff_node_id;
    switch (nmt.command) {
      case NmtCommand::Start:
        n.state = NmtState::Operational;
        if (cutoff) {
          // Operational, still cut until the controller enables it; a start clears a latched cut,
          // and its emergency with an error reset (CiA 301: EMCY code 0000h).
          if (cutoff_latched_) {
            hal::canopen::EmcyMessage reset;
            reset.node_id = plan_.cutoff_node_id;
            reset.error_code = hal::canopen::kEmcyNoError;
            queue(hal::canopen::encode_emcy(reset).value, now_us);
          }
          set_cutoff(CutoffState::Cut, CutoffReason::Commanded);
          cutoff_latched_ = false;
          cutoff_heartbeat_armed_ = false;
          cutoff_command_armed_ = false;
        }
        if (valve) {
          // A start clears a fail-safe; the monitors re-arm on the first heartbeat and command.
          valve_state_ = ValveState::Active;
          valve_reason_ = ValveReason::None;
          commanded_.fill(0.0);
          heartbeat_armed_ = false;
          command_armed_ = false;
        }
        break;
      case NmtCommand::Stop:
      case NmtCommand::EnterPreOperational:
        n.state = nmt.command == NmtCommand::Stop ? NmtState::Stopped : NmtState::PreOperational;
        if (valve) {
          valve_state_ = ValveState::Disabled;
          valve_reason_ = ValveReason::None;
          commanded_.fill(0.0);
        }
        if (cutoff) set_cutoff(CutoffState::Cut, CutoffReason::NotOperational);
        break;
      case NmtCommand::ResetNode:
      case NmtCommand::ResetCommunication: boot(n, now_us); break;
    }
  }
}

void Simulator::on_sync(std::int64_t now_us) noexcept {
  ++counters_.syncs;
  for (std::size_t j = 0; j < plan_.num_joints; ++j) {
    const Node& n = nodes_[j];
    if (n.state != NmtState::Operational) continue;
    const int joint = static_cast<int>(j);
    const bool stuck_now = fault_active(FaultKind::EncoderStuck, FaultTarget::Kind::Joint, joint);
    const hal::pdo::EncoderKind kind = plan_.encoders[j].kind;
    const double counts_per_si =
        kind == hal::pdo::EncoderKind::Rotary ? 180.0 / std::numbers::pi / hal::pdo::kRotaryDegPerCount
                                              : 1000.0 / hal::pdo::kLinearMmPerCount;
    const double noise_si = config_.encoder_noise_counts * gaussian() / counts_per_si;
    const auto counts = hal::pdo::si_to_counts(actuators_[j].position() + noise_si, kind);
    if (stuck_now && !stuck_[j]) stuck_counts_[j] = counts.value;
    stuck_[j] = stuck_now;
    if (fault_active(FaultKind::EncoderDropout, FaultTarget::Kind::Joint, joint)) continue;
    hal::pdo::EncoderPosition pos{n.node_id, stuck_now ? stuck_counts_[j] : counts.value, 0};
    if (!counts.ok()) pos.status = hal::pdo::kEncoderStatusAlarm;
    if (const Fault* lie = find_fault(FaultKind::EncoderOffset, FaultTarget::Kind::Joint, joint); lie != nullptr && !stuck_now) {
      const double lie_si = lie->offset + lie->offset_rate * (truth_.t_s - lie->start_s);
      const auto lied = hal::pdo::si_to_counts(actuators_[j].position() + noise_si + lie_si, kind);
      pos.position_counts = lied.value;
      pos.status = lied.ok() ? 0 : hal::pdo::kEncoderStatusAlarm;
    }
    queue(hal::pdo::encode_encoder_position(pos).value, now_us);
  }

  if (inclinometer_node_ != 0 && nodes_[inclinometer_node_].state == NmtState::Operational) emit_inclinometer(now_us);

  const Node& cutoff = nodes_[cutoff_node_];
  if (cutoff.state == NmtState::Operational) {
    queue(hal::pdo::encode_cutoff_status({plan_.cutoff_node_id, cutoff_state_, cutoff_reason_, pilot_pressure()}).value, now_us);
  }

  const Node& valve = nodes_[valve_node_];
  if (valve.state != NmtState::Operational) return;
  hal::pdo::ValveStatus status{plan_.valve_node_id, valve_state_, valve_reason_, 0, command_counter_};
  queue(hal::pdo::encode_valve_status(status).value, now_us);
  const std::size_t banks = (plan_.num_joints + hal::pdo::kJointsPerValveFrame - 1) / hal::pdo::kJointsPerValveFrame;
  for (std::size_t b = 0; b < banks; ++b) {
    hal::pdo::ValveApplied applied{plan_.valve_node_id, static_cast<std::uint8_t>(b), {}};
    for (std::size_t k = 0; k < hal::pdo::kJointsPerValveFrame; ++k) {
      const std::size_t j = b * hal::pdo::kJointsPerValveFrame + k;
      if (j < plan_.num_joints) applied.velocity_permyriad[k] = hal::pdo::fraction_to_permyriad(truth_.spool[j]).value;
    }
    queue(hal::pdo::encode_valve_applied(applied).value, now_us);
  }
}

void Simulator::on_valve_command(const hal::pdo::ValveCommand& cmd, std::int64_t t_us) noexcept {
  if (valve_state_ != ValveState::Active || fault_active(FaultKind::ValveIgnore)) {
    ++counters_.commands_ignored;
    return;
  }
  ++counters_.commands_accepted;
  ++command_counter_;
  command_armed_ = true;
  last_command_us_ = t_us;
  for (std::size_t k = 0; k < hal::pdo::kJointsPerValveFrame; ++k) {
    const std::size_t j = static_cast<std::size_t>(cmd.bank) * hal::pdo::kJointsPerValveFrame + k;
    if (j < plan_.num_joints) commanded_[j] = hal::pdo::permyriad_to_fraction(cmd.velocity_permyriad[k]);
  }
}

void Simulator::supervise_valve(std::int64_t now_us) noexcept {
  if (valve_state_ != ValveState::Active) return;
  if (heartbeat_armed_ && now_us - last_controller_heartbeat_us_ > plan_.timing.valve_heartbeat_timeout_us) {
    enter_fail_safe(ValveReason::ControllerHeartbeatLost, now_us);
  } else if (command_armed_ && now_us - last_command_us_ > plan_.timing.valve_command_timeout_us &&
             !fault_active(FaultKind::ValveIgnore)) {
    enter_fail_safe(ValveReason::CommandTimeout, now_us);
  }
}

void Simulator::on_cutoff_command(const hal::pdo::CutoffCommand& cmd, std::int64_t t_us) noexcept {
  if (nodes_[cutoff_node_].state != NmtState::Operational || cutoff_state_ == CutoffState::Fault) return;
  cutoff_command_armed_ = true;
  cutoff_last_command_us_ = t_us;
  if (cmd.command == hal::pdo::PilotCommand::Cut) {
    // A latched cut keeps its reason: the controller must still see why only a start re-arms it.
    if (!cutoff_latched_) set_cutoff(CutoffState::Cut, CutoffReason::Commanded);
  } else if (!cutoff_latched_) {
    set_cutoff(CutoffState::Enabled, CutoffReason::None);
  }
}

void Simulator::supervise_cutoff(std::int64_t now_us) noexcept {
  if (cutoff_state_ != CutoffState::Enabled) return;
  CutoffReason loss = CutoffReason::None;
  if (cutoff_heartbeat_armed_ && now_us - cutoff_last_heartbeat_us_ > plan_.timing.cutoff_heartbeat_timeout_us) {
    loss = CutoffReason::ControllerHeartbeatLost;
  } else if (cutoff_command_armed_ && now_us - cutoff_last_command_us_ > plan_.timing.cutoff_command_timeout_us) {
    loss = CutoffReason::CommandTimeout;
  }
  if (loss == CutoffReason::None) return;
  set_cutoff(CutoffState::Cut, loss);
  cutoff_latched_ = true;
  hal::canopen::EmcyMessage emcy;
  emcy.node_id = plan_.cutoff_node_id;
  emcy.error_code = loss == CutoffReason::ControllerHeartbeatLost ? hal::canopen::kEmcyHeartbeat : hal::canopen::kEmcyRpdoTimeout;
  emcy.error_register = 0x11;
  queue(hal::canopen::encode_emcy(emcy).value, now_us);
}

void Simulator::set_cutoff(CutoffState state, CutoffReason reason) noexcept {
  if (cutoff_state_ == CutoffState::Enabled && state != CutoffState::Enabled) ++counters_.pilot_cuts;
  cutoff_state_ = state;
  cutoff_reason_ = reason;
}

bool Simulator::pilot_pressure() const noexcept {
  return cutoff_state_ == CutoffState::Enabled || fault_active(FaultKind::CutoffFail);
}

void Simulator::enter_fail_safe(ValveReason reason, std::int64_t now_us) noexcept {
  valve_state_ = ValveState::FailSafe;
  valve_reason_ = reason;
  commanded_.fill(0.0);
  truth_.spool.fill(0.0);  // blocked at once, never floated
  ++counters_.fail_safe_events;
  hal::canopen::EmcyMessage emcy;
  emcy.node_id = plan_.valve_node_id;
  emcy.error_code = reason == ValveReason::ControllerHeartbeatLost ? hal::canopen::kEmcyHeartbeat
                                                                    : hal::canopen::kEmcyRpdoTimeout;
  emcy.error_register = 0x11;  // generic + communication error (CiA 301 0x1001 bits 0 and 4)
  queue(hal::canopen::encode_emcy(emcy).value, now_us);
}

void Simulator::emit_inclinometer(std::int64_t now_us) noexcept {
  constexpr FaultTarget::Kind kTarget = FaultTarget::Kind::Inclinometer;
  const double noise_rad = config_.inclinometer.noise_sigma_deg * std::numbers::pi / 180.0 * gaussian(inclinometer_random_);
  const auto counts = hal::pdo::si_to_counts(inclinometer_filtered_rad_ + noise_rad, hal::pdo::EncoderKind::Rotary);
  const bool stuck_now = fault_active(FaultKind::EncoderStuck, kTarget, -1);
  if (stuck_now && !inclinometer_stuck_) inclinometer_stuck_counts_ = counts.value;
  inclinometer_stuck_ = stuck_now;
  if (fault_active(FaultKind::EncoderDropout, kTarget, -1)) return;
  hal::pdo::EncoderPosition pos{plan_.inclinometer_node_id, stuck_now ? inclinometer_stuck_counts_ : counts.value, 0};
  if (!counts.ok()) pos.status = hal::pdo::kEncoderStatusAlarm;
  if (const Fault* lie = find_fault(FaultKind::EncoderOffset, kTarget, -1); lie != nullptr && !stuck_now) {
    const double lie_si = lie->offset + lie->offset_rate * (truth_.t_s - lie->start_s);
    const auto lied = hal::pdo::si_to_counts(inclinometer_filtered_rad_ + noise_rad + lie_si, hal::pdo::EncoderKind::Rotary);
    pos.position_counts = lied.value;
    pos.status = lied.ok() ? 0 : hal::pdo::kEncoderStatusAlarm;
  }
  queue(hal::pdo::encode_encoder_position(pos).value, now_us);
}

void Simulator::emit_heartbeats(std::int64_t now_us) noexcept {
  for (std::size_t i = 0; i < num_nodes_; ++i) {
    Node& n = nodes_[i];
    if (now_us < n.next_heartbeat_us) continue;
    n.next_heartbeat_us += plan_.timing.device_heartbeat_period_us;
    if (n.next_heartbeat_us <= now_us) n.next_heartbeat_us = now_us + plan_.timing.device_heartbeat_period_us;
    const bool lost = i < plan_.num_joints
                          ? fault_active(FaultKind::HeartbeatLost, FaultTarget::Kind::Joint, static_cast<int>(i))
                      : n.node_id == plan_.uwb_gateway_node_id
                          ? fault_active(FaultKind::HeartbeatLost, FaultTarget::Kind::UwbGateway, -1)
                      : n.node_id == plan_.valve_node_id
                          ? fault_active(FaultKind::HeartbeatLost, FaultTarget::Kind::Valve, -1)
                      : i == inclinometer_node_ && inclinometer_node_ != 0
                          ? fault_active(FaultKind::HeartbeatLost, FaultTarget::Kind::Inclinometer, -1)
                          : fault_active(FaultKind::HeartbeatLost, FaultTarget::Kind::Cutoff, -1);
    if (lost) continue;
    queue(hal::canopen::encode_heartbeat({n.node_id, n.state}).value, now_us);
  }
}

void Simulator::emit_uwb(std::int64_t now_us) noexcept {
  const Node& gateway = nodes_[plan_.num_joints];
  const auto period_us = static_cast<std::int64_t>(std::llround(kUsPerS / config_.uwb.rate_hz));
  const auto latency_us = static_cast<std::int64_t>(std::llround(config_.uwb.latency_ms * 1e3));
  const bool silent = fault_active(FaultKind::UwbSilent);
  for (std::size_t t = 0; t < tags_.size(); ++t) {
    if (now_us < next_fix_us_[t]) continue;
    next_fix_us_[t] += period_us;
    if (next_fix_us_[t] <= now_us) next_fix_us_[t] = now_us + period_us;
    if (gateway.state != NmtState::Operational || silent) continue;
    tag_sequence_[t] = static_cast<std::uint8_t>((tag_sequence_[t] + 1) % hal::pdo::kUwbSequenceModulo);
    emit_fix(tags_[t].tag_id, tag_sequence_[t], tag_position(tags_[t]), tags_[t].on_machine ? machine_tag_random_ : random_, now_us,
             latency_us);
  }
  for (std::size_t t = 0; t < site_tags_.size(); ++t) {
    if (now_us < next_site_fix_us_[t]) continue;
    next_site_fix_us_[t] += period_us;
    if (next_site_fix_us_[t] <= now_us) next_site_fix_us_[t] = now_us + period_us;
    if (gateway.state != NmtState::Operational || silent) continue;
    site_tag_sequence_[t] = static_cast<std::uint8_t>((site_tag_sequence_[t] + 1) % hal::pdo::kUwbSequenceModulo);
    emit_fix(site_tags_[t].tag_id, site_tag_sequence_[t], site_tag_position(site_tags_[t]), site_tag_random_, now_us, latency_us);
  }
}

void Simulator::emit_fix(std::uint8_t tag_id, std::uint8_t sequence, const Eigen::Vector3d& truth, planning::Random& random,
                         std::int64_t now_us, std::int64_t latency_us) noexcept {
  ++counters_.tag_fixes;
  const double sigma = config_.uwb.noise_sigma_m;
  const Fault* noisy = find_fault(FaultKind::TagNoise, FaultTarget::Kind::Tag, tag_id);
  const double extra = noisy != nullptr ? noisy->sigma_m : 0.0;
  hal::pdo::UwbTagPosition fix{plan_.uwb_gateway_node_id, tag_id, {}, sequence, uwb_quality(sigma)};
  bool in_range = true;
  for (int a = 0; a < 3; ++a) {
    const double noise = sigma * gaussian(random) + extra * gaussian(random);
    const auto c = hal::pdo::metres_to_uwb_counts(truth[a] + noise);
    in_range = in_range && c.ok();
    fix.position_cm[static_cast<std::size_t>(a)] = c.value;
  }
  if (!in_range) {
    fix.quality = hal::pdo::kUwbQualityNoFix;
    fix.position_cm.fill(hal::pdo::kUwbNoPosition);
  }
  if (random.uniform() < config_.uwb.dropout_probability) {
    ++counters_.tag_fixes_dropped;
    return;
  }
  queue(hal::pdo::encode_uwb_tag_position(fix).value, now_us, latency_us);
}

void Simulator::queue(const CanFrame& frame, std::int64_t now_us, std::int64_t extra_delay_us) noexcept {
  if (bus_off_ || num_pending_ >= kPendingCapacity) {
    ++counters_.frames_dropped;
    return;
  }
  const Fault* delay = find_fault(FaultKind::FrameDelay, FaultTarget::Kind::None, -1);
  const std::int64_t delay_us = delay != nullptr ? static_cast<std::int64_t>(std::llround(delay->delay_ms * 1e3)) : 0;
  pending_[num_pending_++] = {now_us + extra_delay_us + delay_us, pending_order_++, frame};
}

void Simulator::flush(std::int64_t now_us) noexcept {
  // Due frames leave in release order, ties in queueing order; the rest keep their order.
  while (true) {
    std::size_t best = num_pending_;
    for (std::size_t i = 0; i < num_pending_; ++i) {
      if (pending_[i].release_us > now_us) continue;
      if (best == num_pending_ || pending_[i].release_us < pending_[best].release_us ||
          (pending_[i].release_us == pending_[best].release_us && pending_[i].order < pending_[best].order)) {
        best = i;
      }
    }
    if (best == num_pending_) return;
    if (bus_.send(pending_[best].frame) == Status::Ok) {
      ++counters_.frames_sent;
    } else {
      ++counters_.frames_dropped;
    }
    for (std::size_t i = best + 1; i < num_pending_; ++i) pending_[i - 1] = pending_[i];
    --num_pending_;
  }
}

}  // namespace mgc::sim

namespace mgc::sim {

void apply_simulation_spec(const planning::Scenario& scenario, SimConfig& config) {
  const planning::SimulationSpec& s = scenario.simulation;
  if (s.physics_rate_hz) config.physics_rate_hz = *s.physics_rate_hz;
  if (s.actuator_lag_s) config.actuator_lag_s = *s.actuator_lag_s;
  if (s.valve_deadband_pct) config.valve_deadband = *s.valve_deadband_pct / 100.0;
  if (s.encoder_noise_counts) config.encoder_noise_counts = *s.encoder_noise_counts;
  if (s.uwb_noise_sigma_m) config.uwb.noise_sigma_m = *s.uwb_noise_sigma_m;
  if (s.uwb_rate_hz) config.uwb.rate_hz = *s.uwb_rate_hz;
  if (s.uwb_latency_ms) config.uwb.latency_ms = *s.uwb_latency_ms;
  if (s.uwb_dropout_pct) config.uwb.dropout_probability = *s.uwb_dropout_pct / 100.0;
  if (s.scenario_time_offset_s) config.scenario_time_offset_s = *s.scenario_time_offset_s;
  for (const auto& [text, ref] : s.faults) {
    try {
      config.faults.push_back(parse_machine_fault(text, scenario.machine.joints));
    } catch (const std::invalid_argument& e) {
      throw planning::io::InputError(ref.file, ref.line, ref.field, e.what());
    }
  }
}

}  // namespace mgc::sim
