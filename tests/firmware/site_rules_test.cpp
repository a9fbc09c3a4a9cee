// SPDX-License-Identifier: Apache-2.0
// The site rules (docs/site.md) in stepped time: live to stale after exactly the documented time,
// the fallbacks of a stale machine, the priority roles and predictions, and the mutual-stop rule
// with the lower-priority machine stopping one horizon before the higher one.

#include <mgc/firmware/site_rules.hpp>

#include "mgc/planning/io/site_loader.hpp"
#include "site_support.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <memory>

using namespace mgc::firmware;
using mgc::site_plan_t;
using mgc::site_state_t;
using mgc::test::tower_plan;
using mgc::test::tower_state;

namespace {

// The loop's monotonic clock in these tests. [µs]
constexpr std::int64_t kNow0_us = 50'000'000;

}  // namespace

TEST_CASE("the roster of the shipped site: ids, priorities, joint ranges, tags and speed bounds", "[unit]") {
  const mgc::planning::Site site = mgc::planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml");
  const SiteRoster roster = make_site_roster(site);
  REQUIRE(roster.count == 2);
  CHECK(roster.index_of(1) == 0);
  CHECK(roster.index_of(2) == 1);
  CHECK(roster.index_of(3) == -1);
  const SiteRosterEntry& tms = roster.machines[0];
  CHECK(tms.priority == 2);
  CHECK(tms.num_joints == 4);
  CHECK(tms.position_max[2] == Approx(33.528));
  CHECK_FALSE(tms.has_uwb_tags);
  CHECK(tms.revolute[1]);
  CHECK_FALSE(tms.revolute[2]);
  const SiteRosterEntry& tower = roster.machines[1];
  CHECK(tower.priority == 1);
  CHECK(tower.num_joints == 3);
  CHECK(tower.continuous[0]);
  CHECK(tower.position_max[1] == Approx(59.7));
  CHECK(tower.has_uwb_tags);
  // Its slew alone moves the jib tip at 59.7 m x 0.8 rpm, some 5 m/s.
  CHECK(tower.max_point_speed_m_s >= 59.7 * 0.8 * 2.0 * std::numbers::pi / 60.0);
  CHECK(tms.max_point_speed_m_s > 0.0);
}

