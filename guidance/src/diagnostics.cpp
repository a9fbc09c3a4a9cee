// SPDX-License-Identifier: Apache-2.0
#include "mgc/guidance/diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mgc::guidance {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double sign(double v) noexcept { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

}  // namespace

const char* to_string(PlausibilityFault fault) noexcept {
  switch (fault) {
    case PlausibilityFault::None: return "None";
    case PlausibilityFault::EncoderOutOfRange: return "EncoderOutOfRange";
    case PlausibilityFault::EncoderStep: return "EncoderStep";
    case PlausibilityFault::EncoderStuck: return "EncoderStuck";
    case PlausibilityFault::JointNotFollowing: return "JointNotFollowing";
    case PlausibilityFault::JointRunaway: return "JointRunaway";
    case PlausibilityFault::ValveNotObeying: return "ValveNotObeying";
    case PlausibilityFault::PoseDisagrees: return "PoseDisagrees";
    case PlausibilityFault::AngleDisagrees: return "AngleDisagrees";
  }
  return "unknown";
}

PlausibilityMonitor::PlausibilityMonitor(std::span<const PlausibilityJoint> joints, const PlausibilityConfig& config)
    : config_(config) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("PlausibilityMonitor: " + what); };
  if (joints.empty() || joints.size() > joints_.size()) fail("expected 1.." + std::to_string(joints_.size()) + " joints");
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const PlausibilityJoint& p = joints[j];
    if (!(p.max_velocity > 0.0 && std::isfinite(p.max_velocity)) || !(p.max_acceleration > 0.0 && std::isfinite(p.max_acceleration))) {
      fail("joint " + std::to_string(j) + ": max_velocity and max_acceleration must be finite and > 0");
    }
    joints_[j] = p;
  }
  n_ = joints.size();
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!(config.gain_tolerance >= 0.0 && config.gain_tolerance < 1.0) || !(config.deadband_fraction >= 0.0 && config.deadband_fraction < 0.5)) {
    fail("gain_tolerance must be in [0, 1) and deadband_fraction in [0, 0.5)");
  }
  if (!positive(config.lag_min_s) || !(config.lag_max_s >= config.lag_min_s) || !std::isfinite(config.lag_max_s)) {
    fail("expected 0 < lag_min_s <= lag_max_s");
  }
  if (config.window_us <= 0 || config.valve_mismatch_us <= 0 || config.valve_counter_timeout_us <= 0 || config.step_time_allowance_us < 0) {
    fail("window_us, valve_mismatch_us and valve_counter_timeout_us must be > 0, step_time_allowance_us >= 0");
  }
  if (!positive(config.tolerance_rad) || !positive(config.tolerance_m) || !positive(config.step_speed_factor) ||
      !positive(config.valve_tolerance) || !positive(config.valve_ramp_per_s) || config.stuck_samples < 1 ||
      !(config.range_margin_rad >= 0.0) || !(config.range_margin_m >= 0.0) || !(config.step_noise_rad >= 0.0) ||
      !(config.step_noise_m >= 0.0) || !(config.stuck_travel_rad >= 0.0) || !(config.stuck_travel_m >= 0.0) ||
      !positive(config.drift_tolerance_rad) || !positive(config.drift_tolerance_m)) {
    fail("tolerances, margins and rates must be finite and positive (margins and noise >= 0), stuck_samples >= 1");
  }
  push_every_us_ = std::max<std::int64_t>(1, config.window_us / static_cast<std::int64_t>(kWindowEntries - 8));
}

void PlausibilityMonitor::reset() noexcept {
  result_ = {};
  for (JointState& s : state_) s = JointState{};
  started_ = false;
  counter_known_ = false;
  peak_window_ratio_ = 0.0;
  peak_drift_ratio_ = 0.0;
}

void PlausibilityMonitor::raise(PlausibilityFault fault, int joint, std::int64_t now_us) noexcept {
  if (result_.fault != PlausibilityFault::None) return;
  result_.fault = fault;
  result_.joint = joint;
  result_.detected_us = now_us;
  result_.cut_required = fault == PlausibilityFault::JointRunaway || fault == PlausibilityFault::ValveNotObeying;
}

