// SPDX-License-Identifier: Apache-2.0
// The plausibility monitor (docs/diagnostics.md) on a joint simulated here, independently of the
// monitor's own model: a valve ramp, a deadband and a first-order lag with an acceleration limit,
// an encoder quantised to the protocol's resolution. Healthy motion raises nothing; each fault is
// named, with its joint, within its documented time.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "mgc/guidance/diagnostics.hpp"

using namespace mgc::guidance;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr std::int64_t kCycleUs = 10'000;

//! The boom of the thesis crane: 1.04 deg/s, 0.52 deg/s^2, 0..80 deg.
PlausibilityJoint boom() { return {1.04 * kDeg, 0.52 * kDeg, 0.0, 80.0 * kDeg, false, false}; }
//! The boom of the Cat 320: 24 deg/s, 48 deg/s^2, -50..60 deg.
PlausibilityJoint excavator_boom() { return {24.0 * kDeg, 48.0 * kDeg, -50.0 * kDeg, 60.0 * kDeg, false, false}; }
//! Its swing: continuous, 3.75 deg/s, 1.875 deg/s^2.
PlausibilityJoint swing() { return {3.75 * kDeg, 1.875 * kDeg, -std::numbers::pi, std::numbers::pi, true, false}; }

//! One joint as a hydraulic drive: the valve ramps its spool at 10/s toward the command, no flow in
//! a 3 % deadband (which the command mapping compensates), a 0.15 s lag with the acceleration limit.
struct Drive {
  PlausibilityJoint joint;
  double lag_s = 0.15;
  double position = 0.0;
  double velocity = 0.0;
  double spool = 0.0;
  bool ignore = false;     //!< the valve keeps its last spool
  bool jammed = false;     //!< the joint does not move whatever the valve does
  bool end_stops = false;  //!< the joint stops hard at its range's ends (a cylinder at the end of its stroke)

  void step(double command, double dt_s) {
    const double target_spool = ignore ? spool : std::clamp(command / joint.max_velocity, -1.0, 1.0);
    spool += std::clamp(target_spool - spool, -10.0 * dt_s, 10.0 * dt_s);
    const double target_v = jammed ? 0.0 : spool * joint.max_velocity;
    const double dv = std::clamp((target_v - velocity) * (1.0 - std::exp(-dt_s / lag_s)), -joint.max_acceleration * dt_s,
                                 joint.max_acceleration * dt_s);
    velocity += dv;
    position += velocity * dt_s;
    if (end_stops && (position > joint.position_max || position < joint.position_min)) {
      position = std::clamp(position, joint.position_min, joint.position_max);
      velocity = 0.0;
    }
  }
};

//! A joint, its drive, the encoder and the monitor stepped in 10 ms cycles, the drive in 1 ms.
struct Bench {
  std::vector<PlausibilityJoint> joints;
  std::vector<Drive> drives;
  PlausibilityMonitor monitor;
  std::int64_t now_us = 1'000'000;
  std::vector<double> command;   //!< what the loop commands this cycle [rad/s | m/s]
  std::vector<double> previous;  //!< last cycle's command, which the valve applies now
  std::vector<double> encoder;   //!< last encoder sample
  std::vector<bool> frozen;      //!< the encoder repeats its sample
  std::vector<double> lie;       //!< added to the sample [rad | m]
  std::uint8_t counter = 0;
  std::uint32_t sent = 0;
  bool counter_stalls = false;
  bool sync_lag = false;  //!< the encoder answers the previous cycle's SYNC
  bool valve_reports = true;  //!< the valve's status arrives fresh (false: a gap in its reports)

  explicit Bench(std::vector<PlausibilityJoint> j, double start = 40.0 * kDeg)
      : joints(std::move(j)), monitor(joints), command(joints.size()), previous(joints.size()),
        encoder(joints.size()), frozen(joints.size()), lie(joints.size()) {
    for (const PlausibilityJoint& p : joints) drives.push_back({p, 0.15, start});
  }

  static double quantise(double value, bool prismatic) {
    const double q = prismatic ? 1e-4 : 0.001 * kDeg;
    return std::round(value / q) * q;
  }

