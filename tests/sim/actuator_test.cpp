// SPDX-License-Identifier: Apache-2.0
// The hydraulic joint model: deadband, first-order lag, acceleration and speed limits, end stops.
#include <catch2/catch.hpp>

#include <cmath>

#include "mgc/sim/actuator.hpp"

using mgc::sim::ActuatorParams;
using mgc::sim::HydraulicActuator;

namespace {

ActuatorParams params() {
  ActuatorParams p;
  p.max_velocity = 0.1;
  p.max_acceleration = 1e6;  // lag only, unless a test sets it
  p.lag_s = 0.2;
  p.deadband = 0.05;
  p.position_min = -1.0;
  p.position_max = 1.0;
  return p;
}

}  // namespace

TEST_CASE("the valve's deadband: no flow inside it, linear flow beyond", "[sim][actuator]") {
  const HydraulicActuator a(params(), 0.0);
  CHECK(a.target_velocity(0.0) == 0.0);
  CHECK(a.target_velocity(0.05) == 0.0);
  CHECK(a.target_velocity(-0.049) == 0.0);
  CHECK(a.target_velocity(1.0) == Approx(0.1));
  CHECK(a.target_velocity(-1.0) == Approx(-0.1));
  CHECK(a.target_velocity(0.525) == Approx(0.05));
  CHECK(a.target_velocity(3.0) == Approx(0.1));  // a spool cannot open past full
}

TEST_CASE("velocity follows the spool with the first-order lag, independent of the step size", "[sim][actuator]") {
  for (const double dt : {1e-4, 1e-3, 5e-3}) {
    HydraulicActuator a(params(), 0.0);
    const int steps = static_cast<int>(std::lround(0.2 / dt));
    for (int i = 0; i < steps; ++i) a.step(1.0, dt);
    CAPTURE(dt);
    // After one time constant: 1 - 1/e of the step.
    CHECK(a.velocity() == Approx(0.1 * (1.0 - std::exp(-1.0))).epsilon(1e-9));
    // Position: the trapezoid of the exact exponential, close to its integral.
    const double exact = 0.1 * (0.2 - 0.2 * (1.0 - std::exp(-1.0)));
    CHECK(a.position() == Approx(exact).epsilon(1e-3));
  }
}

TEST_CASE("the acceleration limit caps how fast the velocity changes", "[sim][actuator]") {
  ActuatorParams p = params();
  p.max_acceleration = 0.05;  // 2 s to full speed, far slower than the lag
  HydraulicActuator a(p, 0.0);
  for (int i = 0; i < 1000; ++i) a.step(1.0, 1e-3);
  CHECK(a.velocity() == Approx(0.05).epsilon(1e-9));
  CHECK(a.acceleration() == Approx(0.05).epsilon(1e-9));
  for (int i = 0; i < 10'000; ++i) a.step(1.0, 1e-3);
  CHECK(a.velocity() == Approx(0.1).epsilon(1e-6));
  CHECK(a.velocity() <= 0.1);
}

TEST_CASE("an end stop halts the joint, driving away from it works", "[sim][actuator]") {
  HydraulicActuator a(params(), 0.99);
  for (int i = 0; i < 2000; ++i) a.step(1.0, 1e-3);
  CHECK(a.position() == 1.0);
  CHECK(a.velocity() == 0.0);
  for (int i = 0; i < 2000; ++i) a.step(-1.0, 1e-3);
  CHECK(a.position() < 0.9);
  CHECK(a.velocity() < 0.0);
}

TEST_CASE("a continuous joint has no end stops", "[sim][actuator]") {
  ActuatorParams p = params();
  p.continuous = true;
  HydraulicActuator a(p, 0.99);
  for (int i = 0; i < 2000; ++i) a.step(1.0, 1e-3);
  CHECK(a.position() > 1.1);
}
