// SPDX-License-Identifier: Apache-2.0
// The controller as a site member on the stepped site rig (docs/site.md): two machines whose lifts
// cross complete without true contact at every offset of a timing sweep; only the lower-priority
// one re-plans; a stale member is posed by its frozen pose with an alert; forged, replayed and
// malformed site messages are refused, counted and never acted on; message loss, delays and a
// member killed mid-lift end without contact.

#include "mgc/firmware/site_auth.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_rig.hpp"
#include "mgc/sim/stepped_rig.hpp"
#include "site_member_support.hpp"
#include "mgc/planning/machine_model.hpp"

#include <mgc/alert_t.hpp>
#include <mgc/site_state_t.hpp>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

using namespace mgc;

namespace {

//! The TMS870 (machine 1, priority 2) and a tower crane (machine 2, priority 1) whose load swings
//! across the TMS870's route.
planning::Site crossing_site() { return planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/crossing-cranes.yaml"); }

constexpr std::int32_t kLower = 1;   // the TMS870
constexpr std::int32_t kHigher = 2;  // the tower crane
//! Both lifts take under 100 s alone; a run that waits for the other machine and goes round it
//! gets three times that.
constexpr double kLimitS = 300.0;

std::string summary(sim::SiteRig& rig) {
  std::string s;
  for (sim::SiteRigMember& m : rig.members()) {
    const firmware::ControllerStats& st = m.controller->stats();
    char line[256];
    std::snprintf(line, sizeof line, "machine %d: goals %d, plans %d, repairs %d, site stops %d (%llu cycles), alerts %llu cycles\n",
                  m.machine_id, st.goals_reached, st.plans, st.replans, st.site_stops,
                  static_cast<unsigned long long>(st.site_stop_cycles), static_cast<unsigned long long>(m.site_alert_cycles));
    s += line + m.log;
  }
  char line[128];
  std::snprintf(line, sizeof line, "t %.2f s, least true clearance between the machines %.2f m\n", rig.sim_s(), rig.least_between_m());
  return s + line;
}

//! Whether the snapshot carries the site alert from source naming machine_id (any severity when 0).
bool has_site_alert(const firmware::GuidanceSnapshot& g, std::int8_t source, std::int32_t machine_id, std::int8_t severity = 0) {
  for (int a = 0; a < g.num_alerts; ++a) {
    const firmware::SnapshotAlert& alert = g.alerts[static_cast<std::size_t>(a)];
    // A stale machine's alert gives the prediction that poses it (unit none); the rules' the meet time.
    const std::int8_t unit = source == mgc::alert_t::SOURCE_SENSING ? mgc::alert_t::UNIT_NONE : mgc::alert_t::UNIT_SECOND;
    if (alert.source == source && alert.index == machine_id && alert.value_unit == unit && (severity == 0 || alert.severity == severity)) {
      return true;
    }
  }
  return false;
}

//! The stale machine's alert on the snapshot gives the prediction that poses machine_id.
bool stale_alert_says(const firmware::GuidanceSnapshot& g, std::int32_t machine_id, firmware::SitePrediction prediction) {
  for (int a = 0; a < g.num_alerts; ++a) {
    const firmware::SnapshotAlert& alert = g.alerts[static_cast<std::size_t>(a)];
    if (alert.source == mgc::alert_t::SOURCE_SENSING && alert.index == machine_id && alert.value_unit == mgc::alert_t::UNIT_NONE &&
        alert.value == static_cast<double>(prediction)) {
      return true;
    }
  }
  return false;
}

//! Largest distance between a moving body's centre posed at q and at the truth's joints. [m]
double posed_off_m(const planning::MachineModel& model, const planning::JointVector& q, const sim::TrueState& truth) {
  planning::JointVector t(model.dof());
  for (int j = 0; j < model.dof(); ++j) t[j] = truth.position[static_cast<std::size_t>(j)];
  planning::Kinematics a;
  planning::Kinematics b;
  model.forward_kinematics(q, a);
  model.forward_kinematics(t, b);
  double worst = 0.0;
  for (std::size_t k = 0; k < model.bodies().size(); ++k) {
    worst = std::max(worst, (a.bodies[k].world_from_body.translation() - b.bodies[k].world_from_body.translation()).norm());
  }
  return worst;
}

}  // namespace

TEST_CASE("crossing lifts end without true contact at every offset of the timing sweep", "[site][sim]") {
  // The tower crane's lift starts 0, 1, ... 16 s after the TMS870's: its load reaches the
  // TMS870's route before, while and after the TMS870's load passes there.
  std::string table = "offset_s, lower_done, higher_done, lower_repairs, lower_site_stops, higher_site_stops, least_m, least_at_s, end_s\n";
  int completed = 0;
  for (int offset = 0; offset <= 16; ++offset) {
    sim::SiteRigConfig config;
    config.lift_start_s = {0.0, static_cast<double>(offset)};
    sim::SiteRig rig(crossing_site(), config, "sweep-" + std::to_string(offset));
    rig.run_until(kLimitS, true);
    INFO(summary(rig));
    CAPTURE(offset);
    const firmware::ControllerStats& lower = rig.member(kLower).controller->stats();
    const firmware::ControllerStats& higher = rig.member(kHigher).controller->stats();
    CHECK(rig.pairs().front().samples_in_contact == 0);
    CHECK(rig.least_between_m() > 0.5);
    // The higher-priority machine never re-plans, at any offset.
    CHECK(higher.plans == 1);
    CHECK(higher.replans == 0);
    if (lower.goals_reached == 1 && higher.goals_reached == 1) ++completed;
    char row[192];
    std::snprintf(row, sizeof row, "%d, %s, %s, %d, %d, %d, %.2f, %.1f, %.1f\n", offset, lower.goals_reached == 1 ? "done" : "no",
                  higher.goals_reached == 1 ? "done" : "no", lower.replans, lower.site_stops, higher.site_stops, rig.least_between_m(),
                  rig.pairs().front().least_t_s, rig.sim_s());
    table += row;
  }
  INFO(table);
  CHECK(completed == 17);
  std::printf("%s", table.c_str());
}

TEST_CASE("the priority rule: the lower-priority machine re-plans round the higher one's plan, the higher never re-plans", "[site][sim]") {
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 0.0};
  sim::SiteRig rig(crossing_site(), config, "priority");
  rig.run_until(kLimitS, true);
  INFO(summary(rig));
  const firmware::ControllerStats& lower = rig.member(kLower).controller->stats();
  const firmware::ControllerStats& higher = rig.member(kHigher).controller->stats();
  REQUIRE(lower.goals_reached == 1);
  REQUIRE(higher.goals_reached == 1);
  // The crossing is seen by both: the lower one stopped for the higher one's coming motion...
  CHECK(lower.site_stop_cycles > 0);
  CHECK(lower.site_replans >= 1);
  CHECK(lower.replans >= 1);
  // ... and the higher one planned once and never re-planned or escaped for the lower one.
  CHECK(higher.plans == 1);
  CHECK(higher.replans == 0);
  CHECK(higher.escapes == 0);
  CHECK(higher.site_replans == 0);
  // Each told the other its plan.
  CHECK(rig.member(kHigher).plans_sent >= 1);
  CHECK(rig.member(kLower).plans_sent >= 2);
  CHECK(rig.least_between_m() > 0.5);
}

