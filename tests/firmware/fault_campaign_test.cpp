// SPDX-License-Identifier: Apache-2.0
// The fault and attack campaign against the controller, in stepped time on the in-process bus: the
// thesis lift, each of the simulator's device faults and each attack on the bus injected while the
// boom moves at speed. Every outcome is measured in the simulator's true state, not in what the
// controller believes: the fault named within its detection time, the true machine at rest, no
// contact, the load above the ground and the load chart never exceeded.
#include <catch2/catch.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "../sim/sim_rig.hpp"
#include <mgc/alert_t.hpp>

#include "mgc/firmware/controller.hpp"
#include "mgc/sim/truth_monitor.hpp"

using namespace mgc;
using test::SimRig;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr const char* kSite = "thesis-steel-frame.yaml";
constexpr int kBoom = 1;
constexpr int kSwing = 0;

//! A UWB tag on the boom tip, half a metre down the boom from the tip: it moves with the swing,
//! the luffing and the telescope, not with the hoist rope.
constexpr std::uint8_t kTipTag = 200;
void add_boom_tip_tag(planning::Scenario& s) {
  planning::MachineTagSpec tag;
  tag.id = kTipTag;
  tag.body = "boom_tip";
  tag.position_m = Eigen::Vector3d(0.0, 0.0, -0.5);
  s.machine_tags.push_back(tag);
}

//! The campaign's lift: the thesis crane from its pick with the boom raised to 70 deg, over the
//! frame to the set-down, then the boom luffed down at full speed to the thesis's goal, so that
//! the faults strike while the boom runs down towards the chart's minimum angle and the ground.
//! (From the thesis's own start the planner turns the long way round and the boom never luffs.)
void campaign_lift(planning::Scenario& s) { s.start[kBoom] = 70.0 * kDeg; }

//! The controller on the rig, with the referee's view of the true machine every 50 ms.
struct Lift {
  SimRig rig;
  firmware::Controller controller;
  firmware::ControllerOutput out{};
  //! The referee: mgc-sim's truth monitor on the simulator's true state, every 50 ms.
  std::unique_ptr<sim::TruthMonitor> truth;
  bool goal_sent = false;
  std::string log;
  //! When the supervisor first left EXECUTING for a stop or a fault, and why. [µs on the rig clock]
  std::int64_t stop_us = -1;
  guidance::TransitionReason stop_reason = guidance::TransitionReason::None;
  //! Cycles in which the snapshot carried an alert of the cut-off's failure.
  int cutoff_alert_cycles = 0;

  explicit Lift(sim::SimConfig config, bool machine_tags = false)
      : rig(kSite, std::move(config), "campaign",
            [machine_tags](planning::Scenario& s) {
              campaign_lift(s);
              if (machine_tags) add_boom_tip_tag(s);
            }),
        controller(rig.scenario, firmware::ControllerConfig{}) {
    truth = std::make_unique<sim::TruthMonitor>(rig.scenario);
    REQUIRE(truth->has_ground_clearance());
    REQUIRE(truth->has_load_chart());
    rig.calibrate_valves();
    rig.on_cycle = [this](const hal::SensorSnapshot& s) { cycle(s); };
  }

  [[nodiscard]] double sim_s() const { return static_cast<double>(rig.t_us - SimRig::kSimZeroUs) * 1e-6; }

  void cycle(const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) {
      commands.goal_request = true;
      goal_sent = true;
    }
    out = controller.step(s, rig.cycle_us, commands, false);
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    if (out.supervisor.transitioned) {
      log += std::to_string(sim_s()) + " s " + guidance::to_string(out.supervisor.state) + " (" +
             guidance::to_string(out.supervisor.reason) + ")\n";
      if (stop_us < 0 && goal_sent &&
          (out.supervisor.state == guidance::SupervisorState::Stopping || out.supervisor.state == guidance::SupervisorState::Fault)) {
        stop_us = s.t_us;
        stop_reason = out.supervisor.reason;
      }
    }
    const firmware::GuidanceSnapshot& g = controller.snapshot();
    for (int a = 0; a < g.num_alerts; ++a) {
      const firmware::SnapshotAlert& alert = g.alerts[static_cast<std::size_t>(a)];
      if (alert.severity == mgc::alert_t::SEVERITY_FAULT &&
          alert.value == static_cast<double>(static_cast<int>(guidance::TransitionReason::CutoffFailed))) {
        ++cutoff_alert_cycles;
      }
    }
    (void)truth->sample(*rig.sim);
  }

  // The true state's extremes since start, as the referee measured them.
  [[nodiscard]] double least_clearance_m() const { return truth->summary().least_clearance.distance_m; }
  [[nodiscard]] double least_load_above_ground_m() const { return truth->summary().least_ground_clearance_m; }
  [[nodiscard]] double peak_utilisation() const { return truth->summary().peak_chart_utilisation; }
  [[nodiscard]] bool outside_chart() const { return truth->summary().samples_outside_chart > 0; }

  [[nodiscard]] bool truly_at_rest() const {
    for (int j = 0; j < controller.num_joints(); ++j) {
      if (std::abs(rig.sim->truth().velocity[static_cast<std::size_t>(j)]) > 1e-6) return false;
    }
    return true;
  }
};

