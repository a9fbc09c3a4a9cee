// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mgc/firmware/guidance_snapshot.hpp"
#include "mgc/firmware/obstacle_tracker.hpp"
#include "mgc/firmware/rate_limiter.hpp"
#include "mgc/firmware/site_member.hpp"
#include "mgc/firmware/site_rules.hpp"
#include "mgc/guidance/diagnostics.hpp"
#include "mgc/guidance/online.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/guidance/safety.hpp"
#include "mgc/guidance/supervisor.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/planners/replanner.hpp"
#include "mgc/planning/path_shortener.hpp"
#include "mgc/planning/retreat.hpp"
#include "mgc/planning/scenario.hpp"

//! The controller's cycle (docs/controller.md): one step() per period turns the Hal's snapshot and
//! the operator's commands into rate-limited joint velocity commands and a guidance snapshot. It
//! owns everything between the bus and the feed: joint state estimate, obstacle trackers, the stop
//! check, the rated capacity limiter, the supervisor, a bounded slice of the (re-)planner, the
//! one-joint-at-a-time path follower and the rate limiter. The harness around it (the `mgc`
//! binary, tests) owns the clock, the Hal and the LCM feed.
namespace mgc::firmware {

struct ControllerConfig {
  std::string replanner{planning::kDefaultReplanner};  //!< make_replanner() name
  //! Planner iterations per cycle while planning or re-planning: bounded work in the cycle, the
  //! query spread over cycles. [-]
  int plan_iterations_per_cycle = 10;
  //! The planned motion runs at this fraction of each joint's speed and acceleration; the rest is
  //! the position feedback's authority. [-]
  double follow_speed_fraction = 0.8;
  double position_gain_per_s = 2.0;   //!< feedback on the setpoint's position error [1/s]
  //! The command leads the setpoint's velocity by its acceleration times this: the valve and
  //! actuator's flow-to-velocity lag, identified at commissioning (mgc-sim: 0.15 s). Without it the
  //! machine trails the setpoint by that lag and the feedback alone brings it back, after it has
  //! run past a goal by about deceleration × lag / position gain. 0 turns the lead off. [s]
  double acceleration_lead_s = 0.15;
  //! A reading at most this far past a joint's end stop is taken as at the stop (encoder noise at
  //! a fully extended boom); farther out it is kept as read. [m] and [rad]
  double end_stop_tolerance_m = 0.01;
  double end_stop_tolerance_rad = 0.1 * 3.14159265358979323846 / 180.0;
  //! A joint whose estimated speed stays below this is at rest. [rad/s | m/s]
  double rest_speed = 0.005;
  //! Weight of a new velocity sample in the estimate's first-order filter (1: no filter). [-]
  double velocity_filter = 0.5;
  //! Margin the planner keeps beyond the scenario's dilation: the stop check's stop margin, so
  //! that a planned path does not itself trigger a stop, plus what the follower may lag. Dynamic
  //! obstacles are grown further, by how far a standing one may come while the machine stops
  //! (obstacle_speed_floor_m_s times the longest stop from full speed). [m]
  double planning_margin_m = 1.0;
  //! The margin of the escape plan, for a machine that an obstacle stopped next to, within the
  //! planning margin: the stop margin plus a quarter metre of following allowance. [m]
  double escape_margin_m = 0.75;
  //! Added to each obstacle's tracked speed: UWB noise left over the window, and a motion that is
  //! only starting. The stop check's dynamic_obstacle_speed_m_s stands until a window is full. [m/s]
  double obstacle_speed_floor_m_s = 0.3;
  //! Span over which an obstacle's speed is measured from its tracked poses. [µs]
  std::int64_t obstacle_speed_window_us = 2'000'000;
  //! The stop check reduces the clearance to the tracked obstacles by this many of the largest
  //! 1-sigma of a standing obstacle's averaged pose (ObstacleTracker::still, position_sigma_m):
  //! the average's own uncertainty. A moving obstacle's pose is one fit, whose UWB error the stop
  //! margin covers (guidance::StopCheckConfig::stop_margin_m). [-]
  double obstacle_sigma_factor = 2.0;
  //! A repair after a safety stop waits until no obstacle moves faster than its floor plus this:
  //! a path planned around an obstacle still on its way would be cut again at once. [m/s]
  double settled_speed_m_s = 0.2;
  //! The planner keeps every monitored point this far inside the scenario's working envelope: the
  //! planning world's edge checks leave up to half its dilation between samples, and the follower
  //! may lag; so a planned motion never reaches the limit, where the limiter cuts it. [m]
  double envelope_planning_margin_m = 1.25;
  //! The same for an escape plan, above half the escape world's dilation. [m]
  double envelope_escape_margin_m = 0.5;
  //! A repair whose path takes more than this many times the direct one-joint-at-a-time move from
  //! the stop to the goal (each joint's travel at its following speed, one after the other) is
  //! compared with a fresh plan from the stop; the quicker of the two is followed. [-]
  double repair_detour_ratio = 2.0;
  //! Iteration cap of an escape plan and of its repairs (at least the scenario's caps). [-]
  int escape_max_iterations = 20000;
  //! Planner iterations per cycle of an escape: its hard query makes an iteration up to 20 times
  //! dearer than a first plan's (mgc-bench loop, intrusion sweep: 2 ms of thread CPU for 10,
  //! 0.96 ms for 4, 0.7 ms for 3), so few per cycle keep the cycle well under its 1 ms; the
  //! machine is at rest meanwhile. [-]
  int escape_iterations_per_cycle = 3;
  //! Where not even the escape planner accepts the stopped machine as a start, one joint moves it
  //! out first (planning::RetreatSearch, docs/controller.md "Retreat"), measured against the stop
  //! check's world and ending valid in the escape world.
  planning::RetreatSettings retreat{};
  //! Configurations the retreat search measures per cycle (two clearance queries each). [-]
  int retreat_configs_per_cycle = 2;
  //! Repaired and escape paths are shortened before they are followed (planning::PathShortener):
  //! chunks of edge validated per cycle, each at most 2 m of body travel. The first plan is
  //! followed as planned. [-]
  int shorten_chunks_per_cycle = 3;
  //! Most waypoints a followed path may have (retreat and shortening corners included). [-]
  std::size_t max_path_waypoints = 1024;
  //! While an escape (or a retreat and escape) is followed and every obstacle is settled, the stop
  //! check stops only a motion that comes this much nearer than where the machine started it, or
  //! nearer than the stop margin if it started outside (guidance::StopCheck::set_retreat_floor). [m]
  double retreat_floor_tolerance_m = 0.1;
  //! The goal is reached when every joint stands this near its last waypoint: a fast joint that
  //! overshoots is at rest for an instant where it turns back, and must not end the lift there. [rad]
  double goal_tolerance_rad = 0.2 * 3.14159265358979323846 / 180.0;
  double goal_tolerance_m = 0.02;  //!< the same for a prismatic joint [m]
  //! A machine at rest is warned of a moving obstacle that would come within the stop margin of it
  //! this soon: the obstacle's tracked velocity and slew rate carried forward (docs/controller.md,
  //! "Approach warning"). The controller never moves the machine out of the way on its own. [s]
  double approach_horizon_s = 8.0;
  //! Predicted poses this far apart; one is measured a cycle, so a scan of the horizon takes
  //! approach_horizon_s / approach_step_s cycles. Each is measured to the stop margin grown by
  //! half the fastest moving obstacle's travel in a step, so none passes between two unseen. [s]
  double approach_step_s = 0.5;
  //! After the setpoint has finished, how long the machine may take to come within the goal
  //! tolerance before the path counts as complete anyway (stats().settle_timeouts). [µs]
  std::int64_t settle_timeout_us = 5'000'000;
  guidance::StopCheckConfig stop_check{};
  //! num_joints and uwb_required are set from the scenario.
  guidance::SupervisorConfig supervisor{};
  TrackerConfig tracker{};
  guidance::RatedCapacityConfig rated_capacity{};
  //! The sensor and actuator plausibility checks (docs/diagnostics.md).
  guidance::PlausibilityConfig plausibility{};
  //! The machine's own UWB tags against forward kinematics (docs/diagnostics.md "Machine tags").
  guidance::MachineTagCheckConfig machine_tags{};
  guidance::InclinometerCheckConfig inclinometer{};
};

//! Operator commands of this cycle, already authenticated (command_auth.hpp).
struct ControllerCommands {
  bool stop = false;
  bool goal_request = false;
  bool acknowledge = false;
  //! The requested goal; goal_joints == 0 means the scenario's goal. [rad | m]
  std::array<double, kMaxJoints> goal{};
  int goal_joints = 0;
};

struct ControllerOutput {
  std::span<const double> velocity;  //!< for Hal::write [rad/s | m/s]
  bool start_nodes = false;          //!< send NMT start to all nodes
  bool reset_watchdog = false;       //!< an acknowledgement was accepted
  //! Keep pilot pressure on (hal::Hal::set_pilot_enabled): false in FAULT, and at once when the
  //! valve is in doubt, so that a valve that does not obey is stopped through the second channel.
  bool pilot_enable = false;
  guidance::SupervisorOutput supervisor{};
};

//! What happened over the controller's life, for the summary and the tests.
struct ControllerStats {
  std::uint64_t cycles = 0;
  int plans = 0;             //!< first plans started (goal requests accepted)
  int replans = 0;           //!< repairs started after a safety stop
  int escapes = 0;           //!< plans and repairs made in the escape world: an obstacle stood within the planning margin
  int repairs_planned_afresh = 0;  //!< repairs that spent their iteration cap and were planned anew from the stop
  int detours_compared = 0;   //!< repairs slow enough to follow that a fresh plan from the stop was made beside them
  int detours_replaced = 0;   //!< of those, repairs the fresh plan replaced, being quicker to follow
  int retreats = 0;          //!< retreats found where not even the escape planner accepted the start
  int retreats_refused = 0;  //!< retreat searches that found no single-joint way out
  int retreats_in_contact = 0;  //!< retreats not searched: the machine touched an obstacle (the stop check's dilated bodies)
  int paths_shortened = 0;   //!< repaired or escape paths the shortener took waypoints or corners from
  int waypoints_removed = 0; //!< waypoints the shortener removed over all paths (corners it added subtract)
  std::uint64_t retreat_cycles = 0;  //!< moving cycles the retreat floor let through the stop margin
  int safety_stops = 0;      //!< EXECUTING -> STOPPING for the stop check, the envelope or the load chart
  int goals_reached = 0;
  int commands_rejected = 0; //!< operator commands the supervisor refused
  double min_clearance_m = 1e9;  //!< least clearance the stop check reported while moving [m]
  std::uint64_t planner_cycles = 0;  //!< cycles with a planner slice
  std::uint64_t rcl_cut_cycles = 0;  //!< cycles in which the load chart cut a motion
  std::uint64_t envelope_cut_cycles = 0;  //!< cycles in which the working envelope slowed or cut a joint moving faster than rest_speed
  double min_envelope_m = 1e9;  //!< least envelope distance of a monitored point while moving (1e9: no envelope) [m]
  std::uint64_t estimate_invalid_cycles = 0;  //!< cycles without a valid position of every joint
  std::uint64_t trajectory_errors = 0;  //!< cycles whose setpoint generator refused its input
  int settle_timeouts = 0;  //!< paths completed without the machine within the goal tolerance of the last waypoint
  //! Times a moving obstacle was predicted to come within the stop margin of the machine at rest
  //! (the approach warning raised; each rise counts once).
  int approach_warnings = 0;
  //! The plausibility monitor's finding (None: none) and when it was seen, or the machine tag
  //! check's (PoseDisagrees) or the inclinometer check's (AngleDisagrees), whichever came first.
  //! [µs on the snapshot clock]
  guidance::PlausibilityFault plausibility_fault = guidance::PlausibilityFault::None;
  //! The joint it named; -1 for the valve's counter; the tag id for PoseDisagrees.
  int plausibility_joint = -1;
  //! PoseDisagrees: bit j set when the tag sees joint j (one of their encoders is wrong).
  std::uint32_t pose_joints_seen = 0;
  //! Largest residual/threshold of any judged machine tag fix (1 = at the threshold). [-]
  double machine_tag_peak_ratio = 0.0;
  std::uint64_t machine_tag_fixes_judged = 0;  //!< [-]
  std::uint64_t machine_tag_stale_cycles = 0;  //!< cycles with a machine tag stale (alerted, not judged) [-]
  //! The boom inclinometer against the boom's encoder: pairs judged, the largest mean residual's
  //! share of its threshold, and cycles in which the bus plan has one but it could not be judged
  //! (missing, stale or faulted). [-]
  std::uint64_t inclinometer_judged = 0;
  double inclinometer_peak_ratio = 0.0;
  std::uint64_t inclinometer_unavailable_cycles = 0;
  std::int64_t plausibility_detected_us = 0;
  //! Largest share of its threshold any of the monitor's motion checks reached (1 = a fault). [-]
  double plausibility_peak_ratio = 0.0;
  int pilot_cuts = 0;  //!< times the controller cut pilot pressure
  // A site member's (docs/site.md, "The controller as a site member"); 0 without a site.
  std::uint64_t site_stop_cycles = 0;      //!< cycles in which the site asked to stop
  std::uint64_t site_slow_cycles = 0;      //!< cycles in which the site asked to slow down
  int site_stops = 0;                      //!< times the site's stop was raised (each rise once)
  int site_replans = 0;                    //!< safety stops the site asked for to re-plan round a higher-priority machine
  int site_stale_alerts = 0;               //!< times a machine went stale or was never heard (each rise once)
  int site_plans_published = 0;            //!< site_plan_t contents produced
  std::uint64_t site_tag_cycles = 0;       //!< cycles in which a stale machine was posed from its UWB tags
  std::uint64_t site_frozen_cycles = 0;    //!< cycles in which a stale machine was posed frozen and grown
  //! Least gap between my stopping envelope and another machine's, stop margin not taken off, as
  //! the scan measured it at its first step (now). [m]
  double site_min_gap_m = 1e9;
};

class Controller {
 public:
  //! Builds the model, the planning and safety worlds, the trackers and the re-planner for the
  //! scenario. Start-up only: allocates, throws std::invalid_argument naming what is wrong.
  Controller(const planning::Scenario& scenario, const ControllerConfig& config);
  //! A member of a coordinated site (site null: as the two-argument form, bit for bit): the other
  //! machines of site->site enter its worlds (site_member_scenario()) and the site rules its cycle.
  Controller(const planning::Scenario& scenario, const ControllerConfig& config, const SiteMemberConfig* site);