TEST_CASE("a member whose messages stop is stale: its frozen pose grown by its speed stops the other, with an alert", "[site][sim]") {
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 0.0};
  sim::SiteRig rig(crossing_site(), config, "stale");
  rig.run_until(3.0);
  sim::SiteRigMember& lower = rig.member(kLower);
  REQUIRE(lower.controller->site_decision().peers[1].link == firmware::SiteLink::Live);
  // Until the first state arrives the tower crane is never heard (anywhere it can reach): the
  // start's one alert, over by now.
  REQUIRE(lower.controller->stats().site_stale_alerts == 1);
  REQUIRE_FALSE(has_site_alert(lower.controller->snapshot(), mgc::alert_t::SOURCE_SENSING, kHigher));
  const std::uint64_t stale_cycles = lower.stale_alert_cycles;
  // The tower crane's controller runs on, but nothing it sends arrives any more.
  rig.mute(kHigher);
  rig.run_until(3.2);
  CHECK(lower.controller->site_decision().peers[1].link == firmware::SiteLink::Live);  // 200 ms: still within 250 ms
  rig.run_until(3.3);
  const firmware::SitePeerDecision& d = lower.controller->site_decision().peers[1];
  CHECK(d.link == firmware::SiteLink::Stale);
  CHECK(d.prediction == firmware::SitePrediction::FrozenPose);
  CHECK(lower.stale_alert_cycles > stale_cycles);
  CHECK(lower.controller->stats().site_stale_alerts == 2);
  // The frozen pose grows at the tower crane's speed bound: within seconds it reaches the TMS870,
  // which stops and stays stopped while it hears nothing.
  rig.run_until(30.0);
  INFO(summary(rig));
  CHECK(lower.controller->stats().site_stop_cycles > 0);
  CHECK(lower.controller->stats().goals_reached == 0);
  CHECK(has_site_alert(lower.controller->snapshot(), mgc::alert_t::SOURCE_SENSING, kHigher, mgc::alert_t::SEVERITY_STOP));
  CHECK(rig.pairs().front().samples_in_contact == 0);
  CHECK(rig.least_between_m() > 0.5);
}

