// SPDX-License-Identifier: Apache-2.0
// Which way a continuous joint turns when start and goal are half a turn apart.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::kDeg;

namespace {

constexpr double kPi = std::numbers::pi;

// x moved k ulps toward +infinity (k > 0) or -infinity (k < 0).
double ulps(double x, int k) {
  for (; k > 0; --k) x = std::nextafter(x, 10.0);
  for (; k < 0; ++k) x = std::nextafter(x, -10.0);
  return x;
}

MobileCrane make_crane() {
  const MachineDefinition m = io::load_machine(mgc::test::source_path("scenarios/machines/grove-tms870.yaml"));
  LiftTask task;
  task.load_lb = 20000;
  task.load_size_m = {3.0, 2.0, 1.0};
  task.sling_length_m = 2.0;
  return MobileCrane(m.name, m.joints, m.mobile_crane, *m.load_chart, m.luff_table, task, Eigen::Isometry3d::Identity());
}

}  // namespace

TEST_CASE("wrap_angle stays in [-pi, pi), also where the raise by 2 pi rounds", "[unit]") {
  for (const double centre : {kPi, -kPi, 3.0 * kPi, -3.0 * kPi}) {
    for (int k = -4; k <= 4; ++k) {
      const double angle = ulps(centre, k);
      CAPTURE(angle, k);
      CHECK(wrap_angle(angle) >= -kPi);
      CHECK(wrap_angle(angle) < kPi);
    }
  }
  // Half an ulp of 2 pi below -pi: the naive raise lands on 2 pi and would give +pi.
  CHECK(wrap_angle(ulps(-kPi, -1)) == -kPi);
  CHECK(wrap_angle(kPi) == -kPi);
  CHECK(wrap_angle(-kPi) == -kPi);
}

TEST_CASE("half a turn goes the negative way, a few ulps either side of pi included", "[unit]") {
  for (const double half : {kPi, -kPi}) {
    for (int k = -4; k <= 4; ++k) {
      const double delta = ulps(half, k);
      CAPTURE(delta, k);
      const double turn = shorter_turn(delta);
      CHECK(turn < 0.0);
      CHECK(std::abs(turn + kPi) <= kHalfTurnTolerance_rad);
      // The same place: the turn differs from delta by whole turns.
      CHECK(std::abs(wrap_angle(turn - delta)) <= 1e-15);
    }
  }
  // Beyond the tolerance the shorter way wins, whichever it is.
  CHECK(shorter_turn(kPi - 2.0 * kHalfTurnTolerance_rad) == Approx(kPi - 2.0 * kHalfTurnTolerance_rad).epsilon(1e-15));
  CHECK(shorter_turn(-kPi + 2.0 * kHalfTurnTolerance_rad) == Approx(-kPi + 2.0 * kHalfTurnTolerance_rad).epsilon(1e-15));
  CHECK(shorter_turn(0.5) == 0.5);
  CHECK(shorter_turn(-0.5) == -0.5);
  CHECK(shorter_turn(1.5 * kPi) == Approx(-0.5 * kPi));
}

TEST_CASE("a swing between angles given in degrees 180 apart goes the negative way, in either order", "[unit]") {
  const MobileCrane crane = make_crane();
  JointVector a(4);
  JointVector b(4);
  a << 0.0, 45 * kDeg, 30.0, 10.0;
  b = a;
  // As the scenario loader reads a swing: degrees times kDeg, wrapped.
  for (int tenth = -1800; tenth <= 1800; ++tenth) {
    const double deg = tenth / 10.0;
    a[0] = wrap_angle(deg * kDeg);
    b[0] = wrap_angle((deg + 180.0) * kDeg);
    CAPTURE(deg);
    const double ab = crane.difference(a, b)[0];
    const double ba = crane.difference(b, a)[0];
    REQUIRE(ab < 0.0);
    REQUIRE(ba < 0.0);
    REQUIRE(std::abs(ab + kPi) <= kHalfTurnTolerance_rad);
    REQUIRE(std::abs(ba + kPi) <= kHalfTurnTolerance_rad);
  }
  // Halfway from swing 0 to swing 180 deg the boom points to -90 deg: clockwise seen from above.
  a[0] = 0.0;
  b[0] = wrap_angle(180.0 * kDeg);
  CHECK(crane.interpolate(a, b, 0.5)[0] == Approx(-90 * kDeg));
  CHECK(crane.interpolate(b, a, 0.5)[0] == Approx(90 * kDeg));
}
