// SPDX-License-Identifier: Apache-2.0
// The site file (docs/scenario-format.md, "Site file"): the shipped example reads into the machines,
// buses and lifts it writes, and every site-level refusal is one line naming the file, the line and
// the field.
#include <catch2/catch.hpp>

#include <string>

#include "mgc/planning/io/site_loader.hpp"
#include "mgc/planning/site.hpp"
#include "test_support.hpp"

using namespace mgc::planning;
using mgc::test::replace_first;
using mgc::test::TempFile;

namespace {

const std::filesystem::path kSite = mgc::test::source_path("scenarios/sites/thesis-steel-frame.yaml");

// The shipped site, its machine files named by absolute path so that a copy in the temp folder reads.
std::string site_text() {
  std::ifstream in(kSite);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string machines = mgc::test::source_path("scenarios/machines/").string();
  for (std::size_t pos = text.find("../machines/"); pos != std::string::npos; pos = text.find("../machines/", pos + machines.size())) {
    text.replace(pos, 12, machines);
  }
  return text;
}

// The one-line message loading text gives; fails the test when it loads.
std::string load_error(const std::string& text) {
  TempFile file("site.yaml", text);
  try {
    (void)io::load_site(file.path());
  } catch (const io::InputError& e) {
    const std::string what = e.what();
    CHECK(what.find('\n') == std::string::npos);
    CHECK(what.rfind(file.path().string() + ":", 0) == 0);  // starts with the file
    return what.substr(file.path().string().size());
  }
  FAIL("the site loaded");
  return {};
}

}  // namespace

TEST_CASE("the shipped site reads into its two machines, buses and crossing lifts", "[unit]") {
  const Site site = io::load_site(kSite);
  CHECK(site.name == "thesis-steel-frame-site");
  REQUIRE(site.key_file.has_value());
  CHECK(std::filesystem::path(*site.key_file) == kSite.parent_path() / "site.key");
  CHECK(site.obstacles.size() == 535);
  CHECK(site.planner.max_iterations == 1000);
  REQUIRE(site.machines.size() == 2);

  const SiteMachine& tms = site.machines[0];
  CHECK(tms.id == 1);
  CHECK(tms.priority == 2);
  CHECK(tms.machine.kind == MachineKind::MobileCrane);
  CHECK(tms.world_from_base.translation().isZero());
  CHECK(tms.bus.controller_url() == "udp:127.0.0.1:47011,peer=127.0.0.1:47010");
  CHECK(tms.bus.machine_url() == "udp:127.0.0.1:47010,peer=127.0.0.1:47011");
  CHECK(tms.uwb_tags.empty());
  REQUIRE(tms.lifts.size() == 1);
  REQUIRE(tms.lifts[0].task.has_value());
  CHECK(tms.lifts[0].task->load_lb == 20000.0);
  CHECK(tms.lifts[0].start[0] == Approx(80.0 * mgc::test::kDeg));
  CHECK(tms.lifts[0].goal[0] == Approx(-80.0 * mgc::test::kDeg));

  const SiteMachine& tower = site.machines[1];
  CHECK(tower.id == 2);
  CHECK(tower.priority == 1);
  CHECK(tower.machine.kind == MachineKind::TowerCrane);
  CHECK(tower.world_from_base.translation().isApprox(Eigen::Vector3d(-40, -10, 0)));
  REQUIRE(tower.uwb_tags.size() == 4);
  CHECK(tower.uwb_tags[0].id == 1);
  CHECK(tower.uwb_tags[0].body == "jib");
  CHECK(tower.uwb_tags[0].position_m.isApprox(Eigen::Vector3d(0, 0, 29.85)));
  CHECK(tower.uwb_tags[1].body == "trolley");
  CHECK(tower.uwb_tags[2].body == "counter_jib");
  CHECK(tower.uwb_tags[3].id == 4);
  CHECK(tower.uwb_tags[3].body == "hook");
  REQUIRE(tower.lifts.size() == 1);
  CHECK(tower.lifts[0].goal[1] == 45.0);

  CHECK(io::site_machine_index(site, 2) == 1);
  const Scenario lift = lift_scenario(site, 0, 0);
  CHECK(lift.name == "thesis-steel-frame-site/1/steel-bundle-north-to-south");
  CHECK(lift.obstacles.size() == 535);
  CHECK(lift.start == tms.lifts[0].start);
  CHECK(lift.task->load_lb == 20000.0);
  const auto model = build_model(lift);
  // At least the boom tip's speed at full swing rate and full boom length, far below a vehicle's.
  const double swing_rad_s = tms.machine.joints[0].max_velocity;
  CHECK(max_point_speed_m_s(*model) > swing_rad_s * tms.machine.joints[2].position_max);
  CHECK(max_point_speed_m_s(*model) < 50.0);
}