TEST_CASE("a stale member seen by the site's UWB tags is posed from them: tracked, no needless stop, and without tags frozen and grown", "[site][sim][uwb]") {
  // The tower crane's messages stop 1 s into both lifts while it lifts on under its own plan; the
  // site's RTLS sees its tags on the TMS870's bus, with the single-machine scenarios' UWB noise,
  // rate, latency and dropouts.
  const double mute_s = 1.0;
  SECTION("with tags: tracked within 1.5 m, both lifts complete, no contact") {
    sim::SiteRigConfig config;
    config.lift_start_s = {0.0, 0.0};
    config.uwb = sim::UwbParams{};
    sim::SiteRig rig(test::tagged_crossing_site(), config, "stale-uwb");
    const auto model = planning::build_model(planning::lift_scenario(test::tagged_crossing_site(), 1, 0));
    rig.run_until(mute_s);
    rig.mute(kHigher);
    sim::SiteRigMember& lower = rig.member(kLower);
    sim::SiteRigMember& higher = rig.member(kHigher);
    rig.run_until(mute_s + 0.3);
    {
      const firmware::SitePeerDecision& d = lower.controller->site_decision().peers[1];
      CHECK(d.link == firmware::SiteLink::Stale);
      CHECK(d.prediction == firmware::SitePrediction::UwbTags);
      CHECK(stale_alert_says(lower.controller->snapshot(), kHigher, firmware::SitePrediction::UwbTags));
    }
    // Every cycle while it is stale and posed from its tags, its posed bodies against the true ones.
    double worst_off_m = 0.0;
    double worst_grow_m = 0.0;
    double least_margin_m = 1e9;  // grown pose less how far off it is: never negative
    std::uint64_t posed = 0;
    while (rig.sim_s() < kLimitS && !(rig.lift_done(lower) && rig.lift_done(higher))) {
      rig.run_until(rig.sim_s() + 0.01);
      const firmware::SiteTagPose* pose = lower.controller->site_tag_pose(kHigher);
      REQUIRE(pose != nullptr);
      if (lower.controller->site_decision().peers[1].prediction != firmware::SitePrediction::UwbTags) continue;
      ++posed;
      // The pose is the fit at its newest fix, carried at its velocity to now, as the scan carries it.
      planning::JointVector q = pose->q;
      const double age_s = static_cast<double>(lower.rig->t_us - pose->t_us) * 1e-6;
      for (int j = 0; j < model->dof(); ++j) q[j] += pose->v[j] * age_s;
      const double off_m = posed_off_m(*model, q, higher.rig->sim->truth());
      worst_off_m = std::max(worst_off_m, off_m);
      worst_grow_m = std::max(worst_grow_m, pose->grow_m);
      least_margin_m = std::min(least_margin_m, pose->grow_m + pose->speed_error_m_s * age_s - off_m);
    }
    INFO(summary(rig));
    CAPTURE(worst_off_m, worst_grow_m, least_margin_m, posed);
    const firmware::ControllerStats& st = lower.controller->stats();
    CHECK(posed > 1000);
    CHECK(st.site_tag_cycles >= posed);
    // Frozen and grown only before the tower crane's first state (never heard, no velocity yet).
    CHECK(st.site_frozen_cycles < 10);
    CHECK(worst_off_m < 1.5);
    CHECK(least_margin_m >= 0.0);
    // Both lifts done, the TMS870's within the time it takes with the tower crane heard.
    CHECK(rig.lift_done(lower));
    CHECK(rig.lift_done(higher));
    CHECK(rig.sim_s() < 150.0);
    CHECK(rig.pairs().front().samples_in_contact == 0);
    CHECK(rig.least_between_m() > 0.5);
    CHECK(lower.controller->site_decision().peers[1].link == firmware::SiteLink::Stale);
  }
  SECTION("without tags: frozen and grown as before, the TMS870 stopped for good") {
    sim::SiteRigConfig config;
    config.lift_start_s = {0.0, 0.0};
    config.uwb = sim::UwbParams{};
    sim::SiteRig rig(crossing_site(), config, "stale-frozen");
    rig.run_until(mute_s);
    rig.mute(kHigher);
    rig.run_until(60.0);
    INFO(summary(rig));
    sim::SiteRigMember& lower = rig.member(kLower);
    CHECK(lower.controller->site_tag_pose(kHigher) == nullptr);
    CHECK(lower.controller->site_decision().peers[1].prediction == firmware::SitePrediction::FrozenPose);
    CHECK(stale_alert_says(lower.controller->snapshot(), kHigher, firmware::SitePrediction::FrozenPose));
    CHECK(lower.controller->stats().site_tag_cycles == 0);
    CHECK(lower.controller->stats().site_frozen_cycles > 5000);
    CHECK(lower.controller->stats().site_stop_cycles > 0);
    CHECK(lower.controller->stats().goals_reached == 0);
    CHECK(rig.lift_done(rig.member(kHigher)));
    CHECK(rig.pairs().front().samples_in_contact == 0);
  }
}