std::vector<std::string> joint_names() {
  std::vector<std::string> names;
  for (const auto& j : planning::io::load_scenario(test::scenario_path(kSite)).machine.joints) names.push_back(j.name);
  return names;
}

//! A simulation time at which the boom moves at over 60 % of its speed in the fault-free lift
//! (same seed, same plan: the faulted runs are identical up to their fault). [s]
double boom_moving_s() {
  static const double t_s = [] {
    Lift nominal(SimRig::quiet_config());
    const double v_max = nominal.controller.model().joints()[kBoom].max_velocity;
    for (int block = 0; block < 1200; ++block) {
      nominal.rig.run(100'000);
      // Half a cycle off the controller's grid: the run up to the fault ends before the cycle in
      // which a fault or an attack first acts.
      if (std::abs(nominal.rig.sim->truth().velocity[kBoom]) > 0.6 * v_max) return std::floor((nominal.sim_s() + 0.3) * 100.0) / 100.0 + 0.005;
    }
    return -1.0;
  }();
  REQUIRE(t_s > 0.0);
  return t_s;
}

//! Runs the lift with the faults until fault_s + after_s, and checks what every case shares: the
//! fault ends the lift in FAULT for `reason` within detect_s, no contact, load above ground, chart
//! kept, and the true machine at rest.
struct Outcome {
  double detect_s = 0.0;        //!< fault to the supervisor's stop or fault [s]
  double boom_travel_deg = 0.0; //!< true boom motion from the fault to the end [deg]
  double swing_travel_deg = 0.0;
};

Outcome expect_caught(Lift& lift, double fault_s, guidance::TransitionReason reason, double detect_s, double after_s = 15.0) {
  lift.rig.run(SimRig::at_sim_s(fault_s) - lift.rig.t_us);
  INFO(lift.log);
  REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
  const double boom_at_fault = lift.rig.sim->truth().position[kBoom];
  const double swing_at_fault = lift.rig.sim->truth().position[kSwing];
  lift.rig.run(static_cast<std::int64_t>(after_s * 1e6));
  INFO(lift.log);
  Outcome o;
  o.detect_s = static_cast<double>(lift.stop_us - SimRig::at_sim_s(fault_s)) * 1e-6;
  o.boom_travel_deg = std::abs(lift.rig.sim->truth().position[kBoom] - boom_at_fault) / kDeg;
  o.swing_travel_deg = std::abs(lift.rig.sim->truth().position[kSwing] - swing_at_fault) / kDeg;
  CAPTURE(o.detect_s, o.boom_travel_deg, o.swing_travel_deg, lift.least_clearance_m(), lift.least_load_above_ground_m(),
          lift.peak_utilisation());
  CHECK(lift.stop_reason == reason);
  CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
  CHECK(lift.controller.supervisor().reason() == reason);
  CHECK(lift.stop_us >= SimRig::at_sim_s(fault_s));
  CHECK(o.detect_s <= detect_s);
  CHECK(lift.truly_at_rest());
  CHECK(lift.least_clearance_m() > 0.0);
  CHECK(lift.least_load_above_ground_m() > 0.0);
  CHECK_FALSE(lift.outside_chart());
  CHECK(lift.peak_utilisation() <= 1.0);
  // The fault is an alert for the operator that names its device.
  const firmware::GuidanceSnapshot& g = lift.controller.snapshot();
  bool named = false;
  for (int i = 0; i < g.num_alerts; ++i) {
    const firmware::SnapshotAlert& a = g.alerts[static_cast<std::size_t>(i)];
    named = named || (a.severity == mgc::alert_t::SEVERITY_FAULT && a.value == static_cast<double>(static_cast<int>(reason)));
  }
  CHECK(named);
  WARN(guidance::to_string(reason) << ": detected " << o.detect_s << " s after the fault; boom travel " << o.boom_travel_deg
                                   << " deg, swing " << o.swing_travel_deg << " deg to rest");
  return o;
}

sim::SimConfig with_fault(const std::string& text) {
  sim::SimConfig c = SimRig::quiet_config();
  c.encoder_noise_counts = 0.5;  // a live encoder, as mgc-sim's default
  c.faults.push_back(sim::parse_machine_fault(text, planning::io::load_scenario(test::scenario_path(kSite)).machine.joints));
  return c;
}

}  // namespace

