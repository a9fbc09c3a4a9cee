// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

#include "mgc/planning/planners/node_tree.hpp"
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/random.hpp"
#include "mgc/planning/spline_trajectory.hpp"

namespace mgc::planning {

//! Seed 002's cart-RRT (Ragaglia, Argiolas & Niccolini): a single tree grown in the space of the
//! tool point -- the hook of a crane, the bucket tip of an excavator -- whose edges are straight
//! Cartesian lines tracked by differential inverse kinematics; each iteration either extends
//! toward a random Cartesian sample or, with probability goal_bias, runs the greedy extension
//! toward a point of the Cartesian goal region (Alg. 1-3). The path found is shortcut with
//! straight Cartesian lines, then a clamped cubic spline through evenly spaced via
//! configurations, uniformly time-scaled to the joints' velocity and acceleration limits (§2.6).
//!
//! Edges (Alg. 4, the note's robust variant): the line is cut into targets at most
//! cart_step_m() apart and each is tracked by Newton steps of a weighted, damped least-squares
//! inverse of a central-difference Jacobian; joints at their end stops drop out of the solve.
//! Every stored configuration joins its predecessor by a straight joint-space edge checked by
//! CollisionWorld::validate_edge at the problem's step, so the tree -- and every path -- is made of
//! ordinary valid joint-space edges. Each tracked configuration is a tree node (the paper keeps
//! them in the edge's Q matrix), so nearest-neighbour search, by task-space distance, sees them
//! too. An edge is all or nothing, as in the paper: one that fails part-way adds no node.
//!
//! Task space and redundancy:
//!  - tower crane: the hook (slew, trolley, hoist: square, one solution);
//!  - excavator: the bucket tip and the bucket's ground angle (swing, boom, arm, bucket: square);
//!    samples draw the angle between the start's and the goal's, so a move-to-dump with both
//!    equal keeps the soil in all the way, as seed 003 asks;
//!  - mobile crane: the hook with four joints, one redundant. The least-squares step minimises
//!    the joints' rates in units of their top speeds (sum (dq_j / v_j)^2), and a secondary
//!    objective in the Jacobian's null space draws the redundant joints toward the goal
//!    configuration, so a node that reaches the goal's hook position is close to the goal.
//!
//! path() is the spline sampled as densely as validate_edge samples an edge (no joint moving more
//! than a step, no body point more than the dilation, between samples), every chord validated:
//! so the spline itself keeps the half dilation a valid edge keeps. A via set whose spline fails
//! is replaced by one twice as dense; when even the spline through every shortcut configuration
//! fails, the trajectory stops at each of them and path() is the shortcut path itself.
//!
//! Resumable and allocation-free after reset(): the node pool holds node_capacity nodes (default
//! 8 per iteration); the tree's path is copied into a buffer of at most 4096 configurations, and
//! a longer one is reported as PoolExhausted too. One iteration is one extension while growing,
//! one shortcut attempt, or one spline round's set-up or 16 of its chords; max_iterations caps
//! the growing only.
class CartRrtPlanner final : public Planner {
 public:
  //! Post-processing and task-space figures of the last query.
  struct Report {
    double raw_tool_length_m = 0.0;       //!< tool-point path length of the tree's path [m]
    double tool_length_m = 0.0;           //!< the same after shortcutting [m]
    int raw_nodes = 0;                    //!< configurations on the tree's path
    int waypoints = 0;                    //!< configurations after shortcutting
    int shortcuts = 0;                    //!< shortcuts accepted
    int spline_rounds = 0;                //!< via sets tried (each denser than the last)
    int vias = 0;                         //!< via configurations of the final trajectory
    bool stops_at_vias = false;           //!< fallback: rest to rest between waypoints
    double duration_s = 0.0;              //!< trajectory duration = k_tau [s]
    int post_iterations = 0;              //!< iterations spent after the goal was reached
  };

  //! Shortcut attempts after the path is found ([GAP] in seed 002; smoothing's default).
  static constexpr int kShortcutAttempts = 50;
  //! Vias of the first spline round ([GAP]); each failing round doubles the density.
  static constexpr int kInitialVias = 8;

  [[nodiscard]] std::string_view name() const noexcept override { return "cart-rrt"; }
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;

  //! The time-scaled trajectory once step() returned Solved.
  [[nodiscard]] const SplineTrajectory& trajectory() const noexcept { return trajectory_; }
  //! The shortcut path the trajectory interpolates (valid straight joint-space edges).
  [[nodiscard]] const std::vector<JointVector>& waypoints() const noexcept { return waypoints_; }
  [[nodiscard]] const Report& report() const noexcept { return report_; }

  //! Spacing of the tracked targets along a Cartesian edge and the longest extension, set at
  //! reset from the tool point's workspace box (its diagonal / 200 and / 20). [m]
  [[nodiscard]] double cart_step_m() const noexcept { return cart_step_m_; }
  [[nodiscard]] double max_length_m() const noexcept { return max_length_m_; }
  //! Task coordinates of q: tool point (x, y, z) [m] and, for the excavator, the bucket's ground
  //! angle [rad] (0 otherwise).
  [[nodiscard]] Eigen::Vector4d task_point(const JointVector& q) const noexcept;
  //! d task / d q by central differences. Column j: per unit of joint j.
  void jacobian(const JointVector& q, Eigen::Matrix<double, 4, kMaxJoints>& out) const noexcept;

