// SPDX-License-Identifier: Apache-2.0
#include "mgc/hal/hal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mgc::hal {

const char* to_string(Health health) noexcept {
  switch (health) {
    case Health::Missing: return "missing";
    case Health::Alive: return "alive";
    case Health::Stale: return "stale";
    case Health::Faulted: return "faulted";
  }
  return "unknown";
}

Hal::Hal(CanBus& bus, const BusPlan& plan, std::span<const double> max_velocity) : bus_(bus), plan_(plan) {
  if (plan.num_joints == 0 || plan.num_joints > kMaxBusJoints) {
    throw std::invalid_argument("Hal: the bus plan has no joints or more than 8");
  }
  if (max_velocity.size() != plan.num_joints) {
    throw std::invalid_argument("Hal: one max velocity per joint of the bus plan is needed");
  }
  for (std::size_t j = 0; j < plan.num_joints; ++j) {
    if (!(max_velocity[j] > 0.0) || !std::isfinite(max_velocity[j])) {
      throw std::invalid_argument("Hal: every joint's max velocity must be finite and > 0");
    }
    max_velocity_[j] = max_velocity[j];
    snap_.encoders[j].node_id = plan.encoders[j].node_id;
  }
  snap_.num_joints = plan.num_joints;
  if (plan.inclinometer_node_id != 0) {
    if (plan.inclinometer_joint < 0 || static_cast<std::size_t>(plan.inclinometer_joint) >= plan.num_joints) {
      throw std::invalid_argument("Hal: the bus plan's inclinometer names no joint of the plan");
    }
    snap_.inclinometer_joint = plan.inclinometer_joint;
    snap_.inclinometer.node_id = plan.inclinometer_node_id;
  }
  snap_.uwb_gateway.node_id = plan.uwb_gateway_node_id;
  snap_.valve.node_id = plan.valve_node_id;
  snap_.valve_status.node_id = plan.valve_node_id;
  snap_.cutoff.node_id = plan.cutoff_node_id;
  snap_.cutoff_status.node_id = plan.cutoff_node_id;
  tag_slot_.fill(-1);
  plausible_min_.fill(-std::numeric_limits<double>::infinity());
  plausible_max_.fill(std::numeric_limits<double>::infinity());
}

void Hal::set_joint_plausible_range(std::size_t joint, double min, double max) {
  if (joint >= plan_.num_joints) throw std::invalid_argument("Hal: no joint " + std::to_string(joint) + " in the bus plan");
  if (std::isnan(min) || std::isnan(max) || min > max) {
    throw std::invalid_argument("Hal: joint " + std::to_string(joint) + "'s plausible range must be min <= max, not NaN");
  }
  plausible_min_[joint] = min;
  plausible_max_[joint] = max;
}

DeviceStatus* Hal::device(std::uint8_t node_id) noexcept {
  if (node_id == plan_.uwb_gateway_node_id) return &snap_.uwb_gateway;
  if (node_id == plan_.valve_node_id) return &snap_.valve;
  if (node_id == plan_.cutoff_node_id) return &snap_.cutoff;
  if (plan_.inclinometer_node_id != 0 && node_id == plan_.inclinometer_node_id) return &snap_.inclinometer;
  for (std::size_t j = 0; j < plan_.num_joints; ++j) {
    if (plan_.encoders[j].node_id == node_id) return &snap_.encoders[j];
  }
  return nullptr;
}

