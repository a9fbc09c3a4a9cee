// SPDX-License-Identifier: Apache-2.0
// Every kind of bad input gives one InputError naming the file, the line, the field and what was
// expected -- nothing crashes and nothing is silently defaulted.
#include <catch2/catch.hpp>

#include <regex>

#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::TempFile;

namespace {

std::string machine_path() { return mgc::test::source_path("scenarios/machines/grove-tms870.yaml").string(); }

// A small valid scenario; each test replaces one piece of it.
std::string scenario_text() {
  return "name: bad-input-base\n"
         "machine: " + machine_path() + "\n"
         "base:\n"
         "  position_m: [0, 0, 0]\n"
         "  yaw_deg: 0\n"
         "task:\n"
         "  load_lb: 20000\n"
         "  outriggers: fully_extended\n"
         "  counterweight_lb: 18000\n"
         "  constraint: load_chart\n"
         "  load_size_m: [2, 2, 1]\n"
         "  sling_length_m: 1\n"
         "obstacles:\n"
         "  - name: block\n"
         "    type: box\n"
         "    size_m: [2, 2, 2]\n"
         "    position_m: [0, 15, 1]\n"
         "start:\n"
         "  swing_deg: 0\n"
         "  boom_elevation_deg: 45\n"
         "  boom_length_m: 20\n"
         "  cable_length_m: 5\n"
         "goal:\n"
         "  swing_deg: 180\n"
         "  boom_elevation_deg: 45\n"
         "  boom_length_m: 20\n"
         "  cable_length_m: 5\n"
         "planner:\n"
         "  seed: 1\n";
}

struct Expect {
  int line;
  std::string field;
  std::string message;  // a fragment of what was expected
};

void expect_error(const std::string& text, const Expect& e) {
  TempFile file("scenario.yaml", text);
  try {
    auto loaded = io::load_and_build(file.path());
    const auto errors = io::check_endpoints(loaded);
    REQUIRE(errors.size() >= 1);
    throw errors.front();
  } catch (const io::InputError& error) {
    const std::string what = error.what();
    CAPTURE(what);
    CHECK(error.file() == file.path().string());
    CHECK(error.line() == e.line);
    CHECK(error.field() == e.field);
    CHECK(what.find(e.message) != std::string::npos);
    // One line: "<file>:<line>: <field>: ..."
    CHECK(what.find('\n') == std::string::npos);
    const std::string prefix = file.path().string() + ":" + std::to_string(e.line) + ": " + (e.field.empty() ? "" : e.field + ": ");
    CHECK(what.rfind(prefix, 0) == 0);
  }
}

}  // namespace

TEST_CASE("the base scenario of these tests is valid", "[unit]") {
  TempFile file("scenario.yaml", scenario_text());
  auto loaded = io::load_and_build(file.path());
  CHECK(io::check_endpoints(loaded).empty());
}

TEST_CASE("bad input: missing field", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "  counterweight_lb: 18000\n", ""), {6, "task.counterweight_lb", "missing field"});
}

TEST_CASE("bad input: unknown field", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "  sling_length_m: 1\n", "  sling_length_m: 1\n  slingg: 2\n"),
               {13, "task.slingg", "unknown field"});
}

TEST_CASE("bad input: duplicate field", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "  sling_length_m: 1\n", "  sling_length_m: 1\n  sling_length_m: 2\n"),
               {13, "task.sling_length_m", "duplicate field"});
}

TEST_CASE("bad input: wrong type", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "load_lb: 20000", "load_lb: heavy"), {7, "task.load_lb", "expected a number, got 'heavy'"});
  expect_error(mgc::test::replace_first(scenario_text(), "size_m: [2, 2, 2]", "size_m: 2"), {16, "obstacles[0].size_m", "expected a list of 3 positive numbers"});
  expect_error(mgc::test::replace_first(scenario_text(), "type: box", "type: sphere"), {15, "obstacles[0].type", "expected one of box, cylinder, capsule, mesh, steel_frame"});
}

