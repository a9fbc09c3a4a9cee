// SPDX-License-Identifier: Apache-2.0
#pragma once

// The site of fuzz_site_messages: the receiver's clock, the site key and the roster, which
// mgc_fuzz_seeds signs and fills its seed messages for.
#include <mgc/firmware/site_auth.hpp>
#include <mgc/firmware/site_rules.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <numbers>

namespace mgc::fuzz::site {

//! The receiver's clock for every input; the seeds are sent at it. [µs]
inline constexpr std::int64_t kNowUs = 1'800'000'000'000'000;
inline constexpr std::int32_t kMe = 1;
inline constexpr std::int32_t kOther = 2;

inline firmware::SiteKey site_key() {
  std::array<std::uint8_t, firmware::kCommandKeyBytes> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(0x5a ^ i);
  return firmware::SiteKey(bytes);
}

//! A mobile crane (swing, boom elevation, boom length, cable) and a tower crane's three joints.
inline firmware::SiteRoster roster() {
  firmware::SiteRoster r;
  firmware::SiteRosterEntry crane;
  crane.machine_id = kMe;
  crane.priority = 1;
  crane.num_joints = 4;
  const double pi = std::numbers::pi;
  crane.position_min = {-pi, 0.0, 11.0, 0.5};
  crane.position_max = {pi, 1.4, 40.0, 60.0};
  crane.max_velocity = {0.1, 0.05, 0.4, 1.0};
  crane.revolute = {true, true, false, false};
  crane.continuous = {true, false, false, false};
  crane.max_point_speed_m_s = 6.0;
  firmware::SiteRosterEntry tower;
  tower.machine_id = kOther;
  tower.priority = 2;
  tower.num_joints = 3;
  tower.position_min = {-pi, 3.0, 0.5};
  tower.position_max = {pi, 45.0, 30.0};
  tower.max_velocity = {0.12, 1.0, 1.5};
  tower.revolute = {true, false, false};
  tower.continuous = {true, false, false};
  tower.has_uwb_tags = true;
  tower.max_point_speed_m_s = 6.0;
  r.machines[0] = crane;
  r.machines[1] = tower;
  r.count = 2;
  return r;
}

}  // namespace mgc::fuzz::site