const SensorSnapshot& Hal::read(std::int64_t now_us) noexcept {
  ++snap_.cycle;
  snap_.t_us = now_us;
  snap_.sync_counter = 0;
  if (sync_enabled_) {
    sync_counter_ = canopen::next_sync_counter(sync_counter_, plan_.timing.sync_counter_overflow);
    const auto sync = canopen::encode_sync({sync_counter_});
    if (sync.ok() && bus_.send(sync.value) == Status::Ok) snap_.sync_counter = sync_counter_;
  }

  for (std::size_t j = 0; j < snap_.num_joints; ++j) snap_.joints[j].updated = false;
  snap_.inclinometer_angle.updated = false;
  for (std::size_t i = 0; i < snap_.num_tags; ++i) snap_.tags[i].updated = false;
  snap_.rx_lost = false;
  snap_.rx_backlog = false;
  snap_.frames = 0;
  while (true) {
    if (snap_.frames >= kMaxFramesPerRead) {
      snap_.rx_backlog = true;
      break;
    }
    const std::size_t room = std::min(rx_.size(), kMaxFramesPerRead - snap_.frames);
    const ReceiveResult r = bus_.receive(std::span<TimedFrame>(rx_.data(), room));
    if (r.status == Status::RxOverflow) snap_.rx_lost = true;
    for (std::size_t k = 0; k < r.count; ++k) handle(rx_[k]);
    snap_.frames += static_cast<std::uint32_t>(r.count);
    if (r.count < room) break;
  }
  snap_.bus_state = bus_.state();
  snap_.bus = bus_.counters();
  // The data answering the previous read's SYNC is as fresh as the bus can make it, however late
  // this read is.
  const std::int64_t data_age_ref_us =
      have_previous_read_ && sync_enabled_ ? std::min(now_us, previous_read_us_ + plan_.timing.sync_period_us) : now_us;
  previous_read_us_ = now_us;
  have_previous_read_ = true;
  update_health(now_us, data_age_ref_us);
  return snap_;
}

void Hal::handle(const TimedFrame& timed) noexcept {
  const CanFrame& f = timed.frame;
  if (f.is_error()) return;  // the transport has already folded it into state() and counters()
  const Classified c = classify(f, plan_);
  switch (c.kind) {
    case MessageKind::Unknown:
      snap_.codec.record(Status::UnknownId);
      return;
    case MessageKind::Heartbeat: {
      const auto hb = canopen::decode_heartbeat(f);
      snap_.codec.record(hb.status);
      if (hb.ok()) handle_heartbeat(hb.value, timed.t_us);
      return;
    }
    case MessageKind::Emcy: {
      const auto emcy = canopen::decode_emcy(f);
      snap_.codec.record(emcy.status);
      if (emcy.ok()) handle_emcy(emcy.value);
      return;
    }
    case MessageKind::EncoderPosition: {
      const auto pos = pdo::decode_encoder_position(f);
      snap_.codec.record(pos.status);
      if (!pos.ok() || c.index < 0) return;
      const auto j = static_cast<std::size_t>(c.index);
      JointReading& joint = snap_.joints[j];
      joint.position = pdo::counts_to_si(pos.value.position_counts, plan_.encoders[j].kind);
      if (joint.position < plausible_min_[j] || joint.position > plausible_max_[j]) ++snap_.codec.implausible;
      joint.status = pos.value.status;
      joint.t_us = timed.t_us;
      joint.updated = true;
      ++joint.samples;
      return;
    }
    case MessageKind::InclinometerAngle: {
      const auto pos = pdo::decode_encoder_position(f);
      snap_.codec.record(pos.status);
      if (!pos.ok()) return;
      JointReading& angle = snap_.inclinometer_angle;
      angle.position = pdo::counts_to_si(pos.value.position_counts, pdo::EncoderKind::Rotary);
      angle.status = pos.value.status;
      angle.t_us = timed.t_us;
      angle.updated = true;
      ++angle.samples;
      return;
    }
    case MessageKind::UwbTagPosition: {
      const auto fix = pdo::decode_uwb_tag_position(f);
      snap_.codec.record(fix.status);
      if (fix.ok()) handle_tag(fix.value, timed.t_us);
      return;
    }
    case MessageKind::ValveStatus: {
      const auto st = pdo::decode_valve_status(f);
      snap_.codec.record(st.status);
      if (!st.ok()) return;
      snap_.valve_status = st.value;
      valve_status_t_us_ = timed.t_us;
      return;
    }
    case MessageKind::ValveApplied: {
      const auto applied = pdo::decode_valve_applied(f);
      snap_.codec.record(applied.status);
      if (!applied.ok()) return;
      const std::size_t first = static_cast<std::size_t>(applied.value.bank) * pdo::kJointsPerValveFrame;
      for (std::size_t k = 0; k < pdo::kJointsPerValveFrame && first + k < snap_.num_joints; ++k) {
        snap_.valve_applied_fraction[first + k] = pdo::permyriad_to_fraction(applied.value.velocity_permyriad[k]);
      }
      return;
    }
    case MessageKind::CutoffStatus: {
      const auto st = pdo::decode_cutoff_status(f);
      snap_.codec.record(st.status);
      if (!st.ok()) return;
      snap_.cutoff_status = st.value;
      cutoff_status_t_us_ = timed.t_us;
      return;
    }
    case MessageKind::Nmt:
    case MessageKind::Sync:
    case MessageKind::ValveCommand:
    case MessageKind::CutoffCommand: {
      // Another master on the bus: decoded so that malformed ones are counted, otherwise ignored.
      const Status s = c.kind == MessageKind::Nmt            ? canopen::decode_nmt(f).status
                       : c.kind == MessageKind::Sync         ? canopen::decode_sync(f).status
                       : c.kind == MessageKind::ValveCommand ? pdo::decode_valve_command(f).status
                                                             : pdo::decode_cutoff_command(f).status;
      snap_.codec.record(s);
      return;
    }
  }
}