TEST_CASE("bad input: NaN and infinity", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "boom_length_m: 20\n  cable", "boom_length_m: .nan\n  cable"),
               {21, "start.boom_length_m", "expected a finite number, got '.nan'"});
  expect_error(mgc::test::replace_first(scenario_text(), "position_m: [0, 15, 1]", "position_m: [0, .inf, 1]"),
               {17, "obstacles[0].position_m[1]", "expected a finite number"});
}

TEST_CASE("bad input: non-positive sizes", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "size_m: [2, 2, 2]", "size_m: [2, -2, 2]"), {16, "obstacles[0].size_m[1]", "expected a positive number, got '-2'"});
}

TEST_CASE("bad input: load above every chart entry", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "load_lb: 20000", "load_lb: 150000"), {7, "task.load_lb", "a load the chart rates (at most 140000 lb"});
  // The capacity reduction counts: 130,000 lb + 10 % is above 140,000.
  expect_error(mgc::test::replace_first(scenario_text(), "load_lb: 20000", "load_lb: 130000\n  capacity_reduction_pct: 10"),
               {7, "task.load_lb", "this is 143000 lb"});
}

TEST_CASE("bad input: rigging the chart does not cover", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "outriggers: fully_extended", "outriggers: retracted"),
               {8, "task.outriggers", "expected 'fully_extended', the rigging of the load chart"});
}

TEST_CASE("bad input: start or goal outside the joint ranges", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "boom_length_m: 20\n  cable", "boom_length_m: 40\n  cable"),
               {21, "start.boom_length_m", "expected a value within the joint range [10.9728, 33.528] m"});
  expect_error(mgc::test::replace_first(scenario_text(), "  swing_deg: 180\n  boom_elevation_deg: 45", "  swing_deg: 180\n  boom_elevation_deg: 85"),
               {25, "goal.boom_elevation_deg", "[0, 80] deg"});
}

TEST_CASE("bad input: start in collision names the obstacle", "[unit]") {
  // Swing 90 deg puts the load (radius 14.1 m, 8.1 m up) ... lower it onto the block at (0, 15).
  expect_error(mgc::test::replace_first(scenario_text(), "  swing_deg: 0\n  boom_elevation_deg: 45\n  boom_length_m: 20\n  cable_length_m: 5",
                       "  swing_deg: 90\n  boom_elevation_deg: 45\n  boom_length_m: 20\n  cable_length_m: 13"),
               {18, "start", "infeasible: collision: load hits obstacle 'block'"});
}

TEST_CASE("bad input: goal against the load chart names the chart row", "[unit]") {
  // 20 m boom at 35 deg: below the 70-ft row's 39.5 deg minimum for 20,000 lb.
  expect_error(mgc::test::replace_first(scenario_text(), "  swing_deg: 180\n  boom_elevation_deg: 45", "  swing_deg: 180\n  boom_elevation_deg: 35"),
               {23, "goal", "load-chart row 70 ft boom, radius 50 ft): value 35 deg, limit 39.5 deg"});
}

