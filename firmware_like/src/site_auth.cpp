// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/site_auth.hpp"

#include <mgc/machine_state_t.hpp>

#include <sodium.h>

#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace mgc::firmware {
namespace {

static_assert(sizeof(site_state_t::mac) == kCommandMacBytes);
static_assert(sizeof(site_plan_t::mac) == kCommandMacBytes);
static_assert(std::extent_v<decltype(site_state_t::joint_position)> == site_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(site_state_t::stop_travel)> == site_state_t::MAX_JOINTS);
static_assert(std::extent_v<decltype(site_plan_t::waypoint_time_s)> == site_plan_t::MAX_WAYPOINTS);
static_assert(std::extent_v<decltype(site_plan_t::positions), 1> == site_plan_t::MAX_JOINTS);
static_assert(site_state_t::MAX_JOINTS == kMaxJoints);
static_assert(static_cast<std::size_t>(SiteReason::OutOfRange) + 1 == kNumSiteReasons);

// Both types are fixed size: site_state_t encodes to a few hundred bytes, site_plan_t to under 5 KB.
constexpr std::size_t kSiteEncodedMaxBytes = 8192;

template <class Msg>
std::size_t canonical(const Msg& msg, std::array<std::uint8_t, kSiteEncodedMaxBytes>& buf) noexcept {
  return encoded_without_mac(msg, buf);
}

template <class Msg>
bool decode_exact(std::span<const std::uint8_t> bytes, Msg& msg) noexcept {
  msg = Msg{};
  const int size = static_cast<int>(bytes.size());
  // decode() returns the bytes it used, the type's one encoded size: trailing bytes would be
  // unauthenticated, so a message with any is refused too.
  if (bytes.size() > kSiteEncodedMaxBytes || msg.decode(bytes.data(), 0, size) != size) {
    msg = Msg{};
    return false;
  }
  return true;
}

}  // namespace

SiteKey load_site_key(const std::string& path) { return load_key_file(path, "site key file"); }

const char* site_reason_name(SiteReason reason) noexcept {
  switch (reason) {
    case SiteReason::Accepted: return "accepted";
    case SiteReason::Undecodable: return "undecodable";
    case SiteReason::BadMac: return "bad MAC";
    case SiteReason::UnknownMachine: return "unknown machine";
    case SiteReason::OwnMachine: return "own machine id";
    case SiteReason::WrongPriority: return "wrong priority";
    case SiteReason::TimeAhead: return "sender time ahead of the clock";
    case SiteReason::TimeBehind: return "sender time behind the clock";
    case SiteReason::StaleSequence: return "stale sequence";
    case SiteReason::NotFinite: return "not finite";
    case SiteReason::JointCount: return "wrong joint count";
    case SiteReason::OutOfRange: return "out of range";
    case SiteReason::WaypointTimes: return "waypoint times not increasing";
    case SiteReason::BadField: return "bad field";
  }
  return "unknown";
}

void sign_site_state(site_state_t& msg, const SiteKey& key) noexcept {
  std::array<std::uint8_t, kSiteEncodedMaxBytes> buf{};
  compute_mac(std::span(buf.data(), canonical(msg, buf)), key, msg.mac);
}

void sign_site_plan(site_plan_t& msg, const SiteKey& key) noexcept {
  std::array<std::uint8_t, kSiteEncodedMaxBytes> buf{};
  compute_mac(std::span(buf.data(), canonical(msg, buf)), key, msg.mac);
}

SiteVerifier::SiteVerifier(const SiteKey& key, const SiteRoster& roster, std::int32_t my_id, std::int64_t max_skew_us,
                           const SiteTolerances& tolerances)
    : key_(key), roster_(roster), my_id_(my_id), max_skew_us_(max_skew_us), tolerances_(tolerances) {
  if (max_skew_us <= 0) throw std::invalid_argument("SiteVerifier: the tolerated clock skew must be > 0 µs");
  if (roster.index_of(my_id) < 0) {
    throw std::invalid_argument("SiteVerifier: machine id " + std::to_string(my_id) + " is not in the site's roster");
  }
  // Idempotent and thread-safe; picks the fastest implementation once, before any check.
  if (sodium_init() < 0) throw std::runtime_error("libsodium: sodium_init failed");
}

SiteReason SiteVerifier::counted(SiteReason reason) noexcept {
  counts_[static_cast<std::size_t>(reason)].fetch_add(1, std::memory_order_relaxed);
  return reason;
}

std::uint64_t SiteVerifier::count(SiteReason reason) const noexcept {
  const auto i = static_cast<std::size_t>(reason);
  return i < counts_.size() ? counts_[i].load(std::memory_order_relaxed) : 0;
}

std::uint64_t SiteVerifier::refused() const noexcept {
  std::uint64_t total = 0;
  for (std::size_t i = 1; i < counts_.size(); ++i) total += counts_[i].load(std::memory_order_relaxed);
  return total;
}

std::int64_t SiteVerifier::last_state_sequence(std::int32_t machine_id) const noexcept {
  const int i = roster_.index_of(machine_id);
  return i < 0 ? 0 : last_state_sequence_[static_cast<std::size_t>(i)];
}

std::int64_t SiteVerifier::last_plan_sequence(std::int32_t machine_id) const noexcept {
  const int i = roster_.index_of(machine_id);
  return i < 0 ? 0 : last_plan_sequence_[static_cast<std::size_t>(i)];
}

