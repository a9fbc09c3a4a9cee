// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/site_rules.hpp"

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

//! Authentication and checks of the site channel (docs/site.md): every site_state_t and
//! site_plan_t carries a MAC under the site key (libsodium crypto_auth, the operator commands'
//! scheme and key-file format), a per-machine sequence and the sender's clock; the receiver refuses
//! what does not verify, what is not fresh, what the site file does not know and what is malformed.
//! Nothing refused is handed on.
namespace mgc::firmware {

//! The site key: 32 raw bytes, the operator command key's format. Wiped when destroyed.
using SiteKey = CommandKey;

//! load_key_file(path, "site key file"). Start-up only.
[[nodiscard]] SiteKey load_site_key(const std::string& path);

//! Why a site message was refused (or Accepted). The checks run in this order and the first that
//! fails names the refusal (WaypointTimes applies to plans, WrongPriority to states).
enum class SiteReason : std::uint8_t {
  Accepted = 0,
  Undecodable,      //!< the bytes do not decode as the type, or have trailing bytes
  BadMac,           //!< the MAC does not verify under the site key
  UnknownMachine,   //!< machine_id is not in the site file
  OwnMachine,       //!< machine_id is the receiver's own (its own echo, or someone posing as it)
  WrongPriority,    //!< a state whose priority is not the one the site file gives its machine
  TimeAhead,        //!< sender_time_us more than the tolerated skew ahead of the receiver's clock
  TimeBehind,       //!< sender_time_us more than the tolerated skew behind it: a recording or a late message
  StaleSequence,    //!< sequence not above the last accepted one of that machine and type: a replay or reordering
  JointCount,       //!< num_joints is not the machine's joint count
  BadField,         //!< another field outside its documented values (supervisor state, a negative
                    //!< plan id or time, a negative time to rest; a plan id <= 0, 2..64 waypoints)
  NotFinite,        //!< a NaN or infinite number among the valid entries
  WaypointTimes,    //!< waypoint times not starting at >= 0 and strictly increasing
  OutOfRange,       //!< a position (or position + stop_travel) outside the joint range by more than the
                    //!< tolerance, or a speed above the joint's maximum by more than the tolerance
};
inline constexpr std::size_t kNumSiteReasons = 14;

//! Short English name of a reason, e.g. "bad MAC". Never null.
[[nodiscard]] const char* site_reason_name(SiteReason reason) noexcept;

//! Fills msg.mac under key (the sender's side; mgc's publisher, tests and tools). RT-safe.
void sign_site_state(site_state_t& msg, const SiteKey& key) noexcept;
void sign_site_plan(site_plan_t& msg, const SiteKey& key) noexcept;

//! How far a value may lie outside the machine's limits before it is refused: encoders and
//! estimates overshoot a little at a range end, and a plan may be smoothed past a corner.
struct SiteTolerances {
  double revolute_rad = 0.035;   //!< 2 deg beyond a revolute joint's range [rad]
  double prismatic_m = 0.1;      //!< beyond a prismatic joint's range [m]
  double velocity_factor = 1.5;  //!< |velocity| up to this times the joint's maximum [-]
};

//! Checks site messages from the other machines against the site key, the roster (the site file)
//! and the receiver's CLOCK_REALTIME (passed in), keeping one sequence counter per machine and
//! type. A message is accepted only when it decodes (the _bytes forms), its MAC verifies, its
//! machine is in the roster and is not mine, a state's priority is the roster's, its sender time is
//! within +-max_skew_us of now_us, its sequence is above the machine's last accepted one of its type,
//! and every field is well formed for that machine. Only an accepted message moves a counter.
//! Not thread-safe: one thread (the LCM I/O thread) checks; any thread may read the counts.
//! RT-safe after construction: no alloc, no lock, no throw.
class SiteVerifier {
 public:
  //! my_id must be in roster and max_skew_us > 0; throws std::invalid_argument otherwise. Start-up only.
  SiteVerifier(const SiteKey& key, const SiteRoster& roster, std::int32_t my_id,
               std::int64_t max_skew_us = kDefaultSiteSkew_us, const SiteTolerances& tolerances = {});

  [[nodiscard]] SiteReason check_state(const site_state_t& msg, std::int64_t now_us) noexcept;
  [[nodiscard]] SiteReason check_plan(const site_plan_t& msg, std::int64_t now_us) noexcept;
  //! Decodes bytes from the bus into msg, then check_*(); msg is value-initialised when they do not
  //! decode. msg holds the decoded message whatever the verdict: decode into scratch and hand it on
  //! (copy it where the loop reads) only when the verdict is Accepted.
  [[nodiscard]] SiteReason check_state_bytes(std::span<const std::uint8_t> bytes, site_state_t& msg, std::int64_t now_us) noexcept;
  [[nodiscard]] SiteReason check_plan_bytes(std::span<const std::uint8_t> bytes, site_plan_t& msg, std::int64_t now_us) noexcept;

  //! Messages that ended with reason (Accepted: the accepted ones). [-]
  [[nodiscard]] std::uint64_t count(SiteReason reason) const noexcept;
  //! Every refused message. [-]
  [[nodiscard]] std::uint64_t refused() const noexcept;
  //! The last accepted sequence of machine_id's states / plans; 0 when none (or not in the roster). [-]
  [[nodiscard]] std::int64_t last_state_sequence(std::int32_t machine_id) const noexcept;
  [[nodiscard]] std::int64_t last_plan_sequence(std::int32_t machine_id) const noexcept;
  [[nodiscard]] const SiteRoster& roster() const noexcept { return roster_; }

 private:
  SiteReason counted(SiteReason reason) noexcept;
  //! The checks both types share: the MAC first (nothing else about an unauthenticated message is
  //! worth looking at), then the machine and the sender's clock. Sets index to the machine's
  //! roster index.
  template <class Msg>
  [[nodiscard]] SiteReason authenticate(const Msg& msg, std::int64_t now_us, int& index) const noexcept;
  [[nodiscard]] bool in_range(const SiteRosterEntry& m, int joint, double position_rad_or_m) const noexcept;

  SiteKey key_;
  SiteRoster roster_;
  std::int32_t my_id_;
  std::int64_t max_skew_us_;
  SiteTolerances tolerances_;
  std::array<std::int64_t, kMaxSiteMachines> last_state_sequence_{};
  std::array<std::int64_t, kMaxSiteMachines> last_plan_sequence_{};
  std::array<std::atomic<std::uint64_t>, kNumSiteReasons> counts_{};
};

}  // namespace mgc::firmware
