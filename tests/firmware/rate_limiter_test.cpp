// SPDX-License-Identifier: Apache-2.0
// The rate limiter (docs/control-loop.md §Rate limiter): acceleration and jerk limits hold over
// random command sequences and periods, a constant target is reached exactly and within the
// time-optimal bound, the controlled stop decelerates at the limit, reset continues from the
// measured state, and bad inputs are reported.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/firmware/rate_limiter.hpp"

using namespace mgc::firmware;

namespace {

constexpr double kPeriodS = 0.01;

//! Crane and excavator joint limits: 0.05-2 rad/s, velocity reached in 0.2-4 s, acceleration
//! reached in 0.05-1 s.
RateLimits random_limits(std::mt19937_64& rng, bool jerk) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, unit(rng)); };
  RateLimits l;
  l.max_velocity = log_uniform(0.05, 2.0);
  l.max_acceleration = l.max_velocity / log_uniform(0.2, 4.0);
  l.max_jerk = jerk ? l.max_acceleration / log_uniform(0.05, 1.0) : 0.0;
  return l;
}

//! Continuous-time optimal duration of a velocity change dv from rest to rest of the acceleration.
double optimal_time_s(double dv, const RateLimits& l) {
  dv = std::abs(dv);
  if (l.max_jerk <= 0.0) return dv / l.max_acceleration;
  if (dv >= l.max_acceleration * l.max_acceleration / l.max_jerk) {
    return dv / l.max_acceleration + l.max_acceleration / l.max_jerk;
  }
  return 2.0 * std::sqrt(dv / l.max_jerk);
}

}  // namespace

TEST_CASE("acceleration, jerk and velocity limits hold over random command sequences", "[property]") {
  for (const bool jerk : {false, true}) {
    const std::uint64_t seed = jerk ? 11 : 12;
    CAPTURE(jerk, seed);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 40; ++trial) {
      std::array<RateLimits, 4> limits{};
      for (auto& l : limits) l = random_limits(rng, jerk);
      RateLimiter limiter(limits);
      std::array<double, 4> target{};
      std::array<double, 4> previous_v{};
      std::array<double, 4> previous_a{};
      double previous_period_s = kPeriodS;
      for (int cycle = 0; cycle < 2000; ++cycle) {
        // A new random target on some joints now and then: within and beyond the velocity limit,
        // sign flips, and a rare NaN.
        for (std::size_t j = 0; j < 4; ++j) {
          if (unit(rng) < 0.02) target[j] = (2.6 * unit(rng) - 1.3) * limits[j].max_velocity;
          if (unit(rng) < 0.0005) target[j] = std::numeric_limits<double>::quiet_NaN();
        }
        // The true elapsed time varies: a loop at 100 Hz with jitter, now and then an overrun.
        const double period_s = unit(rng) < 0.01 ? 0.03 : kPeriodS * (0.8 + 0.4 * unit(rng));
        const bool stopping = cycle % 500 >= 450;  // a controlled stop now and then
        const RateLimitResult r = stopping ? limiter.stop(period_s) : limiter.update(target, period_s);
        REQUIRE(r.status == RateLimitStatus::Ok);
        for (std::size_t j = 0; j < 4; ++j) {
          const RateLimits& l = limits[j];
          const double v = limiter.velocity()[j];
          const double a = (v - previous_v[j]) / period_s;
          CAPTURE(trial, cycle, j, v, previous_v[j], a, previous_a[j], period_s);
          REQUIRE(std::isfinite(v));
          REQUIRE(std::abs(a) <= l.max_acceleration * (1.0 + 1e-9));
          REQUIRE(std::abs(v) <= l.max_velocity * (1.0 + 1e-12));
          if (!stopping) {
            REQUIRE(limiter.acceleration()[j] == Approx(a).margin(1e-9 * l.max_acceleration));
          }
          if (jerk && !stopping) {
            // Jerk holds everywhere but on the stop (waived there, documented): from the state the
            // last cycle left, which after a completed stop is rest.
            // A cycle under half the previous one may end a landing faster (documented).
            const double allowance = std::max(1.0, previous_period_s / (2.0 * period_s));
            REQUIRE(std::abs(a - previous_a[j]) <=
                    l.max_jerk * period_s * allowance * (1.0 + 1e-9) + 1e-9 * l.max_acceleration);
          }
          previous_v[j] = v;
          previous_a[j] = limiter.acceleration()[j];
        }
        previous_period_s = period_s;
      }
    }
  }
}