void Hal::handle_heartbeat(const canopen::HeartbeatMessage& hb, std::int64_t t_us) noexcept {
  DeviceStatus* dev = device(hb.node_id);
  if (dev == nullptr) return;  // our own id, or another controller
  dev->heard = true;
  dev->nmt_state = hb.state;
  dev->last_heartbeat_us = t_us;
  if (hb.state == canopen::NmtState::BootUp) {
    ++dev->boot_count;
    dev->emcy_code = canopen::kEmcyNoError;  // a rebooted node has no active error
  }
}

void Hal::handle_emcy(const canopen::EmcyMessage& emcy) noexcept {
  DeviceStatus* dev = device(emcy.node_id);
  if (dev == nullptr) return;
  dev->emcy_code = emcy.error_code;
  ++dev->emcy_count;
}

void Hal::handle_tag(const pdo::UwbTagPosition& fix, std::int64_t t_us) noexcept {
  std::int8_t slot = tag_slot_[fix.tag_id];
  if (slot < 0) {
    if (snap_.num_tags >= kMaxTags) {
      ++snap_.tags_dropped;
      return;
    }
    slot = static_cast<std::int8_t>(snap_.num_tags++);
    tag_slot_[fix.tag_id] = slot;
    TagReading& fresh = snap_.tags[static_cast<std::size_t>(slot)];
    fresh.tag_id = fix.tag_id;
    fresh.sequence = static_cast<std::uint8_t>((fix.sequence + pdo::kUwbSequenceModulo - 1) % pdo::kUwbSequenceModulo);
  }
  TagReading& tag = snap_.tags[static_cast<std::size_t>(slot)];
  const auto gap = static_cast<std::uint32_t>((fix.sequence + pdo::kUwbSequenceModulo - tag.sequence - 1) %
                                              pdo::kUwbSequenceModulo);
  tag.missed += gap;
  tag.sequence = fix.sequence;
  if (fix.quality == pdo::kUwbQualityNoFix) {
    ++tag.no_fix;
    return;  // the last fix ages on and goes stale; it is never refreshed by a "no fix"
  }
  for (std::size_t a = 0; a < 3; ++a) tag.position_m[a] = fix.position_cm[a] * pdo::kUwbMetresPerCount;
  tag.quality = fix.quality;
  tag.sigma_m = fix.quality == pdo::kUwbQualityUnknown ? std::numeric_limits<double>::infinity() : fix.quality * 0.1;
  tag.t_us = t_us;
  tag.updated = true;
  ++tag.fixes;
}