  //! One cycle: the drives run period_ms on the previous command, the encoder samples, the monitor
  //! checks. With sync_lag the sample read is the one taken at the previous cycle's SYNC, as on
  //! the bus: a late cycle then reads a sample that spans the whole late period.
  const PlausibilityResult& cycle(int period_ms = 10) {
    std::vector<double> at_sync(drives.size());
    for (std::size_t j = 0; j < drives.size(); ++j) at_sync[j] = drives[j].position;
    for (int k = 0; k < period_ms; ++k) {
      for (std::size_t j = 0; j < drives.size(); ++j) drives[j].step(previous[j], 1e-3);
    }
    now_us += period_ms * 1000;
    PlausibilityInputs in;
    in.now_us = now_us;
    in.drive_enabled = true;  // a valve whose reports are late is taken at its commands
    in.valve_active = valve_reports;
    for (std::size_t j = 0; j < drives.size(); ++j) {
      const double sampled = sync_lag ? at_sync[j] : drives[j].position;
      if (!frozen[j]) encoder[j] = quantise(sampled + lie[j], joints[j].prismatic);
      in.position[j] = encoder[j];
      in.valid[j] = true;
      in.updated[j] = true;
      in.commanded_velocity[j] = previous[j];
      in.valve_commanded[j] = std::clamp(previous[j] / joints[j].max_velocity, -1.0, 1.0);
      in.valve_applied[j] = drives[j].spool;
    }
    if (!counter_stalls) ++counter;
    in.valve_command_counter = counter;
    in.valve_commands_sent = ++sent;
    const PlausibilityResult& r = monitor.update(in);
    previous = command;
    return r;
  }

  //! Runs for seconds with command() giving each cycle's command from the time since start.
  template <class Command>
  const PlausibilityResult& run(double seconds, Command&& command_at) {
    const auto cycles = static_cast<int>(std::lround(seconds * 1e6 / kCycleUs));
    for (int c = 0; c < cycles; ++c) {
      command_at(command);
      cycle();
      if (monitor.result().fault != PlausibilityFault::None) break;
    }
    return monitor.result();
  }
};

//! A luffing move as the controller makes it: full speed (80 %), a ramp up and a ramp down at the
//! acceleration limit, with a feedback correction on top.
double luff(double t_s, const PlausibilityJoint& j) {
  const double v = 0.8 * j.max_velocity;
  const double ramp_s = v / j.max_acceleration;
  if (t_s < ramp_s) return -j.max_acceleration * t_s;
  if (t_s < 6.0) return -v;
  if (t_s < 6.0 + ramp_s) return -v + j.max_acceleration * (t_s - 6.0);
  return 0.0;
}

//! The luffing move as the loop's command, one cycle per call, with the time it has run. Passed
//! to Bench::run by reference, so that a run continues where the last one stopped.
struct Luffing {
  PlausibilityJoint joint;
  double t_s = 0.0;
  double stop_at_s = std::numeric_limits<double>::infinity();  //!< the loop commands zero from here
  void operator()(std::vector<double>& cmd) {
    cmd[0] = t_s < stop_at_s ? luff(t_s, joint) : 0.0;
    t_s += 0.01;
  }
};

}  // namespace

TEST_CASE("healthy motion, stops and reversals raise no plausibility fault", "[guidance][diagnostics]") {
  Bench b({boom(), swing()});
  double t = 0.0;
  const PlausibilityResult& r = b.run(20.0, [&](std::vector<double>& cmd) {
    cmd[0] = luff(t, b.joints[0]);
    // The swing reverses every 3 s at full command: a step the rate limiter would not even allow.
    cmd[1] = (static_cast<int>(t / 3.0) % 2 == 0 ? 1.0 : -1.0) * b.joints[1].max_velocity * (t < 18.0 ? 1.0 : 0.0);
    t += 0.01;
  });
  CHECK(r.fault == PlausibilityFault::None);
  // The checks kept a margin: the largest excursion used under two thirds of a threshold.
  CHECK(b.monitor.peak_window_ratio() < 0.67);
  WARN("healthy: peak window ratio " << b.monitor.peak_window_ratio());
}