  //! One cycle. dt_us: true time since the previous cycle (CycleTiming::dt_us; the period on the
  //! first). RT-safe: no allocation, no throw, no clock.
  ControllerOutput step(const hal::SensorSnapshot& snapshot, std::int64_t dt_us, const ControllerCommands& commands,
                        bool watchdog_tripped) noexcept;
  //! One cycle of a site member: site holds the other machines' latest verified messages (on the
  //! snapshot's clock). Without a site given at construction it is step() above. RT-safe.
  ControllerOutput step(const hal::SensorSnapshot& snapshot, std::int64_t dt_us, const ControllerCommands& commands,
                        bool watchdog_tripped, const SiteInputs& site) noexcept;

  [[nodiscard]] bool site_member() const noexcept { return site_ != nullptr; }
  //! This cycle's site_state_t content (sequence, sender time and MAC left to the publisher).
  [[nodiscard]] const site_state_t& site_state() const noexcept { return site_state_; }
  //! The plan's site_plan_t content (the same left out), and a count that moves each time it changes:
  //! a new plan, or its window moved on.
  [[nodiscard]] const site_plan_t& site_plan() const noexcept { return site_plan_; }
  [[nodiscard]] std::uint64_t site_plan_version() const noexcept { return site_plan_version_; }
  //! The site rules' decision of the last cycle (count 0 without a site).
  [[nodiscard]] const SiteDecision& site_decision() const noexcept { return site_decision_; }
  //! Per roster entry, the time until my stopping envelope and that machine's would meet, as last
  //! scanned (+inf: not within the scan). [s]
  [[nodiscard]] double site_meet_in_s(std::size_t roster_index) const noexcept { return site_meet_s_[roster_index]; }
  //! What the site's UWB tags on machine_id give of it this cycle (valid: it may pose it); null for
  //! a machine of no tags, myself or one not on the site.
  [[nodiscard]] const SiteTagPose* site_tag_pose(std::int32_t machine_id) const noexcept;

