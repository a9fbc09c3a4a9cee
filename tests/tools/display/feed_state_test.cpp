// SPDX-License-Identifier: Apache-2.0
// mgc-display without its server, in stepped time: the staleness rule, the alert list, plans once
// per page, malformed messages, the scene, and playback of a log (its errors included).
#include <catch2/catch.hpp>
#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "feed_state.hpp"
#include "json.hpp"
#include "mgc/firmware/lcm_feed.hpp"
#include "playback.hpp"
#include "mgc/firmware/site_rules.hpp"
#include "mgc/planning/obstacle.hpp"
#include "mgc/planning/site.hpp"
#include "scene.hpp"
#include "site_view.hpp"

namespace {

using mgc::display::FeedState;
namespace ch = mgc::firmware::channel;

template <typename T>
std::vector<std::uint8_t> encoded(const T& msg) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  REQUIRE(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
  return bytes;
}

template <typename T>
void feed(FeedState& state, const char* channel, const T& msg, std::int64_t now_us) {
  const auto bytes = encoded(msg);
  state.on_message(channel, bytes.data(), static_cast<int>(bytes.size()), now_us);
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

mgc::machine_state_t crane_state(double swing_rad) {
  mgc::machine_state_t m{};
  m.utime = 42;
  m.machine_kind = mgc::machine_state_t::MACHINE_KIND_MOBILE_CRANE;
  m.num_joints = 4;
  m.joint_position[0] = swing_rad;
  m.joint_position[1] = 0.9;
  m.joint_position[2] = 30.0;
  m.joint_position[3] = 20.0;
  m.supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
  m.load_moment_pct = 72.0;
  return m;
}

mgc::alert_t alert(std::int32_t id, bool active) {
  mgc::alert_t a{};
  a.alert_id = id;
  a.severity = mgc::alert_t::SEVERITY_STOP;
  a.source = mgc::alert_t::SOURCE_COLLISION;
  a.active = active;
  a.value_unit = mgc::alert_t::UNIT_SECOND;
  a.value = 3.5;
  a.limit = NAN;
  return a;
}

std::string scenario_path() { return std::string(MGC_SOURCE_DIR) + "/scenarios/thesis-steel-frame.yaml"; }

}  // namespace

TEST_CASE("the feed is alive for 0.5 s after the last machine state and stale after", "[display]") {
  FeedState state(nullptr);
  std::string j = state.json(1'000'000, nullptr);
  CHECK(contains(j, "\"alive\":false"));
  CHECK(contains(j, "\"state_age_s\":null"));
  CHECK_FALSE(contains(j, "\"state\":"));

  feed(state, ch::kMachineState, crane_state(0.5), 1'000'000);
  j = state.json(1'000'000 + mgc::display::kStaleAfter_us, nullptr);
  CHECK(contains(j, "\"alive\":true"));
  CHECK(contains(j, "\"supervisor\":4"));
  CHECK(contains(j, "\"load_moment_pct\":72"));
  CHECK(contains(j, "\"joints\":[0.5,0.9,30,20]"));
  j = state.json(1'000'001 + mgc::display::kStaleAfter_us, nullptr);
  CHECK(contains(j, "\"alive\":false"));
  CHECK(contains(j, "\"state_age_s\":0.500001"));
}

TEST_CASE("alerts are listed when raised, marked when cleared and dropped 30 s later", "[display]") {
  FeedState state(nullptr);
  feed(state, ch::kAlert, alert(9, false), 0);  // a clear for an alert never seen raised
  CHECK(contains(state.json(0, nullptr), "\"alerts\":[]"));

  feed(state, ch::kAlert, alert(7, true), 1'000'000);
  std::string j = state.json(2'000'000, nullptr);
  CHECK(contains(j, "\"id\":7,\"severity\":4,\"source\":1,\"active\":true"));
  CHECK(contains(j, "\"raised_ago_s\":1,"));
  CHECK(contains(j, "\"limit\":null"));  // NaN is not JSON

  feed(state, ch::kAlert, alert(7, true), 3'000'000);  // the 1 Hz repeat keeps the raise time
  feed(state, ch::kAlert, alert(7, false), 4'000'000);
  j = state.json(5'000'000, nullptr);
  CHECK(contains(j, "\"id\":7,\"severity\":4,\"source\":1,\"active\":false"));
  CHECK(contains(j, "\"raised_ago_s\":4,"));
  CHECK(contains(j, "\"cleared_ago_s\":1}"));

  // Another alert 30 s after the clear sweeps the cleared one out.
  feed(state, ch::kAlert, alert(8, true), 4'000'001 + mgc::display::kClearedAlertKept_us);
  j = state.json(4'000'001 + mgc::display::kClearedAlertKept_us, nullptr);
  CHECK_FALSE(contains(j, "\"id\":7,"));
  CHECK(contains(j, "\"id\":8,"));

  // A full list drops the alert cleared longest ago first, then the active one heard longest ago.
  feed(state, ch::kAlert, alert(8, false), 41'000'000);
  for (int id = 100; id < 100 + static_cast<int>(mgc::display::kMaxAlertsKept); ++id) feed(state, ch::kAlert, alert(id, true), 42'000'000 + id);
  j = state.json(42'000'000, nullptr);
  CHECK_FALSE(contains(j, "\"id\":8,"));
  CHECK(contains(j, "\"id\":100,"));
  feed(state, ch::kAlert, alert(100, true), 43'000'000);  // 100 repeats, 101 does not
  feed(state, ch::kAlert, alert(200, true), 43'000'001);
  j = state.json(43'000'001, nullptr);
  CHECK(contains(j, "\"id\":100,"));
  CHECK_FALSE(contains(j, "\"id\":101,"));
  CHECK(contains(j, "\"id\":102,"));
  CHECK(contains(j, "\"id\":200,"));
}

TEST_CASE("malformed messages are counted per channel and change nothing", "[display]") {
  FeedState state(nullptr);
  const char junk[] = "not an LCM message";
  state.on_message(ch::kMachineState, junk, sizeof junk, 0);
  state.on_message(ch::kAlert, junk, 3, 0);
  state.on_message("SOMEONE_ELSES", junk, sizeof junk, 0);  // not the feed: ignored, not counted

  // A plan whose counts claim 2^31 - 1 waypoints of 4 joints in a few bytes.
  mgc::plan_t plan{};
  plan.planner_name = "x";
  plan.num_joints = 4;
  auto bytes = encoded(plan);
  const std::size_t counts_at = 8 + 8 + 4 + 2 + 8 + 1 + 4;  // fingerprint, utime, name, seed, status, num_joints
  bytes[counts_at] = 0x7f;
  bytes[counts_at + 1] = bytes[counts_at + 2] = bytes[counts_at + 3] = 0xff;
  state.on_message(ch::kPlan, bytes.data(), static_cast<int>(bytes.size()), 0);

  // An instruction whose text length is 0 (the generated decoder throws on it).
  mgc::operator_instruction_t instruction{};
  instruction.text = "swing left";
  bytes = encoded(instruction);
  bytes[16] = bytes[17] = bytes[18] = bytes[19] = 0;
  state.on_message(ch::kOperatorInstruction, bytes.data(), static_cast<int>(bytes.size()), 0);

  CHECK(state.malformed() == 4);
  CHECK(state.received() == 4);
  const std::string j = state.json(0, nullptr);
  CHECK(contains(j, "\"malformed\":{\"MGC_ALERT\":1,\"MGC_MACHINE_STATE\":1,\"MGC_OPERATOR_INSTRUCTION\":1,\"MGC_PLAN\":1}"));
  CHECK_FALSE(contains(j, "\"state\":"));
  CHECK_FALSE(contains(j, "\"instruction\":"));
  CHECK(contains(j, "\"plan_version\":0"));
}

TEST_CASE("the machine is drawn through the scenario's model and a plan reaches each page once", "[display]") {
  const mgc::display::Scene scene(scenario_path());
  REQUIRE(scene.dof() == 4);
  FeedState state(&scene);
  feed(state, ch::kMachineState, crane_state(0.5), 0);
  std::string j = state.json(0, nullptr);
  CHECK(contains(j, "\"machine\":{\"bodies\":[[["));

  // The hook at the state's joints is the model's: compare with the tool point it computes.
  mgc::planning::JointVector q(4);
  q << 0.5, 0.9, 30.0, 20.0;
  const auto hook = scene.tool_path({q}).front();
  mgc::display::Json expected;
  expected.point(hook);
  CHECK(contains(j, "\"tool\":" + expected.str()));

  mgc::plan_t plan{};
  plan.planner_name = "test";
  plan.num_joints = 4;
  plan.positions = {{0.5, 0.9, 30.0, 20.0}, {1.2, 0.9, 30.0, 20.0}};
  plan.num_waypoints = 2;
  plan.moving_joint = {0, mgc::plan_t::NO_JOINT};
  feed(state, ch::kPlan, plan, 0);
  std::uint64_t page_a = 0;
  std::uint64_t page_b = 0;
  j = state.json(0, &page_a);
  CHECK(contains(j, "\"plan\":{\"version\":1,\"planner\":\"test\""));
  CHECK(contains(j, "\"tool_path\":[["));
  CHECK_FALSE(contains(state.json(0, &page_a), "\"plan\":"));
  CHECK(contains(state.json(0, &page_b), "\"plan\":{\"version\":1"));
  // 0.7 rad of swing in steps of at most 2 deg: 21 steps, 22 points.
  mgc::planning::JointVector q_end(4);
  q_end << 1.2, 0.9, 30.0, 20.0;
  CHECK(scene.tool_path({q, q_end}).size() == 22);

  // A plan for another machine (2 joints) has no path on this one.
  plan.num_joints = 2;
  plan.positions = {{0.0, 0.0}, {1.0, 0.0}};
  feed(state, ch::kPlan, plan, 0);
  CHECK(contains(state.json(0, &page_a), "\"tool_path\":[]"));
}

namespace {

//! Crane 2 of thesis-steel-frame (dynamic obstacle 0) at (-30, -6, 0), yawed -90 deg, moving;
//! a second entry for another obstacle index as given.
mgc::obstacle_poses_t crane_two_poses() {
  mgc::obstacle_poses_t m{};
  m.utime = 77;
  m.num_tracked = 1;
  m.num_obstacles = 1;
  for (int i = 0; i < mgc::obstacle_poses_t::MAX_OBSTACLES; ++i) {
    m.obstacle_index[i] = -1;
    m.x[i] = m.y[i] = m.z[i] = m.yaw[i] = m.position_sigma[i] = m.speed[i] = m.yaw_rate[i] = m.fix_age[i] = NAN;
  }
  m.obstacle_index[0] = 0;
  m.valid[0] = true;
  m.still[0] = false;
  m.x[0] = -30.0;
  m.y[0] = -6.0;
  m.z[0] = 0.0;
  m.yaw[0] = -M_PI / 2;
  m.position_sigma[0] = 0.15;
  m.speed[0] = 1.25;
  m.yaw_rate[0] = -0.0625;
  m.fix_age[0] = 0.05;
  return m;
}

std::string status_of(const std::string& json) {
  const std::string key = "\"status\":\"";
  const auto at = json.find(key);
  if (at == std::string::npos) return "";
  return json.substr(at + key.size(), json.find('"', at + key.size()) - at - key.size());
}

}  // namespace

TEST_CASE("tracked obstacles are drawn from the scenario's parts at their pose, and never old ones as current", "[display]") {
  const mgc::display::Scene scene(scenario_path());
  FeedState state(&scene);
  CHECK_FALSE(contains(state.json(0, nullptr), "\"obstacles\":"));

  feed(state, ch::kObstaclePoses, crane_two_poses(), 1'000'000);
  std::string j = state.json(1'100'000, nullptr);
  CHECK(contains(j, "\"obstacles\":{\"age_s\":0.1,\"current\":true,\"num_tracked\":1,\"list\":[{\"index\":0,\"name\":\"crane-2\""));
  CHECK(status_of(j) == "moving");
  CHECK(contains(j, "\"position\":[-30.000,-6.000,0.000]"));
  CHECK(contains(j, "\"speed_m_s\":1.25,\"yaw_rate_rad_s\":-0.0625"));
  CHECK(contains(j, "\"fix_age_s\":0.15"));  // 0.05 s when published, 0.1 s since
  // The first part (the carrier: 13 x 2.6 x 2 m at (2, 0, 1) in crane 2's frame) where the
  // project's outline puts it at that pose: yawed -90 deg, its long side along y, south of x = -30.
  const auto& spec = scene.scenario().dynamic_obstacles.at(0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(-30.0, -6.0, 0.0));
  pose.rotate(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()));
  const auto carrier = mgc::planning::outline_points(spec.obstacle.parts.at(0), pose);
  mgc::display::Json first;
  first.begin_array();
  for (const auto& p : carrier) first.point(p);
  first.end_array();
  CHECK(contains(j, "\"parts\":[" + first.str() + ",["));
  double y_min = 1e9, y_max = -1e9;
  for (const auto& p : carrier) {
    CHECK(std::abs(p.x() + 30.0) <= 1.3 + 1e-9);
    y_min = std::min(y_min, p.y());
    y_max = std::max(y_max, p.y());
  }
  CHECK(y_min == Approx(-6.0 - 8.5));
  CHECK(y_max == Approx(-6.0 + 4.5));