TEST_CASE("a loop that wakes 38 ms late and catches up is no encoder step", "[guidance][diagnostics]") {
  // The swing at 80 % of its speed; every half second a cycle of 48 ms, then one of 2 ms. The
  // sample read after the short cycle spans the whole late period, while the two reads are 2 ms
  // apart: the step must be judged against the time between their SYNCs, not between their reads.
  Bench b({swing()});
  b.sync_lag = true;
  for (int c = 0; c < 1000 && b.monitor.result().fault == PlausibilityFault::None; ++c) {
    b.command[0] = 0.8 * b.joints[0].max_velocity;
    if (c % 50 == 49) {
      b.cycle(48);
      b.command[0] = 0.8 * b.joints[0].max_velocity;
      b.cycle(2);
    } else {
      b.cycle();
    }
  }
  CHECK(b.monitor.result().fault == PlausibilityFault::None);
  // A forged step is still a step under the same timing.
  b.lie[0] = 1.0 * kDeg;
  b.cycle();
  CHECK(b.monitor.result().fault == PlausibilityFault::EncoderStep);
}

TEST_CASE("a gap of 60 ms in the valve's reports while the boom runs is no valve that does not obey", "[guidance][diagnostics]") {
  // A stalled valve node (or bus) sends no status for 60 ms; the valve keeps its spool on the
  // command. Its first fresh report after the gap shows the spool where the commands put it.
  Bench b({boom()});
  Luffing command{b.joints[0]};
  REQUIRE(b.run(3.0, command).fault == PlausibilityFault::None);
  b.valve_reports = false;
  REQUIRE(b.run(0.06, command).fault == PlausibilityFault::None);
  b.valve_reports = true;
  CHECK(b.run(1.0, command).fault == PlausibilityFault::None);
}

TEST_CASE("a slower or faster actuator within the model's bounds is not a fault", "[guidance][diagnostics]") {
  for (const double lag_s : {0.08, 0.3}) {
    CAPTURE(lag_s);
    Bench b({boom()});
    b.drives[0].lag_s = lag_s;
    const PlausibilityResult& r = b.run(10.0, Luffing{b.joints[0]});
    CHECK(r.fault == PlausibilityFault::None);
  }
}

TEST_CASE("a stuck encoder is found within 0.3 s and under 0.5 deg of travel", "[guidance][diagnostics]") {
  Bench b({boom()});
  Luffing command{b.joints[0]};
  REQUIRE(b.run(4.0, command).fault == PlausibilityFault::None);
  const double fault_position = b.drives[0].position;
  const std::int64_t fault_us = b.now_us;
  b.frozen[0] = true;
  const PlausibilityResult& r = b.run(2.0, command);
  REQUIRE(r.fault == PlausibilityFault::EncoderStuck);
  CHECK(r.joint == 0);
  CHECK_FALSE(r.cut_required);
  const double detect_s = static_cast<double>(r.detected_us - fault_us) * 1e-6;
  const double travel_deg = std::abs(b.drives[0].position - fault_position) / kDeg;
  CAPTURE(detect_s, travel_deg);
  CHECK(detect_s <= 0.3);
  CHECK(travel_deg < 0.5);
}