  //! The guidance snapshot of the last step() (timing left for the harness to fill).
  [[nodiscard]] const GuidanceSnapshot& snapshot() const noexcept { return snap_; }
  [[nodiscard]] GuidanceSnapshot& snapshot() noexcept { return snap_; }
  [[nodiscard]] const ControllerStats& stats() const noexcept { return stats_; }
  [[nodiscard]] guidance::Supervisor& supervisor() noexcept { return supervisor_; }
  [[nodiscard]] const guidance::StopCheckResult& stop_check() const noexcept { return check_; }
  [[nodiscard]] const guidance::PlausibilityMonitor& plausibility() const noexcept { return monitor_; }
  [[nodiscard]] const guidance::MachineTagCheck& machine_tags() const noexcept { return tag_check_; }
  //! The joint whose angle the bus plan's inclinometer measures; -1 when the machine has none.
  [[nodiscard]] int inclinometer_joint() const noexcept { return inclinometer_check_.result().joint; }
  //! The working-envelope limiter's verdict on the last command (nothing when the site has no envelope).
  [[nodiscard]] const guidance::EnvelopeResult& envelope() const noexcept { return envelope_result_; }
  [[nodiscard]] bool has_envelope() const noexcept { return envelope_ != nullptr; }
  [[nodiscard]] const planning::MachineModel& model() const noexcept { return *model_; }
  //! The planner whose path the machine follows.
  [[nodiscard]] const planning::Replanner& planner() const noexcept { return *active_; }
  //! The measured joint positions, continuous joints unwrapped from the first reading. [rad | m]
  [[nodiscard]] const planning::JointVector& position() const noexcept { return q_unwrapped_; }
  [[nodiscard]] int num_joints() const noexcept { return n_; }
  [[nodiscard]] const ObstacleTracker& tracker(std::size_t i) const noexcept { return trackers_[i]; }
  [[nodiscard]] std::size_t num_trackers() const noexcept { return trackers_.size(); }
  //! In how many seconds a moving obstacle is predicted to come within the stop margin of the machine
  //! at rest (the approach warning); +infinity when none is within approach_horizon_s. [s]
  [[nodiscard]] double approach_s() const noexcept { return approach_s_; }
  //! The speed the stop check assumes for the dynamic obstacles this cycle. [m/s]
  [[nodiscard]] double obstacle_speed_m_s() const noexcept { return obstacle_speed_m_s_; }
  //! The follower's path has been completed: the setpoint has finished the last segment and the
  //! machine stands within the goal tolerance of it, or has had settle_timeout_us to get there.
  [[nodiscard]] bool path_complete() const noexcept { return following_ && target_ >= path_size_ && settled_; }

