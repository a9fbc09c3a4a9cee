// SPDX-License-Identifier: Apache-2.0
// A small safety campaign (mgc-bench --suite campaign): every lift, disturbed or not, is judged in
// the simulator's true state, and any lift replays alone to the same record.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "campaign_bench.hpp"
#include "campaign_checks.hpp"

using namespace mgc::bench;

namespace {

CampaignOptions small_campaign() {
  CampaignOptions o;
  o.scenarios_dir = std::string(MGC_SOURCE_DIR) + "/scenarios";
  o.lifts = 20;
  o.threads = 2;
  o.progress = false;
  return o;
}

using test::check_true_state;

}  // namespace

TEST_CASE("campaign: 20 randomized lifts keep the true state's limits, and each replays alone to the same record", "[bench][campaign]") {
  const CampaignOptions options = small_campaign();
  const std::vector<LiftRecord> records = run_campaign(options);
  REQUIRE(records.size() == 20);
  int disturbed = 0;
  int intrusions = 0;
  int faults = 0;
  int completed_twins = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const LiftRecord& rec = records[i];
    CAPTURE(i);
    CHECK(rec.index == static_cast<int>(i));
    check_true_state(rec, rec.twin);
    check_true_state(rec, rec.run);
    // The twin is undisturbed: nothing moves into it.
    CHECK(std::isnan(rec.twin.contact_s));
    if (rec.twin.completed) ++completed_twins;
    if (rec.disturbance != Disturbance::None) ++disturbed;
    if (rec.disturbance == Disturbance::Crane || rec.disturbance == Disturbance::Truck || rec.disturbance == Disturbance::Worker) ++intrusions;
    if (rec.disturbance == Disturbance::Fault) {
      ++faults;
      CHECK_FALSE(rec.fault_text.empty());
      // The fault starts while the twin moves, so the lift is identical to its twin up to it.
      CHECK(rec.fault_s > rec.twin.motion_start_s);
    }
  }
  // The draw covers the kinds of disturbance, and most lifts run to their goal undisturbed.
  CHECK(disturbed > 0);
  CHECK(intrusions > 0);
  CHECK(faults > 0);
  CHECK(completed_twins >= 15);

  // --lift N: the lift alone, on this thread, gives the record it had in the campaign's pool;
  // an intrusion, a fault and a lift left alone.
  std::vector<int> replay;
  for (const Disturbance kind : {Disturbance::Fault, Disturbance::None, Disturbance::Crane, Disturbance::Truck, Disturbance::Worker}) {
    for (const LiftRecord& rec : records) {
      if (rec.disturbance == kind) {
        replay.push_back(rec.index);
        break;
      }
    }
  }
  REQUIRE(replay.size() >= 3);
  for (const int n : replay) {
    CAPTURE(n);
    const LiftRecord again = run_campaign_lift(options, n);
    CHECK(lift_record_text(again) == lift_record_text(records[static_cast<std::size_t>(n)]));
  }
}

TEST_CASE("campaign: a lift's record names its fault, the finding expected and when it came", "[bench][campaign]") {
  const CampaignOptions options = small_campaign();
  // The first lifts of the default seeds: find one with a fault the controller must find.
  for (int n = 0; n < options.lifts; ++n) {
    const LiftRecord rec = run_campaign_lift(options, n);
    if (rec.disturbance != Disturbance::Fault || rec.expected_reasons.empty()) continue;
    INFO(lift_record_text(rec));
    CHECK(lift_record_text(rec).find(rec.fault_text) != std::string::npos);
    CHECK(rec.detect_budget_s > 0.0);
    REQUIRE(rec.detected);
    CHECK(rec.detect_s >= 0.0);
    CHECK_FALSE(rec.run.completed);
    CHECK(rec.run.state == std::string("FAULT"));
    // The machine came to rest after the finding, within the run.
    CHECK(rec.run.rest_after_fault_s >= rec.detect_s);
    return;
  }
  FAIL("no fault among the first 20 lifts");
}