void Hal::update_health(std::int64_t now_us, std::int64_t data_age_ref_us) noexcept {
  const BusTiming& timing = plan_.timing;
  const auto node_health = [&](DeviceStatus& dev) {
    if (!dev.heard || now_us - dev.last_heartbeat_us > timing.device_heartbeat_timeout_us) {
      dev.health = Health::Missing;
    } else if (dev.emcy_code != canopen::kEmcyNoError) {
      dev.health = Health::Faulted;
    } else {
      dev.health = Health::Alive;
    }
  };
  // Bus-off: nothing is received, so everything ages into Missing/Stale on its own timeouts; the
  // snapshot's bus_state says why.
  for (std::size_t j = 0; j < snap_.num_joints; ++j) {
    DeviceStatus& dev = snap_.encoders[j];
    node_health(dev);
    JointReading& joint = snap_.joints[j];
    if (dev.health != Health::Alive) {
      joint.health = dev.health;
    } else if ((joint.status & pdo::kEncoderStatusAlarm) != 0) {
      joint.health = Health::Faulted;
    } else if (joint.samples == 0 || data_age_ref_us - joint.t_us > timing.encoder_stale_after_us) {
      joint.health = Health::Stale;
    } else {
      joint.health = Health::Alive;
    }
    joint.valid = joint.health == Health::Alive;
  }
  if (plan_.inclinometer_node_id != 0) {
    // The same rules as an encoder's: it answers every SYNC.
    DeviceStatus& dev = snap_.inclinometer;
    node_health(dev);
    JointReading& angle = snap_.inclinometer_angle;
    if (dev.health != Health::Alive) {
      angle.health = dev.health;
    } else if ((angle.status & pdo::kEncoderStatusAlarm) != 0) {
      angle.health = Health::Faulted;
    } else if (angle.samples == 0 || data_age_ref_us - angle.t_us > timing.encoder_stale_after_us) {
      angle.health = Health::Stale;
    } else {
      angle.health = Health::Alive;
    }
    angle.valid = angle.health == Health::Alive;
  }

  node_health(snap_.uwb_gateway);
  const bool gateway_alive = snap_.uwb_gateway.health == Health::Alive;
  for (std::size_t i = 0; i < snap_.num_tags; ++i) {
    TagReading& tag = snap_.tags[i];
    tag.valid = gateway_alive && tag.fixes > 0 && now_us - tag.t_us <= timing.uwb_tag_stale_after_us;
  }

  node_health(snap_.valve);
  snap_.valve_status_t_us = valve_status_t_us_;
  snap_.valve_status_valid =
      valve_status_t_us_ != 0 && data_age_ref_us - valve_status_t_us_ <= timing.encoder_stale_after_us;
  if (snap_.valve.health == Health::Alive && snap_.valve_status_valid &&
      (snap_.valve_status.state == pdo::ValveState::FailSafe || snap_.valve_status.state == pdo::ValveState::Fault ||
       snap_.valve_status.joint_fault_mask != 0)) {
    snap_.valve.health = Health::Faulted;
  }

  node_health(snap_.cutoff);
  snap_.cutoff_status_valid =
      cutoff_status_t_us_ != 0 && data_age_ref_us - cutoff_status_t_us_ <= timing.encoder_stale_after_us;
  if (snap_.cutoff.health == Health::Alive && snap_.cutoff_status_valid && snap_.cutoff_status.state == pdo::CutoffState::Fault) {
    snap_.cutoff.health = Health::Faulted;
  }
}

void Hal::set_valve_deadband(double fraction) {
  if (!(fraction >= 0.0 && fraction <= 0.5)) throw std::invalid_argument("valve deadband must be in [0, 0.5] of spool travel");
  valve_deadband_ = fraction;
}