TEST_CASE("a lift queue: the first lift's scenario goal, then each later lift's start (unless there already) and goal", "[unit][lifts]") {
  planning::Site site = crossing_site();
  planning::SiteLift back = site.machines[0].lifts[0];
  back.start = site.machines[0].lifts[0].goal;  // starts where the first ends: no leg to its start
  back.goal = site.machines[0].lifts[0].start;
  planning::SiteLift away = back;
  away.start[0] = 0.5;  // starts elsewhere: a leg there first
  away.goal[0] = -0.5;
  site.machines[0].lifts.push_back(back);
  site.machines[0].lifts.push_back(away);
  firmware::SiteLiftQueue q(site, kLower);
  std::array<double, mgc::kMaxJoints> goal{};
  int joints = -1;
  REQUIRE(q.goal(goal, joints));
  CHECK(joints == 0);  // the scenario's own goal
  CHECK(q.reached());
  REQUIRE(q.goal(goal, joints));
  CHECK(joints == 4);
  CHECK(goal[0] == back.goal[0]);
  CHECK(q.lift() == 1);
  CHECK(q.reached());
  REQUIRE(q.goal(goal, joints));
  CHECK(goal[0] == 0.5);
  CHECK_FALSE(q.reached());  // only at its start
  REQUIRE(q.goal(goal, joints));
  CHECK(goal[0] == -0.5);
  CHECK(q.lifts_done() == 2);
  CHECK(q.reached());
  CHECK(q.done());
  CHECK(q.lifts_done() == 3);
  CHECK_FALSE(q.goal(goal, joints));
  CHECK_THROWS_AS(firmware::SiteLiftQueue(site, 7), std::invalid_argument);
}