TEST_CASE("a lying encoder: a forged step, a value out of range, a drift at rest", "[guidance][diagnostics]") {
  SECTION("a 20 deg step on the swing is a step no actuator makes") {
    Bench b({swing()}, 78.4 * kDeg);
    REQUIRE(b.run(1.0, [](std::vector<double>& cmd) { cmd[0] = 0.0; }).fault == PlausibilityFault::None);
    b.lie[0] = -20.0 * kDeg;
    const std::int64_t fault_us = b.now_us;
    const PlausibilityResult& r = b.run(1.0, [](std::vector<double>& cmd) { cmd[0] = 0.0; });
    CHECK(r.fault == PlausibilityFault::EncoderStep);
    CHECK(r.joint == 0);
    CHECK(r.detected_us - fault_us == kCycleUs);
  }
  SECTION("a step of 0.1 deg at full speed is beyond the actuator") {
    Bench b({boom()});
    Luffing command{b.joints[0]};
    REQUIRE(b.run(3.0, command).fault == PlausibilityFault::None);
    b.lie[0] = 0.1 * kDeg;
    CHECK(b.run(0.1, command).fault == PlausibilityFault::EncoderStep);
  }
  SECTION("INT32 extremes are beyond the end stops") {
    Bench b({boom()});
    REQUIRE(b.run(0.5, [](std::vector<double>& cmd) { cmd[0] = 0.0; }).fault == PlausibilityFault::None);
    b.lie[0] = 2147483.647 * kDeg;
    const PlausibilityResult& r = b.run(0.1, [](std::vector<double>& cmd) { cmd[0] = 0.0; });
    CHECK(r.fault == PlausibilityFault::EncoderOutOfRange);
  }
  SECTION("a drift of 1 deg/s on a joint at rest: motion no command allows") {
    Bench b({boom()});
    REQUIRE(b.run(1.0, [](std::vector<double>& cmd) { cmd[0] = 0.0; }).fault == PlausibilityFault::None);
    const std::int64_t fault_us = b.now_us;
    double lie = 0.0;
    const PlausibilityResult& r = b.run(2.0, [&](std::vector<double>& cmd) {
      cmd[0] = 0.0;
      lie += 1.0 * kDeg * 0.01;
      b.lie[0] = lie;
    });
    CHECK(r.fault == PlausibilityFault::JointRunaway);
    CHECK(r.cut_required);
    CHECK(static_cast<double>(r.detected_us - fault_us) * 1e-6 <= 0.3);
  }
}

TEST_CASE("a valve that ignores commands: its applied spools, its counter, the joint's motion", "[guidance][diagnostics]") {
  Luffing luffing{boom(), 0.0, 4.0};  // the controller stops at 4 s
  SECTION("the applied spool stays while the command goes to zero") {
    Bench b({boom()});
    REQUIRE(b.run(4.0, luffing).fault == PlausibilityFault::None);
    b.drives[0].ignore = true;
    const std::int64_t fault_us = b.now_us;
    const PlausibilityResult& r = b.run(2.0, luffing);
    CHECK(r.fault == PlausibilityFault::ValveNotObeying);
    CHECK(r.joint == 0);
    CHECK(r.cut_required);
    CHECK(static_cast<double>(r.detected_us - fault_us) * 1e-6 <= 0.3);
  }
  SECTION("the counter stops while commands go out") {
    Bench b({boom()});
    REQUIRE(b.run(2.0, luffing).fault == PlausibilityFault::None);
    b.counter_stalls = true;
    const std::int64_t fault_us = b.now_us;
    const PlausibilityResult& r = b.run(1.0, luffing);
    CHECK(r.fault == PlausibilityFault::ValveNotObeying);
    CHECK(r.joint == -1);
    CHECK(static_cast<double>(r.detected_us - fault_us) * 1e-6 <= 0.15);
  }
}

TEST_CASE("a jammed joint that the valve drives is not following", "[guidance][diagnostics]") {
  Bench b({boom()});
  Luffing command{b.joints[0]};
  REQUIRE(b.run(3.0, command).fault == PlausibilityFault::None);
  b.drives[0].jammed = true;
  // The encoder is alive: it flickers by one count, so the value is never frozen.
  int flick = 0;
  const PlausibilityResult& r = b.run(2.0, [&](std::vector<double>& cmd) {
    command(cmd);
    b.lie[0] = (++flick % 2) * 0.001 * kDeg;
  });
  CHECK(r.fault == PlausibilityFault::JointNotFollowing);
  CHECK_FALSE(r.cut_required);
}

//! Stop/start reversals as a follower makes them round a waypoint next to an end stop: 0.6 s
//! toward the upper stop at 90 % of the speed, 0.2 s standing, 0.2 s back at half speed, again
//! and again; from push_from_s on, one sustained push toward the stop.
struct Reversals {
  PlausibilityJoint joint;
  double push_from_s = std::numeric_limits<double>::infinity();
  double t_s = 0.0;
  void operator()(std::vector<double>& cmd) {
    const double phase_s = std::fmod(t_s, 1.0);
    const bool push = t_s >= push_from_s || phase_s < 0.6;
    cmd[0] = push ? 0.9 * joint.max_velocity : (phase_s < 0.8 ? 0.0 : -0.5 * joint.max_velocity);
    t_s += 0.01;
  }
};