TEST_CASE("campaign: the fault-free lift raises no plausibility fault and keeps its margin", "[firmware][sim][campaign]") {
  sim::SimConfig config = SimRig::quiet_config();
  config.encoder_noise_counts = 0.5;
  Lift lift(config);
  for (int block = 0; block < 40 && lift.controller.stats().goals_reached == 0; ++block) lift.rig.run(5'000'000);
  INFO(lift.log);
  REQUIRE(lift.controller.stats().goals_reached == 1);
  CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::None);
  CHECK(lift.controller.stats().pilot_cuts == 0);
  CHECK(lift.controller.stats().plausibility_peak_ratio < 0.5);
  CHECK(lift.least_load_above_ground_m() > 0.0);
  CHECK(lift.peak_utilisation() <= 1.0);
  WARN("fault-free lift: plausibility peak ratio " << lift.controller.stats().plausibility_peak_ratio);
}

TEST_CASE("campaign: a stuck boom encoder is found within 0.3 s, the boom stopped", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  Lift lift(with_fault("encoder-stuck:boom_elevation@" + std::to_string(t)));
  const Outcome o = expect_caught(lift, t, guidance::TransitionReason::EncoderStuck, 0.3);
  CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::EncoderStuck);
  // The controlled stop at the deceleration limit from full speed takes the rest of the travel.
  CHECK(o.boom_travel_deg < 1.5);
}

TEST_CASE("campaign: a lying boom encoder, by a step and by a drift, is found within 0.3 s", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  SECTION("a 0.3 deg step") {
    Lift lift(with_fault("encoder-offset:boom_elevation@" + std::to_string(t) + ",offset=0.3"));
    (void)expect_caught(lift, t, guidance::TransitionReason::EncoderImplausible, 0.03);
  }
  SECTION("a drift of 2 deg/s") {
    Lift lift(with_fault("encoder-offset:boom_elevation@" + std::to_string(t) + ",rate=2"));
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    const double boom_at_fault = lift.rig.sim->truth().position[kBoom];
    lift.rig.run(15'000'000);
    INFO(lift.log);
    const double detect_s = static_cast<double>(lift.stop_us - SimRig::at_sim_s(t)) * 1e-6;
    CAPTURE(detect_s);
    // The motion checks or the boom inclinometer, whichever sees it first.
    const bool motion_fault = lift.stop_reason == guidance::TransitionReason::JointRunaway ||
                              lift.stop_reason == guidance::TransitionReason::JointNotFollowing ||
                              lift.stop_reason == guidance::TransitionReason::AngleDisagrees;
    CHECK(motion_fault);
    CHECK(detect_s <= 0.3);
    CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
    CHECK(lift.truly_at_rest());
    CHECK(lift.least_load_above_ground_m() > 0.0);
    CHECK(lift.peak_utilisation() <= 1.0);
    WARN("drift lie: " << guidance::to_string(lift.stop_reason) << " " << detect_s << " s after the fault, boom travel "
                                << std::abs(lift.rig.sim->truth().position[kBoom] - boom_at_fault) / kDeg << " deg");
  }
}

TEST_CASE("campaign: the boom inclinometer finds a boom-encoder drift the loop follows, and a lying inclinometer", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  SECTION("the encoder drifts at 0.65 of the boom's speed limit") {
    // Lift 183 of the campaign: the motion checks take the encoder's shortfall for a slow actuator.
    Lift lift(with_fault("encoder-offset:boom_elevation@" + std::to_string(t) + ",rate=0.67"));
    const Outcome o = expect_caught(lift, t, guidance::TransitionReason::AngleDisagrees, 0.3);
    CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::AngleDisagrees);
    CHECK(lift.controller.stats().plausibility_joint == kBoom);
    CHECK(o.boom_travel_deg < 1.5);
  }
  SECTION("the inclinometer drifts") {
    Lift lift(with_fault("encoder-offset:inclinometer@" + std::to_string(t) + ",rate=0.67"));
    (void)expect_caught(lift, t, guidance::TransitionReason::AngleDisagrees, 0.3);
  }
  SECTION("the inclinometer is stuck") {
    Lift lift(with_fault("encoder-stuck:inclinometer@" + std::to_string(t)));
    (void)expect_caught(lift, t, guidance::TransitionReason::AngleDisagrees, 0.3);
  }
}

