// SPDX-License-Identifier: Apache-2.0
// Campaign lifts (mgc-bench --suite campaign --lift N) whose boom-encoder drift the motion checks
// could not tell from a slow actuator: the closed loop followed the lie, and in lift 183 drove the
// true boom past the load chart and the load into the ground. The boom inclinometer finds each.
#include <catch2/catch.hpp>

#include <string>

#include "campaign_bench.hpp"

using namespace mgc::bench;

TEST_CASE("campaign lifts 183, 230, 520, 182, 912: a boom-encoder drift the loop follows is found by the inclinometer within 0.3 s",
          "[bench][campaign]") {
  CampaignOptions options;
  options.scenarios_dir = std::string(MGC_SOURCE_DIR) + "/scenarios";
  options.threads = 1;
  options.progress = false;
  for (const int lift : {183, 230, 520, 182, 912}) {
    const LiftRecord rec = run_campaign_lift(options, lift);
    INFO(lift_record_text(rec));
    REQUIRE(rec.disturbance == Disturbance::Fault);
    REQUIRE(rec.fault_text.rfind("encoder-offset:boom_elevation", 0) == 0);
    CHECK(rec.detected);
    CHECK(rec.detect_s <= 0.3);
    // A drift that cancels the boom's motion leaves the encoder repeating itself (520): stuck.
    const bool named = rec.run.first_stop_reason == "AngleDisagrees" || rec.run.first_stop_reason == "EncoderStuck";
    CHECK(named);
    CHECK(rec.run.first_stop_value == 1);
    CHECK(rec.run.state == "FAULT");
    // Judged in the true state: the chart kept, the load above the ground, the machine at rest.
    CHECK(rec.run.samples_chart_exceeded == 0);
    CHECK(rec.run.samples_below_ground == 0);
    CHECK(rec.run.least_ground_m > 0.0);
    CHECK(rec.run.peak_chart <= 1.0);
    CHECK(rec.run.rest_after_fault_s < 5.0);
  }
}