TEST_CASE("a reversal and a stop right after it, as a follower corrects an overshoot, is no fault", "[guidance][diagnostics]") {
  // The excavator's boom at 80 % of its speed; the command falls at the acceleration limit past
  // zero to a correction back at 16 %, and the stop takes it to zero before the actuator, 0.15 s
  // behind, has turned round. An actuator between the fastest and the slowest lag is then still on
  // its way back when the fast ones have stopped and the slow ones still go forward.
  const PlausibilityJoint j = excavator_boom();
  for (const double hold_s : {0.1, 0.3, 0.5}) {
    CAPTURE(hold_s);
    Bench b({j}, 0.0);
    double t = 0.0;
    const double a = j.max_acceleration;
    const double v0 = 0.8 * j.max_velocity;
    const double back = -0.16 * j.max_velocity;
    const double fall_s = (v0 - back) / a;
    const PlausibilityResult& r = b.run(4.0, [&](std::vector<double>& cmd) {
      if (t < 1.0) cmd[0] = std::min(a * t, v0);
      else if (t < 1.0 + fall_s) cmd[0] = v0 - a * (t - 1.0);
      else if (t < 1.0 + fall_s + hold_s) cmd[0] = back;
      else cmd[0] = std::min(0.0, back + a * (t - 1.0 - fall_s - hold_s));
      t += 0.01;
    });
    CHECK(r.fault == PlausibilityFault::None);
    WARN("reversal then stop, correction held " << hold_s << " s: peak window ratio " << b.monitor.peak_window_ratio());
  }
}

TEST_CASE("a joint driven onto its end stop by stop/start reversals, its command still outward, is no fault", "[guidance][diagnostics]") {
  // The excavator's boom 2 deg below its end stop: each push runs it onto the stop, where it stands
  // while its command still asks for more (the actuator's lag overshoots the follower's setpoint).
  for (const bool live_encoder : {true, false}) {
    CAPTURE(live_encoder);
    const PlausibilityJoint j = excavator_boom();
    Bench b({j}, j.position_max - 2.0 * kDeg);
    b.drives[0].end_stops = true;
    Reversals reversals{j};
    int flick = 0;
    int cycles_on_stop = 0;
    const PlausibilityResult& r = b.run(8.0, [&](std::vector<double>& cmd) {
      reversals(cmd);
      // A live encoder flickers by a count; a quiet one repeats its value on the stop.
      b.lie[0] = live_encoder ? (++flick % 2) * 0.001 * kDeg : 0.0;
      if (b.drives[0].position == j.position_max && cmd[0] > 0.0) ++cycles_on_stop;
    });
    CHECK(r.fault == PlausibilityFault::None);
    CHECK(cycles_on_stop > 100);  // pushed against the stop for over a second in all
  }
}

TEST_CASE("after stop/start reversals, a joint jammed short of its end stop and a valve that ignores commands are found", "[guidance][diagnostics]") {
  const PlausibilityJoint j = excavator_boom();
  SECTION("jammed 5 deg or more short of the end stop, pushed toward it") {
    Bench b({j}, j.position_max - 40.0 * kDeg);
    b.drives[0].end_stops = true;
    Reversals reversals{j, 3.0};
    REQUIRE(b.run(3.0, reversals).fault == PlausibilityFault::None);
    REQUIRE(j.position_max - b.drives[0].position > 5.0 * kDeg);
    b.drives[0].jammed = true;
    b.drives[0].velocity = 0.0;
    const std::int64_t fault_us = b.now_us;
    int flick = 0;
    const PlausibilityResult& r = b.run(2.0, [&](std::vector<double>& cmd) {
      reversals(cmd);
      b.lie[0] = (++flick % 2) * 0.001 * kDeg;
    });
    CHECK(r.fault == PlausibilityFault::JointNotFollowing);
    CHECK(r.joint == 0);
    // The bracket's least motion must first turn round from the way back: 0.6 s
    // (docs/diagnostics.md, "Detection times").
    CHECK(static_cast<double>(r.detected_us - fault_us) * 1e-6 <= 0.6);
    WARN("jammed after reversals: JointNotFollowing " << static_cast<double>(r.detected_us - fault_us) * 1e-6 << " s after the jam");
  }
  SECTION("a valve that keeps its spool") {
    Bench b({j}, j.position_max - 40.0 * kDeg);
    b.drives[0].end_stops = true;
    Reversals reversals{j};
    REQUIRE(b.run(3.1, reversals).fault == PlausibilityFault::None);
    b.drives[0].ignore = true;
    const std::int64_t fault_us = b.now_us;
    const PlausibilityResult& r = b.run(2.0, reversals);
    CHECK(r.fault == PlausibilityFault::ValveNotObeying);
    CHECK(r.cut_required);
    CHECK(static_cast<double>(r.detected_us - fault_us) * 1e-6 <= 0.3);
  }
}