TEST_CASE("campaign: a silent inclinometer leaves the lift to its goal, judged no more and counted", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  Lift lift(with_fault("heartbeat-lost:inclinometer@" + std::to_string(t)));
  // The operator is told: a sensing warning naming the boom, from the silence on, never before.
  const int boom = lift.controller.inclinometer_joint();
  REQUIRE(boom >= 0);
  double first_alert_s = -1.0;
  double oldest_age_s = 0.0;
  int alert_cycles_before = 0;
  const auto cycle = lift.rig.on_cycle;
  lift.rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    cycle(s);
    const firmware::GuidanceSnapshot& snap = lift.controller.snapshot();
    for (int a = 0; a < snap.num_alerts; ++a) {
      const firmware::SnapshotAlert& alert = snap.alerts[static_cast<std::size_t>(a)];
      if (alert.source != mgc::alert_t::SOURCE_SENSING || alert.value_unit != mgc::alert_t::UNIT_SECOND || alert.index != boom) continue;
      if (lift.sim_s() < t) ++alert_cycles_before;
      else if (first_alert_s < 0.0) first_alert_s = lift.sim_s();
      CHECK(alert.severity == mgc::alert_t::SEVERITY_WARN);
      oldest_age_s = std::max(oldest_age_s, alert.value);
    }
  };
  for (int block = 0; block < 40 && lift.controller.stats().goals_reached == 0; ++block) lift.rig.run(5'000'000);
  INFO(lift.log);
  CAPTURE(t, first_alert_s, oldest_age_s);
  CHECK(alert_cycles_before == 0);
  REQUIRE(first_alert_s >= t);
  // The Hal calls a device whose heartbeat stopped stale after its consumer time (250 ms after
  // the last heartbeat, which came up to 100 ms before the silence); the alert comes in that cycle.
  CHECK(first_alert_s - t <= 1e-6 * static_cast<double>(hal::BusTiming{}.device_heartbeat_timeout_us));
  // Its value is the age of the last valid sample: it grows with the silence.
  CHECK(oldest_age_s > lift.sim_s() - t - 0.2);
  const firmware::ControllerStats& st = lift.controller.stats();
  CHECK(st.goals_reached == 1);
  CHECK(st.plausibility_fault == guidance::PlausibilityFault::None);
  CHECK(st.inclinometer_judged > 1000);
  CHECK(st.inclinometer_unavailable_cycles > 100);
  CHECK(st.inclinometer_peak_ratio < 0.6);
  WARN("fault-free until the inclinometer fell silent: " << st.inclinometer_judged << " pairs judged, peak ratio " << st.inclinometer_peak_ratio);
}

TEST_CASE("campaign: a valve that ignores commands is found within 0.3 s and stopped through the cut-off", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  Lift lift(with_fault("valve-ignore@" + std::to_string(t)));
  const Outcome o = expect_caught(lift, t, guidance::TransitionReason::ValveNotObeying, 0.3);
  CHECK(lift.controller.stats().pilot_cuts >= 1);
  CHECK_FALSE(lift.rig.sim->truth().pilot_pressure);
  // The detection's travel plus the boom's stop from 80 % speed at its acceleration limit, as the
  // simulated actuator decelerates once its spool is neutral: 0.1 + 0.67 deg.
  CHECK(o.boom_travel_deg < 1.0);
}

TEST_CASE("campaign: a cut-off that does not cut is alerted at once, with the valve's own stop left", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  SECTION("with a lost encoder: the FAULT asks for the cut, pressure stays, the valve's stop holds") {
    sim::SimConfig config = with_fault("cutoff-fail@" + std::to_string(t));
    config.faults.push_back(sim::parse_fault("heartbeat-lost:swing@" + std::to_string(t), joint_names()));
    Lift lift(config);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    REQUIRE(lift.cutoff_alert_cycles == 0);
    lift.rig.run(15'000'000);
    INFO(lift.log);
    CHECK(lift.stop_reason == guidance::TransitionReason::EncoderMissing);
    CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
    CHECK_FALSE(lift.out.pilot_enable);
    CHECK(lift.rig.sim->truth().pilot_pressure);
    CHECK(lift.cutoff_alert_cycles > 0);
    CHECK(lift.truly_at_rest());
  }
  SECTION("with a valve that ignores commands: both channels failed, the operator told within 0.2 s") {
    sim::SimConfig config = with_fault("cutoff-fail@" + std::to_string(t));
    config.faults.push_back(sim::parse_fault("valve-ignore@" + std::to_string(t), joint_names()));
    Lift lift(config);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    lift.rig.run(1'000'000);
    INFO(lift.log);
    CHECK(lift.stop_reason == guidance::TransitionReason::ValveNotObeying);
    CHECK(lift.cutoff_alert_cycles > 0);
    CHECK(lift.rig.sim->truth().pilot_pressure);
    // Neither channel stops it: only the machine's own emergency stop is left.
    CHECK(std::abs(lift.rig.sim->truth().velocity[kBoom]) > 0.1 * lift.controller.model().joints()[kBoom].max_velocity);
  }
}

TEST_CASE("campaign: the cut-off node's heartbeat lost ends in a controlled stop and FAULT", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  Lift lift(with_fault("heartbeat-lost:cutoff@" + std::to_string(t)));
  (void)expect_caught(lift, t, guidance::TransitionReason::CutoffLost, 0.4);
}

