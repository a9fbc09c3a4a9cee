// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mgc/limits.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/machine_tags.hpp"

//! Plausibility of the machine's sensors and actuators (docs/diagnostics.md): every cycle, each
//! joint's measured motion against what its valve command and a bracketing actuator model allow,
//! each encoder's samples against what an actuator can do, and the valve node's own account of its
//! spools and commands against what the controller sent. A detection is a named fault with the
//! joint it names and the time it was seen; the first one is latched until reset().
namespace mgc::guidance {

enum class PlausibilityFault : std::uint8_t {
  None = 0,
  EncoderOutOfRange,  //!< a value beyond the joint's end stops (plus a margin)
  EncoderStep,        //!< a step between two samples that no actuator can make in their interval
  EncoderStuck,       //!< the value repeats exactly while the commanded motion must change it
  JointNotFollowing,  //!< the joint moves less than its command allows (jammed, valve, or encoder)
  JointRunaway,       //!< the joint moves more than its command allows, or moves while commanded to stop
  ValveNotObeying,    //!< the valve's applied spools or its command counter do not follow the commands
  PoseDisagrees,      //!< a machine tag's fixes disagree with forward kinematics of the encoders (MachineTagCheck)
  AngleDisagrees,     //!< the boom inclinometer disagrees with the boom's encoder (InclinometerCheck)
};
[[nodiscard]] const char* to_string(PlausibilityFault fault) noexcept;

//! One joint as the monitor models it (from the machine model's joint limits).
struct PlausibilityJoint {
  double max_velocity = 0.0;      //!< at full valve command [rad/s | m/s]
  double max_acceleration = 0.0;  //!< [rad/s^2 | m/s^2]
  double position_min = 0.0;      //!< end stop [rad | m]
  double position_max = 0.0;      //!< end stop [rad | m]
  bool continuous = false;        //!< a slew ring: no end stops, positions compared modulo a turn
  bool prismatic = false;         //!< tolerances in metres rather than radians
};

//! The bounds of the actuator model and the thresholds; defaults and their reasons in
//! docs/diagnostics.md.
struct PlausibilityConfig {
  //! The joint's speed for a command may be this fraction off the commanded one (load, oil
  //! temperature, valve calibration). [-]
  double gain_tolerance = 0.25;
  //! Up to this fraction of max velocity may be lost in (or added by a mis-calibrated) deadband. [-]
  double deadband_fraction = 0.05;
  //! The joint follows its command with a first-order lag somewhere in [lag_min_s, lag_max_s]
  //! (valve ramp, transport delay and the actuator's own lag together). [s]
  double lag_min_s = 0.05;
  double lag_max_s = 0.40;
  //! The measured travel over this window is compared with the model's travel bracket. [µs]
  std::int64_t window_us = 300'000;
  //! Travel beyond the bracket that counts as a fault. [rad]
  double tolerance_rad = 0.15 * 3.14159265358979323846 / 180.0;
  double tolerance_m = 0.02;  //!< the same for a prismatic joint [m]
  //! A slow lie that the window's tolerance hides: the shortfall against the model's least travel,
  //! accumulated for as long as the model asks for motion one way (a CUSUM: it falls back toward 0
  //! where the joint does better than the least, and restarts when the model no longer asks for
  //! that motion), beyond this is JointNotFollowing. Encoder noise (0.5 counts) and the sample's
  //! timing against the model stay far below it; they do not add up. [rad | m]
  double drift_tolerance_rad = 0.1 * 3.14159265358979323846 / 180.0;
  double drift_tolerance_m = 0.01;
  //! A value this far beyond an end stop is out of range. [rad | m]
  double range_margin_rad = 0.5 * 3.14159265358979323846 / 180.0;
  double range_margin_m = 0.05;
  //! A step between samples beyond step_speed_factor × max velocity × (the longest their SYNCs can
  //! be apart + step_time_allowance_us), plus step_noise, cannot be motion. The SYNCs are bounded by
  //! the loop's own cycle times, not by the receive stamps, which a late cycle squeezes together
  //! (docs/diagnostics.md). [- | µs | rad | m]
  double step_speed_factor = 1.5;
  std::int64_t step_time_allowance_us = 10'000;
  double step_noise_rad = 0.005 * 3.14159265358979323846 / 180.0;
  double step_noise_m = 0.0005;
  //! An encoder repeating its value over this many samples while the model's least travel since the
  //! last change exceeds stuck_travel is stuck. [samples | rad | m]
  int stuck_samples = 5;
  double stuck_travel_rad = 0.02 * 3.14159265358979323846 / 180.0;
  double stuck_travel_m = 0.002;
  //! An applied spool this far from the commanded one (after the valve's documented ramp) for
  //! valve_mismatch_us does not obey. [- | µs]
  double valve_tolerance = 0.05;
  std::int64_t valve_mismatch_us = 50'000;
  double valve_ramp_per_s = 10.0;  //!< the valve node's set-point ramp (docs/protocol.md) [1/s]
  //! The valve's command counter standing still for this long while commands are sent. [µs]
  std::int64_t valve_counter_timeout_us = 100'000;
};

//! One cycle's inputs: the Hal's snapshot and the loop's previous command, mapped by the loop.
struct PlausibilityInputs {
  std::int64_t now_us = 0;
  std::array<double, kMaxJoints> position{};       //!< last decoded sample [rad | m]
  std::array<bool, kMaxJoints> valid{};            //!< the Hal's JointReading::valid
  std::array<bool, kMaxJoints> updated{};          //!< a new sample this cycle
  //! The velocity the loop commanded in its previous cycle, which the valve applies now. [rad/s | m/s]
  std::array<double, kMaxJoints> commanded_velocity{};
  //! The commands can move the machine: pilot pressure is on and the valve does not say it is
  //! idle (a valve whose reports are late is taken at its commands). Otherwise the model's input
  //! is zero.
  bool drive_enabled = false;
  //! The valve node reports Active with a fresh status: its applied spools and counter are checked.
  bool valve_active = false;
  std::array<double, kMaxJoints> valve_applied{};    //!< spools the valve reports in force [-1, 1]
  std::array<double, kMaxJoints> valve_commanded{};  //!< spools the loop last sent, same scale [-1, 1]
  std::uint8_t valve_command_counter = 0;            //!< the valve's count of accepted commands, mod 256
  std::uint32_t valve_commands_sent = 0;             //!< command writes that went out [-]
};

struct PlausibilityResult {
  PlausibilityFault fault = PlausibilityFault::None;
  int joint = -1;               //!< the joint it names; -1 for the valve's counter
  std::int64_t detected_us = 0;  //!< when it was seen [µs]
  //! The valve is in doubt (it does not obey, or a joint moves beyond its command): stopping
  //! through it cannot be trusted, so the loop cuts pilot pressure at once.
  bool cut_required = false;
};

class PlausibilityMonitor {
 public:
  //! One entry per joint (1..kMaxJoints). Start-up only: throws std::invalid_argument for a joint
  //! without positive max velocity and acceleration, or a configuration out of range.
  PlausibilityMonitor(std::span<const PlausibilityJoint> joints, const PlausibilityConfig& config = {});