TEST_CASE("a machine with two queued lifts completes both, one after the other", "[site][sim][lifts]") {
  // The TMS870's first lift north to south, then a second from south-west of there back north: a
  // leg to the second lift's start, then to its goal. The tower crane stands at its start.
  planning::Site site = crossing_site();
  planning::SiteLift second = site.machines[0].lifts[0];
  second.name = "steel-bundle-back-north";
  second.start[0] = -60.0 * 3.14159265358979323846 / 180.0;
  second.goal = site.machines[0].lifts[0].start;
  site.machines[0].lifts.push_back(second);
  const firmware::SiteLiftQueue queue(site, kLower);
  CHECK(queue.lifts() == 2);
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, -1.0};
  sim::SiteRig rig(site, config, "two-lifts");
  sim::SiteRigMember& lower = rig.member(kLower);
  rig.run_until(kLimitS, true);
  INFO(summary(rig));
  CHECK(rig.lift_done(lower));
  CHECK(lower.lifts->lifts_done() == 2);
  // The first lift's goal, the second's start, the second's goal.
  CHECK(lower.controller->stats().goals_reached == 3);
  const sim::TrueState& truth = lower.rig->sim->truth();
  for (int j = 0; j < 4; ++j) CHECK(truth.position[static_cast<std::size_t>(j)] == Approx(second.goal[j]).margin(0.02));
  CHECK(rig.member(kHigher).controller->stats().goals_reached == 0);
  CHECK(rig.pairs().front().samples_in_contact == 0);
  CHECK(rig.least_between_m() > 0.5);
}

TEST_CASE("forged, replayed and malformed site messages are refused, counted and never acted on", "[site][sim]") {
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, -1.0};  // the tower crane stays where it is
  sim::SiteRig rig(crossing_site(), config, "refused");
  rig.run_until(1.0);
  sim::SiteRigMember& lower = rig.member(kLower);
  const firmware::SiteVerifier& verifier = *lower.verifier;
  const std::uint64_t accepted = verifier.count(firmware::SiteReason::Accepted);
  REQUIRE(accepted >= 19);
  REQUIRE(verifier.refused() == 0);
  const site_state_t before = lower.inputs.peers[1].state;
  // The start's stop, until the tower crane was first heard.
  const std::uint64_t stop_cycles = lower.controller->stats().site_stop_cycles;
  REQUIRE(stop_cycles < 10);

  // The tower crane's last state, decoded: the material of every attack below.
  const std::vector<std::uint8_t> recorded = rig.last_state_bytes(kHigher);
  site_state_t msg;
  REQUIRE(msg.decode(recorded.data(), 0, static_cast<int>(recorded.size())) == static_cast<int>(recorded.size()));
  const auto bytes_of = [](const site_state_t& m) {
    std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
    (void)m.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  // Its load swung onto the TMS870's boom: what an attacker would want the TMS870 to act on.
  site_state_t threat = msg;
  threat.joint_position[0] = 3.0;  // slew toward the TMS870
  threat.joint_position[1] = 40.0;
  threat.sequence += 1000;

  // Forged: signed under another key.
  site_state_t forged = threat;
  std::array<std::uint8_t, firmware::kCommandKeyBytes> other{};
  other.fill(0x42);
  firmware::sign_site_state(forged, firmware::SiteKey(other));
  rig.inject_state(kLower, bytes_of(forged));
  CHECK(verifier.count(firmware::SiteReason::BadMac) == 1);
  // Tampered: the real MAC on changed contents.
  site_state_t tampered = threat;
  std::copy(std::begin(msg.mac), std::end(msg.mac), std::begin(tampered.mac));
  rig.inject_state(kLower, bytes_of(tampered));
  CHECK(verifier.count(firmware::SiteReason::BadMac) == 2);
  // Replayed: the recorded message, byte for byte.
  rig.inject_state(kLower, recorded);
  CHECK(verifier.count(firmware::SiteReason::StaleSequence) == 1);
  // Malformed, though signed with the site key: a joint count the tower crane does not have, and bytes cut short.
  site_state_t malformed = threat;
  malformed.num_joints = 5;
  firmware::sign_site_state(malformed, rig.key());
  rig.inject_state(kLower, bytes_of(malformed));
  CHECK(verifier.count(firmware::SiteReason::JointCount) == 1);
  std::vector<std::uint8_t> cut = recorded;
  cut.resize(cut.size() / 2);
  rig.inject_state(kLower, cut);
  CHECK(verifier.count(firmware::SiteReason::Undecodable) == 1);
  CHECK(verifier.refused() == 5);
  // None of it reached the loop: the tower crane's state as it was.
  CHECK(lower.inputs.peers[1].state.sequence == before.sequence);
  CHECK(lower.inputs.peers[1].state.joint_position[0] == before.joint_position[0]);

  // The TMS870 lifts on as if nothing came: no site stop, the goal reached.
  rig.run_until(kLimitS, true);
  INFO(summary(rig));
  CHECK(lower.controller->stats().site_stop_cycles == stop_cycles);
  CHECK(lower.controller->stats().goals_reached == 1);
  CHECK(verifier.refused() == 5);
}