PlausibilityMonitor::Travel PlausibilityMonitor::update_models(JointState& s, const PlausibilityJoint& joint, double command,
                                                                double dt_s) noexcept {
  // The true velocity follows the command with a first-order lag in [lag_min_s, lag_max_s] and a
  // gain and deadband within the tolerances. Its bounds: the upper one rises toward the largest
  // speed the command may give as fast as any such actuator can and falls toward it as slowly;
  // the lower one the other way round. Four fixed models (each lag on each speed) do not bound it
  // after a reversal: a fast model has already come back to the new command while a slow one is
  // still on the old one, and an actuator between them is past both.
  const double g = config_.gain_tolerance;
  const double deadband = config_.deadband_fraction * joint.max_velocity;
  const double magnitude = std::min(std::abs(command), joint.max_velocity);
  const double most = sign(command) * std::min(magnitude * (1.0 + g) + (magnitude > 0.0 ? deadband : 0.0), joint.max_velocity * (1.0 + g));
  const double least = sign(command) * std::max(0.0, magnitude * (1.0 - g) - deadband);
  const double target_hi = std::max(most, least);
  const double target_lo = std::min(most, least);
  const double fast = 1.0 - std::exp(-dt_s / config_.lag_min_s);
  const double slow = 1.0 - std::exp(-dt_s / config_.lag_max_s);
  const double accel_fast = joint.max_acceleration * (1.0 + g) * dt_s;
  const double accel_slow = joint.max_acceleration * (1.0 - g) * dt_s;
  const double to_hi = target_hi - s.v_hi;
  s.v_hi += to_hi > 0.0 ? std::min(to_hi * fast, accel_fast) : std::max(to_hi * slow, -accel_slow);
  const double to_lo = target_lo - s.v_lo;
  s.v_lo += to_lo < 0.0 ? std::max(to_lo * fast, -accel_fast) : std::min(to_lo * slow, accel_slow);
  if (!joint.continuous && s.have_sample) {
    // A joint on its end stop stands, whatever its command: the bounds may not carry it on (and,
    // when the command turns back, start the way back from a speed into the stop it never had).
    const double tolerance = joint.prismatic ? config_.tolerance_m : config_.tolerance_rad;
    if (s.q >= joint.position_max - tolerance) {
      s.v_hi = std::min(s.v_hi, 0.0);
      s.v_lo = std::min(s.v_lo, 0.0);
    }
    if (s.q <= joint.position_min + tolerance) {
      s.v_hi = std::max(s.v_hi, 0.0);
      s.v_lo = std::max(s.v_lo, 0.0);
    }
  }
  const double lo = s.v_lo;
  const double hi = s.v_hi;
  // The least distance the joint must have covered, each way: only when the whole bracket has one sign.
  if (lo > 0.0) s.expected_plus_since_change += lo * dt_s;
  if (hi < 0.0) s.expected_minus_since_change -= hi * dt_s;
  return {lo * dt_s, hi * dt_s};
}

void PlausibilityMonitor::check_samples(std::size_t j, const PlausibilityInputs& in) noexcept {
  JointState& s = state_[j];
  const PlausibilityJoint& joint = joints_[j];
  if (!in.valid[j]) {
    // No data: nothing to compare, and the history must not bridge the gap.
    s.have_sample = false;
    s.drift_ready = false;
    s.count = 0;
    s.frozen = 0;
    s.expected_plus_since_change = 0.0;
    s.expected_minus_since_change = 0.0;
    return;
  }
  if (!in.updated[j] && s.have_sample) return;
  const double raw = in.position[j];
  const double margin = joint.prismatic ? config_.range_margin_m : config_.range_margin_rad;
  if (!std::isfinite(raw) || (!joint.continuous && (raw < joint.position_min - margin || raw > joint.position_max + margin))) {
    raise(PlausibilityFault::EncoderOutOfRange, static_cast<int>(j), in.now_us);
    return;
  }
  const std::int64_t previous_cycle_us = previous_cycle_us_;
  if (!s.have_sample) {
    s.have_sample = true;
    s.raw = raw;
    s.sample_after_us = previous_cycle_us;
    s.q = raw;
    s.count = 0;
    s.frozen = 0;
    s.expected_plus_since_change = 0.0;
    s.expected_minus_since_change = 0.0;
    return;
  }
  double delta = raw - s.raw;
  if (joint.continuous) delta = std::remainder(delta, kTwoPi);
  // Both samples answer SYNCs sent after the cycle before the one that read the first: however
  // late the loop ran, they were at most this far apart.
  const double interval_s = static_cast<double>(std::max<std::int64_t>(in.now_us - s.sample_after_us, 0) + config_.step_time_allowance_us) * 1e-6;
  const double noise = joint.prismatic ? config_.step_noise_m : config_.step_noise_rad;
  if (std::abs(delta) > config_.step_speed_factor * joint.max_velocity * interval_s + noise) {
    raise(PlausibilityFault::EncoderStep, static_cast<int>(j), in.now_us);
    return;
  }
  if (raw == s.raw) {
    ++s.frozen;
    const double travel = joint.prismatic ? config_.stuck_travel_m : config_.stuck_travel_rad;
    // A joint standing on its end stop cannot move on, whatever its command asks.
    double plus = s.expected_plus_since_change;
    double minus = s.expected_minus_since_change;
    if (!joint.continuous) {
      plus = std::min(plus, std::max(joint.position_max - raw, 0.0));
      minus = std::min(minus, std::max(raw - joint.position_min, 0.0));
    }
    if (s.frozen >= config_.stuck_samples && plus + minus > travel) {
      raise(PlausibilityFault::EncoderStuck, static_cast<int>(j), in.now_us);
      return;
    }
  } else {
    s.frozen = 0;
    s.expected_plus_since_change = 0.0;
    s.expected_minus_since_change = 0.0;
  }
  s.raw = raw;
  s.sample_after_us = previous_cycle_us;
  s.q += delta;
}

