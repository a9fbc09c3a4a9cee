// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <limits>

#include "mgc/guidance/envelope.hpp"
#include "mgc/guidance/trajectory.hpp"
#include "mgc/planning/collision_world.hpp"

namespace mgc::guidance {

//! Outcome of the short-horizon stop check.
enum class StopCheckStatus : std::int8_t {
  Clear = 0,     //!< the stopping motion keeps more than the warning margin everywhere
  Warning = 1,   //!< within the warning margin: scale the commanded speed by speed_scale
  Stop = 2,      //!< within the stop margin (or across an envelope limit): stop now and re-plan
  ErrorInput = -1,  //!< a state or limit the stop calculation refused: treated as Stop by callers
};

[[nodiscard]] const char* to_string(StopCheckStatus status) noexcept;

struct StopCheckConfig {
  //! Clearance (beyond the world's dilation) the stopping motion must keep; below it: Stop. Covers
  //! the UWB position error of 0.1-0.3 m and a cycle of latency (DOMAIN-FACTS §3.1). [m]
  double stop_margin_m = 0.5;
  //! Below this clearance along the stop: Warning, speed scaled linearly from 1 here to 0 at the
  //! stop margin. PMERail puts the tool under system control within 1 m of a limit (DOMAIN-FACTS
  //! §4.4). Clearance counts every machine body, the parked carrier too, so a wider margin would
  //! keep a machine set up next to a structure in Warning for good (the thesis site: carrier 1.15 m
  //! from the frame). [m]
  double warning_margin_m = 1.0;
  //! How fast a dynamic obstacle may move toward us; its clearance is reduced by this times the
  //! stop duration. A second crane's boom tip slewing at ~4 deg/s at 15-20 m radius. [m/s]
  double dynamic_obstacle_speed_m_s = 1.0;
  //! Most a body point moves between two samples of the stopping motion where the clearance is
  //! within the warning margin (further out the check advances by the clearance itself). [m]
  double sample_step_m = 0.1;
  //! Cap on samples per check (bounded work per cycle); when reached the step grows, and the
  //! conservative clearance with it. [-]
  int max_samples = 64;
  //! The envelope may be crossed by at most this along the stop (0: not at all). [m]
  double envelope_stop_margin_m = 0.0;
  //! Speed scale for a motion the retreat floor lets through (StopCheck::set_retreat_floor): within
  //! the stop margin but not nearer than the floor, and as the least scale in the warning zone. [-]
  double retreat_speed_scale = 0.25;
  //! Measure the machine's fixed bodies (a carrier) once per check rather than at every sample:
  //! the stopping motion cannot move them, so only the moving bodies' clearance sets the step. Off
  //! only to compare against the all-bodies sweep (mgc-bench --suite safety).
  bool fixed_bodies_once = true;
  //! Measure each sample only as far as the outcome needs (CollisionWorld::nearest_below): at time t
  //! a sample's clearance is measured exactly only below a bound, max(2 E - warning_margin_m, E + the
  //! finest step's travel) + (body travel from t to the end of the stop), E = max(warning_margin_m,
  //! exact_clearance_m); at or above it the step reaches the end of the stop whatever the exact
  //! value. So the samples, the status and the speed scale are those of the all-distance sweep (the
  //! nearest obstacle measured in full at every sample, as with this off), and so are min_clearance_m,
  //! nearest and nearest_time_s when min_clearance_m is below E; equal up to GJK's tolerance (1e-6 m)
  //! where two obstacles are about equally near. Needs fixed_bodies_once; off only to compare
  //! (mgc-bench --suite safety, tests/safety/stop_check_fast_test.cpp). docs/safety.md.
  bool bounded_queries = true;
  //! With bounded_queries: min_clearance_m, nearest and nearest_time_s are exact below this (or below
  //! the warning margin, if larger); when the exact least clearance is at or above it, min_clearance_m
  //! may be any value from it up to the exact one and nearest may name nothing (With::Nothing). [m]
  double exact_clearance_m = 2.0;
};

//! The machine's current state, one entry per joint (positions in the joint's unit).
struct MachineState {
  std::array<JointState, kMaxJoints> joints{};
};

struct StopCheckResult {
  StopCheckStatus status = StopCheckStatus::Clear;
  double speed_scale = 1.0;       //!< [0, 1] for the commanded speed
  bool replan = false;            //!< Stop: the supervisor should re-plan
  double stop_duration_s = 0.0;   //!< time to rest under the braking limits [s]
  planning::JointVector stop_position;  //!< where the machine comes to rest
  //! Least clearance along the stop, conservative: between two samples d0, d1 a distance h of
  //! body travel apart, (d0 + d1 - h) / 2; dynamic obstacles less their reach during the stop. On
  //! Stop the sweep ends at the first interval under the stop margin, so this is that interval's.
  //! With bounded_queries, exact below max(warning margin, exact_clearance_m); at or above that a
  //! lower bound of the exact value, itself at least that (StopCheckConfig::exact_clearance_m). [m]
  double min_clearance_m = 0.0;
  //! Least clearance along the stop as measured, a dynamic obstacle's not lessened by its reach:
  //! what the machine's own motion comes to (the same conservative interval bound). On Stop, up to
  //! where the sweep ended. [m]
  double min_geometric_m = 0.0;
  //! The stop margin was undercut but the retreat floor kept: the motion does not come nearer, so
  //! it goes on at retreat_speed_scale instead of stopping (status Warning).
  bool retreat = false;
  //! What is nearest at that sample (With::Nothing: with bounded_queries, nothing within the
  //! sample's bound there, only when min_clearance_m is at least exact_clearance_m).
  planning::Clearance nearest;
  double nearest_time_s = 0.0;    //!< [s] into the stop
  EnvelopeDistance envelope;      //!< least envelope distance along the stop (None: no envelope)
  int samples = 0;                //!< configurations checked
  TrajectoryStatus calculation = TrajectoryStatus::Working;  //!< of the stop profiles
  int invalid_joint = -1;         //!< ErrorInput: the joint
};

//! Short-horizon safety check, every cycle: from the current state the time-optimal stop of every
//! joint under its braking limits (calculate_stop), sampled so that no body point moves more than
//! sample_step_m between samples (the model's displacement bounds times each joint's peak speed in
//! the stop) where the clearance is near the warning margin, and further apart where it is large
//! (conservative advancement); each sample's clearance to the static and dynamic obstacles (at the
//! poses the caller set this cycle; measured only as far as the outcome needs, bounded_queries) and,
//! if given, its envelope distance. RT-safe after construction: no allocation,
//! no throw. Not thread-safe (it poses the world's machine).
class StopCheck {
 public:
  //! world (and the model behind it) and envelope (may be null) must outlive the check; the world
  //! must be finalized, its static site complete.
  StopCheck(planning::CollisionWorld& world, Envelope* envelope, const StopCheckConfig& config) noexcept;