 private:
  enum class Phase : std::uint8_t { Grow, Shortcut, Spline, Done };
  enum class Track : std::uint8_t { Reached, Failed, Full };

  //! Tracks the straight task-space line from q (at task point from) to `to`, appending the
  //! configurations after q to chain_ and their task points to chain_points_, each joined to
  //! its predecessor by a valid edge. Redundant joints are drawn toward `attractor`: the goal
  //! while growing, the far end's configuration while shortcutting.
  [[nodiscard]] Track track_line(const JointVector& q, const Eigen::Vector4d& from, const Eigen::Vector4d& to,
                                 const JointVector& attractor) noexcept;
  //! Newton steps from q to the task point `target`; false when they do not converge.
  [[nodiscard]] bool solve_ik(JointVector& q, const Eigen::Vector4d& target, const JointVector* attractor) noexcept;
  //! One damped, weighted least-squares step toward `error`, joints saturating at their end
  //! stops; plus, given an attractor, the null-space pull toward it.
  [[nodiscard]] bool ik_step(const JointVector& q, const Eigen::Vector4d& error, const JointVector* attractor,
                             JointVector& dq) noexcept;
  [[nodiscard]] int nearest(const Eigen::Vector4d& p) const noexcept;
  [[nodiscard]] Eigen::Vector4d random_task_point() noexcept;
  [[nodiscard]] Eigen::Vector4d goal_region_point() noexcept;
  [[nodiscard]] double task_distance_m(const Eigen::Vector4d& a, const Eigen::Vector4d& b) const noexcept;
  //! Adds chain_ under `parent`; the index of its last node, -1 when the pool is full.
  [[nodiscard]] int add_chain(int parent) noexcept;
  //! Extends from tree node `from` toward `target` by at most max_length_m().
  [[nodiscard]] Track extend(int from, const Eigen::Vector4d& target, bool& reached, int& added) noexcept;
  //! From node `from` inside the goal region: the Cartesian line to the goal's task point, then
  //! the joint-space edge to the exact goal. True when the goal joined the tree.
  [[nodiscard]] Track connect_goal(int from, bool& joined) noexcept;
  void grow_iteration() noexcept;
  void shortcut_iteration() noexcept;
  void spline_iteration() noexcept;
  [[nodiscard]] bool start_spline_round() noexcept;

  const PlanningProblem* problem_ = nullptr;
  Random random_;
  NodeTree tree_;
  std::vector<Eigen::Vector4d> points_;  //!< task point of every tree node
  int tool_ = -1;                        //!< key point index of the hook or bucket tip
  bool pitch_task_ = false;              //!< excavator: the bucket's ground angle is a task row
  double pitch_lo_rad_ = 0.0;            //!< sampled ground-angle interval [rad]
  double pitch_hi_rad_ = 0.0;
  Eigen::Vector3d box_lo_m_ = Eigen::Vector3d::Zero();  //!< sampling box of the tool point [m]
  Eigen::Vector3d box_hi_m_ = Eigen::Vector3d::Zero();
  double cart_step_m_ = 0.0;
  double max_length_m_ = 0.0;
  Eigen::Vector4d goal_point_ = Eigen::Vector4d::Zero();
  JointVector weights_;                  //!< v_j^2: the least-squares step's joint weights
  std::array<double, kMaxJoints> stop_lo_{};  //!< tracking's joint interval, inside the range [rad | m]
  std::array<double, kMaxJoints> stop_hi_{};
  mutable Kinematics kinematics_;        //!< scratch for task_point()

  Phase phase_ = Phase::Done;
  PlannerStatus status_ = PlannerStatus::NotReset;
  int iterations_ = 0;
  int grow_iterations_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  int greedy_node_ = -1;                 //!< the greedy extension's current node, -1 when idle
  Eigen::Vector4d greedy_target_ = Eigen::Vector4d::Zero();
  int shortcut_attempts_ = 0;
  int spline_vias_ = 0;                  //!< vias asked for in the current round
  std::size_t chord_ = 0;                //!< next chord of path_ to validate

  std::vector<JointVector> chain_;        //!< configurations of the line being tracked
  std::vector<Eigen::Vector4d> chain_points_;
  std::vector<JointVector> waypoints_;    //!< tree path, then shortcut path
  std::vector<Eigen::Vector4d> waypoint_points_;
  std::vector<JointVector> scratch_;      //!< next shortcut path
  std::vector<Eigen::Vector4d> scratch_points_;
  std::vector<double> arc_;               //!< cumulative chord time along waypoints_ [s]
  std::vector<JointVector> vias_;
  SplineTrajectory trajectory_;
  std::vector<JointVector> path_;
  Report report_;
};

}  // namespace mgc::planning