TEST_CASE("bad input: inverted range in a machine file", "[unit]") {
  std::ifstream in(machine_path());
  std::string machine((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  machine = mgc::test::replace_first(machine, "range_deg: [0, 80]", "range_deg: [80, 0]");
  TempFile bad_machine("machine.yaml", machine);
  try {
    (void)io::load_machine(bad_machine.path());
    FAIL("no error");
  } catch (const io::InputError& e) {
    CHECK(e.field() == "joints[1].range_deg");
    CHECK(std::string(e.what()).find("expected a pair [min, max] with min < max") != std::string::npos);
    CHECK(e.line() > 0);
  }
}

TEST_CASE("bad input: a load chart row of the wrong length", "[unit]") {
  std::ifstream in(machine_path());
  std::string machine((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  machine = mgc::test::replace_first(machine, "[140000, 110500, 69800, 78750, 59800, 27600, ~,", "[140000, 110500, 69800, 78750, 59800, 27600,");
  TempFile bad_machine("machine.yaml", machine);
  try {
    (void)io::load_machine(bad_machine.path());
    FAIL("no error");
  } catch (const io::InputError& e) {
    CHECK(e.field() == "load_chart.capacity_lb[0]");
    CHECK(std::string(e.what()).find("expected a row of 21 cells") != std::string::npos);
  }
}

TEST_CASE("bad input: machine file missing, YAML syntax error, mesh index", "[unit]") {
  expect_error(mgc::test::replace_first(scenario_text(), "machine: " + machine_path(), "machine: nowhere.yaml"),
               {2, "machine", "does not exist"});
  expect_error(mgc::test::replace_first(scenario_text(), "  yaw_deg: 0\n", "  yaw_deg: [0\n"), {6, "", "YAML syntax error"});
  expect_error(mgc::test::replace_first(scenario_text(), "    type: box\n    size_m: [2, 2, 2]\n",
                       "    type: mesh\n    vertices_m: [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\n    triangles: [[0, 1, 3]]\n"),
               {17, "obstacles[0].triangles[0][2]", "expected an integer in [0, 2]"});
}

TEST_CASE("bad input: keyframes must move forward in time", "[unit]") {
  const std::string dynamic =
      "dynamic_obstacles:\n"
      "  - name: truck\n"
      "    parts: [{type: box, size_m: [8, 2.5, 3], position_m: [0, 0, 1.5]}]\n"
      "    motion:\n"
      "      - {t_s: 5, position_m: [0, -30, 0], yaw_deg: 0}\n"
      "      - {t_s: 5, position_m: [0, -20, 0], yaw_deg: 0}\n"
      "start:\n";
  expect_error(mgc::test::replace_first(scenario_text(), "start:\n", dynamic), {23, "dynamic_obstacles[0].motion[1].t_s", "a time after the previous key's 5 s"});
}

TEST_CASE("bad input: UWB tag ids are 0..255 and unique", "[unit]") {
  const std::string dynamic =
      "dynamic_obstacles:\n"
      "  - name: truck\n"
      "    parts: [{type: box, size_m: [8, 2.5, 3], position_m: [0, 0, 1.5]}]\n"
      "    motion: [{t_s: 0, position_m: [0, -30, 0], yaw_deg: 0}]\n"
      "    tags:\n"
      "      - {id: 4, position_m: [0, 0, 3]}\n"
      "      - {id: ID, position_m: [3, 0, 3]}\n"
      "start:\n";
  expect_error(mgc::test::replace_first(scenario_text(), "start:\n", mgc::test::replace_first(dynamic, "ID", "4")),
               {24, "dynamic_obstacles[0].tags[1].id", "a tag id not used by another tag"});
  expect_error(mgc::test::replace_first(scenario_text(), "start:\n", mgc::test::replace_first(dynamic, "ID", "256")),
               {24, "dynamic_obstacles[0].tags[1].id", "an integer"});
  TempFile file("scenario.yaml", mgc::test::replace_first(scenario_text(), "start:\n", mgc::test::replace_first(dynamic, "ID", "5")));
  const Scenario s = io::load_scenario(file.path());
  REQUIRE(s.dynamic_obstacles[0].tags.size() == 2);
  CHECK(s.dynamic_obstacles[0].tags[1].id == 5);
  CHECK(s.dynamic_obstacles[0].tags[1].position_m.x() == 3.0);
}

TEST_CASE("bad input: machine tags sit on a rigid body of the machine, with unique ids, near it", "[unit]") {
  const auto tags = [](const std::string& entry) {
    return scenario_text() + "machine_tags:\n  - {id: 7, body: boom_tip, position_m: [0, 0, 0.5]}\n  - " + entry + "\n";
  };
  // Line 30 is `machine_tags:`, 31 the good tag, 32 the entry under test.
  expect_error(tags("{id: 8, body: jib, position_m: [0, 0, 0]}"), {32, "machine_tags[1].body", "a body or frame the joints pose rigidly"});
  expect_error(tags("{id: 8, body: hook, position_m: [0, 0, 0]}"), {32, "machine_tags[1].body", "the rope, hook, sling and load swing"});
  expect_error(tags("{id: 8, body: load, position_m: [0, 0, 0]}"), {32, "machine_tags[1].body", "got 'load'"});
  expect_error(tags("{id: 8, body: boom, position_m: [0, 0, 0]}"), {32, "machine_tags[1].body", "the boom telescopes"});
  expect_error(tags("{id: 7, body: carrier, position_m: [0, 0, 0]}"), {32, "machine_tags[1].id", "a tag id not used by another tag"});
  expect_error(tags("{id: 300, body: carrier, position_m: [0, 0, 0]}"), {32, "machine_tags[1].id", "an integer"});
  expect_error(tags("{id: 8, body: carrier, position_m: [0, 0, 1e9]}"), {32, "machine_tags[1].position_m[2]", "within the site extent"});
  expect_error(tags("{id: 8, body: carrier, position_m: [150, 0, 0]}"), {32, "machine_tags[1].position_m", "within 100 m of the body's origin"});
  expect_error(tags("{id: 8, body: carrier}"), {32, "machine_tags[1].position_m", "missing field"});
  // An obstacle's tag and a machine tag share one id space.
  const std::string dynamic =
      "dynamic_obstacles:\n"
      "  - name: truck\n"
      "    parts: [{type: box, size_m: [8, 2.5, 3], position_m: [0, 0, 1.5]}]\n"
      "    motion: [{t_s: 0, position_m: [0, -30, 0], yaw_deg: 0}]\n"
      "    tags: [{id: 7, position_m: [0, 0, 3]}]\n";
  expect_error(dynamic + tags("{id: 8, body: carrier, position_m: [0, 0, 0]}"),
               {36, "machine_tags[0].id", "a tag id not used by another tag (obstacle tags included)"});
  std::string nine = scenario_text() + "machine_tags:\n";
  for (int i = 0; i < 9; ++i) nine += "  - {id: " + std::to_string(i) + ", body: carrier, position_m: [0, 0, 0]}\n";
  expect_error(nine, {39, "machine_tags[8]", "at most 8 machine tags"});

  TempFile file("scenario.yaml", tags("{id: 9, body: superstructure, position_m: [1, -2, 3]}"));
  const Scenario s = io::load_scenario(file.path());
  REQUIRE(s.machine_tags.size() == 2);
  CHECK(s.machine_tags[0].id == 7);
  CHECK(s.machine_tags[0].body == "boom_tip");
  CHECK(s.machine_tags[0].position_m.z() == 0.5);
  CHECK(s.machine_tags[1].body == "superstructure");
  CHECK(s.machine_tags[1].position_m == Eigen::Vector3d(1, -2, 3));
  CHECK(s.machine_tags[1].ref.line == 32);
}

TEST_CASE("bad input: the simulation section is checked field by field", "[unit]") {
  expect_error(scenario_text() + "simulation:\n  uwb_rate_hz: 0\n", {31, "simulation.uwb_rate_hz", "a number in"});
  expect_error(scenario_text() + "simulation:\n  uwb_noise_m: 0.2\n", {31, "simulation.uwb_noise_m", "unknown field"});
  expect_error(scenario_text() + "simulation:\n  faults: [{kind: bus-off}]\n", {31, "simulation.faults[0]", "expected text"});
  TempFile file("scenario.yaml", scenario_text() + "simulation:\n  uwb_latency_ms: 80\n  faults: [bus-off@2+1]\n");
  const Scenario s = io::load_scenario(file.path());
  REQUIRE(s.simulation.uwb_latency_ms);
  CHECK(*s.simulation.uwb_latency_ms == 80.0);
  CHECK_FALSE(s.simulation.uwb_rate_hz);
  REQUIRE(s.simulation.faults.size() == 1);
  CHECK(s.simulation.faults[0].first == "bus-off@2+1");
  CHECK(s.simulation.faults[0].second.line == 32);
}

TEST_CASE("bad input: working envelope", "[unit]") {
  const auto with = [](const std::string& envelope) { return scenario_text() + "envelope:\n" + envelope; };
  {
    TempFile file("scenario.yaml", with("  points: [boom_tip, hook]\n  height_ceiling_m: 40\n  slew_left_deg: 120\n"
                                        "  slew_right_deg: -120\n  walls:\n    - {normal: [2, 0, 0], offset_m: -8}\n"));
    const Scenario s = io::load_scenario(file.path());
    REQUIRE(s.envelope.has_value());
    CHECK(s.envelope->points == std::vector<std::string>{"boom_tip", "hook"});
    CHECK(s.envelope->points_ref.line == 31);
    CHECK(*s.envelope->height_ceiling_m == 40.0);
    CHECK(*s.envelope->slew_left_rad == Approx(120.0 * M_PI / 180.0));
    CHECK(*s.envelope->slew_right_rad == Approx(-120.0 * M_PI / 180.0));
    REQUIRE(s.envelope->walls.size() == 1);
    CHECK(s.envelope->walls[0].normal.isApprox(Eigen::Vector3d::UnitX()));  // normalised
    CHECK(!s.envelope->radius_min_m.has_value());
    CHECK(!s.envelope->slowdown_band_m.has_value());
  }
  expect_error(with("  points: [hook]\n"), {30, "envelope", "an envelope needs at least one limit"});
  expect_error(with("  points: [hook]\n  slew_left_deg: 90\n"), {32, "envelope.slew_left_deg", "slew limits come in pairs"});
  expect_error(with("  points: [hook, hook]\n  height_ceiling_m: 30\n"), {31, "envelope.points[1]", "a key point not already listed"});
  expect_error(with("  points: []\n  height_ceiling_m: 30\n"), {31, "envelope.points", "expected a non-empty list"});
  expect_error(with("  points: [hook]\n  height_ceiling_m: 10\n  depth_floor_m: 12\n"),
               {33, "envelope.depth_floor_m", "a floor below height_ceiling_m"});
  expect_error(with("  points: [hook]\n  walls:\n    - {normal: [0, 0, 0], offset_m: 1}\n"),
               {33, "envelope.walls[0].normal", "a non-zero normal"});
  expect_error(with("  points: [hook]\n  radius_min_m: 10\n  radius_max_m: 5\n"), {33, "envelope.radius_max_m", "a radius above radius_min_m"});
  expect_error(with("  points: [hook]\n  slew_left_deg: 30\n  slew_right_deg: 30\n"), {32, "envelope.slew_left_deg", "an angle other than"});
  expect_error(with("  points: [hook]\n  ceiling_m: 30\n"), {32, "envelope.ceiling_m", "unknown field"});
  expect_error(with("  points: [hook]\n  height_ceiling_m: 30\n  slowdown_band_m: 0\n"), {33, "envelope.slowdown_band_m", "positive"});
}

TEST_CASE("bad input: guidance margins", "[unit]") {
  const auto with = [](const std::string& guidance) { return scenario_text() + "guidance:\n" + guidance; };
  {
    TempFile file("scenario.yaml", with("  stop_margin_m: 0.1\n  planning_margin_m: 0.35\n"));
    const Scenario s = io::load_scenario(file.path());
    REQUIRE(s.guidance.has_value());
    CHECK(*s.guidance->stop_margin_m == 0.1);
    CHECK(*s.guidance->planning_margin_m == 0.35);
    CHECK_FALSE(s.guidance->warning_margin_m.has_value());
    CHECK_FALSE(s.guidance->escape_margin_m.has_value());
    CHECK(s.guidance->ref.line == 30);
    CHECK(s.guidance->ref.field == "guidance");
  }
  expect_error(with("  stop_margin_m: 0\n"), {31, "guidance.stop_margin_m", "expected a number in [0.01, 10]"});
  expect_error(with("  stop_margin_m: far\n"), {31, "guidance.stop_margin_m", "expected a number"});
  expect_error(with("  stop_margin: 0.2\n"), {31, "guidance.stop_margin", "unknown field"});
}