TEST_CASE("site faults: 20 % message loss and delays up to 200 ms, then a member killed mid-lift, end without contact", "[site][sim]") {
  SECTION("loss and delay: both lifts complete, no machine goes stale for long") {
    sim::SiteRigConfig config;
    config.lift_start_s = {0.0, 0.0};
    config.faults.loss_probability = 0.2;
    config.faults.max_delay_us = 200'000;
    config.faults.seed = 7;
    sim::SiteRig rig(crossing_site(), config, "lossy");
    rig.run_until(kLimitS, true);
    INFO(summary(rig));
    const sim::SiteRigMember& lower = rig.member(kLower);
    const sim::SiteRigMember& higher = rig.member(kHigher);
    CHECK(lower.messages_lost > 0);
    CHECK(higher.messages_lost > 0);
    CHECK(static_cast<double>(higher.messages_lost) / static_cast<double>(higher.states_sent + higher.plans_sent) == Approx(0.2).margin(0.03));
    CHECK(lower.controller->stats().goals_reached == 1);
    CHECK(higher.controller->stats().goals_reached == 1);
    CHECK(higher.controller->stats().replans == 0);
    CHECK(rig.pairs().front().samples_in_contact == 0);
    CHECK(rig.least_between_m() > 0.5);
    // Late and lost messages are refused as nothing worse than stale: old sequences after a
    // newer one arrived are replays to the verifier, and count as such.
    CHECK(lower.verifier->count(firmware::SiteReason::BadMac) == 0);
  }
  SECTION("the tower crane's controller killed mid-lift: its machine stops, the TMS870 treats it as stale") {
    sim::SiteRigConfig config;
    config.lift_start_s = {0.0, 0.0};
    config.faults.kills.push_back({kHigher, 20.0});
    sim::SiteRig rig(crossing_site(), config, "killed");
    rig.run_until(60.0);
    INFO(summary(rig));
    const sim::SiteRigMember& lower = rig.member(kLower);
    CHECK(rig.member(kHigher).killed);
    CHECK(has_site_alert(lower.controller->snapshot(), mgc::alert_t::SOURCE_SENSING, kHigher));
    CHECK(lower.controller->stats().site_stale_alerts >= 2);  // never heard at the start, then killed
    CHECK(lower.controller->site_decision().peers[1].link == firmware::SiteLink::Stale);
    CHECK(rig.pairs().front().samples_in_contact == 0);
    CHECK(rig.least_between_m() > 0.5);
  }
}