 private:
  void estimate(const hal::SensorSnapshot& s, double dt_s) noexcept;
  void track_obstacles(const hal::SensorSnapshot& s) noexcept;
  void run_safety() noexcept;
  //! One predicted pose of the approach warning's scan (machine at rest only).
  void predict_approach() noexcept;
  void handle_plan_request(const guidance::SupervisorOutput& out) noexcept;
  //! The machine stands within the planning margin of a dynamic obstacle: plans in the escape
  //! world, and where even that refuses the start, searches a one-joint retreat first.
  void plan_escape() noexcept;
  //! A goal the planner refused because a dynamic obstacle covers it is GoalOccupied: time may
  //! clear it.
  [[nodiscard]] planning::PlannerStatus goal_refusal(planning::PlannerStatus status) noexcept;
  //! Following time of a path one joint at a time at the follower's speeds, without ramps. [s]
  [[nodiscard]] double follow_time_s(const std::vector<planning::JointVector>& path) const noexcept;
  //! A repair just solved: starts the fresh plan to compare it with if it is a long detour, and
  //! takes the quicker path once that plan ends. Returns whether the repair's path may be taken.
  [[nodiscard]] bool detour_checked() noexcept;
  //! Every tracked obstacle's speed is measured and near its floor.
  [[nodiscard]] bool obstacles_settled() const noexcept;
  void load_path() noexcept;
  //! settled_ for this cycle.
  void update_settled() noexcept;
  //! Takes the planner's solution into path_: behind the retreat's start when there is one, and
  //! shortened unless it is the first plan.
  void take_path() noexcept;
  //! Waypoint i of the followed path.
  [[nodiscard]] const planning::JointVector& waypoint(std::size_t i) const noexcept { return path_[i]; }
  //! The follower's velocity command into v_target_.
  void follow(double dt_s, double speed_scale) noexcept;
  void fill_snapshot(const hal::SensorSnapshot& s, const guidance::SupervisorOutput& out) noexcept;
  //! The trackers' poses into snap_.obstacles, for the operator's display.
  void fill_snapshot_obstacles() noexcept;
  ControllerOutput step_impl(const hal::SensorSnapshot& s, std::int64_t dt_us, const ControllerCommands& commands,
                             bool watchdog_tripped, const SiteInputs* site) noexcept;
  //! The site rules for this cycle: decision, speed factor, safety stop, peers posed.
  void site_cycle(const SiteInputs& in, const hal::SensorSnapshot& s) noexcept;
  //! Distance from me at my_q to peer p posed at peer_q in its meet world, each body grown by grow_m,
  //! when it is below bound_m (nearest_below()'s: clearance()'s, except that clearance() reports 0
  //! wherever is_free() sees a contact); when nothing is nearer, a lower bound of it at least
  //! bound_m, from bounding boxes alone. me, if given, is my kinematics at my_q: the bodies' world
  //! boxes are compared first, and a machine they show beyond the bound costs no meet-world query.
  [[nodiscard]] double site_gap_m(SitePeerModel& p, const planning::JointVector& peer_q, double grow_m,
                                  const planning::JointVector& my_q, double bound_m,
                                  const planning::Kinematics* me = nullptr) noexcept;
  //! Poses p's moving bodies in its meet world as p.kinematics has them, each grown by grow_m.
  void site_pose_meet(SitePeerModel& p, double grow_m) noexcept;
  //! Whether my way leads apart from peer p (posed at peer_q, grown by grow_m): whether my gap to it
  //! at moving_q exceeds my gap standing at still_q by more than kSiteApartM, each gap clearance()'s.
  //! A gap already measured below its bound in the meet world as posed so (site_gap_m()) may be
  //! given for one of the two; NaN when not known. The other is measured only up to what decides.
  [[nodiscard]] bool site_leads_apart(SitePeerModel& p, const planning::JointVector& peer_q, double grow_m,
                                      const planning::JointVector& moving_q, double moving_known_m,
                                      const planning::JointVector& still_q, double still_known_m) noexcept;
  //! Whether bounding boxes alone show my bodies (me) and p's moving bodies as posed in
  //! p.kinematics, those grown by grow_m, at least bound_m apart: if so, a lower bound of their
  //! distance at least bound_m, else a value below it. Per pair the distance between their world
  //! boxes, and where it is below the bound the larger of it and their own boxes' gap along each
  //! one's face normals. [m]
  [[nodiscard]] double site_apart_m(const SitePeerModel& p, const planning::Kinematics& me, double grow_m,
                                    double bound_m) const noexcept;
  //! The other machines in the planning and escape worlds, from the cycle's inputs: a higher-priority
  //! machine at its pose and along its plan, a lower one parked, a stale one at its grown frozen pose.
  void site_pose_worlds(const SiteInputs& in) noexcept;
  //! Poses peer p's moving bodies at q as copy c in the planning and escape worlds, grown by grow_m.
  void site_pose_copy(SitePeerModel& p, int copy, const planning::JointVector& q, double grow_m) noexcept;
  //! Parks peer p's copies from from_copy on; those already parked are not touched again.
  void site_park(SitePeerModel& p, int from_copy) noexcept;
  void site_park_copy(SitePeerModel& p, int copy) noexcept;
  void site_fill_state(const guidance::SupervisorOutput& out) noexcept;
  void site_fill_plan() noexcept;
  void raise(std::size_t kind, bool active, std::int8_t severity, std::int8_t source, std::int8_t clear,
             std::int8_t unit, double value, double limit, std::int32_t index) noexcept;