  //! One cycle. RT-safe: no allocation, no throw. Returns the latched result.
  const PlausibilityResult& update(const PlausibilityInputs& in) noexcept;

  //! Forgets the latched fault and the history: after an operator's acknowledgement, at rest.
  void reset() noexcept;

  [[nodiscard]] const PlausibilityResult& result() const noexcept { return result_; }
  //! Largest share of its threshold any window check reached since reset (1 = at the threshold):
  //! the margin the motion checks kept against a false alarm. [-]
  [[nodiscard]] double peak_window_ratio() const noexcept { return peak_window_ratio_; }
  //! Largest share of its tolerance the accumulated shortfall reached since reset. [-]
  [[nodiscard]] double peak_drift_ratio() const noexcept { return peak_drift_ratio_; }
  [[nodiscard]] const PlausibilityConfig& config() const noexcept { return config_; }

 private:
  static constexpr std::size_t kWindowEntries = 40;
  struct Entry {
    std::int64_t t_us = 0;
    double q = 0.0;       //!< measured, unwrapped [rad | m]
    double lo = 0.0;      //!< model's least travel since start [rad | m]
    double hi = 0.0;      //!< model's most travel since start [rad | m]
  };
  struct JointState {
    bool have_sample = false;
    double raw = 0.0;                 //!< last sample as decoded [rad | m]
    //! The cycle before the one that read it: its SYNC was sent no earlier (a sample answers the
    //! SYNC of the cycle that reads it or of the one before). [µs]
    std::int64_t sample_after_us = 0;
    double q = 0.0;                   //!< unwrapped measured position [rad | m]
    double v_lo = 0.0;                //!< least velocity the actuator model allows [rad/s | m/s]
    double v_hi = 0.0;                //!< most velocity the actuator model allows [rad/s | m/s]
    double lo = 0.0;                  //!< integral of the bracket's lower velocity [rad | m]
    double hi = 0.0;                  //!< integral of the bracket's upper velocity [rad | m]
    int frozen = 0;                   //!< consecutive samples equal to the one before
    //! The model's least travel in + and in - since the value last changed (each >= 0). [rad | m]
    double expected_plus_since_change = 0.0;
    double expected_minus_since_change = 0.0;
    std::array<Entry, kWindowEntries> ring{};
    std::size_t head = 0;             //!< next slot
    std::size_t count = 0;
    double spool_model = 0.0;         //!< the valve's ramp applied to the commands [-]
    double spool_model_prev = 0.0;
    std::int64_t mismatch_since_us = -1;
    //! The accumulated shortfall against the model's least travel in + and in - (each >= 0), and
    //! the measured position and model integrals it was last brought up to. [rad | m]
    bool drift_ready = false;
    double shortfall_plus = 0.0;
    double shortfall_minus = 0.0;
    double drift_q = 0.0;
    double drift_lo = 0.0;
    double drift_hi = 0.0;
  };