TEST_CASE("campaign: forged encoder frames on the bus are refused as implausible, nothing moves for them", "[firmware][sim][campaign]") {
  const double t = boom_moving_s();
  struct Attack {
    const char* what;
    int joint;
    bool extreme;  //!< INT32_MAX - 1 counts instead of a plausible lie
  };
  for (const Attack attack : {Attack{"20 deg off on the swing", kSwing, false}, Attack{"INT32 extreme on the boom", kBoom, true}}) {
    CAPTURE(attack.what);
    Lift lift(with_fault("tag-noise:99@1000"));  // a fault that never starts: the same noise as the other cases
    const hal::BusPlan& plan = lift.rig.sim->plan();
    const std::int64_t start_us = SimRig::at_sim_s(t);
    const std::int64_t end_us = start_us + 2'000'000;
    lift.rig.before_read = [&] {
      if (lift.rig.t_us <= start_us || lift.rig.t_us > end_us) return;
      const double truth = lift.rig.sim->truth().position[static_cast<std::size_t>(attack.joint)];
      const auto lie = hal::pdo::si_to_counts(truth - 20.0 * kDeg, plan.encoders[static_cast<std::size_t>(attack.joint)].kind);
      const std::int32_t counts = attack.extreme ? INT32_MAX - 1 : lie.value;
      const auto frame = hal::pdo::encode_encoder_position({plan.encoders[static_cast<std::size_t>(attack.joint)].node_id, counts, 0});
      // Two per cycle: 200 frames per second, as the campaign sent them.
      (void)lift.rig.third_party->send(frame.value);
      (void)lift.rig.third_party->send(frame.value);
    };
    const Outcome o = expect_caught(lift, t, guidance::TransitionReason::EncoderImplausible, 0.03);
    // The swing stood still when the lie began: the lie moved it by nothing.
    CHECK(o.swing_travel_deg < 0.05);
  }
}

TEST_CASE("campaign: 24 randomized faults on the lift are found or stay within the target travel, the true machine at rest and clear", "[firmware][sim][campaign]") {
  // Draws by seed: the fault (a stuck encoder, a step lie, a drift lie on any joint, or a valve that
  // ignores commands), when it starts (2-40 s into the lift, moving or not), and the simulator's
  // noise seed. A fault on a joint at rest shows only once the joint must move; so the figure
  // is: found before the lift ends (or, not found, within the target's travel), the machine at
  // rest, and the true state within its limits.
  const std::vector<std::string> names = joint_names();
  int found = 0;
  int latent = 0;  //!< not found: a stuck encoder on a joint holding its position
  double worst_latent_m = 0.0;  //!< the largest true creep of such a joint (all prismatic here) [m]
  int runs = 0;
  double slowest_s = 0.0;
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    planning::Random random(seed);
    const auto joint = static_cast<std::size_t>(random.uniform() * static_cast<double>(names.size())) % names.size();
    const double start_s = 2.0 + 38.0 * random.uniform();
    const bool revolute = joint < 2;
    std::string text;
    switch (static_cast<int>(random.uniform() * 4.0)) {
      case 0: text = "encoder-stuck:" + names[joint]; break;
      case 1: text = "encoder-offset:" + names[joint] + "@S,offset=" + (revolute ? "0.4" : "0.05"); break;
      case 2: text = "encoder-offset:" + names[joint] + "@S,rate=" + (revolute ? "-1.5" : "0.2"); break;
      default: text = "valve-ignore"; break;
    }
    if (const auto at = text.find("@S"); at != std::string::npos) {
      text.replace(at, 2, "@" + std::to_string(start_s));
    } else {
      text += "@" + std::to_string(start_s);
    }
    CAPTURE(seed, text);
    sim::SimConfig config = with_fault(text);
    config.seed = seed;
    Lift lift(config);
    for (int block = 0; block < 30 && lift.controller.stats().goals_reached == 0 &&
                        lift.controller.supervisor().state() != guidance::SupervisorState::Fault;
         ++block) {
      lift.rig.run(5'000'000);
    }
    lift.rig.run(10'000'000);
    INFO(lift.log);
    ++runs;
    const bool caught = lift.controller.stats().plausibility_fault != guidance::PlausibilityFault::None;
    if (caught) {
      ++found;
      slowest_s = std::max(slowest_s, static_cast<double>(lift.controller.stats().plausibility_detected_us - SimRig::at_sim_s(start_s)) * 1e-6);
      CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
    } else {
      // Not found: a stuck encoder on a joint that did not have to move again, where the position
      // feedback's small corrections, below what the model counts on (its deadband allowance), let
      // the joint creep. The lift reached its goal, and the true machine stands within the
      // detection target's travel (0.5 deg, 5 cm) of where the controller believes it does.
      ++latent;
      CHECK(lift.controller.stats().goals_reached == 1);
      for (int j = 0; j < lift.controller.num_joints(); ++j) {
        CAPTURE(j);
        const double off = std::abs(lift.rig.sim->truth().position[static_cast<std::size_t>(j)] - lift.controller.position()[j]);
        worst_latent_m = std::max(worst_latent_m, j >= 2 ? off : 0.0);
        CHECK(off < (j < 2 ? 0.5 * kDeg : 0.05));
      }
    }
    CHECK(lift.truly_at_rest());
    CHECK(lift.least_clearance_m() > 0.0);
    CHECK(lift.least_load_above_ground_m() > 0.0);
    CHECK_FALSE(lift.outside_chart());
    CHECK(lift.peak_utilisation() <= 1.0);
  }
  CHECK(found + latent == runs);
  WARN("randomized faults: " << found << " of " << runs << " found, " << latent
                             << " not found (a stuck encoder on a holding joint, true creep up to " << worst_latent_m
                             << " m); the latest finding " << slowest_s
                             << " s after its fault began (a fault on a joint at rest waits for its motion)");
}