void PlausibilityMonitor::check_window(std::size_t j, std::int64_t now_us) noexcept {
  JointState& s = state_[j];
  if (!s.have_sample) return;
  const PlausibilityJoint& joint = joints_[j];
  if (s.count > 0) {
    // The oldest entry within the window: the measured travel since then against the model's.
    const std::size_t oldest = (s.head + kWindowEntries - s.count) % kWindowEntries;
    std::size_t k = oldest;
    for (std::size_t i = 0; i < s.count; ++i, k = (k + 1) % kWindowEntries) {
      if (now_us - s.ring[k].t_us <= config_.window_us) break;
    }
    const Entry& then = s.ring[k];
    if (now_us - then.t_us <= config_.window_us) {
      const double travel = s.q - then.q;
      const double tolerance = joint.prismatic ? config_.tolerance_m : config_.tolerance_rad;
      double lo = s.lo - then.lo;
      double hi = s.hi - then.hi;
      if (!joint.continuous) {
        // The least travel toward an end stop is at most the room the joint had to it: a joint
        // driven onto its end stop (an overshoot of the setpoint by the actuator's lag) stands
        // there, as it must.
        lo = std::min(lo, std::max(joint.position_max - then.q, 0.0));
        hi = std::max(hi, std::min(joint.position_min - then.q, 0.0));
      }
      const double below = lo - travel;  // > 0: less far in + than the least the model allows
      const double above = travel - hi;  // > 0: further in + than the most the model allows
      peak_window_ratio_ = std::max(peak_window_ratio_, std::max(below, above) / tolerance);
      if (below > tolerance || above > tolerance) {
        // Short of a motion the command asks for, without reversing, is not following; beyond it,
        // against it, or motion where none was commanded is a runaway.
        const bool short_of_plus = below > tolerance && lo > 0.0 && travel >= -tolerance;
        const bool short_of_minus = above > tolerance && hi < 0.0 && travel <= tolerance;
        raise(short_of_plus || short_of_minus ? PlausibilityFault::JointNotFollowing : PlausibilityFault::JointRunaway,
              static_cast<int>(j), now_us);
        return;
      }
    }
  }
}

void PlausibilityMonitor::check_drift(std::size_t j, bool fresh, std::int64_t now_us) noexcept {
  JointState& s = state_[j];
  if (!s.have_sample) return;
  const PlausibilityJoint& joint = joints_[j];
  // Within the tolerance of an end stop the model's bounds take no speed into the stop (the joint
  // stands there) while the joint may still run the rest of the way onto it: the sums start again
  // outside.
  const double tolerance_stop = joint.prismatic ? config_.tolerance_m : config_.tolerance_rad;
  const bool at_end_stop = !joint.continuous && (s.q <= joint.position_min + tolerance_stop || s.q >= joint.position_max - tolerance_stop);
  if (!s.drift_ready || at_end_stop) {
    s.drift_ready = true;
    s.shortfall_plus = 0.0;
    s.shortfall_minus = 0.0;
  } else if (fresh) {
    // The step since the last sample: the sample (the machine at the previous SYNC) against the
    // model's travel up to then, as in the window. Where the joint does better than the least the
    // sum falls, never below 0, so slack earned before a lie began does not hide it. A cycle
    // without a sample adds its model travel to the next one's.
    const double travel = s.q - s.drift_q;
    const double least_plus = s.lo - s.drift_lo;
    const double least_minus = s.hi - s.drift_hi;
    s.shortfall_plus = s.v_lo > 0.0 ? std::max(0.0, s.shortfall_plus + least_plus - travel) : 0.0;
    s.shortfall_minus = s.v_hi < 0.0 ? std::max(0.0, s.shortfall_minus + travel - least_minus) : 0.0;
  } else {
    return;
  }
  s.drift_q = s.q;
  s.drift_lo = s.lo;
  s.drift_hi = s.hi;
  const double tolerance = joint.prismatic ? config_.drift_tolerance_m : config_.drift_tolerance_rad;
  const double shortfall = std::max(s.shortfall_plus, s.shortfall_minus);
  peak_drift_ratio_ = std::max(peak_drift_ratio_, shortfall / tolerance);
  // A value that repeats is the stuck check's to judge (5 samples); the sum carries on meanwhile.
  if (shortfall > tolerance && s.frozen == 0) raise(PlausibilityFault::JointNotFollowing, static_cast<int>(j), now_us);
}