TEST_CASE("a machine goes from live to stale after exactly the documented time", "[unit]") {
  const SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  REQUIRE(config.stale_after_us() == 250'000);  // 3 states at 20 Hz + 100 ms skew, as docs/site.md states
  const site_state_t state = tower_state(1);
  std::array<SitePeerInput, 2> peers{};
  peers[1].state = &state;
  peers[1].state_received_us = kNow0_us;
  for (std::int64_t t = kNow0_us; t <= kNow0_us + 300'000; t += 1'000) {
    const SiteDecision d = decide_site(roster, 1, peers, t, config);
    CAPTURE(t - kNow0_us);
    REQUIRE(d.peers[0].link == SiteLink::Self);
    const SitePeerDecision& tower = d.peers[1];
    REQUIRE(tower.age_us == t - kNow0_us);
    REQUIRE(tower.link == (t - kNow0_us <= 250'000 ? SiteLink::Live : SiteLink::Stale));
  }
  // Exactly at the edge and one microsecond past it.
  CHECK(decide_site(roster, 1, peers, kNow0_us + 250'000, config).peers[1].link == SiteLink::Live);
  CHECK(decide_site(roster, 1, peers, kNow0_us + 250'001, config).peers[1].link == SiteLink::Stale);
  // A new state makes it live again.
  peers[1].state_received_us = kNow0_us + 260'000;
  CHECK(decide_site(roster, 1, peers, kNow0_us + 260'000, config).peers[1].link == SiteLink::Live);
}

TEST_CASE("a stale machine falls back to its UWB tags, else its frozen pose grown, else its whole reach", "[unit]") {
  SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  std::array<SitePeerInput, 2> peers{};
  // Never heard, with tags that posed it: tags.
  peers[1].tags_posed = true;
  SiteDecision d = decide_site(roster, 1, peers, kNow0_us, config);
  CHECK(d.peers[1].link == SiteLink::Stale);
  CHECK(d.peers[1].prediction == SitePrediction::UwbTags);
  CHECK(d.peers[1].age_us == -1);
  // Tags on it, but no fresh, plausible fit this cycle: as without tags.
  peers[1].tags_posed = false;
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).peers[1].prediction == SitePrediction::WholeReach);
  peers[1].tags_posed = true;
  // Never heard, no tags: everything it can reach, whatever the caller says of tags.
  roster.machines[1].has_uwb_tags = false;
  d = decide_site(roster, 1, peers, kNow0_us, config);
  CHECK(d.peers[1].prediction == SitePrediction::WholeReach);
  CHECK(d.peers[1].role == SiteRole::None);
  // Heard 1 s ago, no tags: the last pose grown by its speed bound times the age plus the skew.
  const site_state_t state = tower_state(1);
  peers[1].state = &state;
  peers[1].state_received_us = kNow0_us - 1'000'000;
  d = decide_site(roster, 1, peers, kNow0_us, config);
  CHECK(d.peers[1].link == SiteLink::Stale);
  CHECK(d.peers[1].prediction == SitePrediction::FrozenPose);
  CHECK(d.peers[1].grow_m == Approx(7.0 * 1.1));
  d = decide_site(roster, 1, peers, kNow0_us + 1'000'000, config);
  CHECK(d.peers[1].grow_m == Approx(7.0 * 2.1));
  // A frozen machine's meet_in_s is not the rules' to judge: the stop check has it as an obstacle.
  peers[1].meet_in_s = 0.0;
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::Proceed);
}

TEST_CASE("a machine posed from its tags stops me with the lower priority's lead, whatever the priorities", "[unit]") {
  SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  const site_state_t state = tower_state(1);
  std::array<SitePeerInput, 2> peers{};
  peers[1].state = &state;
  peers[1].state_received_us = kNow0_us - 1'000'000;
  peers[1].tags_posed = true;
  // Machine 2 (the tower crane, priority 1) seen by machine 1 (priority 2), and the reverse roles:
  // machine 1 given the higher priority. The lead is 2H = 1.0 s either way.
  for (const bool swap : {false, true}) {
    if (swap) std::swap(roster.machines[0].priority, roster.machines[1].priority);
    peers[1].meet_in_s = 1.0;
    SiteDecision d = decide_site(roster, 1, peers, kNow0_us, config);
    CHECK(d.peers[1].prediction == SitePrediction::UwbTags);
    CHECK(d.peers[1].role == SiteRole::None);
    CHECK(d.motion == SiteMotion::Stop);
    CHECK(d.motion_for_id == 2);
    peers[1].meet_in_s = 1.01;
    CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::SlowDown);
    peers[1].meet_in_s = 1.51;
    CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::Proceed);
    peers[1].meet_in_s = std::numeric_limits<double>::quiet_NaN();
    CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::Stop);
  }
}

TEST_CASE("priority: a higher-priority machine is planned around, a lower one's envelope is checked", "[unit]") {
  const SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  const site_state_t tower = tower_state(1);
  site_state_t crane{};
  crane.machine_id = 1;
  crane.priority = 2;
  crane.plan_id = 0;
  std::array<SitePeerInput, 2> peers{};
  peers[0].state = &crane;
  peers[0].state_received_us = kNow0_us;
  peers[1].state = &tower;
  peers[1].state_received_us = kNow0_us;
  // Machine 1 (priority 2) sees machine 2 (priority 1) as an obstacle to plan around.
  SiteDecision d = decide_site(roster, 1, peers, kNow0_us, config);
  CHECK(d.peers[1].link == SiteLink::Live);
  CHECK(d.peers[1].role == SiteRole::PlanAround);
  // Machine 2 does not re-plan for machine 1, but checks its stopping envelope.
  d = decide_site(roster, 2, peers, kNow0_us, config);
  CHECK(d.peers[0].link == SiteLink::Live);
  CHECK(d.peers[0].role == SiteRole::CheckEnvelope);
  CHECK(d.peers[1].link == SiteLink::Self);
}

TEST_CASE("prediction: the plan its state names, else its stopping envelope grown by its age", "[unit]") {
  const SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  site_state_t tower = tower_state(1);  // executes plan 3
  auto plan = tower_plan(1);            // plan 3
  std::array<SitePeerInput, 2> peers{};
  peers[1].state = &tower;
  peers[1].state_received_us = kNow0_us;
  SiteDecision d = decide_site(roster, 1, peers, kNow0_us + 200'000, config);
  CHECK(d.peers[1].prediction == SitePrediction::StoppingEnvelope);  // no plan received
  CHECK(d.peers[1].grow_m == Approx(7.0 * 0.3));                      // 200 ms old + 100 ms skew
  peers[1].plan = plan.get();
  d = decide_site(roster, 1, peers, kNow0_us + 200'000, config);
  CHECK(d.peers[1].prediction == SitePrediction::Plan);
  CHECK(d.peers[1].grow_m == 0.0);
  plan->plan_id = 4;  // a plan it no longer (or not yet) executes
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).peers[1].prediction == SitePrediction::StoppingEnvelope);
  plan->plan_id = 0;
  tower.plan_id = 0;  // no plan at all: plan id 0 never matches
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).peers[1].prediction == SitePrediction::StoppingEnvelope);
}

TEST_CASE("mutual stop: both stop whatever their priority, the lower-priority one a horizon first", "[unit]") {
  const SiteRoster roster = mgc::test::two_machine_roster();
  SiteRulesConfig config;
  config.horizon_s = 0.5;
  const site_state_t tower = tower_state(1);
  site_state_t crane{};
  crane.machine_id = 1;
  crane.priority = 2;
  std::array<SitePeerInput, 2> peers{};
  peers[0].state = &crane;
  peers[1].state = &tower;
  // The two envelopes close at a steady rate: they would meet 3 s after the start. Both machines
  // see the same geometry; each runs the rules every 10 ms with fresh states.
  constexpr std::int64_t kStep_us = 10'000;
  std::int64_t lower_slow_us = -1, lower_stop_us = -1, higher_slow_us = -1, higher_stop_us = -1;
  for (std::int64_t t = 0; t <= 3'000'000; t += kStep_us) {
    const double meet_in_s = static_cast<double>(3'000'000 - t) / 1e6;  // exact at the thresholds
    peers[0].meet_in_s = meet_in_s;
    peers[1].meet_in_s = meet_in_s;
    peers[0].state_received_us = kNow0_us + t;
    peers[1].state_received_us = kNow0_us + t;
    const SiteDecision lower = decide_site(roster, 1, peers, kNow0_us + t, config);
    const SiteDecision higher = decide_site(roster, 2, peers, kNow0_us + t, config);
    if (lower_slow_us < 0 && lower.motion == SiteMotion::SlowDown) lower_slow_us = t;
    if (lower_stop_us < 0 && lower.motion == SiteMotion::Stop) lower_stop_us = t;
    if (higher_slow_us < 0 && higher.motion == SiteMotion::SlowDown) higher_slow_us = t;
    if (higher_stop_us < 0 && higher.motion == SiteMotion::Stop) higher_stop_us = t;
    if (lower.motion != SiteMotion::Proceed) CHECK(lower.motion_for_id == 2);
    if (higher.motion != SiteMotion::Proceed) CHECK(higher.motion_for_id == 1);
  }
  // Lower priority: slow at 3 H = 1.5 s before meeting, stop at 2 H = 1.0 s before.
  CHECK(lower_slow_us == 1'500'000);
  CHECK(lower_stop_us == 2'000'000);
  // Higher priority: slow at 2 H, stop at H before meeting: exactly one horizon later.
  CHECK(higher_slow_us == 2'000'000);
  CHECK(higher_stop_us == 2'500'000);
  CHECK(higher_stop_us - lower_stop_us == 500'000);
}

TEST_CASE("the rules never guess clear: a NaN meeting time or bad inputs stop", "[unit]") {
  const SiteRoster roster = mgc::test::two_machine_roster();
  const SiteRulesConfig config;
  const site_state_t tower = tower_state(1);
  std::array<SitePeerInput, 2> peers{};
  peers[1].state = &tower;
  peers[1].state_received_us = kNow0_us;
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::Proceed);  // +inf: never meet
  peers[1].meet_in_s = std::numeric_limits<double>::quiet_NaN();
  CHECK(decide_site(roster, 1, peers, kNow0_us, config).motion == SiteMotion::Stop);
  const SiteDecision unknown_me = decide_site(roster, 7, peers, kNow0_us, config);
  CHECK(unknown_me.invalid_input);
  CHECK(unknown_me.motion == SiteMotion::Stop);
  const SiteDecision short_peers = decide_site(roster, 1, std::span(peers.data(), 1), kNow0_us, config);
  CHECK(short_peers.invalid_input);
  CHECK(short_peers.motion == SiteMotion::Stop);
}