TEST_CASE("the swing crossing the half turn is no step, and reset() forgets a latched fault", "[guidance][diagnostics]") {
  Bench b({swing()}, 170.0 * kDeg);
  // The encoder of a slew ring reports within one turn: wrap what it reports.
  const PlausibilityResult& r = b.run(8.0, [&](std::vector<double>& cmd) {
    cmd[0] = b.joints[0].max_velocity;
    b.lie[0] = std::remainder(b.drives[0].position, 2.0 * std::numbers::pi) - b.drives[0].position;
  });
  CHECK(r.fault == PlausibilityFault::None);
  CHECK(std::abs(b.drives[0].position) > 185.0 * kDeg);

  b.lie[0] += 30.0 * kDeg;
  REQUIRE(b.run(0.05, [](std::vector<double>& cmd) { cmd[0] = 0.0; }).fault == PlausibilityFault::EncoderStep);
  b.monitor.reset();
  CHECK(b.monitor.result().fault == PlausibilityFault::None);
  CHECK(b.monitor.peak_window_ratio() == 0.0);
}

TEST_CASE("the plausibility monitor refuses joints and settings it cannot work with", "[guidance][diagnostics]") {
  std::vector<PlausibilityJoint> none;
  CHECK_THROWS_AS(PlausibilityMonitor(none), std::invalid_argument);
  std::vector<PlausibilityJoint> still{{0.0, 1.0, 0.0, 1.0, false, false}};
  CHECK_THROWS_AS(PlausibilityMonitor(still), std::invalid_argument);
  std::vector<PlausibilityJoint> ok{boom()};
  PlausibilityConfig c;
  c.lag_max_s = 0.01;
  CHECK_THROWS_AS(PlausibilityMonitor(ok, c), std::invalid_argument);
  c = {};
  c.tolerance_rad = -1.0;
  CHECK_THROWS_AS(PlausibilityMonitor(ok, c), std::invalid_argument);
  CHECK_NOTHROW(PlausibilityMonitor(ok));
}

namespace {

//! The mobile crane's telescope: 0.124 m/s, 0.062 m/s^2, 10.97..33.53 m.
PlausibilityJoint telescope() { return {0.124, 0.062, 10.9728, 33.528, false, true}; }

//! The follower on one joint: a setpoint moving at 80 % of the speed limit from start_m toward
//! end_m, then holding, and the command its speed plus 2/s times the measured error, as the loop
//! makes it, within the speed limit. The loop sees the encoder, so it follows a lie.
struct Follow {
  const Bench* bench = nullptr;
  double start_m = 0.0;
  double end_m = 0.0;
  double t_s = 0.0;
  void operator()(std::vector<double>& cmd) {
    const PlausibilityJoint& j = bench->joints[0];
    const double speed = 0.8 * j.max_velocity * (end_m > start_m ? 1.0 : -1.0);
    const double travelled = speed * t_s;
    const bool moving = std::abs(travelled) < std::abs(end_m - start_m);
    const double setpoint = moving ? start_m + travelled : end_m;
    const double v = (moving ? speed : 0.0) + 2.0 * (setpoint - bench->encoder[0]);
    cmd[0] = std::clamp(v, -j.max_velocity, j.max_velocity);
    t_s += 0.01;
  }
};

}  // namespace