void PlausibilityMonitor::check_valve(const PlausibilityInputs& in, double dt_s) noexcept {
  // The model follows every command sent, whether or not the valve's reports arrive: a gap in its
  // status (a stalled node, a late bus) must not restart the model from zero, or the first fresh
  // report after it would read as a valve that does not follow.
  const double ramp = config_.valve_ramp_per_s * dt_s;
  for (std::size_t j = 0; j < n_; ++j) {
    JointState& s = state_[j];
    // The report answers the previous cycle's SYNC: it may show the command one step behind.
    s.spool_model_prev = s.spool_model;
    s.spool_model += std::clamp(in.valve_commanded[j] - s.spool_model, -ramp, ramp);
  }
  if (!in.valve_active) {
    counter_known_ = false;
    for (std::size_t j = 0; j < n_; ++j) state_[j].mismatch_since_us = -1;
    return;
  }
  for (std::size_t j = 0; j < n_; ++j) {
    JointState& s = state_[j];
    const double error = std::min(std::abs(in.valve_applied[j] - s.spool_model), std::abs(in.valve_applied[j] - s.spool_model_prev));
    if (error <= config_.valve_tolerance) {
      s.mismatch_since_us = -1;
    } else if (s.mismatch_since_us < 0) {
      s.mismatch_since_us = in.now_us;
    } else if (in.now_us - s.mismatch_since_us >= config_.valve_mismatch_us) {
      raise(PlausibilityFault::ValveNotObeying, static_cast<int>(j), in.now_us);
      return;
    }
  }
  if (!counter_known_ || in.valve_command_counter != last_counter_) {
    counter_known_ = true;
    last_counter_ = in.valve_command_counter;
    counter_change_us_ = in.now_us;
    sent_at_change_ = in.valve_commands_sent;
    return;
  }
  // Commands keep going out and the node counts none of them.
  if (in.now_us - counter_change_us_ >= config_.valve_counter_timeout_us && in.valve_commands_sent - sent_at_change_ >= 5U) {
    raise(PlausibilityFault::ValveNotObeying, -1, in.now_us);
  }
}

const PlausibilityResult& PlausibilityMonitor::update(const PlausibilityInputs& in) noexcept {
  if (result_.fault != PlausibilityFault::None) return result_;
  const double dt_s = started_ ? static_cast<double>(std::max<std::int64_t>(in.now_us - last_us_, 0)) * 1e-6 : 0.0;
  // The cycle before this one (this one on the very first call).
  previous_cycle_us_ = started_ ? last_us_ : in.now_us;
  started_ = true;
  last_us_ = in.now_us;
  const bool push = in.now_us - last_push_us_ >= push_every_us_;
  for (std::size_t j = 0; j < n_; ++j) {
    JointState& s = state_[j];
    const Travel step = update_models(s, joints_[j], in.drive_enabled ? in.commanded_velocity[j] : 0.0, dt_s);
    check_samples(j, in);
    if (result_.fault != PlausibilityFault::None) return result_;
    // The sample read now shows the machine at the previous SYNC: it is compared with the model's
    // travel up to then, and this cycle's step is added after.
    check_window(j, in.now_us);
    if (result_.fault != PlausibilityFault::None) return result_;
    check_drift(j, in.valid[j] && in.updated[j], in.now_us);
    if (result_.fault != PlausibilityFault::None) return result_;
    if (push && s.have_sample) {
      s.ring[s.head] = {in.now_us, s.q, s.lo, s.hi};
      s.head = (s.head + 1) % kWindowEntries;
      s.count = std::min(s.count + 1, kWindowEntries);
    }
    s.lo += step.lo;
    s.hi += step.hi;
  }
  if (push) last_push_us_ = in.now_us;
  check_valve(in, dt_s);
  return result_;
}