TEST_CASE("campaign: 12 fault-free lifts with other noise seeds raise no plausibility finding", "[firmware][sim][campaign]") {
  double peak = 0.0;
  for (std::uint64_t seed = 101; seed <= 112; ++seed) {
    CAPTURE(seed);
    sim::SimConfig config = SimRig::quiet_config();
    config.encoder_noise_counts = 0.5;
    config.uwb.noise_sigma_m = 0.15;
    config.uwb.dropout_probability = 0.02;
    config.seed = seed;
    Lift lift(config);
    for (int block = 0; block < 40 && lift.controller.stats().goals_reached == 0; ++block) lift.rig.run(5'000'000);
    INFO(lift.log);
    CHECK(lift.controller.stats().goals_reached == 1);
    CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::None);
    peak = std::max(peak, lift.controller.stats().plausibility_peak_ratio);
  }
  CHECK(peak < 0.5);
  WARN("12 fault-free lifts: plausibility peak ratio " << peak);
}

namespace {

//! The lift with a boom-tip tag and mgc-sim's default noise: UWB 0.15 m per axis (quality 2: a
//! 0.2 m sigma), 2 % of the fixes lost, live encoders.
sim::SimConfig noisy(sim::SimConfig c, std::uint64_t seed = 7) {
  c.encoder_noise_counts = 0.5;
  c.uwb.noise_sigma_m = 0.15;
  c.uwb.dropout_probability = 0.02;
  c.seed = seed;
  return c;
}

//! Runs until the supervisor faults or until_s (simulation time).
void run_until_fault(Lift& lift, double until_s) {
  while (lift.controller.supervisor().state() != guidance::SupervisorState::Fault && lift.rig.t_us < SimRig::at_sim_s(until_s)) {
    lift.rig.run(100'000);
  }
}

//! The boom tip where forward kinematics puts it from these joint positions. [m]
Eigen::Vector3d tip_at(const planning::MachineModel& model, const std::array<double, hal::kMaxBusJoints>& position) {
  planning::JointVector q(model.dof());
  for (int j = 0; j < model.dof(); ++j) q[j] = position[static_cast<std::size_t>(j)];
  planning::Kinematics k;
  model.forward_kinematics(q, k);
  return k.points[static_cast<std::size_t>(model.key_point_index("boom_tip"))];
}

constexpr int kTelescope = 2;

}  // namespace

TEST_CASE("campaign: machine tags: a stuck encoder on a holding telescope that creeps is found by the boom-tip tag", "[firmware][sim][campaign]") {
  // The telescope holds while the boom luffs; its encoder sticks and the joint creeps out at
  // 5 cm/s (a spool that does not centre). The encoder says it stands, the command is to stand:
  // the plausibility monitor has nothing to compare (docs/diagnostics.md, what it cannot see).
  const double t = boom_moving_s();
  sim::SimConfig config = noisy(with_fault("encoder-stuck:boom_length@" + std::to_string(t)));
  config.faults.push_back(sim::parse_machine_fault("joint-creep:boom_length@" + std::to_string(t) + ",rate=0.05",
                                                   planning::io::load_scenario(test::scenario_path(kSite)).machine.joints));
  SECTION("without the tag the creep goes unseen") {
    Lift lift(config);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    const double at_fault_m = lift.rig.sim->truth().position[kTelescope];
    lift.rig.run(20'000'000);
    INFO(lift.log);
    const double creep_m = lift.rig.sim->truth().position[kTelescope] - at_fault_m;
    CAPTURE(creep_m);
    CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::None);
    CHECK(creep_m > 0.9);
  }
  SECTION("with it: PoseDisagrees names the tag and the telescope among its joints, the creep stopped") {
    Lift lift(config, true);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
    const double at_fault_m = lift.rig.sim->truth().position[kTelescope];
    run_until_fault(lift, t + 40.0);
    INFO(lift.log);
    const firmware::ControllerStats& st = lift.controller.stats();
    const double detect_s = static_cast<double>(st.plausibility_detected_us - SimRig::at_sim_s(t)) * 1e-6;
    const double creep_at_stop_m = lift.rig.sim->truth().position[kTelescope] - at_fault_m;
    CAPTURE(detect_s, creep_at_stop_m);
    REQUIRE(lift.stop_reason == guidance::TransitionReason::PoseDisagrees);
    CHECK(st.plausibility_fault == guidance::PlausibilityFault::PoseDisagrees);
    CHECK(st.plausibility_joint == kTipTag);
    CHECK(((st.pose_joints_seen >> kTelescope) & 1u) == 1u);
    CHECK(((st.pose_joints_seen >> 3) & 1u) == 0u);  // not the hoist rope
    CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
    CHECK(lift.controller.supervisor().reason_value() == kTipTag);
    // UWB sees a disagreement of some 0.6 m at the tip (2 sigma, the time offset, the model's
    // allowance), which the creep at 5 cm/s makes in 12-16 s; it must not take much longer.
    CHECK(detect_s < 20.0);
    CHECK(creep_at_stop_m < 1.0);
    // FAULT cuts pilot pressure: the creep ends, the machine at rest, nothing hit.
    lift.rig.run(5'000'000);
    const double settled_m = lift.rig.sim->truth().position[kTelescope];
    lift.rig.run(5'000'000);
    CHECK(std::abs(lift.rig.sim->truth().position[kTelescope] - settled_m) < 1e-6);
    CHECK(lift.truly_at_rest());
    CHECK(lift.least_clearance_m() > 0.0);
    CHECK(lift.least_load_above_ground_m() > 0.0);
    CHECK_FALSE(lift.outside_chart());
    // The operator's alert names the reason and the tag.
    bool named = false;
    const firmware::GuidanceSnapshot& g = lift.controller.snapshot();
    for (int i = 0; i < g.num_alerts; ++i) {
      const firmware::SnapshotAlert& a = g.alerts[static_cast<std::size_t>(i)];
      named = named || (a.severity == mgc::alert_t::SEVERITY_FAULT &&
                        a.value == static_cast<double>(static_cast<int>(guidance::TransitionReason::PoseDisagrees)) && a.index == kTipTag);
    }
    CHECK(named);
    WARN("stuck telescope encoder, creep 5 cm/s: PoseDisagrees " << detect_s << " s after the fault, telescope " << creep_at_stop_m
                                                                 << " m out when the machine stopped; threshold "
                                                                 << lift.controller.machine_tags().result().threshold_m << " m");
  }
}