WriteResult Hal::write(std::span<const double> velocity, std::int64_t now_us) noexcept {
  WriteResult result;
  std::array<std::int16_t, kMaxBusJoints> permyriad{};
  for (std::size_t j = 0; j < plan_.num_joints; ++j) {
    const double v = j < velocity.size() ? velocity[j] : 0.0;
    if (!std::isfinite(v)) {
      result.refused_mask = static_cast<std::uint8_t>(result.refused_mask | (1U << j));
      continue;
    }
    double fraction = v / max_velocity_[j];
    if (fraction > 1.0 || fraction < -1.0) {
      result.clamped_mask = static_cast<std::uint8_t>(result.clamped_mask | (1U << j));
      fraction = std::clamp(fraction, -1.0, 1.0);
    }
    if (fraction != 0.0) fraction = std::copysign(valve_deadband_ + (1.0 - valve_deadband_) * std::abs(fraction), fraction);
    permyriad[j] = pdo::fraction_to_permyriad(fraction).value;
    snap_.valve_command_fraction[j] = pdo::permyriad_to_fraction(permyriad[j]);
  }
  if (velocity.size() != plan_.num_joints || result.refused_mask != 0) result.status = Status::OutOfRange;

  const std::size_t banks = (plan_.num_joints + pdo::kJointsPerValveFrame - 1) / pdo::kJointsPerValveFrame;
  bool commands_sent = true;
  for (std::size_t b = 0; b < banks; ++b) {
    pdo::ValveCommand cmd{plan_.valve_node_id, static_cast<std::uint8_t>(b), {}};
    for (std::size_t k = 0; k < pdo::kJointsPerValveFrame; ++k) {
      cmd.velocity_permyriad[k] = permyriad[b * pdo::kJointsPerValveFrame + k];
    }
    const auto frame = pdo::encode_valve_command(cmd);
    const Status s = frame.ok() ? bus_.send(frame.value) : frame.status;
    if (s != Status::Ok) result.status = s;
    commands_sent = commands_sent && s == Status::Ok;
  }
  if (commands_sent) ++snap_.valve_commands_sent;
  const auto cutoff = pdo::encode_cutoff_command(
      {plan_.cutoff_node_id, pilot_enabled_ ? pdo::PilotCommand::Enable : pdo::PilotCommand::Cut});
  const Status cs = cutoff.ok() ? bus_.send(cutoff.value) : cutoff.status;
  if (cs != Status::Ok) result.status = cs;
  snap_.pilot_enable_sent = pilot_enabled_ && cs == Status::Ok;
  const Status hb = heartbeat(now_us);
  if (hb != Status::Ok) result.status = hb;
  return result;
}

Status Hal::send_nmt(canopen::NmtCommand command, std::uint8_t node_id) noexcept {
  const auto frame = canopen::encode_nmt({command, node_id});
  return frame.ok() ? bus_.send(frame.value) : frame.status;
}

Status Hal::heartbeat(std::int64_t now_us) noexcept {
  if (heartbeat_sent_ && now_us < next_heartbeat_us_) return Status::Ok;
  const auto frame = canopen::encode_heartbeat({plan_.controller_node_id, canopen::NmtState::Operational});
  const Status s = frame.ok() ? bus_.send(frame.value) : frame.status;
  if (s == Status::Ok) {
    // Scheduled from the previous due time, so the period does not drift with the cycle phase.
    const std::int64_t period_us = plan_.timing.controller_heartbeat_period_us;
    next_heartbeat_us_ = heartbeat_sent_ ? next_heartbeat_us_ + period_us : now_us + period_us;
    if (next_heartbeat_us_ <= now_us) next_heartbeat_us_ = now_us + period_us;  // after a pause: no burst
    heartbeat_sent_ = true;
  }
  return s;
}

}  // namespace mgc::hal
