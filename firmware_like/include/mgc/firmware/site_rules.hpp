// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include "mgc/limits.hpp"
#include "mgc/planning/site.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

//! The site rules (docs/site.md): what one machine's controller makes of the other machines of the
//! coordinated site, from their latest verified site messages and the times it received them.
//! A pure function of its inputs: no I/O, no clock (time is passed in), no allocation.
namespace mgc::firmware {

//! Machines on one site, this one included. [-]
inline constexpr std::size_t kMaxSiteMachines = planning::kMaxSiteMachines;

//! Period at which each mgc publishes site_state_t (20 Hz). [µs]
inline constexpr std::int64_t kSiteStatePeriod_us = 50'000;
//! Period at which each mgc publishes its current site_plan_t again (1 Hz), besides at once on a change. [µs]
inline constexpr std::int64_t kSitePlanPeriod_us = 1'000'000;
//! The tolerated difference between a site message's sender_time_us and the receiver's
//! CLOCK_REALTIME, either way. [µs]
inline constexpr std::int64_t kDefaultSiteSkew_us = 100'000;

//! One machine of the site as the channel's checks and rules need it, built once from the site file.
struct SiteRosterEntry {
  std::int32_t machine_id = 0;  //!< [-]
  std::int32_t priority = 0;    //!< 1 is the highest [-]
  int num_joints = 0;           //!< [-]
  std::array<double, kMaxJoints> position_min{};  //!< [rad | m]
  std::array<double, kMaxJoints> position_max{};  //!< [rad | m]
  std::array<double, kMaxJoints> max_velocity{};  //!< [rad/s | m/s]
  std::array<bool, kMaxJoints> revolute{};
  std::array<bool, kMaxJoints> continuous{};
  bool has_uwb_tags = false;         //!< the site's RTLS sees it
  double max_point_speed_m_s = 0.0;  //!< planning::max_point_speed_m_s() of its model [m/s]
};

//! Every machine of the site; fixed capacity.
struct SiteRoster {
  std::array<SiteRosterEntry, kMaxSiteMachines> machines{};
  std::size_t count = 0;

  //! Index of machine id, or -1. RT-safe.
  [[nodiscard]] int index_of(std::int32_t machine_id) const noexcept;
};

//! The roster of a loaded site: joint ranges and speeds from each machine's file, the speed bound
//! from its model at its base. Start-up only (allocates; throws std::invalid_argument when a
//! machine's model cannot be built).
[[nodiscard]] SiteRoster make_site_roster(const planning::Site& site);

//! The rules' timing and look-ahead.
struct SiteRulesConfig {
  std::int64_t state_period_us = kSiteStatePeriod_us;  //!< [µs]
  std::int64_t max_skew_us = kDefaultSiteSkew_us;      //!< [µs]
  //! States that may go missing in a row before a machine is stale. [-]
  int stale_periods = 3;
  //! The short horizon H of the mutual-stop rule: the stop check's look-ahead. [s]
  double horizon_s = 0.5;