TEST_CASE("campaign: machine tags: a slow drift of the boom encoder is found by the boom-tip tag", "[firmware][sim][campaign]") {
  // 0.15 deg/s: under what the actuator model's bracket can tell from motion (docs/diagnostics.md).
  // The boom inclinometer silent from the start: the tag is the only second source.
  const double t = boom_moving_s();
  const sim::SimConfig drift = noisy(with_fault("encoder-offset:boom_elevation@" + std::to_string(t) + ",rate=0.15"));
  sim::SimConfig config = drift;
  config.faults.push_back(sim::parse_machine_fault("heartbeat-lost:inclinometer@0", {}));
  SECTION("with the boom inclinometer: AngleDisagrees within 1 s") {
    Lift lift(drift, true);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
    run_until_fault(lift, t + 40.0);
    INFO(lift.log);
    const double detect_s = static_cast<double>(lift.controller.stats().plausibility_detected_us - SimRig::at_sim_s(t)) * 1e-6;
    CAPTURE(detect_s);
    REQUIRE(lift.stop_reason == guidance::TransitionReason::AngleDisagrees);
    CHECK(detect_s < 1.0);
    WARN("boom encoder drifting 0.15 deg/s: AngleDisagrees " << detect_s << " s after the fault");
  }
  SECTION("without the tag or the inclinometer it goes unseen") {
    Lift lift(config);
    lift.rig.run(SimRig::at_sim_s(t) + 20'000'000 - lift.rig.t_us);
    INFO(lift.log);
    CHECK(lift.controller.stats().plausibility_fault == guidance::PlausibilityFault::None);
  }
  SECTION("with it: PoseDisagrees within 20 s") {
    Lift lift(config, true);
    lift.rig.run(SimRig::at_sim_s(t) - lift.rig.t_us);
    REQUIRE(lift.controller.supervisor().state() == guidance::SupervisorState::Executing);
    run_until_fault(lift, t + 40.0);
    INFO(lift.log);
    const firmware::ControllerStats& st = lift.controller.stats();
    const double detect_s = static_cast<double>(st.plausibility_detected_us - SimRig::at_sim_s(t)) * 1e-6;
    // How far the controller's belief is from the truth when it stops believing it.
    const double lie_deg = 0.15 * detect_s;
    const Eigen::Vector3d truth_tip = tip_at(lift.controller.model(), lift.rig.sim->truth().position);
    CAPTURE(detect_s, lie_deg);
    REQUIRE(lift.stop_reason == guidance::TransitionReason::PoseDisagrees);
    CHECK(st.plausibility_joint == kTipTag);
    CHECK(((st.pose_joints_seen >> kBoom) & 1u) == 1u);
    CHECK(detect_s < 20.0);
    CHECK(lift.controller.supervisor().state() == guidance::SupervisorState::Fault);
    lift.rig.run(10'000'000);
    CHECK(lift.truly_at_rest());
    CHECK(lift.least_clearance_m() > 0.0);
    CHECK(lift.least_load_above_ground_m() > 0.0);
    CHECK_FALSE(lift.outside_chart());
    WARN("boom encoder drifting 0.15 deg/s: PoseDisagrees " << detect_s << " s after the fault, the encoder then " << lie_deg
                                                            << " deg off; true tip at " << truth_tip.transpose());
  }
}

