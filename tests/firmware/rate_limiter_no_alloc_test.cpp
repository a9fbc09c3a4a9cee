// SPDX-License-Identifier: Apache-2.0
// The rate limiter runs every control cycle: update, stop and reset must not touch the heap.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <random>

#include "allocation_counter.hpp"
#include "mgc/firmware/rate_limiter.hpp"

using namespace mgc::firmware;

TEST_CASE("the rate limiter does not allocate", "[unit]") {
  const std::array<RateLimits, 4> limits{RateLimits{0.1, 0.05, 0.2}, RateLimits{0.05, 0.05, 0.5},
                                         RateLimits{0.3, 0.3, 0.0}, RateLimits{0.5, 0.5, 2.0}};
  RateLimiter limiter(limits);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::array<double, 4> target{};
  double sink = 0.0;
  const long before = mgc::test::allocation_count();
  for (int cycle = 0; cycle < 20'000; ++cycle) {
    if (cycle % 37 == 0) {
      for (double& t : target) t = 0.6 * u(rng);
    }
    if (cycle % 1000 == 999) limiter.reset(target);
    const RateLimitResult r = cycle % 400 > 350 ? limiter.stop(0.01) : limiter.update(target, 0.01);
    sink += limiter.velocity()[0] + r.limited_mask;
  }
  CHECK(mgc::test::allocation_count() == before);
  CHECK(std::isfinite(sink));
}
