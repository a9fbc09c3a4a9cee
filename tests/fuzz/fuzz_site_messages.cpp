// SPDX-License-Identifier: Apache-2.0
// The site channel's checks (firmware_like site_auth.hpp: SiteVerifier) on what arrives from the
// network. The first byte picks the type (site_state_t or site_plan_t) and the mode; the rest is
// the message as it arrives.
// - As received: the bytes go to check_*_bytes unchanged; the fuzzer does not hold the site key,
//   so only a message whose MAC is the key's (a seed left intact) may be accepted.
// - Signed: a message that decodes is signed with the site key and encoded again first, so that
//   every check after the MAC is reached; it must not be refused as undecodable or for its MAC.
// Either way an accepted message carries the key's MAC, is well formed for its machine (in the
// roster and not the receiver, its joint count, every valid number finite and within its joint's
// range and speed, a plan's times increasing, sent within the clock skew), its sequence becomes
// the machine's last, and the same bytes again are refused as a replay. A refused one moves no
// counter.
#include <mgc/firmware/site_auth.hpp>
#include <mgc/firmware/site_rules.hpp>
#include <mgc/machine_state_t.hpp>

#include <cmath>
#include <cstddef>
#include <algorithm>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

#include "fuzz_support.hpp"
#include "site_fuzz.hpp"

using mgc::fuzz::require;
using namespace mgc::firmware;
using namespace mgc::fuzz::site;

namespace {

template <class Msg>
std::vector<std::uint8_t> encoded(const Msg& msg) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(msg.getEncodedSize()));
  const int n = msg.encode(out.data(), 0, static_cast<int>(out.size()));
  require(n > 0, "a decoded site message does not encode");
  out.resize(static_cast<std::size_t>(n));
  return out;
}

//! Within the joint's range by the verifier's tolerance (a continuous joint has none).
bool within(const SiteRosterEntry& m, int j, double value) {
  const auto k = static_cast<std::size_t>(j);
  if (m.continuous[k]) return std::isfinite(value);
  const SiteTolerances tol;
  const double slack = m.revolute[k] ? tol.revolute_rad : tol.prismatic_m;
  return value >= m.position_min[k] - slack && value <= m.position_max[k] + slack;
}

const SiteRosterEntry& entry_of(const SiteRoster& r, std::int32_t id) {
  const int i = r.index_of(id);
  require(i >= 0, "an accepted message names a machine outside the roster");
  return r.machines[static_cast<std::size_t>(i)];
}

void check_accepted_state(const mgc::site_state_t& msg, const SiteRoster& r) {
  require(msg.machine_id != kMe, "a state posing as the receiver was accepted");
  const SiteRosterEntry& m = entry_of(r, msg.machine_id);
  require(msg.priority == m.priority, "a state with the wrong priority was accepted");
  require(msg.num_joints == m.num_joints, "a state with the wrong joint count was accepted");
  require(msg.supervisor_state > mgc::machine_state_t::SUPERVISOR_UNKNOWN && msg.supervisor_state <= mgc::machine_state_t::SUPERVISOR_ESTOP,
          "a state with an unknown supervisor state was accepted");
  require(std::isfinite(msg.time_to_rest_s) && msg.time_to_rest_s >= 0.0, "a state with a bad time to rest was accepted");
  require(msg.plan_id >= 0 && std::isfinite(msg.plan_time_s) && msg.plan_time_s >= 0.0, "a state with a bad plan id or time was accepted");
  const SiteTolerances tol;
  for (int j = 0; j < m.num_joints; ++j) {
    require(within(m, j, msg.joint_position[j]), "a state with a joint outside its range was accepted");
    require(std::isfinite(msg.joint_velocity[j]) &&
                std::abs(msg.joint_velocity[j]) <= tol.velocity_factor * m.max_velocity[static_cast<std::size_t>(j)],
            "a state with a joint faster than its limit was accepted");
    require(std::isfinite(msg.stop_travel[j]) && within(m, j, msg.joint_position[j] + msg.stop_travel[j]),
            "a state whose stop ends outside the joint's range was accepted");
  }
}