  ControllerConfig config_;
  planning::Scenario scenario_;
  std::unique_ptr<planning::MachineModel> model_;
  std::unique_ptr<planning::CollisionWorld> plan_world_;    //!< dilated by the planning margin
  std::unique_ptr<planning::CollisionWorld> safety_world_;  //!< the scenario's dilation
  planning::PlanningProblem problem_{};
  planning::ReplanSettings replan_settings_{};
  std::unique_ptr<planning::Replanner> replanner_;
  //! A repair that keeps the old path's far end can make a long detour (a crane parked across the
  //! rest of the route): the same planner plans afresh from the stop in this one, and whichever
  //! path is quicker to follow becomes replanner_. Its problem differs from problem_ only in the
  //! start, which the re-planners copy at reset.
  planning::PlanningProblem spare_problem_{};
  std::unique_ptr<planning::Replanner> spare_;
  bool comparing_ = false;           //!< spare_ is planning afresh to compare with a long repair
  double repair_follow_s_ = 0.0;     //!< the long repair's estimated following time [s]
  //! For a machine stopped within the margins of plan_world_: the same planner in a world that
  //! keeps escape_margin_m, the obstacles at their own size.
  std::unique_ptr<planning::CollisionWorld> escape_world_;
  planning::PlanningProblem escape_problem_{};
  planning::ReplanSettings escape_settings_{};
  std::unique_ptr<planning::Replanner> escape_;
  planning::Replanner* active_ = nullptr;  //!< whose path is followed
  std::unique_ptr<planning::RetreatSearch> retreat_;
  bool retreat_searching_ = false;
  //! The planner's next solution follows retreat_from_: the escape from the retreat's end.
  bool retreat_prefix_ = false;
  //! The followed path: the planner's solution, possibly behind a retreat and shortened.
  planning::PathShortener path_;
  bool path_taken_ = false;  //!< the planner's current solution is in path_ (or being shortened)
  bool shortening_ = false;
  bool repairing_ = false;  //!< the planner's query is a repair or an escape, not a goal's first plan
  bool planned_afresh_ = false;  //!< the current repair spent its cap and was planned anew
  //! The current query was refused or escaped because a dynamic obstacle stood at the start.
  bool start_blocked_ = false;
  planning::JointVector retreat_from_;
  //! Least clearance, not lessened by any reach, where the machine started the escape it follows. [m]
  double escape_start_m_ = 0.0;
  bool replan_pending_ = false;            //!< a repair waits for the obstacles to settle
  planning::PlannerStatus planner_status_ = planning::PlannerStatus::NotReset;
  std::vector<ObstacleTracker> trackers_;
  //! Tracked poses of one obstacle, evenly over the speed window, for its speed.
  struct PoseHistory {
    static constexpr std::size_t kSamples = 21;
    std::array<std::int64_t, kSamples> t_us{};
    std::array<Eigen::Vector3d, kSamples> position_m{};
    std::array<double, kSamples> yaw_rad{};
    int obstacle = -1;           //!< its index among the scenario's dynamic obstacles (and the worlds')
    std::size_t count = 0;
    std::size_t head = 0;        //!< next slot to write
    double radius_m = 0.0;       //!< farthest point of the obstacle from its frame origin
    double speed_m_s = 0.0;      //!< bound on any of its points' speed over the window, floor included
    Eigen::Vector3d velocity_m_s = Eigen::Vector3d::Zero();  //!< of its frame origin over the window [m/s]
    double yaw_rate_rad_s = 0.0;  //!< about its frame's z over the window [rad/s]
    bool window_full = false;
  };
  std::vector<PoseHistory> histories_;  //!< one per tracker
  double obstacle_speed_m_s_ = 0.0;     //!< what the stop check assumes this cycle
  //! Obstacles moving faster than their floor plus settled_speed_m_s, by tracker index.
  [[nodiscard]] bool obstacle_moving(const PoseHistory& h) const noexcept {
    return h.window_full && h.speed_m_s > config_.obstacle_speed_floor_m_s + config_.settled_speed_m_s;
  }
  int approach_step_ = 0;          //!< predicted poses measured in the current scan
  double approach_s_ = std::numeric_limits<double>::infinity();  //!< the last scan's finding [s]
  int approach_obstacle_ = -1;     //!< which dynamic obstacle it names
  //! The scenario's working envelope (null: none): the limiter, and the stop check's sweep.
  std::unique_ptr<guidance::Envelope> envelope_;
  guidance::EnvelopeResult envelope_result_{};
  bool envelope_slowing_ = false;  //!< this cycle's command was slowed toward a limit (beyond rest_speed)
  //! The envelope as the planning and escape worlds' rule, each with its margin.
  std::unique_ptr<guidance::EnvelopeRule> plan_rule_;
  std::unique_ptr<guidance::EnvelopeRule> escape_rule_;
  guidance::StopCheck stop_check_;
  guidance::StopCheckResult check_{};
  std::unique_ptr<guidance::RatedCapacityLimiter> rcl_;
  guidance::RatedCapacityResult rcl_result_{};
  guidance::Supervisor supervisor_;
  guidance::PlausibilityMonitor monitor_;
  guidance::MachineTagCheck tag_check_;
  guidance::InclinometerCheck inclinometer_check_;
  bool inclinometer_missing_ = false;  //!< the bus plan has one, and it cannot be judged this cycle
  std::int64_t inclinometer_valid_us_ = -1;  //!< its last valid sample, -1 before the first [µs]
  std::array<std::uint8_t, planning::kMaxMachineTags> machine_tag_ids_{};
  std::array<guidance::MachineTagFix, planning::kMaxMachineTags> machine_tag_fixes_{};
  //! What the previous cycle commanded (the valve applies it now) and whether it kept pilot pressure.
  std::array<double, kMaxJoints> last_command_{};
  bool pilot_enabled_ = false;
  RateLimiter limiter_;
  guidance::OneJointAtATime generator_{};
  int n_ = 0;