  // Standing still, then lost: its last pose, said to be unknown.
  auto m = crane_two_poses();
  m.still[0] = true;
  feed(state, ch::kObstaclePoses, m, 1'200'000);
  CHECK(status_of(state.json(1'200'000, nullptr)) == "still");
  m.valid[0] = false;
  feed(state, ch::kObstaclePoses, m, 1'300'000);
  j = state.json(1'300'000, nullptr);
  CHECK(status_of(j) == "pose unknown");
  CHECK(contains(j, "\"position\":[-30.000,-6.000,0.000]"));
  CHECK(contains(j, "\"parts\":[[["));

  // No message for 0.5 s: as last reported, not current, whatever the last one said.
  m.valid[0] = true;
  feed(state, ch::kObstaclePoses, m, 2'000'000);
  CHECK(status_of(state.json(2'000'000 + mgc::display::kObstaclesStaleAfter_us, nullptr)) == "still");
  j = state.json(2'000'001 + mgc::display::kObstaclesStaleAfter_us, nullptr);
  CHECK(contains(j, "\"current\":false"));
  CHECK(status_of(j) == "not current");

  // A tracker that never fitted a pose: nothing to draw.
  m = crane_two_poses();
  m.valid[0] = false;
  m.x[0] = m.y[0] = m.z[0] = m.yaw[0] = NAN;
  feed(state, ch::kObstaclePoses, m, 3'000'000);
  j = state.json(3'000'000, nullptr);
  CHECK(status_of(j) == "never fixed");
  CHECK(contains(j, "\"position\":null"));
  CHECK(contains(j, "\"parts\":[]"));