TEST_CASE("a constant target is reached exactly, without overshoot, within the time-optimal bound", "[property]") {
  for (const bool jerk : {false, true}) {
    std::mt19937_64 rng(jerk ? 21 : 22);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 500; ++trial) {
      const RateLimits l = random_limits(rng, jerk);
      RateLimiter limiter(std::span<const RateLimits>(&l, 1));
      const double start = (2.0 * unit(rng) - 1.0) * l.max_velocity;
      const double target = (2.0 * unit(rng) - 1.0) * l.max_velocity;
      limiter.reset(std::array<double, 1>{start});
      const int bound = static_cast<int>(std::ceil(optimal_time_s(target - start, l) / kPeriodS)) + 2;
      CAPTURE(jerk, trial, start, target, l.max_velocity, l.max_acceleration, l.max_jerk, bound);
      int cycles = 0;
      while (limiter.velocity()[0] != target && cycles < 10 * bound + 100) {
        (void)limiter.update(std::array<double, 1>{target}, kPeriodS);
        ++cycles;
        // Never past the target on the way.
        const double v = limiter.velocity()[0];
        REQUIRE((target - v) * (target - start) >= 0.0);
      }
      REQUIRE(limiter.velocity()[0] == target);  // bit for bit
      CHECK(cycles <= bound);
      // And it stays there, with no acceleration left.
      for (int c = 0; c < 50; ++c) {
        const RateLimitResult r = limiter.update(std::array<double, 1>{target}, kPeriodS);
        REQUIRE(limiter.velocity()[0] == target);
        REQUIRE(limiter.acceleration()[0] == 0.0);
        REQUIRE(r.limited_mask == 0);
      }
    }
  }
}

TEST_CASE("a target beyond the velocity limit is clamped and reached exactly", "[unit]") {
  const RateLimits l{0.5, 1.0, 10.0};
  RateLimiter limiter(std::span<const RateLimits>(&l, 1));
  RateLimitResult r;
  for (int c = 0; c < 200; ++c) r = limiter.update(std::array<double, 1>{-2.0}, kPeriodS);
  CHECK(limiter.velocity()[0] == -0.5);
  CHECK(r.clamped_mask == 1);
  CHECK(r.limited_mask == 0);
}