  [[nodiscard]] StopCheckResult check(const MachineState& state) noexcept;

  [[nodiscard]] const StopCheckConfig& config() const noexcept { return config_; }
  //! How fast the dynamic obstacles may approach from the next check on, e.g. from their tracked
  //! motion (the configured value is the default until then). [m/s], >= 0
  void set_dynamic_obstacle_speed(double speed_m_s) noexcept { config_.dynamic_obstacle_speed_m_s = speed_m_s; }
  //! How far the dynamic obstacles may stand from their estimated poses (their estimate's
  //! uncertainty, e.g. twice the tracker's 1-sigma): their clearance is reduced by this besides
  //! their reach, from the next check on. [m], >= 0; 0 by default
  void set_dynamic_obstacle_allowance(double allowance_m) noexcept { dynamic_allowance_m_ = allowance_m; }
  [[nodiscard]] double dynamic_obstacle_allowance() const noexcept { return dynamic_allowance_m_; }
  //! A machine that must get away from an obstacle it stopped next to (docs/safety.md, "Retreat"):
  //! from the next check on, a stop that undercuts the stop margin is a Stop only when the machine's
  //! own motion also brings it nearer than floor_m (min_geometric_m < floor_m); otherwise the
  //! motion goes on at retreat_speed_scale, and a Warning is never slower than that. A stop
  //! cannot get the machine away from where an obstacle already is, only moving away can.
  //! +infinity (the default): every undercut is a Stop. [m]
  void set_retreat_floor(double floor_m) noexcept { retreat_floor_m_ = floor_m; }
  [[nodiscard]] double retreat_floor() const noexcept { return retreat_floor_m_; }
  //! The braking profile of joint j from the last check.
  [[nodiscard]] const Profile& stop_profile(int j) const noexcept { return profiles_[static_cast<std::size_t>(j)]; }
  //! Full clearance queries (CollisionWorld::clearance) the last check made: with bounded_queries
  //! only at a sample within 1 mm of contact (then the check stops), or should a bounded value ever
  //! need making exact (by the bound's choice it does not, short of rounding); without, every sample.
  [[nodiscard]] int full_queries() const noexcept { return full_queries_; }

 private:
  //! One sample's clearance as the sweep uses it: a dynamic obstacle's less its reach.
  struct Sample {
    planning::Clearance contact;
    double clearance_m = 0.0;
    double geometric_m = 0.0;  //!< the nearest obstacle of either kind, not lessened by a reach
    bool bounded = false;  //!< only known to be at least clearance_m (nothing nearer than the bound)
  };
  [[nodiscard]] Sample measure(const planning::JointVector& q, bool bounded, double bound_m, double reach_m) noexcept;
  [[nodiscard]] Sample measure_full(const planning::JointVector& q, double reach_m) noexcept;

  planning::CollisionWorld& world_;
  Envelope* envelope_;
  StopCheckConfig config_;
  double retreat_floor_m_ = std::numeric_limits<double>::infinity();
  double dynamic_allowance_m_ = 0.0;  //!< [m]
  //! The fixed bodies' clearance to the static obstacles: constant, so measured at construction.
  planning::Clearance fixed_static_;
  std::array<JointLimits, kMaxJoints> limits_{};
  std::array<Profile, kMaxJoints> profiles_{};
  //! The last nearest static and dynamic obstacle: measured first at the next sample or check.
  planning::CollisionWorld::NearestBelow hint_;
  int full_queries_ = 0;
};

}  // namespace mgc::guidance