TEST_CASE("an id the site does not list is refused naming the machines line and the ids it has", "[unit]") {
  const Site site = io::load_site(kSite);
  try {
    (void)io::site_machine_index(site, 7);
    FAIL("id 7 was found");
  } catch (const io::InputError& e) {
    CHECK(std::string(e.what()) == kSite.string() + ":37: machines: no machine with id 7; expected one of 1, 2");
  }
}

TEST_CASE("base footprints: apart, touching and turned into each other", "[unit]") {
  const Site site = io::load_site(kSite);
  const MachineDefinition& tms = site.machines[0].machine;  // carrier 13 x 2.6 m or so
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
  const double width = tms.mobile_crane.carrier_size_m.y();
  b.translate(Eigen::Vector3d(0, width + 0.01, 0));
  CHECK_FALSE(footprints_overlap(base_footprint(tms, a), base_footprint(tms, b)));
  b = Eigen::Isometry3d::Identity();
  b.translate(Eigen::Vector3d(0, width, 0));
  CHECK(footprints_overlap(base_footprint(tms, a), base_footprint(tms, b)));  // touching counts
  // Beside each other and apart, until one turns 90 deg about its own centre and reaches across.
  b = Eigen::Isometry3d::Identity();
  b.translate(Eigen::Vector3d(tms.mobile_crane.carrier_centre_m.x(), 2.0 * width, 0));
  CHECK_FALSE(footprints_overlap(base_footprint(tms, a), base_footprint(tms, b)));
  b.rotate(Eigen::AngleAxisd(0.5 * std::numbers::pi, Eigen::Vector3d::UnitZ()));
  b.translate(Eigen::Vector3d(-tms.mobile_crane.carrier_centre_m.x(), 0, 0));
  CHECK(footprints_overlap(base_footprint(tms, a), base_footprint(tms, b)));
  // Two 1.8 m masts, one turned 45 deg and standing off the other's corner: apart along the
  // turned one's diagonal only, though the first one's own axes see their extents overlap.
  const MachineDefinition& tower = site.machines[1].machine;
  REQUIRE(tower.tower_crane.mast_width_m == 1.8);
  Eigen::Isometry3d c = Eigen::Isometry3d::Identity();
  c.translate(Eigen::Vector3d(1.9, 1.9, 0));
  c.rotate(Eigen::AngleAxisd(0.25 * std::numbers::pi, Eigen::Vector3d::UnitZ()));
  CHECK_FALSE(footprints_overlap(base_footprint(tower, a), base_footprint(tower, c)));
  CHECK_FALSE(footprints_overlap(base_footprint(tower, c), base_footprint(tower, a)));
  c = Eigen::Isometry3d::Identity();
  c.translate(Eigen::Vector3d(1.4, 1.4, 0));
  c.rotate(Eigen::AngleAxisd(0.25 * std::numbers::pi, Eigen::Vector3d::UnitZ()));
  CHECK(footprints_overlap(base_footprint(tower, a), base_footprint(tower, c)));
}