  //! A machine whose last verified state was received longer ago than this is stale:
  //! stale_periods x state_period_us + max_skew_us (250 ms by default). [µs]
  [[nodiscard]] std::int64_t stale_after_us() const noexcept {
    return static_cast<std::int64_t>(stale_periods) * state_period_us + max_skew_us;
  }
};

//! What the rules know of one other machine, in roster order: its latest verified messages (null
//! when none was ever verified), the receiver's time of receipt, and the caller's geometry.
struct SitePeerInput {
  const site_state_t* state = nullptr;
  std::int64_t state_received_us = 0;  //!< on the clock of now_us [µs]
  const site_plan_t* plan = nullptr;
  //! Time until this machine's stopping envelope and mine would meet if both go on as predicted,
  //! from the caller's sweep over its look-ahead; +inf when they do not meet within it. A NaN
  //! (no sweep gives one) counts as meeting now: the rules never guess that a machine is clear. [s]
  double meet_in_s = std::numeric_limits<double>::infinity();
  //! The caller posed this machine from the site's UWB tags on it this cycle: fresh fixes and a
  //! plausible fit (site_fit_tags()). Read only while it is stale. [-]
  bool tags_posed = false;
};

enum class SiteLink : std::uint8_t {
  Self,   //!< this machine's own roster entry
  Live,   //!< a verified state received within stale_after_us
  Stale,  //!< no verified state for longer, or never
};

//! How a live machine enters my planning and checks.
enum class SiteRole : std::uint8_t {
  None,           //!< not live (or myself)
  PlanAround,     //!< higher priority: an obstacle I plan around, its motion predicted
  CheckEnvelope,  //!< lower priority: I do not re-plan for it, but check its stopping envelope
};

//! What poses the other machine in my world.
enum class SitePrediction : std::uint8_t {
  None,              //!< myself
  Plan,              //!< live, with the verified plan its state names: the plan from its plan_time_s on
  StoppingEnvelope,  //!< live, no such plan: between its position and position + stop_travel, grown by grow_m
  UwbTags,           //!< stale, and the RTLS sees it: its pose fitted to its tags' fixes, carried at their velocity
  FrozenPose,        //!< stale, no tags: its last verified pose and stopping envelope, grown by grow_m
  WholeReach,        //!< stale, no tags, never heard: everything it can reach from its base
};

//! The speed command the mutual-stop rule asks for; ordered, the larger the stronger.
enum class SiteMotion : std::uint8_t { Proceed = 0, SlowDown = 1, Stop = 2 };

struct SitePeerDecision {
  std::int32_t machine_id = 0;
  SiteLink link = SiteLink::Stale;
  SiteRole role = SiteRole::None;
  SitePrediction prediction = SitePrediction::None;
  //! Time since its last verified state was received; -1 when never. [µs]
  std::int64_t age_us = -1;
  //! How far it may have moved beyond what its messages say: max_point_speed_m_s x (age_us +
  //! max_skew_us) for a StoppingEnvelope or FrozenPose prediction, else 0. [m]
  double grow_m = 0.0;
  SiteMotion motion = SiteMotion::Proceed;
};

struct SiteDecision {
  std::array<SitePeerDecision, kMaxSiteMachines> peers{};  //!< in roster order
  std::size_t count = 0;
  //! The strongest motion over every peer. [-]
  SiteMotion motion = SiteMotion::Proceed;
  //! The machine that asks for it (the first in roster order); 0 when motion is Proceed. [-]
  std::int32_t motion_for_id = 0;
  //! Whether my decision failed its inputs: my id not in the roster, or peers.size() != roster.count.
  //! The decision is then Stop. [-]
  bool invalid_input = false;
};

//! The site rules at now_us for machine my_id. peers[i] belongs to roster.machines[i] (my own entry
//! is ignored). Per other machine:
//!  - Live while now_us - state_received_us <= stale_after_us(), else Stale (never heard: Stale).
//!  - Live, smaller priority number: PlanAround; larger: CheckEnvelope.
//!  - Live: prediction Plan when its latest verified plan has the plan_id its state executes (not 0),
//!    else StoppingEnvelope. Stale: UwbTags if it has tags and the caller posed it from them
//!    (tags_posed), else FrozenPose if it was ever heard, else WholeReach.
//!  - Live, mutual stop: with lead L = horizon_s when I have the higher priority and 2 horizon_s
//!    when I have the lower, Stop when meet_in_s <= L, SlowDown when meet_in_s <= L + horizon_s.
//!    Both machines stop whatever their priority; the lower-priority one commands its stop one
//!    horizon earlier. A stale machine posed from its UWB tags is judged by the same rule with the
//!    lead of the lower priority, whatever the priorities (it may not hear me); any other stale
//!    machine is left to the stop check as the obstacle its prediction poses.
//! RT-safe: no alloc, no lock, no throw.
[[nodiscard]] SiteDecision decide_site(const SiteRoster& roster, std::int32_t my_id, std::span<const SitePeerInput> peers,
                                       std::int64_t now_us, const SiteRulesConfig& config) noexcept;

[[nodiscard]] const char* to_string(SiteLink link) noexcept;
[[nodiscard]] const char* to_string(SiteRole role) noexcept;
[[nodiscard]] const char* to_string(SitePrediction prediction) noexcept;
[[nodiscard]] const char* to_string(SiteMotion motion) noexcept;

}  // namespace mgc::firmware