  //! The bracket's least and most travel over one step. [rad | m]
  struct Travel {
    double lo = 0.0;
    double hi = 0.0;
  };

  void raise(PlausibilityFault fault, int joint, std::int64_t now_us) noexcept;
  //! Advances the velocity bounds over dt_s on this command; returns the bracket's travel over the step.
  Travel update_models(JointState& s, const PlausibilityJoint& joint, double command, double dt_s) noexcept;
  void check_samples(std::size_t j, const PlausibilityInputs& in) noexcept;
  void check_window(std::size_t j, std::int64_t now_us) noexcept;
  void check_drift(std::size_t j, bool fresh, std::int64_t now_us) noexcept;
  void check_valve(const PlausibilityInputs& in, double dt_s) noexcept;

  std::array<PlausibilityJoint, kMaxJoints> joints_{};
  std::size_t n_ = 0;
  PlausibilityConfig config_;
  std::array<JointState, kMaxJoints> state_{};
  PlausibilityResult result_{};
  bool started_ = false;
  std::int64_t last_us_ = 0;
  std::int64_t previous_cycle_us_ = 0;  //!< the cycle before the one being checked [µs]
  std::int64_t push_every_us_ = 0;
  std::int64_t last_push_us_ = 0;
  bool counter_known_ = false;
  std::uint8_t last_counter_ = 0;
  std::int64_t counter_change_us_ = 0;
  std::uint32_t sent_at_change_ = 0;
  double peak_window_ratio_ = 0.0;
  double peak_drift_ratio_ = 0.0;
};

//! The machine's own UWB tags against forward kinematics of its encoders (docs/diagnostics.md
//! "Machine tags"): a second, independent source of the pose, which sees an encoder that is stuck
//! or lies slowly while its joint holds or moves. Defaults and their reasons in the doc.
struct MachineTagCheckConfig {
  //! A fix is judged against sigma_factor × its 1-sigma (quality × 10 cm, docs/protocol.md). [-]
  double sigma_factor = 2.0;
  //! What the model may be off by at the tag: boom deflection under load, geometry and mounting
  //! tolerances. The simulator's machine is rigid; a real one sets its own deflection here. [m]
  double model_allowance_m = 0.15;
  //! A fix reaches the controller between fix_age_min_us and fix_age_max_us after the tag was
  //! ranged (docs/protocol.md: under 50 ms). It is compared with the encoders at the middle; half
  //! the span plus encoder_age_us (a sample answers the previous SYNC) is the time offset. [µs]
  std::int64_t fix_age_min_us = 0;
  std::int64_t fix_age_max_us = 50'000;
  std::int64_t encoder_age_us = 10'000;
  //! This many consecutive judged fixes beyond their threshold are a finding. At 10 Hz: 0.3 s
  //! from the first to the last. [-]
  int disagree_fixes = 4;
  //! No fix of a tag for this long: stale (docs/protocol.md); an alert, and the tag is not judged. [µs]
  std::int64_t stale_us = 500'000;
};

//! One tag on the machine, resolved against the model (planning::resolve_tag_mount).
struct MachineTag {
  std::uint8_t id = 0;
  planning::TagMount mount{};
  Eigen::Vector3d local_m = Eigen::Vector3d::Zero();  //!< in the mount's axes [m]
};

//! A tag's latest fix, as the Hal's snapshot holds it (TagReading).
struct MachineTagFix {
  std::uint8_t id = 0;
  bool updated = false;                  //!< a new fix this cycle
  std::array<double, 3> position_m{};    //!< site frame [m]
  std::uint8_t quality = 0;              //!< 1..14: 1-sigma <= quality × 10 cm; 15 unknown; 0 no fix
  std::int64_t t_us = 0;                 //!< receive time [µs]
};

//! One cycle's inputs.
struct MachineTagInputs {
  std::int64_t now_us = 0;
  bool joints_valid = false;                      //!< every joint has a valid sample
  std::int64_t joints_t_us = 0;                   //!< receive time of the oldest of them [µs]
  std::array<double, kMaxJoints> position{};      //!< measured, as the model takes them [rad | m]
  std::span<const MachineTagFix> fixes;           //!< every tag the Hal tracks; others' are ignored
};

struct MachineTagResult {
  bool disagrees = false;        //!< latched until reset()
  int tag_id = -1;               //!< the tag that disagrees
  //! Bit j: joint j moves that tag (the joints whose encoders it checks).
  std::uint32_t joints_seen = 0;
  std::int64_t detected_us = 0;  //!< [µs]
  double residual_m = 0.0;       //!< the last disagreeing fix's distance from its prediction [m]
  double threshold_m = 0.0;      //!< and its threshold [m]
};

class MachineTagCheck {
 public:
  static constexpr std::size_t kHistory = 64;  //!< encoder samples kept to meet a late fix: 0.64 s at 100 Hz

