// SPDX-License-Identifier: Apache-2.0
// Operator words for concrete one-DoF-at-a-time plans on each machine kind.

#include <mgc/firmware/operator_words.hpp>

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <string>
#include <vector>

using mgc::kMaxJoints;
using mgc::firmware::joint_move_in_words;
using mgc::firmware::next_moves_in_words;
using mgc::planning::MachineKind;

namespace {

using Waypoint = std::array<double, kMaxJoints>;

constexpr double deg(double d) { return d * 3.14159265358979323846 / 180.0; }

std::string words(MachineKind kind, int nj, const std::vector<Waypoint>& plan, const Waypoint& current, int segment,
                  int max_moves = 2, std::size_t buffer = 96) {
  std::vector<char> out(buffer, 'x');
  const std::size_t n = next_moves_in_words(kind, nj, current, plan, segment, max_moves, out);
  REQUIRE(n < buffer);
  REQUIRE(out[n] == '\0');
  return std::string(out.data());
}

std::string one(MachineKind kind, int joint, double delta) {
  std::array<char, 64> out{};
  REQUIRE(joint_move_in_words(kind, joint, delta, out) > 0);
  return std::string(out.data());
}

}  // namespace

TEST_CASE("mobile crane: swing then boom, from the start of the plan", "[unit]") {
  // (swing, boom_elevation, boom_length, cable_length)
  const std::vector<Waypoint> plan = {
      {0.0, deg(40), 20.0, 10.0},
      {deg(32), deg(40), 20.0, 10.0},   // swing +32 deg = left
      {deg(32), deg(44), 20.0, 10.0},   // boom +4 deg = up
      {deg(32), deg(44), 22.5, 10.0},   // telescope out 2.5 m
  };
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0) == "swing left 32 deg, then boom up 4 deg");
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0, 3) ==
          "swing left 32 deg, then boom up 4 deg, then telescope out 2.5 m");
}

TEST_CASE("mobile crane: part of the active segment done, the rest is said", "[unit]") {
  const std::vector<Waypoint> plan = {
      {deg(10), deg(60), 30.0, 20.0},
      {deg(-20), deg(60), 30.0, 20.0},  // swing right 30 deg
      {deg(-20), deg(60), 30.0, 14.0},  // cable 6 m shorter = hoist up
      {deg(-20), deg(50), 30.0, 14.0},  // boom down
  };
  Waypoint current = plan[0];
  current[0] = deg(0);  // a third of the swing is done
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, current, 0) == "swing right 20 deg, then hoist up 6.0 m");
  // On segment 1, the next move after the hoist is the boom.
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[1], 1) == "hoist up 6.0 m, then boom down 10 deg");
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[3], 2).empty());
}

TEST_CASE("tower crane: slew, trolley, hook", "[unit]") {
  // (slew, trolley_radius, hook_height)
  const std::vector<Waypoint> plan = {
      {0.0, 30.0, 20.0},
      {0.0, 30.0, 35.0},       // hook up 15 m
      {deg(-90), 30.0, 35.0},  // slew right 90 deg
      {deg(-90), 12.0, 35.0},  // trolley in 18 m
  };
  REQUIRE(words(MachineKind::TowerCrane, 3, plan, plan[0], 0, 3) ==
          "hook up 15 m, then slew right 90 deg, then trolley in 18 m");
}

TEST_CASE("excavator: swing, arm and bucket words follow the angle convention", "[unit]") {
  // (swing, boom, arm, bucket); curling in is negative.
  const std::vector<Waypoint> plan = {
      {0.0, deg(10), deg(-90), deg(-60)},
      {0.0, deg(10), deg(-110), deg(-60)},  // arm in 20 deg
      {0.0, deg(10), deg(-110), deg(-100)}, // bucket curl 40 deg
      {deg(45), deg(10), deg(-110), deg(-100)},
      {deg(45), deg(10), deg(-110), deg(-30)},  // bucket dump
  };
  REQUIRE(words(MachineKind::Excavator, 4, plan, plan[0], 0, 4) ==
          "arm in 20 deg, then bucket curl 40 deg, then swing left 45 deg, then bucket dump 70 deg");
  REQUIRE(one(MachineKind::Excavator, 2, deg(15)) == "arm out 15 deg");
  REQUIRE(one(MachineKind::Excavator, 1, deg(-3)) == "boom down 3 deg");
}

TEST_CASE("small moves keep a decimal, a segment moving two joints says both", "[unit]") {
  REQUIRE(one(MachineKind::MobileCrane, 1, deg(0.6)) == "boom up 0.6 deg");
  REQUIRE(one(MachineKind::MobileCrane, 3, -0.05) == "hoist up 0.05 m");
  REQUIRE(one(MachineKind::TowerCrane, 1, 12.4) == "trolley out 12 m");
  const std::vector<Waypoint> plan = {
      {0.0, deg(40), 20.0, 10.0},
      {deg(-5), deg(42), 20.0, 10.0},
  };
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0) == "swing right 5 deg and boom up 2 deg");
}

TEST_CASE("waypoints where nothing moves are skipped, noise is not said", "[unit]") {
  const std::vector<Waypoint> plan = {
      {0.0, deg(40), 20.0, 10.0},
      {0.0, deg(40), 20.0, 10.0},
      {deg(0.1), deg(40), 20.005, 10.0},  // below the thresholds
      {deg(0.1), deg(50), 20.005, 10.0},
  };
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0) == "boom up 10 deg");
}

TEST_CASE("a buffer too small for every move is cut at a move boundary", "[unit]") {
  const std::vector<Waypoint> plan = {
      {0.0, deg(40), 20.0, 10.0},
      {deg(32), deg(40), 20.0, 10.0},
      {deg(32), deg(44), 20.0, 10.0},
  };
  // "swing left 32 deg" is 17 characters; ", then boom up 4 deg" does not fit in 30.
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0, 2, 30) == "swing left 32 deg, ...");
  REQUIRE(words(MachineKind::MobileCrane, 4, plan, plan[0], 0, 2, 8).empty());
}

TEST_CASE("bad input gives empty text", "[unit]") {
  const std::vector<Waypoint> plan = {{0.0, 0.0}, {1.0, 0.0}};
  REQUIRE(words(MachineKind::Excavator, 0, plan, plan[0], 0).empty());
  REQUIRE(words(MachineKind::Excavator, 9, plan, plan[0], 0).empty());
  REQUIRE(words(MachineKind::Excavator, 4, plan, plan[0], -1).empty());
  REQUIRE(words(MachineKind::Excavator, 4, plan, plan[0], 5).empty());
  Waypoint nan_current = plan[0];
  nan_current[0] = std::nan("");
  REQUIRE(words(MachineKind::Excavator, 4, plan, nan_current, 0).empty());
}
