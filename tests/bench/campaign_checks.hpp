// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <catch2/catch.hpp>

#include <cmath>

#include "campaign_bench.hpp"

namespace mgc::bench::test {

//! The properties that must hold on every campaign run, disturbed or not.
inline void check_true_state(const LiftRecord& rec, const LiftRun& run) {
  INFO(lift_record_text(rec));
  CHECK(run.samples > 0);
  // No contact, unless an intruder moved into the machine: never with the site, never with an
  // obstacle that stood still.
  if (!std::isnan(run.contact_s)) CHECK(run.contact_intruder_moving);
  CHECK(run.samples_chart_exceeded == 0);
  CHECK(run.samples_below_ground == 0);
  if (!std::isnan(run.peak_chart)) CHECK(run.peak_chart <= 1.0);
  if (!std::isnan(run.least_ground_m)) CHECK(run.least_ground_m > 0.0);
}

}  // namespace mgc::bench::test
