// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/dual_crane.hpp"
#include "mgc/planning/excavator.hpp"
#include "mgc/planning/load_chart.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "mgc/planning/obstacle.hpp"
#include "mgc/planning/planners/problem.hpp"
#include "mgc/planning/tower_crane.hpp"

namespace mgc::planning {

//! Where a value came from, so that checks made after parsing can still name the file and line.
struct SourceRef {
  std::string file;
  int line = 0;          //!< 1-based; 0 when unknown
  std::string field;     //!< dotted path, e.g. "task.load_lb"
};

//! A machine file: kind, joints with limits, fixed geometry, and (cranes) the load chart.
struct MachineDefinition {
  std::string file;
  std::string name;
  std::string source;  //!< where the numbers come from (free text)
  MachineKind kind = MachineKind::MobileCrane;
  std::vector<JointSpec> joints;
  MobileCraneGeometry mobile_crane;  //!< kind == MobileCrane
  TowerCraneGeometry tower_crane;    //!< kind == TowerCrane
  ExcavatorGeometry excavator;       //!< kind == Excavator
  std::optional<LoadChart> load_chart;
  std::optional<LuffRangeTable> luff_table;
};

//! The lift: what hangs on the hook and under which rule (cranes only).
struct TaskSpec {
  double load_lb = 0.0;                  //!< [lb]
  double capacity_reduction_pct = 0.0;   //!< [%]
  std::string outriggers;                //!< must match the chart's rigging
  double counterweight_lb = 0.0;         //!< must match the chart's rigging [lb]
  CraneConstraintMode constraint = CraneConstraintMode::None;
  Eigen::Vector3d load_size_m{1.0, 1.0, 1.0};  //!< [m]
  double sling_length_m = 0.0;                 //!< [m]
  SourceRef load_ref;
};

//! One key pose of a scripted dynamic obstacle; poses between keys are linear in position and
//! in yaw (the yaw is not wrapped, so a key sequence can swing through any angle).
struct Keyframe {
  double t_s = 0.0;                                   //!< [s] from the start of the scenario
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  //!< obstacle frame origin [m]
  double yaw_rad = 0.0;                               //!< obstacle frame about world z [rad]
};

//! A UWB tag fixed to a dynamic obstacle: the controller learns the obstacle's pose from its tags.
struct UwbTagSpec {
  int id = 0;                                         //!< 0..255, unique in the scenario
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  //!< in the obstacle's frame [m]
};

//! A UWB tag fixed to the machine itself: a second source of its pose beside the encoders
//! (docs/diagnostics.md "Machine tags").
struct MachineTagSpec {
  int id = 0;                                            //!< 0..255, unique in the scenario (obstacle tags too)
  std::string body;                                      //!< tag_mount_problem() accepts it (machine_tags.hpp)
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  //!< in that body's or frame's axes, from its origin [m]
  SourceRef ref;                                         //!< the entry's `body` field, for messages
};

struct DynamicObstacleSpec {
  DynamicObstacle obstacle;
  std::vector<Keyframe> motion;  //!< strictly increasing t_s, at least one key
  std::vector<UwbTagSpec> tags;  //!< may be empty: then no sensor sees it

