// SPDX-License-Identifier: Apache-2.0
// A site member's black box (docs/black-box.md, docs/site.md): two machines of the crossing-cranes
// site in stepped time, each on its own stepped rig with its own controller; the lower-priority
// TMS870 runs as mgc runs it, with the real SiteChannel (memq://) taking the tower crane's signed
// messages into its loop and the real recorder around its Hal and at that hand-off. Its recording
// replays identically with the site, differs without the tower crane's messages, and one with a
// site record missing or corrupt is reported. A version 1 recording still replays.
#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <mgc/alert_t.hpp>

#include "black_box_support.hpp"
#include "mgc/firmware/site_auth.hpp"
#include "mgc/firmware/site_channel.hpp"
#include "mgc/planning/io/site_loader.hpp"

using namespace mgc;
namespace bb = mgc::firmware::black_box;

namespace {

std::string scratch(const char* name) {
  static const test::ScratchDir scratch_dir("mgc-black-box-site-test-");
  return (scratch_dir.dir / name).string();
}

std::string site_path() { return std::string(MGC_SOURCE_DIR) + "/scenarios/sites/crossing-cranes.yaml"; }

constexpr std::int32_t kLower = 1;   // the TMS870: records
constexpr std::int32_t kHigher = 2;  // the tower crane
//! The site's CLOCK_REALTIME at loop clock 0. [µs]
constexpr std::int64_t kRealtimeZero_us = 1'765'000'000'000'000;

//! The loop clock both machines share; the site channel's clocks read it.
std::atomic<std::int64_t> g_now_us{0};
std::int64_t monotonic_now() noexcept { return g_now_us.load(); }
std::int64_t realtime_now() noexcept { return kRealtimeZero_us + g_now_us.load(); }

//! What mgc's loop publishes on the site channel and when (mgc_main.cpp): a state at 20 Hz once
//! the pose is known, the plan when it changes and every second, a changed plan with a state.
struct Posting {
  std::int64_t next_state_us = 0;
  std::int64_t plan_posted_us = 0;
  std::uint64_t plan_version_posted = 0;

  template <class PostPlan, class PostState>
  void after_step(firmware::Controller& c, std::int64_t now_us, PostPlan post_plan, PostState post_state) {
    const bool pose_known = c.supervisor().state() != guidance::SupervisorState::Init;
    const std::uint64_t version = c.site_plan_version();
    bool plan_changed = false;
    if (version > 0 && (version != plan_version_posted || now_us - plan_posted_us >= firmware::kSitePlanPeriod_us)) {
      post_plan(c.site_plan());
      plan_changed = version != plan_version_posted;
      plan_version_posted = version;
      plan_posted_us = now_us;
    }
    if (pose_known && (now_us >= next_state_us || plan_changed)) {
      post_state(c.site_state());
      if (now_us >= next_state_us) next_state_us = std::max(next_state_us + firmware::kSiteStatePeriod_us, now_us);
    }
  }
};

template <class Msg>
std::vector<std::uint8_t> encode(const Msg& msg) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  (void)msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

//! Catches what is published on the recording member's LCM instance.
struct Tap {
  std::vector<std::pair<bool, std::vector<std::uint8_t>>> messages;  // plan?, bytes
  void on_state(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) { add(false, rbuf); }
  void on_plan(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) { add(true, rbuf); }
  void add(bool plan, const lcm::ReceiveBuffer* rbuf) {
    const auto* data = static_cast<const std::uint8_t*>(rbuf->data);
    messages.emplace_back(plan, std::vector<std::uint8_t>(data, data + rbuf->data_size));
  }
};

firmware::SiteKey test_key() {
  std::array<std::uint8_t, firmware::kCommandKeyBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(7 + 13 * i);
  return firmware::SiteKey(k);
}

//! The two machines. The tower crane signs its messages itself and hands them to the TMS870's site
//! channel as LCM would; the TMS870's go out through its channel and reach the tower crane's
//! verifier. Both lifts' goals are requested at once: the TMS870 stops for the tower crane and
//! re-plans round its plan (site_member_test.cpp, "the priority rule").
struct RecordedSite {
  planning::Site site;
  firmware::SiteKey key = test_key();
  firmware::SiteRoster roster;
  // The tower crane.
  firmware::SiteMemberConfig higher_config;
  std::unique_ptr<sim::SteppedRig> higher_rig;
  std::unique_ptr<firmware::Controller> higher;
  std::unique_ptr<firmware::SiteVerifier> higher_verifier;
  std::unique_ptr<firmware::SiteInputs> higher_inputs = std::make_unique<firmware::SiteInputs>();
  Posting higher_posting;
  std::int64_t higher_sequence = 0;
  bool higher_goal_sent = false;
  std::vector<std::pair<bool, std::vector<std::uint8_t>>> to_lower;
  // The TMS870, as mgc runs it.
  firmware::SiteMemberConfig lower_config;
  planning::Scenario lower_lift;
  std::unique_ptr<sim::SteppedRig> lower_rig;
  std::unique_ptr<firmware::Controller> lower;
  bb::Identity identity;
  std::unique_ptr<bb::BlackBox> box;
  std::unique_ptr<bb::RecordingBus> bus;
  std::unique_ptr<firmware::SiteChannel> channel;
  std::unique_ptr<firmware::SiteInputs> lower_inputs = std::make_unique<firmware::SiteInputs>();
  Tap tap;
  Posting lower_posting;
  bool lower_goal_sent = false;
  std::uint64_t cycles = 0;
  std::uint64_t site_stop_cycles = 0;  //!< the TMS870's cycles with the site's stop alert for the tower crane