InclinometerCheck::InclinometerCheck(int joint, const InclinometerCheckConfig& config) : config_(config) {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(config.noise_sigma_rad) || !positive(config.sigma_factor) || !(config.accuracy_rad >= 0.0) ||
      !std::isfinite(config.offset_rad) || !positive(config.filter_s) || !(config.timing_tolerance_s >= 0.0) ||
      config.average_samples < 1 || config.average_samples > kMaxAverage || joint >= static_cast<int>(kMaxJoints)) {
    throw std::invalid_argument("InclinometerCheck: noise, sigma factor and filter must be > 0, accuracy and timing tolerance >= 0, "
                                "average_samples 1.." + std::to_string(kMaxAverage) + ", the joint below " + std::to_string(kMaxJoints));
  }
  result_.joint = joint < 0 ? -1 : joint;
}

void InclinometerCheck::restart() noexcept {
  have_encoder_ = false;
  encoder_fresh_ = false;
  angle_fresh_ = false;
  count_ = 0;
  head_ = 0;
  speed_rad_s_ = 0.0;
}

void InclinometerCheck::reset() noexcept {
  const int joint = result_.joint;
  result_ = {};
  result_.joint = joint;
  restart();
  judging_ = false;
  judged_ = 0;
  peak_ratio_ = 0.0;
}

const InclinometerResult& InclinometerCheck::update(const InclinometerInputs& in) noexcept {
  judging_ = false;
  if (result_.joint < 0 || result_.disagrees) return result_;
  if (!in.encoder_valid || !in.angle_valid || !std::isfinite(in.encoder_rad) || !std::isfinite(in.angle_rad)) {
    // Nothing to compare, and the history must not bridge the gap.
    restart();
    return result_;
  }
  if (in.encoder_updated || !have_encoder_) {
    if (!have_encoder_) {
      // The sensor's filter has long settled on a joint that stood or moved smoothly: start it here.
      have_encoder_ = true;
      predicted_rad_ = in.encoder_rad;
      speed_rad_s_ = 0.0;
    } else {
      const double dt_s = static_cast<double>(std::max<std::int64_t>(in.now_us - last_encoder_us_, 1)) * 1e-6;
      predicted_rad_ += (in.encoder_rad - predicted_rad_) * (1.0 - std::exp(-dt_s / config_.filter_s));
      const double speed = std::abs(in.encoder_rad - last_encoder_rad_) / dt_s;
      // The larger of this step's and the last one's: the allowance must not drop for one quiet sample.
      speed_rad_s_ = std::max(speed, 0.5 * speed_rad_s_);
    }
    last_encoder_rad_ = in.encoder_rad;
    last_encoder_us_ = in.now_us;
    encoder_fresh_ = true;
  }
  if (in.angle_updated) {
    angle_rad_ = in.angle_rad;
    angle_fresh_ = true;
  }
  // A pair: both sources have answered since the last one (the same SYNC, or one period apart).
  if (!(encoder_fresh_ && angle_fresh_)) return result_;
  encoder_fresh_ = false;
  angle_fresh_ = false;
  residuals_[static_cast<std::size_t>(head_)] = angle_rad_ - config_.offset_rad - predicted_rad_;
  head_ = (head_ + 1) % config_.average_samples;
  count_ = std::min(count_ + 1, config_.average_samples);
  if (count_ < config_.average_samples) return result_;
  double mean = 0.0;
  for (int k = 0; k < count_; ++k) mean += residuals_[static_cast<std::size_t>(k)];
  mean /= static_cast<double>(count_);
  const double threshold = config_.sigma_factor * config_.noise_sigma_rad / std::sqrt(static_cast<double>(count_)) +
                           config_.accuracy_rad + config_.timing_tolerance_s * speed_rad_s_;
  judging_ = true;
  ++judged_;
  peak_ratio_ = std::max(peak_ratio_, std::abs(mean) / threshold);
  if (std::abs(mean) > threshold) {
    result_.disagrees = true;
    result_.detected_us = in.now_us;
    result_.residual_rad = mean;
    result_.threshold_rad = threshold;
  }
  return result_;
}

}  // namespace mgc::guidance