  //! The model must outlive the check. Start-up only: throws std::invalid_argument for more than
  //! planning::kMaxMachineTags tags, an unresolved mount, or a configuration out of range.
  MachineTagCheck(const planning::MachineModel& model, std::span<const MachineTag> tags, const MachineTagCheckConfig& config = {});

  //! One cycle. RT-safe: no allocation, no throw. Returns the latched result.
  const MachineTagResult& update(const MachineTagInputs& in) noexcept;

  //! Forgets the latched finding, the counts and the history: after an operator's acknowledgement.
  void reset() noexcept;

  [[nodiscard]] const MachineTagResult& result() const noexcept { return result_; }
  [[nodiscard]] std::size_t num_tags() const noexcept { return n_; }
  //! Tags without a fix for stale_us (never seen counts from the first update). [-]
  [[nodiscard]] std::size_t stale_count() const noexcept { return stale_count_; }
  //! The first stale tag's id, or -1.
  [[nodiscard]] int stale_tag() const noexcept { return stale_tag_; }
  //! Fixes judged and fixes not judged (quality unknown, no encoder sample near their time). [-]
  [[nodiscard]] std::uint64_t judged() const noexcept { return judged_; }
  [[nodiscard]] std::uint64_t not_judged() const noexcept { return not_judged_; }
  //! Largest residual/threshold of any judged fix since reset (1 = at the threshold). [-]
  [[nodiscard]] double peak_ratio() const noexcept { return peak_ratio_; }
  [[nodiscard]] const MachineTagCheckConfig& config() const noexcept { return config_; }

 private:
  struct Sample {
    std::int64_t t_us = 0;
    planning::JointVector q;
  };
  struct TagState {
    MachineTag tag{};
    std::int64_t last_fix_us = 0;  //!< 0: none yet
    int disagreeing = 0;           //!< consecutive judged fixes beyond their threshold
  };

  //! Judges one fix of tag k; false when it could not be judged.
  bool judge(TagState& tag, const MachineTagFix& fix, std::int64_t now_us) noexcept;

