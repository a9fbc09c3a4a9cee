// SPDX-License-Identifier: Apache-2.0
#pragma once

// A two-machine roster and signed site messages for the site channel's tests: machine 1 (a mobile
// crane, priority 2) receives; machine 2 (a tower crane, priority 1) sends.

#include <mgc/firmware/site_auth.hpp>
#include <mgc/firmware/site_rules.hpp>
#include <mgc/machine_state_t.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <numbers>

namespace mgc::test {

//! The receiver's CLOCK_REALTIME in the tests: 2025-12. [µs]
inline constexpr std::int64_t kSiteT0_us = 1'765'000'000'000'000;

inline std::array<std::uint8_t, firmware::kCommandKeyBytes> site_key_bytes(std::uint8_t seed) {
  std::array<std::uint8_t, firmware::kCommandKeyBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(seed + 11 * i);
  return k;
}

inline firmware::SiteRoster two_machine_roster() {
  constexpr double pi = std::numbers::pi;
  firmware::SiteRoster r;
  firmware::SiteRosterEntry& crane = r.machines[0];
  crane.machine_id = 1;
  crane.priority = 2;
  crane.num_joints = 4;
  crane.position_min = {-pi, 0.0, 10.9728, 1.0};
  crane.position_max = {pi, 0.5 * pi, 33.528, 60.0};
  crane.max_velocity = {0.2, 0.05, 0.5, 1.0};
  crane.revolute = {true, true, false, false};
  crane.continuous = {true, false, false, false};
  crane.max_point_speed_m_s = 12.0;
  firmware::SiteRosterEntry& tower = r.machines[1];
  tower.machine_id = 2;
  tower.priority = 1;
  tower.num_joints = 3;
  tower.position_min = {-pi, 3.0, 0.0};
  tower.position_max = {pi, 59.7, 45.0};
  tower.max_velocity = {0.0838, 0.633, 1.083};
  tower.revolute = {true, false, false};
  tower.continuous = {true, false, false};
  tower.has_uwb_tags = true;
  tower.max_point_speed_m_s = 7.0;
  r.count = 2;
  return r;
}

//! A well-formed state of the tower crane (machine 2), unsigned.
inline site_state_t tower_state(std::int64_t sequence, std::int64_t sender_time_us = kSiteT0_us) {
  site_state_t s{};
  s.utime = 5'000'000;
  s.machine_id = 2;
  s.priority = 1;
  s.supervisor_state = machine_state_t::SUPERVISOR_EXECUTING;
  s.num_joints = 3;
  s.joint_position[0] = 0.3;
  s.joint_position[1] = 30.0;
  s.joint_position[2] = 4.5;
  s.joint_velocity[0] = 0.05;
  s.joint_velocity[1] = -0.2;
  s.stop_travel[0] = 0.01;
  s.stop_travel[1] = -0.05;
  s.time_to_rest_s = 1.2;
  s.plan_id = 3;
  s.plan_time_s = 12.5;
  s.sequence = sequence;
  s.sender_time_us = sender_time_us;
  return s;
}

//! A well-formed plan of the tower crane (machine 2) of num_waypoints waypoints, unsigned.
inline std::unique_ptr<site_plan_t> tower_plan(std::int64_t sequence, int num_waypoints = 4,
                                               std::int64_t sender_time_us = kSiteT0_us) {
  auto p = std::make_unique<site_plan_t>();
  *p = site_plan_t{};
  p->utime = 5'000'000;
  p->machine_id = 2;
  p->plan_id = 3;
  p->num_joints = 3;
  p->num_waypoints = static_cast<std::int8_t>(num_waypoints);
  for (int w = 0; w < num_waypoints; ++w) {
    p->waypoint_time_s[w] = 10.0 * w;
    p->positions[w][0] = -0.5 + 0.25 * w;
    p->positions[w][1] = 30.0 + 0.25 * w;
    p->positions[w][2] = 4.5;
  }
  p->ends_at_goal = true;
  p->sequence = sequence;
  p->sender_time_us = sender_time_us;
  return p;
}

}  // namespace mgc::test