TEST_CASE("the controlled stop decelerates at the acceleration limit to exactly zero", "[unit]") {
  const RateLimits l{1.0, 0.8, 4.0};
  RateLimiter limiter(std::span<const RateLimits>(&l, 1));
  RateLimiter jerk_stop(std::span<const RateLimits>(&l, 1));
  // Full speed, still accelerating upward toward a higher target: the worst moment to stop.
  limiter.reset(std::array<double, 1>{0.9}, std::array<double, 1>{0.8});
  jerk_stop.reset(std::array<double, 1>{0.9}, std::array<double, 1>{0.8});

  double distance = 0.0;
  double previous = 0.9;
  int cycles = 0;
  while (!limiter.at_rest()) {
    const RateLimitResult r = limiter.stop(kPeriodS);
    REQUIRE(r.status == RateLimitStatus::Ok);
    const double v = limiter.velocity()[0];
    // Every step a full deceleration step until the last: the limit, no more, no less.
    if (v != 0.0) REQUIRE(previous - v == Approx(l.max_acceleration * kPeriodS).epsilon(1e-12));
    REQUIRE(v >= 0.0);  // never reverses
    REQUIRE(previous - v <= l.max_acceleration * kPeriodS * (1.0 + 1e-12));
    distance += v * kPeriodS;
    previous = v;
    ++cycles;
    REQUIRE(cycles < 1000);
  }
  CHECK(limiter.velocity()[0] == 0.0);
  CHECK(cycles == static_cast<int>(std::ceil(0.9 / (l.max_acceleration * kPeriodS) - 1e-9)));

  // The jerk-limited ramp to zero takes longer and further: the waiver only shortens the stop.
  double jerk_distance = 0.0;
  int jerk_cycles = 0;
  while (!jerk_stop.at_rest() && jerk_cycles < 1000) {
    (void)jerk_stop.update(std::array<double, 1>{0.0}, kPeriodS);
    jerk_distance += jerk_stop.velocity()[0] * kPeriodS;
    ++jerk_cycles;
  }
  CHECK(jerk_stop.velocity()[0] == 0.0);
  CHECK(distance < jerk_distance);
  CHECK(cycles < jerk_cycles);

  // Resuming after a stop starts from rest without a jump.
  (void)limiter.update(std::array<double, 1>{1.0}, kPeriodS);
  CHECK(limiter.velocity()[0] > 0.0);
  CHECK(limiter.velocity()[0] <= l.max_jerk * kPeriodS * kPeriodS * (1.0 + 1e-12));
}

TEST_CASE("a stop in mid-stop resume keeps every joint within its own limit", "[unit]") {
  const std::array<RateLimits, 3> limits{RateLimits{1.0, 0.5, 0.0}, RateLimits{0.2, 0.1, 0.0},
                                         RateLimits{2.0, 4.0, 0.0}};
  RateLimiter limiter(limits);
  limiter.reset(std::array<double, 3>{0.6, -0.2, 1.5});
  (void)limiter.stop(kPeriodS);
  CHECK(limiter.velocity()[0] == Approx(0.6 - 0.005));
  CHECK(limiter.velocity()[1] == Approx(-0.2 + 0.001));
  CHECK(limiter.velocity()[2] == Approx(1.5 - 0.04));
  CHECK_FALSE(limiter.at_rest());
  for (int c = 0; c < 300; ++c) (void)limiter.stop(kPeriodS);
  CHECK(limiter.at_rest());
}

TEST_CASE("reset continues from the measured state without a jump", "[unit]") {
  const RateLimits l{1.0, 0.5, 5.0};
  RateLimiter limiter(std::span<const RateLimits>(&l, 1));

  SECTION("moving: the next command is within one step of the measured velocity") {
    limiter.reset(std::array<double, 1>{0.4}, std::array<double, 1>{0.2});
    CHECK(limiter.velocity()[0] == 0.4);
    CHECK(limiter.acceleration()[0] == 0.2);
    (void)limiter.update(std::array<double, 1>{-1.0}, kPeriodS);
    const double a = (limiter.velocity()[0] - 0.4) / kPeriodS;
    CHECK(std::abs(a - 0.2) <= l.max_jerk * kPeriodS * (1.0 + 1e-12));
  }
  SECTION("a measured acceleration beyond the limit is clamped; NaN is taken as zero") {
    limiter.reset(std::array<double, 1>{0.1}, std::array<double, 1>{3.0});
    CHECK(limiter.acceleration()[0] == 0.5);
    limiter.reset(std::array<double, 1>{std::numeric_limits<double>::quiet_NaN()},
                  std::array<double, 1>{std::numeric_limits<double>::infinity()});
    CHECK(limiter.velocity()[0] == 0.0);
    CHECK(limiter.acceleration()[0] == 0.0);
    CHECK(limiter.at_rest());
  }
  SECTION("a measured overspeed is brought back at the deceleration limit, not cut") {
    limiter.reset(std::array<double, 1>{1.3});
    (void)limiter.update(std::array<double, 1>{1.0}, kPeriodS);
    CHECK(limiter.velocity()[0] > 1.0);
    CHECK(1.3 - limiter.velocity()[0] <= l.max_acceleration * kPeriodS * (1.0 + 1e-12));
    for (int c = 0; c < 500; ++c) (void)limiter.update(std::array<double, 1>{1.0}, kPeriodS);
    CHECK(limiter.velocity()[0] == 1.0);
  }
}