bool SiteVerifier::in_range(const SiteRosterEntry& m, int joint, double value) const noexcept {
  const auto j = static_cast<std::size_t>(joint);
  if (m.continuous[j]) return true;
  const double tol = m.revolute[j] ? tolerances_.revolute_rad : tolerances_.prismatic_m;
  return value >= m.position_min[j] - tol && value <= m.position_max[j] + tol;
}

template <class Msg>
SiteReason SiteVerifier::authenticate(const Msg& msg, std::int64_t now_us, int& index) const noexcept {
  index = -1;
  std::array<std::uint8_t, kSiteEncodedMaxBytes> buf{};
  const std::size_t n = canonical(msg, buf);
  if (n == 0 || !mac_verifies(std::span(buf.data(), n), key_, msg.mac)) return SiteReason::BadMac;
  index = roster_.index_of(msg.machine_id);
  if (index < 0) return SiteReason::UnknownMachine;
  if (msg.machine_id == my_id_) return SiteReason::OwnMachine;
  // The bounds are computed from now_us, a realistic clock far from the int64 limits, so no
  // sender time can make them overflow.
  if (msg.sender_time_us > now_us + max_skew_us_) return SiteReason::TimeAhead;
  if (msg.sender_time_us < now_us - max_skew_us_) return SiteReason::TimeBehind;
  return SiteReason::Accepted;
}

SiteReason SiteVerifier::check_state(const site_state_t& msg, std::int64_t now_us) noexcept {
  int index = -1;
  if (const SiteReason r = authenticate(msg, now_us, index); r != SiteReason::Accepted) return counted(r);
  const auto i = static_cast<std::size_t>(index);
  const SiteRosterEntry& m = roster_.machines[i];
  if (msg.priority != m.priority) return counted(SiteReason::WrongPriority);
  if (msg.sequence <= last_state_sequence_[i]) return counted(SiteReason::StaleSequence);
  if (msg.num_joints != m.num_joints) return counted(SiteReason::JointCount);
  if (msg.supervisor_state <= machine_state_t::SUPERVISOR_UNKNOWN || msg.supervisor_state > machine_state_t::SUPERVISOR_ESTOP ||
      msg.time_to_rest_s < 0.0 || msg.plan_id < 0 || msg.plan_time_s < 0.0) {
    return counted(SiteReason::BadField);
  }
  bool finite = std::isfinite(msg.time_to_rest_s) && std::isfinite(msg.plan_time_s);
  for (int j = 0; j < msg.num_joints; ++j) {
    finite = finite && std::isfinite(msg.joint_position[j]) && std::isfinite(msg.joint_velocity[j]) &&
             std::isfinite(msg.stop_travel[j]);
  }
  if (!finite) return counted(SiteReason::NotFinite);
  for (int j = 0; j < msg.num_joints; ++j) {
    const auto k = static_cast<std::size_t>(j);
    if (!in_range(m, j, msg.joint_position[j]) || !in_range(m, j, msg.joint_position[j] + msg.stop_travel[j]) ||
        std::abs(msg.joint_velocity[j]) > tolerances_.velocity_factor * m.max_velocity[k]) {
      return counted(SiteReason::OutOfRange);
    }
  }
  last_state_sequence_[i] = msg.sequence;
  return counted(SiteReason::Accepted);
}

SiteReason SiteVerifier::check_plan(const site_plan_t& msg, std::int64_t now_us) noexcept {
  int index = -1;
  if (const SiteReason r = authenticate(msg, now_us, index); r != SiteReason::Accepted) return counted(r);
  const auto i = static_cast<std::size_t>(index);
  const SiteRosterEntry& m = roster_.machines[i];
  if (msg.sequence <= last_plan_sequence_[i]) return counted(SiteReason::StaleSequence);
  if (msg.num_joints != m.num_joints) return counted(SiteReason::JointCount);
  if (msg.plan_id <= 0 || msg.num_waypoints < 2 || msg.num_waypoints > site_plan_t::MAX_WAYPOINTS) {
    return counted(SiteReason::BadField);
  }
  bool finite = true;
  for (int w = 0; w < msg.num_waypoints; ++w) {
    finite = finite && std::isfinite(msg.waypoint_time_s[w]);
    for (int j = 0; j < msg.num_joints; ++j) finite = finite && std::isfinite(msg.positions[w][j]);
  }
  if (!finite) return counted(SiteReason::NotFinite);
  if (!(msg.waypoint_time_s[0] >= 0.0)) return counted(SiteReason::WaypointTimes);
  for (int w = 1; w < msg.num_waypoints; ++w) {
    if (!(msg.waypoint_time_s[w] > msg.waypoint_time_s[w - 1])) return counted(SiteReason::WaypointTimes);
  }
  for (int w = 0; w < msg.num_waypoints; ++w) {
    for (int j = 0; j < msg.num_joints; ++j) {
      if (!in_range(m, j, msg.positions[w][j])) return counted(SiteReason::OutOfRange);
    }
  }
  last_plan_sequence_[i] = msg.sequence;
  return counted(SiteReason::Accepted);
}

SiteReason SiteVerifier::check_state_bytes(std::span<const std::uint8_t> bytes, site_state_t& msg, std::int64_t now_us) noexcept {
  if (!decode_exact(bytes, msg)) return counted(SiteReason::Undecodable);
  return check_state(msg, now_us);
}

SiteReason SiteVerifier::check_plan_bytes(std::span<const std::uint8_t> bytes, site_plan_t& msg, std::int64_t now_us) noexcept {
  if (!decode_exact(bytes, msg)) return counted(SiteReason::Undecodable);
  return check_plan(msg, now_us);
}

}  // namespace mgc::firmware