  //! Pose at time t_s: held at the first key before it and at the last key after it.
  [[nodiscard]] Eigen::Isometry3d pose_at(double t_s) const noexcept;
  //! Whether the pose changes anywhere between from_s and to_s (from_s <= to_s).
  [[nodiscard]] bool moves_between(double from_s, double to_s) const noexcept;
  //! An upper bound on how far any point within reach_m of the obstacle's vertical axis moves
  //! between from_s and to_s (from_s <= to_s): per stretch between keys, the origin's travel
  //! plus the yaw turned times reach_m. [m]
  [[nodiscard]] double max_travel_m(double from_s, double to_s, double reach_m) const noexcept;
};

//! Planner parameters as the thesis names them (Table 4.1), in our units.
struct PlannerParams {
  std::uint64_t seed = 0;
  int max_iterations = 1000;          //!< the thesis's Max_Nodes, an iteration cap
  double goal_bias = 0.1;             //!< Biasing_Probability
  int space_resolution = 50;          //!< Space_Resolution (hypercube subdivisions per joint)
  double error_tolerance = 1.0;       //!< goal tolerance in steps of each joint
  double dilation_m = 0.15;           //!< CSpace_Dilation [m]
  int replan_max_iterations = 2000;   //!< Replan_Max_Nodes
  double replan_goal_bias = 0.15;     //!< Replan_Biasing_Probability
};

//! The `simulation` section: how mgc-sim behaves on this site. Every field is optional; an absent
//! one keeps the simulator's default (docs/simulator.md). Planning ignores the section.
struct SimulationSpec {
  std::optional<double> physics_rate_hz;       //!< [Hz]
  std::optional<double> actuator_lag_s;        //!< [s]
  std::optional<double> valve_deadband_pct;    //!< [%]
  std::optional<double> encoder_noise_counts;  //!< 1-sigma [count]
  std::optional<double> uwb_noise_sigma_m;     //!< [m]
  std::optional<double> uwb_rate_hz;           //!< [Hz]
  std::optional<double> uwb_latency_ms;        //!< [ms]
  std::optional<double> uwb_dropout_pct;       //!< [%]
  std::optional<double> scenario_time_offset_s;  //!< [s]
  //! Faults in mgc-sim's --fault syntax, each with where it was written.
  std::vector<std::pair<std::string, SourceRef>> faults;
};

//! Seed 003's free-motion cycle of an excavator (the `work_cycle` section): the scenario's start is
//! the dig pose (bucket full), its goal the dump pose (bucket at the start's ground angle);
//! dumping moves the arm and bucket to `dumped`, returning goes on to `next_dig`.
struct WorkCycleSpec {
  JointVector dumped;    //!< the goal's swing and boom, the arm and bucket after dumping
  JointVector next_dig;  //!< where returning ends: the start unless the file gives another
  SourceRef dumped_ref;
  SourceRef next_dig_ref;  //!< field empty when the file gives no next_dig
};

//! A virtual wall of the working envelope: allowed where normal . p - offset_m >= 0 (world frame).
struct EnvelopeWallSpec {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();  //!< unit, into the allowed side
  double offset_m = 0.0;                              //!< [m]
};

//! The `envelope` section: working-envelope limits as the commercial limiters have them
//! (docs/safety.md), on named key points of the machine. Every limit is optional; slew limits come
//! in pairs. The controller plans inside them and its limiter and stop check enforce them.
struct EnvelopeSpec {
  std::vector<std::string> points;  //!< MachineModel::key_point_names() entries, resolved by the user
  SourceRef points_ref;
  std::optional<double> height_ceiling_m;  //!< world z [m]
  std::optional<double> depth_floor_m;     //!< world z [m]
  std::optional<double> slew_left_rad;     //!< most counter-clockwise azimuth, base frame [rad]
  std::optional<double> slew_right_rad;    //!< most clockwise azimuth, base frame [rad]
  std::optional<double> radius_min_m;      //!< from the base z axis [m]
  std::optional<double> radius_max_m;      //!< [m]
  std::vector<EnvelopeWallSpec> walls;
  std::optional<double> slowdown_band_m;   //!< [m]; absent: the limiter's default
};

//! The `guidance` section: the controller's clearance margins on this site, beyond the planner's
//! dilation (docs/controller.md, "Margins"). Every field is optional; an absent one keeps mgc's
//! default, which suits a crane. An excavator works close to what it digs and loads, and needs
//! smaller ones. The controller checks the combination and names `ref` when it does not hold.
struct GuidanceSpec {
  std::optional<double> stop_margin_m;      //!< the stop check's stop zone [m]
  std::optional<double> warning_margin_m;   //!< the stop check's slow-down zone [m]
  std::optional<double> planning_margin_m;  //!< what plans and repairs keep [m]
  std::optional<double> escape_margin_m;    //!< what an escape keeps [m]
  SourceRef ref;
};

struct Scenario {
  std::string file;
  std::string name;
  std::string description;
  MachineDefinition machine;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  std::optional<TaskSpec> task;     //!< cranes
  std::vector<StaticObstacle> obstacles;
  std::vector<DynamicObstacleSpec> dynamic_obstacles;
  std::vector<MachineTagSpec> machine_tags;  //!< may be empty: no tag on the machine
  JointVector start;
  JointVector goal;
  SourceRef start_ref;
  SourceRef goal_ref;
  PlannerParams planner;
  SimulationSpec simulation;
  std::optional<WorkCycleSpec> work_cycle;  //!< excavators only
  std::optional<EnvelopeSpec> envelope;
  std::optional<GuidanceSpec> guidance;
  //! Two cranes of the machine file's type on one girder (seed 004); then `machine.joints` are
  //! dual_crane_joints(), and there is no base or task.
  std::optional<DualCraneSpec> dual_crane;
};

//! The machine model a scenario describes. Throws std::invalid_argument with the reason when the
//! definition and task do not fit together (callers at the file edge add the file and line).
[[nodiscard]] std::unique_ptr<MachineModel> build_model(const Scenario& scenario);

//! The collision world of a scenario with its dynamic obstacles posed at t_s. With
//! predicted_poses = P, each dynamic obstacle d is added P + 1 times, as world indices
//! d (P + 1) + k, so that copies k = 1..P can stand where it will be (execute_with_replanning).
[[nodiscard]] std::unique_ptr<CollisionWorld> build_world(const Scenario& scenario, const MachineModel& model,
                                                          double t_s = 0.0, int predicted_poses = 0);

//! The scenario's query (start, goal and its planner parameters) on a built model and world;
//! the seed is the scenario's. The model and world must outlive the problem.
[[nodiscard]] PlanningProblem planning_problem(const Scenario& scenario, const MachineModel& model, CollisionWorld& world);

//! Per-joint edge-check step: range / space_resolution (pi / space_resolution for continuous
//! joints, since the thesis's Eq. 3.17 degenerates to 0 for a full circle). [rad | m]
[[nodiscard]] JointVector step_sizes(const MachineModel& model, int space_resolution);

}  // namespace mgc::planning