  // An index the scenario does not have: listed, nameless, no parts.
  m = crane_two_poses();
  m.obstacle_index[0] = 5;
  feed(state, ch::kObstaclePoses, m, 4'000'000);
  j = state.json(4'000'000, nullptr);
  CHECK(contains(j, "\"index\":5,\"name\":\"\""));
  CHECK(contains(j, "\"parts\":[]"));
}

TEST_CASE("malformed obstacle poses are counted and change nothing", "[display]") {
  FeedState state(nullptr);
  feed(state, ch::kObstaclePoses, crane_two_poses(), 0);
  auto m = crane_two_poses();
  m.num_obstacles = 9;  // above the arrays
  m.num_tracked = 9;
  feed(state, ch::kObstaclePoses, m, 1);
  m.num_obstacles = 2;
  m.num_tracked = 1;  // carries more than the controller tracks
  feed(state, ch::kObstaclePoses, m, 2);
  m.num_obstacles = -1;
  feed(state, ch::kObstaclePoses, m, 3);
  const char junk[] = "not an LCM message";
  state.on_message(ch::kObstaclePoses, junk, sizeof junk, 4);
  CHECK(state.malformed() == 4);
  CHECK(state.received() == 5);
  const std::string j = state.json(4, nullptr);
  CHECK(contains(j, "\"malformed\":{\"MGC_OBSTACLE_POSES\":4}"));
  // Still the first message: received at 0, one obstacle.
  CHECK(contains(j, "\"obstacles\":{\"age_s\":4e-06,\"current\":true,\"num_tracked\":1,"));
  CHECK(status_of(j) == "moving");
  CHECK(contains(j, "\"parts\":[]"));  // no scene: nothing to draw
}

