// SPDX-License-Identifier: Apache-2.0
// The filling profiles of a given duration and phase synchronization run in the control cycle as
// the rest of the generator does: they must not touch the heap either.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>

#include "allocation_counter.hpp"
#include "mgc/guidance/trajectory.hpp"

using namespace mgc::guidance;

TEST_CASE("filled durations and phase synchronization do not allocate", "[unit]") {
  // A joint whose stretched family cannot take the durations just above its minimum
  // (docs/trajectory.md): those are filled with a lowered jerk.
  const JointLimits lim{1.0, 1.0, 1.0};
  const JointState fast{0.0, 0.9, -0.8};
  Profile stop, profile;
  REQUIRE(calculate_stop(fast, lim, stop).ok());
  const double target = stop.end_state().position + 0.01;
  REQUIRE(calculate_time_optimal(fast, target, lim, profile).ok());
  const double t_min = profile.duration();
  std::array<JointState, 3> starts{fast, JointState{}, JointState{1.0, 0.0, 0.0}};
  const std::array<double, 3> targets{target, 0.8, -1.0};
  const std::array<JointLimits, 3> limits{lim, JointLimits{0.5, 0.5, 0.5}, JointLimits{0.3, 1.0, 2.0}};
  std::array<Profile, 3> out{};
  double sink = 0.0;
  int filled = 0, phase = 0;
  const long before = mgc::test::allocation_count();
  for (int k = 1; k <= 100; ++k) {
    const CalculationResult r = calculate_for_duration(fast, target, lim, t_min * (1.0 + 0.15 * k / 100.0), profile);
    if (r.ok()) ++filled;
    const SynchronizedResult s = calculate_synchronized(starts.data() + 1, targets.data() + 1, limits.data() + 1, 2,
                                                        out.data(), Synchronization::Phase);
    if (s.ok() && s.phase_synchronized) ++phase;
    const SynchronizedResult t = calculate_synchronized(starts.data(), targets.data(), limits.data(), 3, out.data());
    sink += t.ok() ? t.duration_s : 0.0;
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(filled == 100);
  CHECK(phase == 100);
  CHECK(std::isfinite(sink));
}
