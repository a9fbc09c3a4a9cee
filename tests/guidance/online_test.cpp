// SPDX-License-Identifier: Apache-2.0
// The online trajectory: followed cycle by cycle it matches the offline profile's duration, it
// follows a target change mid-motion within the limits, refuses bad input; and the one-joint-at-
// a-time wrapper moves one joint while the others brake to rest and stay.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "mgc/guidance/online.hpp"

using namespace mgc::guidance;

namespace {

constexpr double kCycleS = 0.01;  // the controller's 10 ms cycle

struct Move {
  JointState start;
  double target = 0.0;
  JointLimits limits;
};

//! Limits and distances of crane and excavator joints (time scales 0.05–5 s), moving starts inside
//! the limits.
Move random_move(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, unit(rng)); };
  Move m;
  m.limits.max_velocity = log_uniform(0.05, 2.0);
  m.limits.max_acceleration = m.limits.max_velocity * log_uniform(0.2, 5.0);
  m.limits.max_jerk = m.limits.max_acceleration * log_uniform(0.2, 20.0);
  m.start.position = (2.0 * unit(rng) - 1.0) * 5.0;
  m.target = (2.0 * unit(rng) - 1.0) * 5.0;
  // A moving start that the profile can reach: sampled from a profile towards a random point.
  Profile p;
  const JointState rest{m.start.position, 0.0, 0.0};
  REQUIRE(calculate_time_optimal(rest, (2.0 * unit(rng) - 1.0) * 5.0, m.limits, p).ok());
  const JointSample s = p.at_time(unit(rng) * p.duration());
  m.start = {s.position, s.velocity, s.acceleration};
  return m;
}

//! True when the cycle's output is within the limits (1e-9 relative) and the acceleration step
//! within what the jerk limit allows in one cycle.
bool within_limits(const JointState& from, const JointState& to, const JointLimits& lim, double dt_s) {
  constexpr double kTol = 1.0 + 1e-9;
  return std::abs(to.velocity) <= lim.max_velocity * kTol && std::abs(to.acceleration) <= lim.max_acceleration * kTol &&
         std::abs(to.acceleration - from.acceleration) <= lim.max_jerk * dt_s * kTol;
}

bool at_rest_at(const JointState& s, double position) {
  return std::abs(s.position - position) <= 1e-8 && std::abs(s.velocity) <= 1e-9 && std::abs(s.acceleration) <= 1e-9;
}

}  // namespace

TEST_CASE("followed at 10 ms the online output ends with the offline profile's duration, to the cycle", "[online]") {
  std::mt19937_64 rng(11);
  for (int n = 0; n < 2000; ++n) {
    const Move m = random_move(rng);
    Profile offline;
    REQUIRE(calculate_time_optimal(m.start, m.target, m.limits, offline).ok());
    JointTrajectory online;
    JointState current = m.start, next;
    long cycles = 0;
    bool limits_ok = true;
    TrajectoryStatus st = TrajectoryStatus::Working;
    while (st == TrajectoryStatus::Working && cycles < 100000) {
      st = online.update(current, m.target, m.limits, kCycleS, next);
      ++cycles;
      limits_ok = limits_ok && within_limits(current, next, m.limits, kCycleS);
      current = next;
    }
    CAPTURE(n, offline.duration(), cycles);
    REQUIRE(st == TrajectoryStatus::Finished);
    // The first cycle whose end reaches the profile's end: ceil(duration / dt).
    CHECK(static_cast<double>(cycles - 1) * kCycleS < offline.duration() * (1.0 + 1e-12));
    CHECK(static_cast<double>(cycles) * kCycleS >= offline.duration() * (1.0 - 1e-12));
    CHECK(at_rest_at(current, m.target));
    CHECK(limits_ok);
    CHECK(online.calculation_count() == 1);  // fed back exactly: never recalculated
    // Held once finished.
    CHECK(online.update(current, m.target, m.limits, kCycleS, next) == TrajectoryStatus::Finished);
    CHECK(at_rest_at(next, m.target));
  }
}

TEST_CASE("a target change mid-motion is followed within the limits", "[online]") {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int n = 0; n < 2000; ++n) {
    const Move m = random_move(rng);
    Profile offline;
    REQUIRE(calculate_time_optimal(m.start, m.target, m.limits, offline).ok());
    const long change_cycle = static_cast<long>(unit(rng) * offline.duration() / kCycleS);
    const double new_target = (2.0 * unit(rng) - 1.0) * 5.0;
    JointTrajectory online;
    JointState current = m.start, next;
    long cycles = 0;
    bool limits_ok = true;
    TrajectoryStatus st = TrajectoryStatus::Working;
    while ((st == TrajectoryStatus::Working || cycles <= change_cycle) && cycles < 200000) {
      const double target = cycles < change_cycle ? m.target : new_target;
      st = online.update(current, target, m.limits, kCycleS, next);
      ++cycles;
      limits_ok = limits_ok && within_limits(current, next, m.limits, kCycleS);
      current = next;
    }
    CAPTURE(n, change_cycle, cycles, m.target, new_target);
    REQUIRE(st == TrajectoryStatus::Finished);
    CHECK(limits_ok);
    CHECK(at_rest_at(current, new_target));
    CHECK(online.calculation_count() == (change_cycle == 0 ? 1u : 2u));
  }
}