TEST_CASE("no standoff: a machine held at rest carries its way forward from rest, so neither waits for the other for good", "[site][sim]") {
  // Offset 16 s of the sweep: the TMS870, stopped for the tower crane, stands where what is left of
  // the tower crane's lift passes within a few metres. The tower crane, held still by the mutual
  // stop, used to carry its way forward at full speed from the first instant, saw itself braking
  // from full speed into the TMS870, and waited for it while the TMS870 waited for it.
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 16.0};
  sim::SiteRig rig(crossing_site(), config, "standoff");
  rig.run_until(kLimitS, true);
  INFO(summary(rig));
  const firmware::ControllerStats& lower = rig.member(kLower).controller->stats();
  const firmware::ControllerStats& higher = rig.member(kHigher).controller->stats();
  CHECK(lower.goals_reached == 1);
  CHECK(higher.goals_reached == 1);
  CHECK(rig.pairs().front().samples_in_contact == 0);
  CHECK(rig.least_between_m() > 0.5);
  CHECK(higher.replans == 0);
  // Done well before the limit: no long wait on either side.
  CHECK(rig.sim_s() < 200.0);
}

TEST_CASE("a new plan goes out with a state that names it: the other member predicts by it in the cycle both arrive", "[site][sim][takeup]") {
  sim::SiteRigConfig config;
  config.lift_start_s = {0.0, 0.0};
  sim::SiteRig rig(crossing_site(), config, "take-up");
  std::vector<sim::SiteRigMember>& members = rig.members();
  REQUIRE(members.size() == 2);
  std::int32_t published[2] = {0, 0};
  std::uint64_t states_before[2] = {0, 0};
  std::int32_t awaited[2] = {0, 0};  // per sender, the new plan id the other must predict by this cycle
  int new_plans = 0;
  int taken_up = 0;
  // 30 s: both first plans, the TMS870 stopped for the tower crane and its re-plans (some 10 s in).
  while (rig.sim_s() < 30.0) {
    for (std::size_t s = 0; s < 2; ++s) states_before[s] = members[s].states_sent;
    rig.run_until(rig.sim_s() + 0.005);
    for (std::size_t s = 0; s < 2; ++s) {
      const std::size_t rx = 1 - s;
      const firmware::Controller& receiver = *members[rx].controller;
      const int k = members[rx].verifier->roster().index_of(members[s].machine_id);
      REQUIRE(k >= 0);
      if (awaited[s] != 0) {
        // Delivered at the top of this cycle, both of them, and used by this cycle's step.
        const firmware::SitePeerMessages& peer = members[rx].inputs.peers[static_cast<std::size_t>(k)];
        CAPTURE(members[s].machine_id, awaited[s], rig.sim_s());
        CHECK(peer.plan.plan_id == awaited[s]);
        CHECK(peer.state.plan_id == awaited[s]);
        CHECK(receiver.site_decision().peers[static_cast<std::size_t>(k)].prediction == firmware::SitePrediction::Plan);
        ++taken_up;
        awaited[s] = 0;
      }
      const firmware::Controller& sender = *members[s].controller;
      if (sender.site_plan_version() > 0 && sender.site_plan().plan_id != published[s]) {
        published[s] = sender.site_plan().plan_id;
        ++new_plans;
        CAPTURE(members[s].machine_id, published[s], rig.sim_s());
        // The state of the same cycle names it and went out with it, off the 50 ms grid or on it.
        CHECK(sender.site_state().plan_id == published[s]);
        CHECK(members[s].states_sent == states_before[s] + 1);
        awaited[s] = published[s];
      }
    }
  }
  INFO(summary(rig));
  // The two first plans and at least one re-plan of the TMS870 round the tower crane.
  CHECK(new_plans >= 3);
  CHECK(taken_up == new_plans);
}