  explicit RecordedSite(const std::string& file) : site(planning::io::load_site(site_path())) {
    roster = firmware::make_site_roster(site);
    g_now_us = 1'000'000;
    const std::size_t hi = planning::io::site_machine_index(site, kHigher);
    const std::size_t lo = planning::io::site_machine_index(site, kLower);
    higher_config.site = site;
    higher_config.machine_id = kHigher;
    higher_rig = std::make_unique<sim::SteppedRig>(planning::lift_scenario(site, hi, 0), sim::SteppedRig::quiet_config(), "bb-site-higher");
    higher_rig->calibrate_valves();
    higher = std::make_unique<firmware::Controller>(higher_rig->scenario, firmware::ControllerConfig{}, &higher_config);
    higher_verifier = std::make_unique<firmware::SiteVerifier>(key, roster, kHigher);
    higher_rig->on_cycle = [this](const hal::SensorSnapshot& s) { higher_cycle(s); };
    higher_sequence = realtime_now();

    lower_config.site = site;
    lower_config.machine_id = kLower;
    lower_lift = planning::lift_scenario(site, lo, 0);
    lower_rig = std::make_unique<sim::SteppedRig>(lower_lift, sim::SteppedRig::quiet_config(), "bb-site-lower");
    lower = std::make_unique<firmware::Controller>(lower_lift, firmware::ControllerConfig{}, &lower_config);
    // As mgc: the identity of the lift scenario (the site file) made a member's, the Hal set up from it.
    identity = bb::identity_for(lower_lift, firmware::ControllerConfig{}.replanner, lower_rig->cycle_us,
                                lower_rig->sim->config().valve_deadband);
    bb::set_plausible_ranges(identity, lower_lift);
    bb::set_site_member(identity, site, kLower);
    box = std::make_unique<bb::BlackBox>(file, identity, bb::ring_bytes_for_minutes(1.0));
    bus = std::make_unique<bb::RecordingBus>(*lower_rig->controller_bus, *box);
    lower_rig->hal = std::make_unique<hal::Hal>(*bus, lower_rig->sim->plan(), sim::max_velocities(lower_lift));
    bb::configure_hal(*lower_rig->hal, identity);
    firmware::SiteChannelConfig channel_config;
    channel_config.lcm_url = "memq://";
    channel_config.realtime_us = &realtime_now;
    channel_config.monotonic_us = &monotonic_now;
    channel = std::make_unique<firmware::SiteChannel>(channel_config, key, roster, kLower);
    channel->lcm().subscribe(firmware::channel::kSiteState, &Tap::on_state, &tap);
    channel->lcm().subscribe(firmware::channel::kSitePlan, &Tap::on_plan, &tap);
    lower_rig->on_cycle = [this](const hal::SensorSnapshot& s) { lower_cycle(s); };
  }

