// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "mgc/planning/load_chart.hpp"
#include "mgc/planning/machine_model.hpp"

namespace mgc::planning {

//! Fixed dimensions of a hydraulic mobile crane. [m]
struct MobileCraneGeometry {
  Eigen::Vector3d carrier_size_m{12.0, 2.6, 2.0};          //!< box, base frame [m]
  Eigen::Vector3d carrier_centre_m{0.0, 0.0, 1.0};         //!< in the base frame [m]
  Eigen::Vector3d superstructure_size_m{5.0, 2.5, 1.8};    //!< box, turns with swing [m]
  Eigen::Vector3d superstructure_centre_m{-1.0, 0.0, 2.9}; //!< in the swing frame: x forward [m]
  double boom_foot_forward_m = 1.0;  //!< boom foot pin ahead of the swing axis [m]
  double boom_foot_height_m = 3.0;   //!< boom foot pin above the ground [m]
  double boom_width_m = 0.9;         //!< boom cross-section across the pivot axis [m]
  double boom_depth_m = 1.1;         //!< boom cross-section in the luffing plane [m]
  double cable_radius_m = 0.05;      //!< hoist rope bundle and hook block radius [m]
};

enum class CraneConstraintMode : std::uint8_t {
  None,       //!< joint ranges only
  LoadChart,  //!< the thesis's load-chart rule (LoadChartRule)
  LuffTable,  //!< seed 000's luff range per boom length (LuffRangeTable)
};

//! What is lifted and under which rule. Loads are in pounds because the published charts are.
struct LiftTask {
  double load_lb = 0.0;                           //!< rated load incl. hook block and rigging [lb]
  double capacity_reduction_pct = 0.0;            //!< thesis LVA: load x (100 + pct) / 100 [%]
  CraneConstraintMode constraint = CraneConstraintMode::LoadChart;
  Eigen::Vector3d load_size_m{2.0, 2.0, 1.0};     //!< box hung under the hook [m]
  double sling_length_m = 2.0;                    //!< hook to top of the load [m]
};

//! Hydraulic mobile crane as in the ICE-Planner thesis (Grove TMS870):
//! q = (swing [rad], boom_elevation [rad above horizontal], boom_length [m], cable_length [m]).
//!
//! Forward kinematics follow the thesis DH chain (App. C, Eq. 3.1) with the zero-length link that
//! keeps the cable vertical (Eq. 3.3-3.8). The thesis's frame {0} has z pointing down and measures
//! the boom angle from vertical; ours has z up and measures elevation from horizontal, so
//! world_from_thesis0 = R_x(pi), theta1 = -swing, theta2 = pi/2 - boom_elevation. The boom foot
//! pin sits at (boom_foot_forward_m, boom_foot_height_m) in the swing frame (DH a1 and d1).
class MobileCrane final : public MachineModel {
 public:
  enum Joint : int { kSwing = 0, kBoomElevation = 1, kBoomLength = 2, kCableLength = 3 };
  enum Frame : int { kFrameBase = 0, kFrameSwing, kFrameBoomFoot, kFrameBoomTip, kFrameHook };
  enum Body : int { kCarrier = 0, kSuperstructure, kBoom, kCable, kLoad, kSling };
  enum Point : int { kPointBoomFoot = 0, kPointBoomTip, kPointHook, kPointLoadBottom };

  //! Throws std::invalid_argument for joints that are not the four above in that order, or a
  //! load the chart cannot rate at any boom length when the load-chart rule is in force.
  MobileCrane(std::string name, std::vector<JointSpec> joints, const MobileCraneGeometry& geometry,
              const LoadChart& chart, std::optional<LuffRangeTable> luff_table, const LiftTask& task,
              const Eigen::Isometry3d& world_from_base);

  [[nodiscard]] MachineKind kind() const noexcept override { return MachineKind::MobileCrane; }
  void forward_kinematics(const JointVector& q, Kinematics& out) const noexcept override;
  [[nodiscard]] ConstraintVerdict check_constraints(const JointVector& q) const noexcept override;
  //! The load chart (or luff table) along the edge, exactly: boom length and elevation are linear
  //! along it, and the rule is constant over each row's span of boom lengths
  //! (LoadChartRule::check_edge). The load-above-ground rule stays checked at the samples.
  [[nodiscard]] ConstraintVerdict check_edge_constraints(const JointVector& from, const JointVector& to,
                                                         double& t_first) const noexcept override;
  //! Along a straight edge the boom length and elevation move linearly, so the boom reaches at
  //! most (longer end) x cos(lower end's elevation) from the swing axis, and the luffing radius is
  //! at most the longer end's boom.
  [[nodiscard]] double edge_displacement_bound(const JointVector& from, const JointVector& to,
                                               int joint) const noexcept override;
  //! In a box: its longest boom at its lowest elevation, the same way.
  [[nodiscard]] double box_displacement_bound(const JointVector& lo, const JointVector& hi,
                                              int joint) const noexcept override;

  [[nodiscard]] const MobileCraneGeometry& geometry() const noexcept { return geometry_; }
  [[nodiscard]] const LiftTask& task() const noexcept { return task_; }
  [[nodiscard]] const LoadChart& chart() const noexcept { return chart_; }
  [[nodiscard]] const LoadChartRule* chart_rule() const noexcept { return rule_ ? &*rule_ : nullptr; }
  //! Horizontal distance from the swing axis to the hook. [m]
  [[nodiscard]] double load_radius_m(const JointVector& q) const noexcept;

 private:
  MobileCraneGeometry geometry_;
  LoadChart chart_;
  std::optional<LuffRangeTable> luff_table_;
  LiftTask task_;
  std::optional<LoadChartRule> rule_;
  //! Per-joint displacement bound with the boom at most boom_m long and at least
  //! lowest_elevation high. [m/rad | m/m]
  [[nodiscard]] double reach_bound(double boom_m, double lowest_elevation, int joint) const noexcept;

  double superstructure_reach_m_ = 0.0;  //!< farthest superstructure corner from the swing axis [m]
  //! Farthest body point beyond the boom tip's radius: the load's (and sling's) corners or the boom box's. [m]
  double boom_margin_m_ = 0.0;
};

}  // namespace mgc::planning