TEST_CASE("a telescope encoder drifting slower than the window's tolerance shows is found by the accumulated shortfall",
          "[guidance][diagnostics]") {
  // Campaign lift 1129: a drift of -0.093 m/s against the extension. The loop, seeing the boom
  // fall behind, commands the full 0.124 m/s; the encoder moves at 0.031 m/s against a least
  // travel of 0.087 m/s: 1.7 cm short per 0.3 s window, under its 2 cm. Accumulated, the shortfall
  // is beyond its 1 cm within (0.01 m / 0.056 m/s) and the bracket's lag: under 0.3 s.
  const auto drifting = [](const PlausibilityConfig& config, double rate_m_s, double* detect_s) {
    Bench b({telescope()}, 15.0);
    b.monitor = PlausibilityMonitor(b.joints, config);
    b.encoder[0] = Bench::quantise(15.0, true);
    Follow follow{&b, 15.0, 32.0};
    REQUIRE(b.run(5.0, follow).fault == PlausibilityFault::None);
    const std::int64_t fault_us = b.now_us;
    double lie = 0.0;
    const PlausibilityResult& r = b.run(20.0, [&](std::vector<double>& cmd) {
      follow(cmd);
      lie += rate_m_s * 0.01;
      b.lie[0] = lie;
    });
    *detect_s = static_cast<double>(r.detected_us - fault_us) * 1e-6;
    return r;
  };
  double detect_s = 0.0;
  const PlausibilityResult& found = drifting(PlausibilityConfig{}, -0.093, &detect_s);
  CAPTURE(detect_s);
  REQUIRE(found.fault == PlausibilityFault::JointNotFollowing);
  CHECK(found.joint == 0);
  CHECK_FALSE(found.cut_required);
  CHECK(detect_s <= 0.3);
  // The window alone (the accumulated check's tolerance out of reach) follows the lie for 20 s.
  PlausibilityConfig window_only;
  window_only.drift_tolerance_m = 1e9;
  CHECK(drifting(window_only, -0.093, &detect_s).fault == PlausibilityFault::None);
  // The documented bound for a slower drift, 0.04 m/s: tolerance / (rate - 0.25 x the command -
  // 5 % of the speed limit) with the command at full speed, plus up to 1 s for the loop to reach
  // it (its 2/s gain on the growing error) and for the bracket to turn.
  const double rate_m_s = 0.04;
  const double bound_s = 0.01 / (rate_m_s - 0.25 * 0.124 - 0.05 * 0.124) + 1.0;
  const PlausibilityResult& slower = drifting(PlausibilityConfig{}, -rate_m_s, &detect_s);
  CAPTURE(detect_s, bound_s);
  CHECK(slower.fault == PlausibilityFault::JointNotFollowing);
  CHECK(detect_s <= bound_s);
}

TEST_CASE("the accumulated shortfall stays quiet with encoder noise, the SYNC's lag and a slow valve", "[guidance][diagnostics]") {
  // Out and back in over the telescope's range, stops between, for 10 minutes of motion: the
  // encoder's noise (0.5 counts before quantisation) and a sample one SYNC old do not add up,
  // and an actuator with the slowest lag the bracket admits short of its 0.4 s is not short.
  for (const double lag_s : {0.15, 0.35}) {
    CAPTURE(lag_s);
    Bench b({telescope()}, 12.0);
    b.drives[0].lag_s = lag_s;
    b.sync_lag = true;
    b.encoder[0] = Bench::quantise(12.0, true);
    std::mt19937 noise(7);
    std::normal_distribution<double> counts(0.0, 0.5e-4);
    double peak = 0.0;
    for (int leg = 0; leg < 20; ++leg) {
      const bool out = leg % 2 == 0;
      Follow follow{&b, out ? 12.0 : 32.0, out ? 32.0 : 12.0};
      const PlausibilityResult& r = b.run(30.0, [&](std::vector<double>& cmd) {
        follow(cmd);
        b.lie[0] = counts(noise);
      });
      REQUIRE(r.fault == PlausibilityFault::None);
      peak = std::max(peak, b.monitor.peak_drift_ratio());
    }
    CAPTURE(peak);
    CHECK(peak < 0.5);
  }
}