  void higher_cycle(const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!higher_goal_sent && higher->supervisor().state() == guidance::SupervisorState::Hold) {
      commands.goal_request = true;
      higher_goal_sent = true;
    }
    const firmware::ControllerOutput out = higher->step(s, higher_rig->cycle_us, commands, false, *higher_inputs);
    if (out.start_nodes) (void)higher_rig->hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    higher_rig->hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < higher->num_joints(); ++j) higher_rig->command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    higher_posting.after_step(
        *higher, s.t_us,
        [&](const site_plan_t& content) {
          site_plan_t msg = content;
          msg.utime = s.t_us;
          msg.sequence = ++higher_sequence;
          msg.sender_time_us = realtime_now();
          firmware::sign_site_plan(msg, key);
          to_lower.emplace_back(true, encode(msg));
        },
        [&](const site_state_t& content) {
          site_state_t msg = content;
          msg.utime = s.t_us;
          msg.sequence = ++higher_sequence;
          msg.sender_time_us = realtime_now();
          firmware::sign_site_state(msg, key);
          to_lower.emplace_back(false, encode(msg));
        });
  }

  //! mgc's cycle (mgc_main.cpp): take the site's messages (the recorder told of each), step, post
  //! to the site channel, write, record the cycle.
  void lower_cycle(const hal::SensorSnapshot& s) {
    firmware::ControllerCommands commands;
    if (!lower_goal_sent && lower->supervisor().state() == guidance::SupervisorState::Hold) {
      commands.goal_request = true;
      lower_goal_sent = true;
    }
    channel->take(*lower_inputs, s.t_us, box.get());
    const firmware::ControllerOutput out = lower->step(s, lower_rig->cycle_us, commands, false, *lower_inputs);
    lower_posting.after_step(
        *lower, s.t_us, [&](const site_plan_t& p) { (void)channel->post_plan(p); }, [&](const site_state_t& st) { (void)channel->post_state(st); });
    if (out.start_nodes) (void)lower_rig->hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    lower_rig->hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < lower->num_joints(); ++j) lower_rig->command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];
    box->push_cycle(bb::make_cycle_entry(cycles, s.t_us, lower_rig->cycle_us, false, s, commands, out, lower->snapshot(), 0));
    ++cycles;
  }

  //! One period of both machines, then the site channel's I/O: the TMS870's posts published, the
  //! tower crane's messages received and verified, the TMS870's delivered to the tower crane.
  void period() {
    g_now_us = higher_rig->t_us + higher_rig->cycle_us;
    higher_rig->run(higher_rig->cycle_us);
    lower_rig->run(lower_rig->cycle_us);
    for (const auto& [plan, bytes] : to_lower) {
      channel->lcm().publish(plan ? firmware::channel::kSitePlan : firmware::channel::kSiteState, bytes.data(),
                             static_cast<unsigned>(bytes.size()));
    }
    to_lower.clear();
    for (int i = 0; i < 16; ++i) channel->run_once(0);
    for (const auto& [plan, bytes] : tap.messages) {
      const std::span<const std::uint8_t> span(bytes.data(), bytes.size());
      // The tap hears the tower crane's messages too: only the TMS870's go to the tower crane.
      if (plan) {
        site_plan_t msg{};
        if (higher_verifier->check_plan_bytes(span, msg, realtime_now()) != firmware::SiteReason::Accepted) continue;
        firmware::take_site_plan(*higher_inputs, roster.index_of(msg.machine_id), msg, nullptr);
      } else {
        site_state_t msg{};
        if (higher_verifier->check_state_bytes(span, msg, realtime_now()) != firmware::SiteReason::Accepted) continue;
        firmware::take_site_state(*higher_inputs, roster.index_of(msg.machine_id), msg, g_now_us.load(), nullptr);
      }
    }
    tap.messages.clear();
  }

  void run_s(double seconds) {
    const auto n = static_cast<int>(seconds * 1e6 / static_cast<double>(lower_rig->cycle_us));
    for (int i = 0; i < n; ++i) {
      period();
      // No writer thread: the recording written out each second, long before the queue fills.
      if (i % 100 == 99) box->write_pending();
    }
  }
};

bool is_site_stop(const bb::AlertDigest& a, double horizon_s) {
  return a.source == mgc::alert_t::SOURCE_COLLISION && a.severity == mgc::alert_t::SEVERITY_STOP && a.limit == horizon_s &&
         std::isfinite(a.value);
}

//! The member's site configuration as mgc-replay builds it.
firmware::SiteMemberConfig lower_member() {
  firmware::SiteMemberConfig c;
  c.site = planning::io::load_site(site_path());
  c.machine_id = kLower;
  return c;
}

planning::Scenario lower_scenario(const firmware::SiteMemberConfig& c) {
  return planning::lift_scenario(c.site, planning::io::site_machine_index(c.site, kLower), 0);
}

//! The recorded TMS870, once for the whole program: some 20 s of the crossing, recorded. [s]
constexpr double kRecordS = 20.0;
const std::string& recorded_file() {
  static const std::string file = [] {
    const std::string f = scratch("member.mgcbb");
    RecordedSite site(f);
    site.run_s(kRecordS);
    site.box->close();
    REQUIRE(site.box->dropped() == 0);
    REQUIRE(site.channel->verifier().refused() == 0);
    return f;
  }();
  return file;
}

}  // namespace