TEST_CASE("a member predicts another machine of more joints than its own along that machine's plan at every joint",
          "[site][sim]") {
  // The tower crane (3 joints) watches the TMS870 (4). The TMS870 first stands with its hook at the
  // boom tip, then takes up a plan that holds its boom where it is and hangs its load 12 m below,
  // beside the tower crane's load. Its prediction along the plan must take the hook's joint, the
  // fourth, from the plan too: the least gap is then the one to the hung load, as measured with
  // the TMS870 standing so.
  const planning::Site site = crossing_site();
  const std::size_t tower_index = planning::io::site_machine_index(site, kHigher);
  const planning::Scenario lift = planning::lift_scenario(site, tower_index, 0);
  const firmware::SiteRoster roster = firmware::make_site_roster(site);
  const int crane_roster = roster.index_of(kLower);
  REQUIRE(crane_roster >= 0);
  // The TMS870's boom toward the tower crane's load at (14, -25), its tip 2.6 m short of the
  // tower crane's hoist rope. Hung 12 m below the tip its load is what is nearest; at the tip,
  // 1.08 m away, the boom is.
  constexpr double kDeg = std::numbers::pi / 180.0;
  const std::array<double, 4> at_tip{-60.75 * kDeg, 30.2 * kDeg, 30.0, 0.0};
  std::array<double, 4> hung = at_tip;
  hung[3] = 12.0;

  // The least gap the tower crane measures: the TMS870 at rest at `first` for 0.5 s, then, if
  // `plan` is given, running a plan that stays at it for 0.5 s.
  const auto least_gap = [&](const std::array<double, 4>& first, const std::array<double, 4>* plan, const char* bus) {
    sim::SteppedRig rig(lift, sim::SteppedRig::quiet_config(), bus);
    rig.calibrate_valves();
    firmware::SiteMemberConfig member;
    member.site = site;
    member.machine_id = kHigher;
    firmware::Controller controller(lift, firmware::ControllerConfig{}, &member);
    firmware::SiteInputs inputs;
    firmware::SitePeerMessages& peer = inputs.peers[static_cast<std::size_t>(crane_roster)];
    peer.has_state = true;
    peer.state.machine_id = kLower;
    peer.state.priority = 2;
    peer.state.num_joints = 4;
    for (std::size_t j = 0; j < 4; ++j) peer.state.joint_position[j] = first[j];
    rig.on_cycle = [&](const hal::SensorSnapshot& s) {
      peer.state_received_us = s.t_us;
      const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, firmware::ControllerCommands{}, false, inputs);
      if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
      rig.hal->set_pilot_enabled(out.pilot_enable);
    };
    rig.run(500'000);
    if (plan != nullptr) {
      peer.state.joint_velocity[0] = 0.02;  // 0.8 m/s at the tip: not at rest, so taken along its plan
      peer.state.plan_id = 7;
      peer.has_plan = true;
      peer.plan.machine_id = kLower;
      peer.plan.plan_id = 7;
      peer.plan.num_joints = 4;
      peer.plan.num_waypoints = 2;
      peer.plan.waypoint_time_s[0] = 0.0;
      peer.plan.waypoint_time_s[1] = 100.0;
      for (std::size_t j = 0; j < 4; ++j) peer.plan.positions[0][j] = peer.plan.positions[1][j] = (*plan)[j];
      rig.run(500'000);
    }
    return controller.stats().site_min_gap_m;
  };
  const double at_tip_m = least_gap(at_tip, nullptr, "predict-tip");
  const double hung_m = least_gap(hung, nullptr, "predict-hung");
  const double by_plan_m = least_gap(at_tip, &hung, "predict-plan");
  CAPTURE(at_tip_m, hung_m, by_plan_m);
  REQUIRE(hung_m < at_tip_m - 0.5);
  // The plan's prediction grows by the speed over the skew (0.15 m here): never farther than the
  // hung load, and not by much nearer.
  CHECK(by_plan_m <= hung_m);
  CHECK(by_plan_m == Approx(hung_m).margin(0.3));
}