TEST_CASE("a measured state that differs from the plan is planned from", "[online]") {
  JointTrajectory online;
  const JointLimits lim{1.0, 1.0, 1.0};
  JointState next;
  REQUIRE(online.update({}, 10.0, lim, kCycleS, next) == TrajectoryStatus::Working);
  JointState measured = next;
  measured.position += 1e-3;
  REQUIRE(online.update(measured, 10.0, lim, kCycleS, next) == TrajectoryStatus::Working);
  CHECK(online.calculation_count() == 2);
  CHECK(online.update(next, 10.0, {1.0, 1.0, 2.0}, kCycleS, next) == TrajectoryStatus::Working);
  CHECK(online.calculation_count() == 3);  // new limits
}

TEST_CASE("the online trajectory refuses invalid input and leaves next alone", "[online][unit]") {
  JointTrajectory online;
  const JointState sentinel{7.0, 8.0, 9.0};
  JointState next = sentinel;
  const JointLimits lim{1.0, 1.0, 1.0};
  CHECK(online.update({}, 1.0, lim, 0.0, next) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(online.invalid_field() == InvalidField::CycleTime);
  CHECK(online.update({}, 1.0, lim, NAN, next) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(online.update({}, 1.0, {1.0, -1.0, 1.0}, kCycleS, next) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(online.invalid_field() == InvalidField::MaxAcceleration);
  CHECK(online.update({}, NAN, lim, kCycleS, next) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(online.invalid_field() == InvalidField::TargetPosition);
  CHECK(online.update({INFINITY, 0.0, 0.0}, 1.0, lim, kCycleS, next) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(online.invalid_field() == InvalidField::CurrentPosition);
  CHECK((next.position == 7.0 && next.velocity == 8.0 && next.acceleration == 9.0));

  OneJointAtATime joints;
  std::array<JointState, 9> states{};
  std::array<JointLimits, 9> limits{};
  std::array<JointState, 9> out{};
  CHECK(joints.update(states.data(), limits.data(), 0, 0, 1.0, kCycleS, out.data()) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(joints.invalid_field() == InvalidField::JointCount);
  CHECK(joints.update(states.data(), limits.data(), 9, 0, 1.0, kCycleS, out.data()) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(joints.update(states.data(), limits.data(), 3, 3, 1.0, kCycleS, out.data()) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(joints.invalid_field() == InvalidField::MovingJoint);
  limits[1].max_jerk = 0.0;
  CHECK(joints.update(states.data(), limits.data(), 3, 0, 1.0, kCycleS, out.data()) == TrajectoryStatus::ErrorInvalidInput);
  CHECK(joints.invalid_joint() == 1);
  CHECK(joints.invalid_field() == InvalidField::MaxJerk);
}

TEST_CASE("one joint moves to its target while the others brake to rest and stay", "[online]") {
  std::mt19937_64 rng(13);
  for (int n = 0; n < 200; ++n) {
    constexpr std::size_t kJoints = 6;
    std::array<JointState, kJoints> current{};
    std::array<JointLimits, kJoints> limits{};
    std::array<double, kJoints> stop_position{};
    std::array<double, kJoints> stop_duration{};
    for (std::size_t i = 0; i < kJoints; ++i) {
      const Move m = random_move(rng);
      current[i] = m.start;
      limits[i] = m.limits;
      Profile stop;
      REQUIRE(calculate_stop(m.start, m.limits, stop).ok());
      stop_position[i] = stop.end_state().position;
      stop_duration[i] = stop.duration();
    }
    const std::size_t moving = static_cast<std::size_t>(n) % kJoints;
    const double target = 3.0 * std::sin(n);
    OneJointAtATime joints;
    std::array<JointState, kJoints> next{};
    TrajectoryStatus st = TrajectoryStatus::Working;
    long cycles = 0;
    bool limits_ok = true;
    std::array<long, kJoints> rest_cycle{};
    while (st == TrajectoryStatus::Working && cycles < 100000) {
      st = joints.update(current.data(), limits.data(), kJoints, moving, target, kCycleS, next.data());
      ++cycles;
      for (std::size_t i = 0; i < kJoints; ++i) {
        limits_ok = limits_ok && within_limits(current[i], next[i], limits[i], kCycleS);
        if (rest_cycle[i] == 0 && i != moving && at_rest_at(next[i], stop_position[i])) rest_cycle[i] = cycles;
      }
      current = next;
    }
    CAPTURE(n, moving, cycles);
    REQUIRE(st == TrajectoryStatus::Finished);
    CHECK(limits_ok);
    CHECK(at_rest_at(current[moving], target));
    for (std::size_t i = 0; i < kJoints; ++i) {
      if (i == moving) continue;
      CAPTURE(i, stop_duration[i], rest_cycle[i]);
      CHECK(joints.hold_position(i) == stop_position[i]);
      CHECK(at_rest_at(current[i], stop_position[i]));
      // Braked time-optimally: at rest in the cycle that covers the stop's duration.
      CHECK(static_cast<double>(rest_cycle[i] - 1) * kCycleS < stop_duration[i] + 1e-9);
    }
    // Another joint is selected: the one that moved now holds where it stopped.
    const std::size_t second = (moving + 1) % kJoints;
    st = TrajectoryStatus::Working;
    for (long c = 0; st == TrajectoryStatus::Working && c < 100000; ++c) {
      st = joints.update(current.data(), limits.data(), kJoints, second, -target, kCycleS, next.data());
      CHECK(at_rest_at(next[moving], target));
      current = next;
    }
    CHECK(st == TrajectoryStatus::Finished);
    CHECK(at_rest_at(current[second], -target));
  }
}
