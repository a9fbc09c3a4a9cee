// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "mgc/firmware/site_rules.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_tags.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/planning/site.hpp"

//! The controller as a member of a coordinated site (docs/site.md, "The controller as a site
//! member"): what it is given at start-up, what the loop hands it every cycle (the verified site
//! messages of the other machines, fixed size), and how the other machines enter its worlds.
namespace mgc::firmware {

//! The latest verified messages of one other machine, as the I/O side hands them to the loop: the
//! decoding and the checks (SiteVerifier) happened before, off the loop.
struct SitePeerMessages {
  bool has_state = false;
  site_state_t state{};
  std::int64_t state_received_us = 0;  //!< on the loop's clock (the snapshot's t_us) [µs]
  bool has_plan = false;
  site_plan_t plan{};
};

//! Every other machine's latest verified messages, in roster order (my own entry is ignored).
struct SiteInputs {
  std::array<SitePeerMessages, kMaxSiteMachines> peers{};
};

//! Told of each verified message as the loop takes it into its SiteInputs (the black box records
//! them there). Implementations are RT-safe: no alloc, no lock, no throw, no wait.
class SiteTakeObserver {
 public:
  virtual ~SiteTakeObserver() = default;
  //! A state for roster entry roster_index, with the receive time the controller is given. [µs]
  virtual void took_site_state(int roster_index, const site_state_t& state, std::int64_t received_us) noexcept = 0;
  virtual void took_site_plan(int roster_index, const site_plan_t& plan) noexcept = 0;
};

//! The loop's hand-off: puts one verified state (received at received_us on the loop's clock) or
//! plan into inputs, the latest of each machine winning, and tells observer (may be null). An
//! index outside the roster is ignored. RT-safe.
void take_site_state(SiteInputs& inputs, int roster_index, const site_state_t& state, std::int64_t received_us,
                     SiteTakeObserver* observer) noexcept;
void take_site_plan(SiteInputs& inputs, int roster_index, const site_plan_t& plan, SiteTakeObserver* observer) noexcept;

//! Start-up description of the site for a member's controller.
struct SiteMemberConfig {
  planning::Site site;
  std::int32_t machine_id = 0;  //!< mine, in the site file
  SiteRulesConfig rules{};
  //! Poses of a higher-priority machine's remaining plan the planning worlds hold (its present
  //! pose one of them). [-]
  int plan_copies = 24;
  //! Step of the scan that finds when two stopping envelopes would meet (meet_in_s). [s]
  double scan_step_s = 0.25;
  //! The site's RTLS (docs/site.md, "Staleness"): a tag fix older than this (its receive time) is
  //! not used to pose a stale machine. Three 10 Hz periods. [µs]
  std::int64_t tag_max_age_us = 300'000;
  //! From a tag's measurement to its fix's receive time at most (the gateway's latency). [µs]
  std::int64_t tag_latency_us = 100'000;
  //! A fit whose largest tag residual exceeds 3 sigma of the fixes plus this is implausible: a
  //! tag moved on the machine, a wrong fix, a swinging hook beyond what posing can carry. [m]
  double tag_residual_gate_m = 1.0;
  //! The velocity a machine posed from its tags is carried at: the slope of its fits over this
  //! window (one kept every 50 ms). [µs]
  std::int64_t tag_velocity_window_us = 800'000;
  //! Speed factor while the mutual-stop rule asks to slow down. [-]
  double slow_down_scale = 0.5;
  //! A lower-priority machine that a higher one keeps stopped this long, on a path already planned
  //! round that machine's plan, re-plans again from where it stands: the higher one may be waiting
  //! for it. [µs]
  std::int64_t wait_replan_us = 2'000'000;
};

//! The scenario a site member's controller works in: the lift's scenario with every other
//! machine's fixed bodies (carrier, mast, undercarriage) as static obstacles at their bases, and
//! its moving bodies as dynamic obstacles, parked far below the site until the rules pose them:
//! plan_copies of each for a machine of higher priority than mine (its pose and its plan), one for
//! a lower one (its frozen pose while stale; I never plan round it live). Start-up only (allocates; throws std::invalid_argument when my id is not
//! in the site or a model cannot be built).
[[nodiscard]] planning::Scenario site_member_scenario(const planning::Scenario& lift, const SiteMemberConfig& config);

//! The scenario of a member's stop check: member (site_member_scenario()'s) without the other
//! machines' moving-body copies, which only the planning worlds pose; parked in the stop check's
//! world they would change no answer and cost every query. own_dynamic: the lift scenario's own
//! dynamic obstacles, which come first. Start-up only.
[[nodiscard]] planning::Scenario site_stop_check_scenario(planning::Scenario member, std::size_t own_dynamic);

//! A machine posed from the site's UWB tags on it (SitePeerModel): the fitted joints, how much the
//! pose may be off, and the velocity from the fits. [rad | m, m, rad/s | m/s]
struct SiteTagPose {
  bool valid = false;             //!< fresh fixes, a plausible fit, a velocity: it may pose the machine
  std::int64_t t_us = 0;          //!< the newest fix used (receive time) [µs]
  planning::JointVector q;        //!< [rad | m]
  planning::JointVector v;        //!< from the fits over the velocity window [rad/s | m/s]
  double grow_m = 0.0;            //!< noise, residual, latency and the joints no tag sees [m]
  double residual_m = 0.0;        //!< largest tag residual of the fit [m]
  //! How fast a body point may move unlike v says (the fixes' noise over the window), and how old
  //! v is beyond t_us (half the window): the caller grows its prediction by both. [m/s, s]
  double speed_error_m_s = 0.0;
  double velocity_lag_s = 0.0;
  int tags_used = 0;              //!< [-]
};

//! The fit's memory for one machine: the last fits, the time each joint was last seen. Fixed size.
struct SiteTagTrack {
  static constexpr std::size_t kHistory = 32;
  std::array<std::int64_t, kHistory> fit_us{};
  std::array<planning::JointVector, kHistory> fit_q{};
  std::size_t fits = 0;  //!< in the ring, newest at (head + fits - 1) % kHistory
  std::size_t head = 0;
  std::array<std::int64_t, kMaxJoints> seen_us{};  //!< when a tag last saw each joint [µs]
  bool seeded = false;
  std::uint64_t fits_done = 0;         //!< [-]
  std::uint64_t fits_implausible = 0;  //!< by residual or by a jump beyond the speed bound [-]
};

//! One other machine's model and the worlds it is measured in. Start-up builds it; the loop poses it.
struct SitePeerModel {
  int roster_index = -1;
  std::int32_t machine_id = 0;
  double max_point_speed_m_s = 0.0;  //!< [m/s]
  std::unique_ptr<planning::MachineModel> model;
  std::vector<int> moving_bodies;  //!< its bodies that move with its joints
  //! My model against its moving bodies (dynamic obstacle k: body moving_bodies[k]), undilated:
  //! where the stopping envelopes are measured.
  std::unique_ptr<planning::CollisionWorld> meet_world;
  int world_first = -1;  //!< first of its dynamic obstacles in the planning worlds: copy c, body k at world_first + c * moving + k
  bool higher = false;   //!< of higher priority than mine, by the site file
  int copies = 0;        //!< of its moving bodies in the planning worlds: plan_copies when higher, else 1
  planning::Kinematics kinematics{};
  planning::JointVector q;  //!< scratch [rad | m]
  // The site's UWB tags on it (the site file's uwb_tags), and the pose they give while it is stale.
  int num_tags = 0;
  std::array<std::uint8_t, planning::kMaxMachineTags> tag_ids{};
  std::array<planning::TagMount, planning::kMaxMachineTags> tag_mounts{};
  std::array<Eigen::Vector3d, planning::kMaxMachineTags> tag_local_m{};
  SiteTagTrack tag_track{};
  SiteTagPose tag_pose{};
  //! The tag pose as a state (positions, velocities, stop travel), for the meet scan and the worlds.
  site_state_t tag_state{};
  planning::Kinematics tag_kinematics{};  //!< scratch
  //! The meet world's nearest pair of the last query, measured first in the next: it lowers the
  //! bound early and changes only the cost.
  planning::CollisionWorld::NearestBelow nearest{};
  // What its copies in the planning worlds hold, so that a copy is set only when what it shows
  // changes (the worlds hold them as set; the loop alone sets them).
  int parked_from = 0;        //!< copies from this one on are parked (set by make_site_peers)
  bool plan_posed = false;  //!< copies 1.. hold plan_posed_from at site_plan_copy_time_s()
  int plan_passed = 0;      //!< copies 1..plan_passed are behind the machine on that plan: parked
  site_plan_t plan_posed_from{};
};

//! Whether two plans move a machine the same way: the same joints, waypoints and times (what
//! site_plan_at() reads), whatever their ids, sequences or MACs. RT-safe.
[[nodiscard]] bool site_same_motion(const site_plan_t& a, const site_plan_t& b) noexcept;

//! Builds the other machines' models and meet worlds for my_model. Start-up only.
[[nodiscard]] std::vector<SitePeerModel> make_site_peers(const SiteMemberConfig& config, const planning::MachineModel& my_model,
                                                         int first_dynamic);

//! The parked pose of copy c of a peer's body k: far below the site, apart from every other. RT-safe.
[[nodiscard]] Eigen::Isometry3d site_parked_pose(int peer, int copy, int body) noexcept;

//! Plan time of copy c (1..copies) of a higher-priority machine's plan of w waypoints: evenly
//! over the whole plan, the last at its end. RT-safe.
[[nodiscard]] double site_plan_copy_time_s(const site_plan_t& plan, int w, int c, int copies) noexcept;

//! A machine's queue of lifts (the site file's `lifts`, docs/site.md "Later lifts"): the goals its
//! controller is asked for, one leg at a time, each when the previous one's goal was reached. The
//! first lift is its scenario's (the controller starts at its start; goal_joints 0: the scenario's
//! goal). Each later lift is a leg to its start, left out when the previous lift's goal is that
//! start, then a leg to its goal. The machine carries its first lift's load and rigging throughout
//! (the controller's model and the simulator have no other). Built at start-up; goal() and
//! reached() allocate nothing.
class SiteLiftQueue {
 public:
  //! Throws std::invalid_argument for a machine id the site does not list.
  SiteLiftQueue(const planning::Site& site, std::int32_t machine_id);