TEST_CASE("site refusals: one line naming the file, the line and the field", "[unit]") {
  const std::string good = site_text();
  {
    TempFile file("site-good.yaml", good);
    CHECK(io::load_site(file.path()).machines.size() == 2);
  }
  SECTION("two bases that overlap") {
    CHECK(load_error(replace_first(good, "position_m: [-40, -10, 0]", "position_m: [3, 1, 0]")) ==
          ":68: machines[1].base: machine 2's base footprint overlaps machine 1's (machines[0].base, line 40); "
          "expected carriers, masts and undercarriages that stand apart");
  }
  SECTION("a duplicate id") {
    CHECK(load_error(replace_first(good, "  - id: 2", "  - id: 1")) ==
          ":66: machines[1].id: expected an id no other machine has (machines[0].id, line 38), got '1'");
  }
  SECTION("a duplicate priority") {
    CHECK(load_error(replace_first(good, "priority: 1", "priority: 2")) ==
          ":71: machines[1].priority: expected a priority no other machine has (machines[0].priority, line 43), got '2'");
  }
  SECTION("an unknown machine file") {
    const std::string text = replace_first(good, "pecco-sk180.yaml", "no-such-crane.yaml");
    const std::string error = load_error(text);
    CHECK(error.rfind(":67: machines[1].machine: expected a machine file relative to the site's folder (", 0) == 0);
    CHECK(error.find("no-such-crane.yaml does not exist)") != std::string::npos);
  }
  SECTION("a bus port another machine uses") {
    CHECK(load_error(replace_first(good, "udp_ports: [47020, 47021]", "udp_ports: [47020, 47011]")) ==
          ":73: machines[1].bus.udp_ports[1]: expected a port no other machine uses (machines[0].bus.udp_ports, line 45), got '47011'");
  }
  SECTION("SocketCAN buses: the URL, a duplicate interface, a name the kernel would refuse") {
    std::string text = replace_first(good, "udp_ports: [47010, 47011]   # [mgc-sim's end, mgc's end]: the binaries' defaults", "socketcan: vcan1");
    {
      TempFile file("site-vcan.yaml", text);
      const Site site = io::load_site(file.path());
      CHECK(site.machines[0].bus.kind == SiteBus::Kind::SocketCan);
      CHECK(site.machines[0].bus.controller_url() == "socketcan:vcan1");
      CHECK(site.machines[0].bus.machine_url() == "socketcan:vcan1");
    }
    CHECK(load_error(replace_first(text, "udp_ports: [47020, 47021]", "socketcan: vcan1")) ==
          ":73: machines[1].bus.socketcan: expected an interface no other machine uses (machines[0].bus.socketcan, line 45), got 'vcan1'");
    CHECK(load_error(replace_first(text, "socketcan: vcan1", "socketcan: 'vcan 1'")) ==
          ":45: machines[0].bus.socketcan: expected an interface name of letters, digits, '_', '-' and '.', got 'vcan 1'");
    CHECK(load_error(replace_first(text, "socketcan: vcan1", "socketcan: vcan456789abcdef")) ==
          ":45: machines[0].bus.socketcan: expected an interface name of at most 15 characters, got 'vcan456789abcdef'");
  }
  SECTION("a UWB tag id another machine has, a tag on a swinging body, a tag far from its mount") {
    const std::string text = replace_first(good, "    priority: 2\n", "    priority: 2\n    uwb_tags: [{id: 3, body: carrier, position_m: [0, 0, 0]}]\n");
    CHECK(load_error(text) ==
          ":78: machines[1].uwb_tags[2].id: expected a tag id no other tag has (machines[0].uwb_tags[0].id, line 44), got '3'");
    CHECK(load_error(replace_first(good, "body: hook", "body: load")) ==
          ":78: machines[1].uwb_tags[3].body: expected a body or frame the joints pose: one of mast, jib, counter_jib, slew, trolley, "
          "hook, got 'load'");
    CHECK(load_error(replace_first(good, "[0, 0, 29.85]", "[0, 0, 129.85]")) ==
          ":75: machines[1].uwb_tags[0].position_m: expected a position within 100 m of the body's origin, got a list of 3");
  }
  SECTION("a start outside the machine's joint range") {
    const std::string error = load_error(replace_first(good, "trolley_radius_m: 30", "trolley_radius_m: 70"));
    CHECK(error.rfind(":86: machines[1].lifts[0].start.trolley_radius_m: expected a value within the joint range [3, 59.7] m", 0) == 0);
  }
  SECTION("a lift without a task on a crane") {
    const std::string text = replace_first(good, "        task:\n          load_size_m: [2.0, 2.0, 2.0]\n          sling_length_m: 2.0\n", "");
    CHECK(load_error(text) == ":80: machines[1].lifts[0].task: missing field");
  }
  SECTION("a later lift of another load than the machine's first") {
    const std::string second =
        "      - name: back-south\n"
        "        task:\n"
        "          load_size_m: [2.0, 2.0, SIZE]\n"
        "          sling_length_m: 2.0\n"
        "        start: {slew_deg: 40, trolley_radius_m: 45, hook_height_m: 4.5}\n"
        "        goal: {slew_deg: -30, trolley_radius_m: 30, hook_height_m: 4.5}\n";
    const auto with_second = [&](const std::string& size) {
      std::string lift = second;
      lift.replace(lift.find("SIZE"), 4, size);
      return good + (good.back() == '\n' ? "" : "\n") + lift;
    };
    {
      TempFile file("site-two-lifts.yaml", with_second("2.0"));
      const Site site = io::load_site(file.path());
      REQUIRE(site.machines[1].lifts.size() == 2);
      CHECK(site.machines[1].lifts[1].name == "back-south");
    }
    const std::string error = load_error(with_second("3.0"));
    CHECK(error.rfind(":93: machines[1].lifts[1].task: differs from the machine's first lift's task; every lift of a machine "
                      "is modelled with the first lift's load, rigging, rule, load size and sling",
                      0) == 0);
  }
  SECTION("more than 16 machines") {
    std::string text = good;
    std::string extra;
    for (int i = 3; i <= 17; ++i) {
      extra += "  - id: " + std::to_string(i) + "\n    machine: x\n";
    }
    text += extra;
    CHECK(load_error(text) == ":37: machines: expected at most 16 machines, got a list of 17");
  }
  SECTION("an unknown field") {
    CHECK(load_error(replace_first(good, "    priority: 1\n", "    priority: 1\n    colour: red\n")) ==
          ":72: machines[1].colour: unknown field (known fields here: base, bus, id, lifts, machine, priority, uwb_tags)");
  }
  SECTION("a name longer than the loader's limit") {
    const std::string error = load_error(replace_first(good, "name: thesis-steel-frame-site", "name: " + std::string(65, 'x')));
    CHECK(error.rfind(":14: name: expected a name of at most 64 characters", 0) == 0);
  }
}