void check_accepted_plan(const mgc::site_plan_t& msg, const SiteRoster& r) {
  require(msg.machine_id != kMe, "a plan posing as the receiver was accepted");
  const SiteRosterEntry& m = entry_of(r, msg.machine_id);
  require(msg.num_joints == m.num_joints, "a plan with the wrong joint count was accepted");
  require(msg.plan_id > 0, "a plan with id <= 0 was accepted");
  require(msg.num_waypoints >= 2 && msg.num_waypoints <= mgc::site_plan_t::MAX_WAYPOINTS, "a plan with a bad waypoint count was accepted");
  for (int w = 0; w < msg.num_waypoints; ++w) {
    require(std::isfinite(msg.waypoint_time_s[w]) && msg.waypoint_time_s[w] >= 0.0, "a plan with a bad waypoint time was accepted");
    if (w > 0) require(msg.waypoint_time_s[w] > msg.waypoint_time_s[w - 1], "a plan whose times do not increase was accepted");
    for (int j = 0; j < m.num_joints; ++j) {
      require(within(m, j, msg.positions[w][j]), "a plan with a waypoint outside a joint's range was accepted");
    }
  }
}

std::uint64_t accepted(const SiteVerifier& v) { return v.count(SiteReason::Accepted); }

//! Sent within the verifier's skew of the receiver's clock.
template <class Msg>
void check_fresh(const Msg& msg) {
  require(msg.sender_time_us >= kNowUs - kDefaultSiteSkew_us && msg.sender_time_us <= kNowUs + kDefaultSiteSkew_us,
          "a message sent outside the clock skew was accepted");
}

template <class Msg>
void run(bool sign, std::span<const std::uint8_t> bytes) {
  const SiteRoster r = roster();
  SiteVerifier verifier(site_key(), r, kMe);
  constexpr bool kState = std::is_same_v<Msg, mgc::site_state_t>;
  const auto check = [&](std::span<const std::uint8_t> b, Msg& msg) {
    if constexpr (kState) {
      return verifier.check_state_bytes(b, msg, kNowUs);
    } else {
      return verifier.check_plan_bytes(b, msg, kNowUs);
    }
  };
  const auto last = [&](std::int32_t id) { return kState ? verifier.last_state_sequence(id) : verifier.last_plan_sequence(id); };

  const auto signed_copy = [](Msg m) {
    if constexpr (kState) {
      sign_site_state(m, site_key());
    } else {
      sign_site_plan(m, site_key());
    }
    return m;
  };
  std::vector<std::uint8_t> wire(bytes.begin(), bytes.end());
  if (sign) {
    Msg decoded{};
    if (decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0) return;
    wire = encoded(signed_copy(decoded));
  }
  Msg msg{};
  const SiteReason reason = check(wire, msg);
  if (sign) {
    require(reason != SiteReason::Undecodable, "a signed message that encodes was refused as undecodable");
    require(reason != SiteReason::BadMac, "a message signed with the site key failed its MAC");
  }
  if (reason != SiteReason::Accepted) {
    require(accepted(verifier) == 0 && last(kOther) == 0, "a refused message moved a counter");
    return;
  }
  const Msg resigned = signed_copy(msg);
  require(std::equal(std::begin(msg.mac), std::end(msg.mac), std::begin(resigned.mac)), "a message without the site key's MAC was accepted");
  if constexpr (kState) {
    check_accepted_state(msg, r);
  } else {
    check_accepted_plan(msg, r);
  }
  check_fresh(msg);
  require(last(msg.machine_id) == msg.sequence, "an accepted message did not become its machine's last sequence");
  Msg again{};
  require(check(wire, again) == SiteReason::StaleSequence, "the same message again was not refused as a replay");
  require(accepted(verifier) == 1, "a replay was counted as accepted");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1 || size > 65536) return -1;
  const std::span<const std::uint8_t> message(data + 1, size - 1);
  switch (data[0] % 4) {
    case 0: run<mgc::site_state_t>(false, message); break;
    case 1: run<mgc::site_state_t>(true, message); break;
    case 2: run<mgc::site_plan_t>(false, message); break;
    default: run<mgc::site_plan_t>(true, message); break;
  }
  return 0;
}