TEST_CASE("bad periods and targets are reported, never passed on", "[unit]") {
  const std::array<RateLimits, 2> limits{RateLimits{1.0, 1.0, 0.0}, RateLimits{1.0, 1.0, 10.0}};
  RateLimiter limiter(limits);
  limiter.reset(std::array<double, 2>{0.5, -0.5});
  for (const double period : {0.0, -0.01, std::numeric_limits<double>::quiet_NaN(),
                              std::numeric_limits<double>::infinity()}) {
    CAPTURE(period);
    CHECK(limiter.update(std::array<double, 2>{1.0, 1.0}, period).status == RateLimitStatus::InvalidPeriod);
    CHECK(limiter.stop(period).status == RateLimitStatus::InvalidPeriod);
    CHECK(limiter.velocity()[0] == 0.5);
    CHECK(limiter.velocity()[1] == -0.5);
  }
  const RateLimitResult r =
      limiter.update(std::array<double, 2>{std::numeric_limits<double>::quiet_NaN(), 0.3}, kPeriodS);
  CHECK(r.status == RateLimitStatus::Ok);
  CHECK(r.refused_mask == 0b01);
  CHECK(limiter.velocity()[0] == Approx(0.49));  // slowing toward zero, at the limit
  CHECK(r.limited_mask == 0b11);
}

TEST_CASE("limits from the machine model's joints", "[unit]") {
  using mgc::planning::JointSpec;
  using mgc::planning::JointType;
  std::vector<JointSpec> joints = {
      mgc::planning::joint_from_ramps("swing", JointType::Revolute, true, -3.14, 3.14, 0.1, 2.0, 0.5),
      mgc::planning::joint_from_ramps("boom_length", JointType::Prismatic, false, 10.0, 40.0, 0.3, 1.0, 0.25),
  };
  const auto on = rate_limits_from(joints, JerkLimit::On);
  CHECK(on[0].max_velocity == 0.1);
  CHECK(on[0].max_acceleration == Approx(0.05));
  CHECK(on[0].max_jerk == Approx(0.1));
  CHECK(on[1].max_jerk == Approx(1.2));
  const auto off = rate_limits_from(joints, JerkLimit::Off);
  CHECK(off[1].max_acceleration == Approx(0.3));
  CHECK(off[1].max_jerk == 0.0);
  RateLimiter limiter(std::span<const RateLimits>(on.data(), joints.size()));
  CHECK(limiter.num_joints() == 2);

  const auto message = [](auto&& make) {
    try {
      make();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  joints[1].max_jerk = 0.0;
  CHECK(message([&] { (void)rate_limits_from(joints, JerkLimit::On); }).find("joint 1 (boom_length).max_jerk") !=
        std::string::npos);
  CHECK(message([&] { (void)rate_limits_from(joints, JerkLimit::Off); }).empty());
  joints[0].max_acceleration = 0.0;
  CHECK(message([&] { (void)rate_limits_from(joints, JerkLimit::Off); }).find("max_acceleration") !=
        std::string::npos);
  CHECK(message([] { (void)rate_limits_from({}, JerkLimit::Off); }).find("joints") != std::string::npos);
  const std::array<RateLimits, mgc::kMaxJoints + 1> too_many{};
  CHECK(message([&] { RateLimiter r(too_many); }).find("joints") != std::string::npos);
}