TEST_CASE("campaign: machine tags: 8 fault-free lifts with UWB noise raise no PoseDisagrees", "[firmware][sim][campaign]") {
  double peak = 0.0;
  std::uint64_t judged = 0;
  for (std::uint64_t seed = 201; seed <= 208; ++seed) {
    CAPTURE(seed);
    Lift lift(noisy(SimRig::quiet_config(), seed), true);
    for (int block = 0; block < 40 && lift.controller.stats().goals_reached == 0; ++block) lift.rig.run(5'000'000);
    INFO(lift.log);
    const firmware::ControllerStats& st = lift.controller.stats();
    CHECK(st.goals_reached == 1);
    CHECK(st.plausibility_fault == guidance::PlausibilityFault::None);
    CHECK(st.machine_tag_stale_cycles == 0);
    // About 10 fixes a second over the lift, less the 2 % lost.
    CHECK(st.machine_tag_fixes_judged > 500);
    peak = std::max(peak, st.machine_tag_peak_ratio);
    judged += st.machine_tag_fixes_judged;
  }
  // A single fix may pass its threshold (about one in a thousand at 0.15 m of noise); four in a
  // row are a finding, and none came.
  WARN("8 fault-free lifts with a boom-tip tag: " << judged << " fixes judged, the largest " << peak << " of its threshold");
}

TEST_CASE("campaign: machine tags: a silent gateway makes the tag stale, an alert naming it, no fault", "[firmware][sim][campaign]") {
  // The site without crane 2, so that no obstacle needs the UWB (its silence would be UwbSilent):
  // the gateway falls silent 20 s into the lift, and the lift goes on without the tag's check.
  sim::SimConfig config = SimRig::quiet_config();
  config.faults.push_back(sim::parse_fault("uwb-silent@20", joint_names()));
  SimRig rig(kSite, config, "campaign-stale", [](planning::Scenario& s) {
    s.dynamic_obstacles.clear();
    add_boom_tip_tag(s);
  });
  rig.calibrate_valves();
  firmware::Controller controller(rig.scenario, firmware::ControllerConfig{});
  bool goal_sent = false;
  int alert_cycles = 0;
  std::int64_t first_alert_us = -1;
  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!goal_sent && controller.supervisor().state() == guidance::SupervisorState::Hold) commands.goal_request = goal_sent = true;
    const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, commands, false);
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < controller.num_joints(); ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    const firmware::GuidanceSnapshot& g = controller.snapshot();
    for (int a = 0; a < g.num_alerts; ++a) {
      const firmware::SnapshotAlert& alert = g.alerts[static_cast<std::size_t>(a)];
      if (alert.source == mgc::alert_t::SOURCE_SENSING && alert.severity == mgc::alert_t::SEVERITY_WARN && alert.index == kTipTag) {
        ++alert_cycles;
        if (first_alert_us < 0) first_alert_us = s.t_us;
      }
    }
  };
  rig.run(SimRig::at_sim_s(20.0) - rig.t_us);
  REQUIRE(controller.supervisor().state() == guidance::SupervisorState::Executing);
  CHECK(alert_cycles == 0);
  const std::uint64_t judged_before = controller.stats().machine_tag_fixes_judged;
  CHECK(judged_before > 150);
  for (int block = 0; block < 40 && controller.stats().goals_reached == 0; ++block) rig.run(5'000'000);
  const firmware::ControllerStats& st = controller.stats();
  const double alert_after_s = static_cast<double>(first_alert_us - SimRig::at_sim_s(20.0)) * 1e-6;
  CAPTURE(alert_after_s, alert_cycles);
  CHECK(st.goals_reached == 1);
  CHECK(st.plausibility_fault == guidance::PlausibilityFault::None);
  // Only the fix still on its way (50 ms latency) when the gateway fell silent.
  CHECK(st.machine_tag_fixes_judged <= judged_before + 1);
  // The last fix came up to 50 ms before the silence (its latency), stale 500 ms later.
  CHECK(alert_after_s > 0.4);
  CHECK(alert_after_s < 0.6);
  CHECK(st.machine_tag_stale_cycles > 100);
}
