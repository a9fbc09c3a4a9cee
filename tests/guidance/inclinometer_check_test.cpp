// SPDX-License-Identifier: Apache-2.0
// The boom inclinometer against the boom's encoder, in stepped time at 100 Hz: a sensor that reads
// the true angle through its filter with noise agrees with a true encoder, moving or not; an
// encoder that drifts as slowly as the loop can follow is found within 0.3 s.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "mgc/guidance/diagnostics.hpp"
#include "mgc/planning/random.hpp"

using namespace mgc::guidance;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr std::int64_t kCycleUs = 10'000;

//! A boom that luffs back and forth at up to speed_deg_s, an inclinometer on it (its filter, its
//! noise), and an encoder that lies by drift_deg_s from drift_from_s on.
struct Boom {
  InclinometerCheck check{1};
  mgc::planning::Random random{7};
  double filtered_rad = 40.0 * kDeg;
  double speed_deg_s = 1.0;
  double drift_deg_s = 0.0;
  double drift_from_s = 1e9;

  double truth_rad(double t_s) const { return (40.0 + speed_deg_s * 10.0 * std::sin(t_s / 10.0)) * kDeg; }

  double gaussian() {
    const double u1 = 1.0 - random.uniform();
    const double u2 = random.uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

  //! Runs to t_end_s; returns the time of the finding, or NaN.
  double run(double t_end_s, bool gap_at_5s = false) {
    for (std::int64_t t_us = 0; t_us <= static_cast<std::int64_t>(t_end_s * 1e6); t_us += kCycleUs) {
      const double t_s = static_cast<double>(t_us) * 1e-6;
      const double q = truth_rad(t_s);
      filtered_rad += (q - filtered_rad) * (1.0 - std::exp(-0.01 / 0.02));
      InclinometerInputs in;
      in.now_us = t_us;
      const bool gap = gap_at_5s && t_s >= 5.0 && t_s < 5.2;
      in.encoder_valid = true;
      in.encoder_updated = true;
      in.encoder_rad = q + (t_s >= drift_from_s ? drift_deg_s * (t_s - drift_from_s) * kDeg : 0.0);
      in.angle_valid = !gap;
      in.angle_updated = !gap;
      in.angle_rad = filtered_rad + 0.02 * kDeg * gaussian();
      if (check.update(in).disagrees) return static_cast<double>(check.result().detected_us) * 1e-6;
    }
    return std::nan("");
  }
};

}  // namespace

TEST_CASE("inclinometer: a true encoder agrees with it, standing, luffing at full speed, across a gap", "[guidance][inclinometer]") {
  for (const double speed : {0.0, 1.04, 10.0}) {
    Boom boom;
    boom.speed_deg_s = speed;
    CAPTURE(speed);
    CHECK(std::isnan(boom.run(60.0, true)));
    CHECK(boom.check.judged() > 5000);
    // Far from its threshold: noise and the filter's lag leave a wide margin.
    CHECK(boom.check.peak_ratio() < 0.6);
    WARN("speed " << speed << " deg/s: peak ratio " << boom.check.peak_ratio());
  }
}

TEST_CASE("inclinometer: an encoder drifting at 0.6 of the boom's speed limit is found within 0.3 s", "[guidance][inclinometer]") {
  for (const double drift : {0.62, -0.62, 0.83, 2.0}) {
    Boom boom;
    boom.speed_deg_s = 1.04;
    boom.drift_deg_s = drift;
    boom.drift_from_s = 20.005;
    const double found_s = boom.run(30.0);
    CAPTURE(drift, found_s);
    REQUIRE_FALSE(std::isnan(found_s));
    CHECK(found_s - boom.drift_from_s <= 0.3);
    CHECK(boom.check.result().joint == 1);
    CHECK(std::abs(boom.check.result().residual_rad) > boom.check.result().threshold_rad);
  }
}

TEST_CASE("inclinometer: without one (joint -1) nothing is judged, and a bad configuration is refused", "[guidance][inclinometer]") {
  InclinometerCheck none(-1);
  InclinometerInputs in;
  in.encoder_valid = in.angle_valid = in.encoder_updated = in.angle_updated = true;
  in.encoder_rad = 0.0;
  in.angle_rad = 1.0;
  for (int k = 0; k < 20; ++k) {
    in.now_us = k * kCycleUs;
    CHECK_FALSE(none.update(in).disagrees);
  }
  CHECK_FALSE(none.enabled());
  InclinometerCheckConfig bad;
  bad.average_samples = 0;
  CHECK_THROWS_AS(InclinometerCheck(1, bad), std::invalid_argument);
}