TEST_CASE("a site member's recording holds the other machine's messages and replays identically with its site", "[firmware][sim][black-box][site]") {
  const bb::Recording rec = bb::read_recording(recorded_file());
  REQUIRE(rec.identity.format_version == bb::kFormatVersion);
  CHECK(rec.identity.site_machine_id == kLower);
  CHECK(rec.identity.site_machines_hash != 0);
  CHECK(rec.ended);

  std::uint64_t cycles = 0, states = 0, plans = 0, site_stop_cycles = 0, replans_solved = 0;
  const firmware::SiteMemberConfig member = lower_member();
  const std::size_t higher_index = static_cast<std::size_t>(firmware::make_site_roster(member.site).index_of(kHigher));
  for (const bb::Entry& e : rec.entries) {
    if (e.type == bb::RecordType::Site) {
      CHECK(static_cast<std::size_t>(e.site.roster_index) == higher_index);
      if (e.site.kind == bb::SiteKind::Plan) {
        ++plans;
        CHECK(rec.plans.at(e.site.plan_index).machine_id == kHigher);
      } else {
        ++states;
        CHECK(e.site.state.machine_id == kHigher);
      }
    }
    if (e.type != bb::RecordType::Cycle) continue;
    ++cycles;
    bool stop = false;
    for (std::size_t a = 0; a < e.cycle.num_alerts; ++a) stop = stop || is_site_stop(e.cycle.alerts[a], member.rules.horizon_s);
    if (stop) ++site_stop_cycles;
    if (e.cycle.transitioned && e.cycle.reason == guidance::TransitionReason::ReplanSolved) ++replans_solved;
  }
  INFO("cycles " << cycles << ", site states " << states << ", plans " << plans << ", site stop cycles " << site_stop_cycles
                 << ", re-plans " << replans_solved);
  REQUIRE(cycles == static_cast<std::uint64_t>(kRecordS * 100.0));
  // 20 Hz states and a plan a second from the tower crane, nearly all the run.
  CHECK(states > 300);
  CHECK(plans >= 15);
  // Decisions that only the tower crane explains: the site's stop for it, then a re-plan round its plan.
  CHECK(site_stop_cycles > 0);
  CHECK(replans_solved >= 1);

  const planning::Scenario scenario = lower_scenario(member);
  const bb::ReplayResult r = bb::replay(rec, scenario, &member);
  INFO(r.field << ": recorded " << r.recorded << ", replayed " << r.replayed << " at cycle " << r.first_cycle << "; " << r.why_incomplete);
  CHECK(r.replayable);
  CHECK_FALSE(r.incomplete);
  CHECK(r.identical);
  CHECK(r.cycles == cycles);
  CHECK(r.site_messages == states + plans);

  // Without its site the recording is not replayable: it says why rather than replaying a lone machine.
  const bb::ReplayResult alone = bb::replay(rec, scenario);
  CHECK_FALSE(alone.replayable);
  CHECK(alone.why_not.find("site member") != std::string::npos);
}

TEST_CASE("the member's decisions depend on the recorded site messages: without them replay differs", "[firmware][sim][black-box][site]") {
  bb::Recording rec = bb::read_recording(recorded_file());
  // Every site record removed and every cycle's count of them zeroed: a consistent recording of a
  // machine that never heard the tower crane.
  std::vector<bb::Entry> kept;
  for (bb::Entry e : rec.entries) {
    if (e.type == bb::RecordType::Site) continue;
    if (e.type == bb::RecordType::Cycle) e.cycle.site_taken = 0;
    kept.push_back(e);
  }
  rec.entries = kept;
  const firmware::SiteMemberConfig member = lower_member();
  const bb::ReplayResult r = bb::replay(rec, lower_scenario(member), &member);
  CHECK_FALSE(r.incomplete);
  CHECK_FALSE(r.identical);
  CHECK(r.cycles < static_cast<std::uint64_t>(kRecordS * 100.0));
}