  // Estimate.
  bool have_reading_ = false;
  planning::JointVector q_raw_;        //!< last decoded positions
  planning::JointVector q_unwrapped_;  //!< continuous joints unwrapped [rad | m]
  planning::JointVector q_wrapped_;    //!< in the model's ranges, for the planner [rad | m]
  std::array<std::int64_t, kMaxJoints> sample_us_{};
  std::array<double, kMaxJoints> velocity_{};
  std::array<double, kMaxJoints> acceleration_{};
  bool at_rest_ = false;
  bool joints_valid_ = false;

  // Goal and follower.
  planning::JointVector goal_;
  bool following_ = false;
  std::size_t path_size_ = 0;
  std::size_t target_ = 1;  //!< index of the waypoint being approached
  planning::JointVector origin_;  //!< unwrapped measured position at load: waypoint 0
  planning::JointVector target_unwrapped_;
  std::array<guidance::JointLimits, kMaxJoints> follow_limits_{};
  std::array<guidance::JointState, kMaxJoints> setpoint_{};
  std::array<guidance::JointState, kMaxJoints> next_{};
  std::array<double, kMaxJoints> v_target_{};
  planning::JointVector v_command_;  //!< for the load chart's cut
  planning::JointVector v_probe_;    //!< a velocity the envelope is asked about
  int moving_joint_ = -1;
  bool settled_ = false;                 //!< within the goal tolerance of the last waypoint, or timed out
  std::int64_t setpoint_done_us_ = -1;   //!< when the setpoint finished the last segment
  std::uint32_t plan_id_ = 0;