  [[nodiscard]] bool done() const noexcept { return leg_ >= legs_.size(); }
  [[nodiscard]] std::size_t lifts() const noexcept { return lifts_; }
  [[nodiscard]] std::size_t lifts_done() const noexcept { return lifts_done_; }
  //! The lift the current leg belongs to (lifts() when done). [-]
  [[nodiscard]] std::size_t lift() const noexcept { return done() ? lifts_ : legs_[leg_].lift; }
  //! The current leg's goal (goal_joints 0: the scenario's own); false when done.
  bool goal(std::array<double, kMaxJoints>& goal, int& goal_joints) const noexcept;
  //! The current leg's goal was reached: on to the next. True when that completed a lift.
  bool reached() noexcept;

 private:
  struct Leg {
    std::array<double, kMaxJoints> goal{};
    int joints = 0;
    std::size_t lift = 0;
    bool ends_lift = false;
  };
  std::vector<Leg> legs_;
  std::size_t leg_ = 0;
  std::size_t lifts_ = 0;
  std::size_t lifts_done_ = 0;
};

//! Poses machine p from the site's UWB fixes of its tags in snapshot (docs/site.md, "Staleness"):
//! a Gauss-Newton fit of its joints through its model, from the last fit (or seed_q, its last
//! verified pose or its lift's start) over the fixes received within config.tag_max_age_us. A joint
//! that no fresh tag sees keeps the value it had and grows the pose by its displacement bound times
//! its maximum speed over the time since a tag last saw it. Implausible, and p.tag_pose invalid:
//! no fresh fix, a residual beyond the gate, or a fit farther from the last one than the speed
//! bound allows. Returns p.tag_pose. RT-safe (fixed-size Eigen, no allocation).
//! seed_us: when seed_q held (its state's receive time less the skew; never heard: INT64_MIN, every
//! joint then unknown until a tag sees it).
const SiteTagPose& site_fit_tags(SitePeerModel& p, const hal::SensorSnapshot& snapshot, const planning::JointVector& seed_q,
                                 std::int64_t seed_us, std::int64_t now_us, const SiteMemberConfig& config) noexcept;

//! Position of a plan at plan time t_s, linear between its timed waypoints, held at its ends. RT-safe.
void site_plan_at(const site_plan_t& plan, double t_s, planning::JointVector& q) noexcept;

}  // namespace mgc::firmware
