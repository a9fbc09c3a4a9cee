// SPDX-License-Identifier: Apache-2.0
// The site channel's types (docs/site.md): every field survives encode/decode, truncated input and
// the other site type are rejected, mac is the last field (the MAC covers everything before it),
// and the encoded sizes are the ones docs/site.md states.

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include <catch2/catch.hpp>

#include <array>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <vector>

namespace {

using Bytes = std::vector<std::uint8_t>;

static_assert(std::extent_v<decltype(mgc::site_state_t::joint_position)> == mgc::site_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::site_state_t::joint_velocity)> == mgc::site_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::site_state_t::stop_travel)> == mgc::site_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::site_state_t::mac)> == mgc::site_state_t::MAC_BYTES);
static_assert(std::extent_v<decltype(mgc::site_plan_t::waypoint_time_s)> == mgc::site_plan_t::MAX_WAYPOINTS);
static_assert(std::extent_v<decltype(mgc::site_plan_t::positions), 0> == mgc::site_plan_t::MAX_WAYPOINTS);
static_assert(std::extent_v<decltype(mgc::site_plan_t::positions), 1> == mgc::site_plan_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(mgc::site_plan_t::mac)> == mgc::site_plan_t::MAC_BYTES);

template <class Msg>
Bytes encode(const Msg& msg) {
  Bytes buf(static_cast<std::size_t>(msg.getEncodedSize()));
  REQUIRE(msg.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  return buf;
}

template <class Msg>
void require_truncations_rejected(const Bytes& buf) {
  for (int len = 0; len < static_cast<int>(buf.size()); ++len) {
    Msg out{};
    REQUIRE(out.decode(buf.data(), 0, len) < 0);
  }
}

// The last 32 bytes of the encoding are mac: changing mac changes them and nothing before them.
template <class Msg>
void require_mac_last(Msg msg) {
  const Bytes before = encode(msg);
  for (std::uint8_t& b : msg.mac) b = static_cast<std::uint8_t>(b ^ 0xFFu);
  const Bytes after = encode(msg);
  REQUIRE(before.size() == after.size());
  const std::size_t body = before.size() - sizeof(msg.mac);
  CHECK(std::equal(before.begin(), before.begin() + static_cast<std::ptrdiff_t>(body), after.begin()));
  for (std::size_t i = body; i < before.size(); ++i) CHECK(before[i] != after[i]);
}

mgc::site_state_t make_state() {
  mgc::site_state_t s{};
  s.utime = 0x0123456789ABCDEFLL;
  s.machine_id = 7;
  s.priority = 2;
  s.supervisor_state = 4;
  s.num_joints = 4;
  for (int j = 0; j < 8; ++j) {
    s.joint_position[j] = 0.25 * j - 1.0;
    s.joint_velocity[j] = -0.01 * j;
    s.stop_travel[j] = 0.002 * j;
  }
  s.time_to_rest_s = 1.75;
  s.plan_id = 12;
  s.plan_time_s = 33.5;
  s.sequence = 1'765'000'000'000'001;
  s.sender_time_us = 1'765'000'000'123'456;
  for (int i = 0; i < 32; ++i) s.mac[i] = static_cast<std::uint8_t>(3 * i + 1);
  return s;
}

mgc::site_plan_t make_plan() {
  mgc::site_plan_t p{};
  p.utime = 42;
  p.machine_id = 7;
  p.plan_id = 12;
  p.num_joints = 3;
  p.num_waypoints = 64;
  for (int w = 0; w < 64; ++w) {
    p.waypoint_time_s[w] = 0.5 * w;
    for (int j = 0; j < 8; ++j) p.positions[w][j] = 0.001 * w + j;
  }
  p.ends_at_goal = true;
  p.sequence = 99;
  p.sender_time_us = 1'765'000'000'000'000;
  for (int i = 0; i < 32; ++i) p.mac[i] = static_cast<std::uint8_t>(255 - i);
  return p;
}

}  // namespace

TEST_CASE("site_state_t round-trips every field at its fixed size", "[unit]") {
  const mgc::site_state_t s = make_state();
  const Bytes buf = encode(s);
  CHECK(buf.size() == 286);  // docs/site.md
  mgc::site_state_t out{};
  REQUIRE(out.decode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  CHECK(out.utime == s.utime);
  CHECK(out.machine_id == 7);
  CHECK(out.priority == 2);
  CHECK(out.supervisor_state == 4);
  CHECK(out.num_joints == 4);
  CHECK(std::to_array(out.joint_position) == std::to_array(s.joint_position));
  CHECK(std::to_array(out.joint_velocity) == std::to_array(s.joint_velocity));
  CHECK(std::to_array(out.stop_travel) == std::to_array(s.stop_travel));
  CHECK(out.time_to_rest_s == 1.75);
  CHECK(out.plan_id == 12);
  CHECK(out.plan_time_s == 33.5);
  CHECK(out.sequence == s.sequence);
  CHECK(out.sender_time_us == s.sender_time_us);
  CHECK(std::to_array(out.mac) == std::to_array(s.mac));
  require_truncations_rejected<mgc::site_state_t>(buf);
  require_mac_last(s);
}

TEST_CASE("site_plan_t round-trips every field at its fixed size", "[unit]") {
  const mgc::site_plan_t p = make_plan();
  const Bytes buf = encode(p);
  CHECK(buf.size() == 4683);  // docs/site.md
  auto out = std::make_unique<mgc::site_plan_t>();
  REQUIRE(out->decode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  CHECK(out->machine_id == 7);
  CHECK(out->plan_id == 12);
  CHECK(out->num_joints == 3);
  CHECK(out->num_waypoints == 64);
  CHECK(std::to_array(out->waypoint_time_s) == std::to_array(p.waypoint_time_s));
  for (int w = 0; w < 64; ++w) {
    for (int j = 0; j < 8; ++j) REQUIRE(out->positions[w][j] == p.positions[w][j]);
  }
  CHECK(out->ends_at_goal);
  CHECK(out->sequence == 99);
  CHECK(out->sender_time_us == p.sender_time_us);
  CHECK(std::to_array(out->mac) == std::to_array(p.mac));
  require_truncations_rejected<mgc::site_plan_t>(buf);
  require_mac_last(p);
}

TEST_CASE("a site state does not decode as a site plan, nor the other way", "[unit]") {
  CHECK(mgc::site_state_t::getHash() != mgc::site_plan_t::getHash());
  const Bytes state = encode(make_state());
  const Bytes plan = encode(make_plan());
  auto as_plan = std::make_unique<mgc::site_plan_t>();
  CHECK(as_plan->decode(state.data(), 0, static_cast<int>(state.size())) < 0);
  mgc::site_state_t as_state{};
  CHECK(as_state.decode(plan.data(), 0, static_cast<int>(plan.size())) < 0);
}