  const planning::MachineModel& model_;
  MachineTagCheckConfig config_;
  std::array<TagState, planning::kMaxMachineTags> tags_{};
  std::size_t n_ = 0;
  std::array<Sample, kHistory> history_{};
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  planning::Kinematics kinematics_{};
  MachineTagResult result_{};
  bool started_ = false;
  std::int64_t start_us_ = 0;
  std::size_t stale_count_ = 0;
  int stale_tag_ = -1;
  std::uint64_t judged_ = 0;
  std::uint64_t not_judged_ = 0;
  double peak_ratio_ = 0.0;
};

//! The boom's inclinometer against the boom's encoder (docs/diagnostics.md "Boom inclinometer"):
//! a second source of the one angle that the closed loop cannot check, because the loop follows
//! the encoder and any lie in it moves the true boom the other way. Defaults and their reasons in
//! the doc.
struct InclinometerCheckConfig {
  double noise_sigma_rad = 0.02 * 3.14159265358979323846 / 180.0;  //!< the inclinometer's 1-sigma per sample [rad]
  //! The mean residual of the last average_samples pairs is judged against sigma_factor × the
  //! mean's 1-sigma plus the allowances. [- | samples]
  double sigma_factor = 4.0;
  int average_samples = 5;
  //! What the two may differ by at rest: the sensor's accuracy, its calibration against the joint
  //! and the link's deflection at the mount. [rad]
  double accuracy_rad = 0.05 * 3.14159265358979323846 / 180.0;
  //! The inclinometer's reading less the joint's angle on a level machine (its calibration). [rad]
  double offset_rad = 0.0;
  //! The sensor's output filter (first order, set on the device) and how far the true one may be
  //! off it, plus the skew between the two samples compared: times the joint's speed. [s]
  double filter_s = 0.02;
  double timing_tolerance_s = 0.02;
};

struct InclinometerInputs {
  std::int64_t now_us = 0;
  bool encoder_valid = false;    //!< the joint's encoder sample may be used (JointReading::valid)
  bool encoder_updated = false;  //!< a new sample this cycle
  double encoder_rad = 0.0;
  bool angle_valid = false;      //!< the inclinometer's sample may be used
  bool angle_updated = false;
  double angle_rad = 0.0;
};

struct InclinometerResult {
  bool disagrees = false;       //!< latched until reset()
  int joint = -1;               //!< the joint whose link the inclinometer measures
  std::int64_t detected_us = 0;  //!< [µs]
  double residual_rad = 0.0;    //!< the disagreeing mean residual [rad]
  double threshold_rad = 0.0;   //!< and its threshold [rad]
};

class InclinometerCheck {
 public:
  static constexpr int kMaxAverage = 32;

  //! joint: the joint whose link carries the inclinometer (-1: none; update() then does nothing).
  //! Start-up only: throws std::invalid_argument for a configuration out of range.
  InclinometerCheck(int joint, const InclinometerCheckConfig& config = {});

  //! One cycle. RT-safe: no allocation, no throw. Returns the latched result.
  const InclinometerResult& update(const InclinometerInputs& in) noexcept;

  //! Forgets the latched finding and the history: after an operator's acknowledgement.
  void reset() noexcept;

  [[nodiscard]] bool enabled() const noexcept { return result_.joint >= 0; }
  [[nodiscard]] const InclinometerResult& result() const noexcept { return result_; }
  //! Both sources valid and compared within the last cycle. [-]
  [[nodiscard]] bool judging() const noexcept { return judging_; }
  //! Pairs judged since reset. [-]
  [[nodiscard]] std::uint64_t judged() const noexcept { return judged_; }
  //! Largest |mean residual| / threshold since reset (1 = at the threshold). [-]
  [[nodiscard]] double peak_ratio() const noexcept { return peak_ratio_; }
  [[nodiscard]] const InclinometerCheckConfig& config() const noexcept { return config_; }

 private:
  void restart() noexcept;

  InclinometerCheckConfig config_;
  InclinometerResult result_{};
  bool have_encoder_ = false;
  double predicted_rad_ = 0.0;     //!< the encoder through the sensor's filter [rad]
  double last_encoder_rad_ = 0.0;
  std::int64_t last_encoder_us_ = 0;
  double speed_rad_s_ = 0.0;       //!< the encoder's speed, largest of the last two steps [rad/s]
  bool encoder_fresh_ = false;     //!< an encoder sample since the last pair judged
  bool angle_fresh_ = false;
  double angle_rad_ = 0.0;
  std::array<double, kMaxAverage> residuals_{};
  int count_ = 0;
  int head_ = 0;
  bool judging_ = false;
  std::uint64_t judged_ = 0;
  double peak_ratio_ = 0.0;
};

}  // namespace mgc::guidance