TEST_CASE("a site record missing from a member's recording is reported as incomplete, a corrupt one as bad input", "[firmware][sim][black-box][site]") {
  const bb::Recording rec = bb::read_recording(recorded_file());
  const firmware::SiteMemberConfig member = lower_member();
  const planning::Scenario scenario = lower_scenario(member);

  SECTION("a state removed: replay stops at the cycle that took it") {
    bb::Recording cut = rec;
    std::size_t at = 0;
    std::uint64_t cycle_after = 0;
    int seen = 0;
    for (std::size_t i = 0; i < cut.entries.size(); ++i) {
      if (cut.entries[i].type == bb::RecordType::Site && cut.entries[i].site.kind == bb::SiteKind::State && ++seen == 100) at = i;
    }
    REQUIRE(at > 0);
    for (std::size_t i = at; i < cut.entries.size(); ++i) {
      if (cut.entries[i].type == bb::RecordType::Cycle) {
        cycle_after = cut.entries[i].cycle.cycle;
        break;
      }
    }
    cut.entries.erase(cut.entries.begin() + static_cast<std::ptrdiff_t>(at));
    const std::string file = scratch("state-removed.mgcbb");
    bb::write_recording(file, cut, bb::ring_bytes_for_minutes(1.0));
    const bb::ReplayResult r = bb::replay(bb::read_recording(file), scenario, &member);
    CHECK(r.incomplete);
    CHECK(r.incomplete_cycle == cycle_after);
    CHECK(r.cycles == cycle_after);
    CHECK(r.why_incomplete.find("site messages") != std::string::npos);
  }

  SECTION("a plan dropped by the recorder's full plan queue: the cycles after it are not replayed") {
    bb::Recording cut = rec;
    const std::string file = scratch("plan-dropped.mgcbb");
    {
      // Rewritten with more plans at once than the plan queue holds before the first cycle: the
      // recorder drops the rest and counts them, as the loop's side would.
      bb::BlackBox box(file, cut.identity, bb::ring_bytes_for_minutes(1.0));
      for (std::size_t i = 0; i < bb::kPlanQueueCapacity + 3; ++i) box.push_site_plan(1, cut.plans.front());
      CHECK(box.site_plans_dropped() == 3);
      CHECK(box.dropped() == 3);
      CHECK(box.site_taken() == bb::kPlanQueueCapacity + 3);
      bb::CycleEntry first;
      for (const bb::Entry& e : cut.entries) {
        if (e.type == bb::RecordType::Cycle) {
          first = e.cycle;
          break;
        }
      }
      box.push_cycle(first);
      box.close();
    }
    const bb::Recording dropped = bb::read_recording(file);
    CHECK(dropped.plans.size() == bb::kPlanQueueCapacity);
    const bb::ReplayResult r = bb::replay(dropped, scenario, &member);
    CHECK(r.incomplete);
    CHECK(r.incomplete_cycle == 0);
    CHECK(r.why_incomplete.find("3 records dropped") != std::string::npos);
  }

  SECTION("a byte flipped in a site record: bad input naming the record's offset") {
    std::ifstream in(recorded_file(), std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // The first block's records, walked from its header: the first site record, well before the end.
    std::size_t at = bb::kFileHeaderBytes + bb::kBlockHeaderBytes;
    const auto u16_at = [&](std::size_t o) {
      return static_cast<std::size_t>(static_cast<std::uint8_t>(bytes[o])) | (static_cast<std::size_t>(static_cast<std::uint8_t>(bytes[o + 1])) << 8);
    };
    while (u16_at(at + 4) != static_cast<std::size_t>(bb::RecordType::Site)) at += bb::kRecordHeaderBytes + u16_at(at + 6);
    REQUIRE(at < bb::kFileHeaderBytes + bb::kBlockBytes / 2);
    bytes[at + bb::kRecordHeaderBytes + 20] ^= 0x10;
    const std::string file = scratch("site-flipped.mgcbb");
    std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    try {
      (void)bb::read_recording(file);
      FAIL("a corrupt site record was read");
    } catch (const bb::BadRecording& e) {
      CHECK(std::string(e.what()).find("(offset " + std::to_string(at) + "): record CRC mismatch") != std::string::npos);
    }
  }
}

TEST_CASE("a version 1 recording still reads and replays", "[firmware][sim][black-box]") {
  const std::string v2 = scratch("lift-v2.mgcbb");
  {
    test::RecordedLift lift(v2, "bb-site-v1", bb::ring_bytes_for_minutes(1.0));
    lift.rig.run(5'000'000);
    lift.box->close();
    REQUIRE(lift.cycles == 500);
  }
  bb::Recording rec = bb::read_recording(v2);
  rec.identity.format_version = 1;
  const std::string v1 = scratch("lift-v1.mgcbb");
  bb::write_recording(v1, rec, bb::ring_bytes_for_minutes(1.0));
  const bb::Recording old = bb::read_recording(v1);
  CHECK(old.identity.format_version == 1);
  CHECK(old.identity.site_machine_id == 0);
  CHECK(old.entries.size() == rec.entries.size());
  const planning::Scenario scenario = planning::io::load_scenario(test::scenario_path("thesis-steel-frame.yaml"));
  const bb::ReplayResult r = bb::replay(old, scenario);
  CHECK(r.replayable);
  CHECK_FALSE(r.incomplete);
  CHECK(r.identical);
  CHECK(r.cycles == 500);
}
