// SPDX-License-Identifier: Apache-2.0
// Campaign lifts on generated sites (mgc-bench --suite campaign, lifts from kShippedLifts on): each
// draws a solvable site family and a site seed from its own seed, writes the site as a scenario
// file, keeps the true state's limits and replays alone to the same record; the shipped sites'
// lifts draw what they drew before the generated lifts were added.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

#include "campaign_bench.hpp"
#include "campaign_checks.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "site_families.hpp"

using namespace mgc::bench;

namespace {

CampaignOptions generated_campaign() {
  CampaignOptions o;
  o.scenarios_dir = std::string(MGC_SOURCE_DIR) + "/scenarios";
  o.sites_dir = (std::filesystem::temp_directory_path() / ("mgc-campaign-generated-test-" + std::to_string(::getpid()))).string();
  o.first_lift = kShippedLifts;
  o.lifts = kShippedLifts + 6;
  o.threads = 2;
  o.progress = false;
  return o;
}

using test::check_true_state;

}  // namespace

TEST_CASE("campaign: lifts on generated sites draw a solvable family, keep the true state's limits and replay alone to the same record",
          "[bench][campaign]") {
  const CampaignOptions options = generated_campaign();
  const std::vector<LiftRecord> records = run_campaign(options);
  REQUIRE(records.size() == 6);
  int intrusions = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const LiftRecord& rec = records[i];
    INFO(lift_record_text(rec));
    CHECK(rec.index == kShippedLifts + static_cast<int>(i));
    // The site: a solvable family's, named by family and site seed, written where the options say,
    // and it loads as any scenario does.
    const SiteFamily* family = find_site_family(rec.family);
    REQUIRE(family != nullptr);
    CHECK(family->expectation == SiteExpectation::Solvable);
    CHECK(rec.site == rec.family + "-s" + std::to_string(rec.site_seed) + ".yaml");
    const std::filesystem::path file = std::filesystem::path(options.sites_dir) / rec.site;
    REQUIRE(std::filesystem::exists(file));
    CHECK_NOTHROW(mgc::planning::io::load_scenario(file.string()));
    CHECK(rec.site_redraws >= 0);
    // A generated site has no other crane to swing in.
    CHECK(rec.disturbance != Disturbance::Crane);
    if (rec.disturbance == Disturbance::Truck || rec.disturbance == Disturbance::Worker) ++intrusions;
    check_true_state(rec, rec.twin);
    check_true_state(rec, rec.run);
    CHECK(std::isnan(rec.twin.contact_s));
  }
  CHECK(intrusions > 0);

  // --lift N: the first intrusion and the first lift of another kind, alone on this thread.
  std::vector<int> replay;
  for (const bool intrusion : {true, false}) {
    for (const LiftRecord& rec : records) {
      const bool is_intrusion = rec.disturbance == Disturbance::Truck || rec.disturbance == Disturbance::Worker;
      if (is_intrusion == intrusion) {
        replay.push_back(rec.index);
        break;
      }
    }
  }
  REQUIRE(replay.size() == 2);
  for (const int n : replay) {
    CAPTURE(n);
    const LiftRecord again = run_campaign_lift(options, n);
    CHECK(lift_record_text(again) == lift_record_text(records[static_cast<std::size_t>(n - kShippedLifts)]));
  }
  std::filesystem::remove_all(options.sites_dir);
}

TEST_CASE("campaign: the shipped sites' lifts draw the sites they drew before generated lifts were added", "[bench][campaign]") {
  CampaignOptions options;
  options.scenarios_dir = std::string(MGC_SOURCE_DIR) + "/scenarios";
  options.threads = 1;
  options.progress = false;
  const std::pair<int, const char*> lifts[] = {{96, "thesis-steel-frame-tower.yaml"}, {183, "thesis-steel-frame-road.yaml"}, {999, "excavator-cycle.yaml"}};
  for (const auto& [lift, site] : lifts) {
    const LiftRecord rec = run_campaign_lift(options, lift);
    INFO(lift_record_text(rec));
    CHECK(rec.family.empty());
    CHECK(rec.site_redraws == 0);
    CHECK(rec.site == site);
  }
}