TEST_CASE("JSON text: strings escaped, non-finite numbers null", "[display]") {
  mgc::display::Json j;
  j.begin_object().key("text").value("a \"b\"\\\n").key("nan").value(NAN).key("inf").value(INFINITY).key("n").value(1.5).end_object();
  CHECK(j.str() == "{\"text\":\"a \\\"b\\\"\\\\\\u000a\",\"nan\":null,\"inf\":null,\"n\":1.5}");
}

TEST_CASE("a recorded log plays in its own time, seeks back and refuses what is not a whole log", "[display]") {
  const std::string dir = std::filesystem::temp_directory_path() / ("mgc-display-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/lift.lcmlog";
  {
    lcm::LogFile log(path, "w");
    REQUIRE(log.good());
    for (int k = 0; k < 100; ++k) {
      const auto bytes = encoded(crane_state(0.01 * k));
      lcm::LogEvent e{};
      e.eventnum = k;
      e.timestamp = 5'000'000 + k * 10'000;
      e.channel = ch::kMachineState;
      e.datalen = static_cast<int32_t>(bytes.size());
      e.data = const_cast<std::uint8_t*>(bytes.data());
      REQUIRE(log.writeEvent(&e) == 0);
    }
  }
  mgc::display::Playback playback(path);
  CHECK(contains(playback.json(), "\"duration_s\":0.99"));
  CHECK(contains(playback.json(), "\"events\":100"));
  std::string error;
  CHECK_FALSE(playback.control("speed", "11", error));
  CHECK(contains(error, "speed: expected a number from 0.1 to 10"));
  CHECK_FALSE(playback.control("seek", "2", error));
  CHECK_FALSE(playback.control("jump", "", error));
  CHECK(playback.control("pause", "", error));
  CHECK(playback.control("seek", "0.5", error));
  CHECK(playback.position_us() == 500'000);

  const auto size = std::filesystem::file_size(path);
  std::filesystem::copy_file(path, dir + "/cut.lcmlog");
  std::filesystem::resize_file(dir + "/cut.lcmlog", size - 5);
  CHECK_THROWS_WITH(mgc::display::Playback(dir + "/cut.lcmlog"),
                    Catch::Contains(std::to_string(size - 5) + " bytes, the last whole event ends at byte") &&
                        Catch::Contains("(truncated log)"));
  {
    std::ofstream text(dir + "/text.lcmlog");
    text << "no events here\n";
  }
  CHECK_THROWS_WITH(mgc::display::Playback(dir + "/text.lcmlog"), Catch::Contains("no LCM log event"));
  CHECK_THROWS_WITH(mgc::display::Playback(dir + "/none.lcmlog"), Catch::Contains("none.lcmlog: No such file"));
  std::filesystem::remove_all(dir);
}

namespace {

std::string site_path() { return std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml"; }

constexpr std::int64_t kSiteNow_us = 1'765'000'000'000'000;  //!< the stepped CLOCK_REALTIME [µs]
std::int64_t site_clock_us() noexcept { return kSiteNow_us; }

//! Machine 2 of the site (the tower crane, 3 joints), as its controller would report it.
mgc::site_state_t tower_state(std::int64_t sequence) {
  mgc::site_state_t s{};
  s.utime = 5'000'000;
  s.machine_id = 2;
  s.priority = 1;
  s.supervisor_state = mgc::machine_state_t::SUPERVISOR_EXECUTING;
  s.num_joints = 3;
  s.joint_position[0] = 0.3;
  s.joint_position[1] = 30.0;
  s.joint_position[2] = 20.0;
  s.time_to_rest_s = 0.0;
  s.sequence = sequence;
  s.sender_time_us = kSiteNow_us;
  return s;
}

mgc::firmware::SiteKey test_site_key(std::uint8_t seed) {
  std::array<std::uint8_t, mgc::firmware::kCommandKeyBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(seed + 7 * i);
  return mgc::firmware::SiteKey(k);
}

}  // namespace

TEST_CASE("the other machines of a site are drawn through their own models at their reported joints", "[display][site]") {
  const mgc::display::Scene scene(scenario_path());
  mgc::display::SiteView site(site_path(), 1, std::nullopt, &site_clock_us);
  FeedState state(&scene);
  state.set_site(&site);
  std::string j = state.json(0, nullptr);
  CHECK(contains(j, "\"site\":{\"name\":\"thesis-steel-frame-site\",\"verified\":false"));
  CHECK(contains(j, "{\"id\":1,\"priority\":2,\"name\":\"Grove TMS870\",\"own\":true,\"age_s\":null}"));
  CHECK(contains(j, "\"own\":false,\"age_s\":null}"));  // machine 2 not heard from yet

  feed(state, ch::kSiteState, tower_state(1), 1'000'000);
  j = state.json(1'100'000, nullptr);
  CHECK(contains(j, "\"own\":false,\"age_s\":0.1,\"current\":true,\"supervisor\":4,\"joints\":[0.3,30,20],\"bodies\":[[["));
  // The bodies are the tower crane's model at its base, at the reported joints.
  const mgc::planning::Site& s = site.site();
  const auto model = mgc::planning::build_model(mgc::planning::lift_scenario(s, 1, 0));
  mgc::planning::JointVector q(3);
  q << 0.3, 30.0, 20.0;
  mgc::planning::Kinematics k;
  model->forward_kinematics(q, k);
  mgc::display::Json body;
  body.begin_array();
  const auto& last_body = k.bodies.at(model->bodies().size() - 1);
  for (const auto& p : mgc::planning::box_corners(last_body.world_from_body, last_body.size_m)) body.point(p);
  body.end_array();
  CHECK(contains(j, body.str() + "],\"base\":"));
  mgc::display::Json base;
  base.point(s.machines[1].world_from_base.translation());
  CHECK(contains(j, "\"base\":" + base.str()));

  // Past the controllers' own staleness rule: not current.
  const std::int64_t stale_us = mgc::firmware::SiteRulesConfig{}.stale_after_us();
  CHECK(contains(state.json(1'000'000 + stale_us, nullptr), "\"current\":true"));
  CHECK(contains(state.json(1'000'001 + stale_us, nullptr), "\"current\":false"));

  // The display's own machine is drawn from its feed: its states on the site channel are its own
  // echoes, counted apart and not drawn. Refused and counted: a machine the site lacks, another
  // joint count, non-finite joints, bytes that are no state. None changes what is drawn.
  auto own = tower_state(2);
  own.machine_id = 1;
  feed(state, ch::kSiteState, own, 2'000'000);
  auto unknown = tower_state(3);
  unknown.machine_id = 7;
  feed(state, ch::kSiteState, unknown, 2'000'000);
  auto joints = tower_state(4);
  joints.num_joints = 4;
  feed(state, ch::kSiteState, joints, 2'000'000);
  auto nan = tower_state(5);
  nan.joint_position[1] = NAN;
  feed(state, ch::kSiteState, nan, 2'000'000);
  const char junk[] = "not a site state";
  state.on_message(ch::kSiteState, junk, sizeof junk, 2'000'000);
  j = state.json(2'000'000, nullptr);
  CHECK(contains(j, "\"MGC_SITE_STATE\":4"));
  CHECK(contains(j, "\"joints\":[0.3,30,20]"));
  CHECK(contains(j, "\"age_s\":1,\"current\":false"));
  CHECK(contains(j, "\"own_echoes\":1,"));
  CHECK(state.malformed() == 4);
  CHECK(state.received() == 6);

  // A playback that seeks back forgets the site's states with the rest.
  state.clear();
  CHECK(contains(state.json(0, nullptr), "\"own\":false,\"age_s\":null}"));
}

TEST_CASE("with a site key only verified site states are drawn", "[display][site]") {
  const mgc::display::Scene scene(scenario_path());
  mgc::display::SiteView site(site_path(), 1, test_site_key(3), &site_clock_us);
  FeedState state(&scene);
  state.set_site(&site);
  CHECK(contains(state.json(0, nullptr), "\"verified\":true"));

  auto forged = tower_state(1);
  mgc::firmware::sign_site_state(forged, test_site_key(4));  // another key
  feed(state, ch::kSiteState, forged, 1'000'000);
  auto late = tower_state(2);
  late.sender_time_us = kSiteNow_us - 10'000'000;  // a recording, 10 s late
  mgc::firmware::sign_site_state(late, test_site_key(3));
  feed(state, ch::kSiteState, late, 1'000'000);
  std::string j = state.json(1'000'000, nullptr);
  CHECK(contains(j, "\"own\":false,\"age_s\":null}"));
  CHECK(contains(j, "\"refused\":{\"" + std::string(mgc::firmware::site_reason_name(mgc::firmware::SiteReason::BadMac)) + "\":1,\"" +
                        mgc::firmware::site_reason_name(mgc::firmware::SiteReason::TimeBehind) + "\":1}"));

  auto good = tower_state(3);
  mgc::firmware::sign_site_state(good, test_site_key(3));
  feed(state, ch::kSiteState, good, 1'000'000);
  feed(state, ch::kSiteState, good, 1'050'000);  // its replay
  j = state.json(1'100'000, nullptr);
  CHECK(contains(j, "\"age_s\":0.1,\"current\":true,\"supervisor\":4,\"joints\":[0.3,30,20]"));
  CHECK(state.malformed() == 3);

  // A recorded lift reviewed an hour later: each state is checked against the time its logger
  // received it, not the review's clock; seeking back replays the same states, accepted again.
  auto recorded = tower_state(10);
  recorded.sender_time_us = kSiteNow_us - 3'600'000'000;
  mgc::firmware::sign_site_state(recorded, test_site_key(3));
  const auto bytes = encoded(recorded);
  const auto play = [&](std::int64_t logged_us) {
    state.on_message(ch::kSiteState, bytes.data(), static_cast<int>(bytes.size()), 2'000'000, logged_us);
  };
  play(recorded.sender_time_us + 4'000);
  CHECK(state.malformed() == 3);
  state.clear();
  play(recorded.sender_time_us + 4'000);
  CHECK(state.malformed() == 3);
  CHECK(contains(state.json(2'000'000, nullptr), "\"age_s\":0,\"current\":true"));
  // Once it has been taken, the same state again is a replay; and a log whose receive time is far
  // from the state's sender time is refused as it is live.
  play(recorded.sender_time_us + 4'000);
  CHECK(state.malformed() == 4);
  state.clear();
  play(recorded.sender_time_us + 10'000'000);
  CHECK(state.malformed() == 5);

  CHECK_THROWS_WITH(mgc::display::SiteView(site_path(), 9, std::nullopt, &site_clock_us), Catch::Contains("9"));
  CHECK_THROWS_AS(mgc::display::SiteView(site_path(), std::nullopt, test_site_key(3), &site_clock_us), std::invalid_argument);
}