  // Alerts: one slot per kind, an id from raise to clear.
  static constexpr std::size_t kAlertKinds = 13;
  static_assert(kAlertKinds <= static_cast<std::size_t>(kSnapshotMaxAlerts), "every alert kind fits a snapshot");
  std::array<SnapshotAlert, kAlertKinds> alerts_{};
  std::array<bool, kAlertKinds> alert_active_{};
  std::array<std::int64_t, kAlertKinds> alert_seen_us_{};  //!< when each condition was last true [µs]
  std::int32_t next_alert_id_ = 1;
  std::int64_t rejected_until_us_ = 0;

  planning::Kinematics kinematics_{};
  std::int64_t now_us_ = 0;
  GuidanceSnapshot snap_{};
  ControllerStats stats_{};

  // Site member (null site_: none).
  std::unique_ptr<SiteMemberConfig> site_;
  SiteRoster site_roster_{};
  std::vector<SitePeerModel> site_peers_;
  std::array<SitePeerInput, kMaxSiteMachines> site_in_{};
  std::array<double, kMaxSiteMachines> site_meet_s_{};
  //! Per roster entry, the plan id that machine executed when my path was last planned. [-]
  std::array<std::int32_t, kMaxSiteMachines> site_planned_round_{};
  SiteDecision site_decision_{};
  SiteMotion site_motion_ = SiteMotion::Proceed;
  bool site_stale_ = false;       //!< a machine is stale or never heard
  bool site_was_stale_ = false;   //!< the same, the cycle before
  std::int64_t site_wait_since_us_ = 0;  //!< since when a higher-priority machine keeps me stopped [µs]
  bool site_replan_ = false;      //!< stop for a higher-priority machine: the supervisor re-plans
  bool site_worlds_due_ = false;  //!< no plan was being computed as the cycle began: the worlds may be posed
  int site_alert_id_ = 0;         //!< machine id the site alert names
  double site_speed_scale_ = 1.0;
  std::int32_t site_priority_ = 0;
  std::uint32_t site_plan_source_ = 0;  //!< plan_id_ of the content in site_plan_
  std::size_t site_plan_first_ = 0;     //!< first path waypoint in the content
  std::uint64_t site_plan_version_ = 0;
  site_state_t site_state_{};
  site_plan_t site_plan_{};
  planning::JointVector site_q_;   //!< scratch, mine [rad | m]
  planning::JointVector site_q2_;  //!< scratch, another machine's configuration [rad | m]
  planning::JointVector site_peer_q_;  //!< another machine's configuration at the meet scan's previous sample [rad | m]
  planning::JointVector site_v_;   //!< my velocity as the scan carries it forward [rad/s | m/s]
  planning::Kinematics site_kin_{};  //!< mine at this cycle's position, for the meet scan's box test
  planning::Kinematics site_way_kin_{};  //!< mine along my way at a later sample of the meet scan, likewise
};

}  // namespace mgc::firmware
