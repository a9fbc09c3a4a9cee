// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mgc/planning/load_chart.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/mobile_crane.hpp"

namespace mgc::planning {

//! Where one crane of the pair stands and how it is rigged for the lift.
struct CraneMount {
  Eigen::Vector3d base_position_m = Eigen::Vector3d::Zero();  //!< ground point on the swing axis [m]
  double base_yaw_rad = 0.0;  //!< carrier heading about world z; also turns the swing zero [rad]
  double boom_length_m = 0.0;  //!< fixed for the whole lift (seed 004: set before the load is attached) [m]
};

//! The lifted girder: uniform, hung by one cable at each end (seed 004 L96).
struct GirderSpec {
  double length_m = 0.0;   //!< anchor to anchor [m]
  double mass_kg = 0.0;    //!< incl. rigging [kg]
  double radius_m = 0.15;  //!< collision capsule around the anchor line [m]
};

//! A two-crane lift: the mounts, the girder and seed 004's suspension limits (Table 1).
struct DualCraneSpec {
  std::array<CraneMount, 2> cranes{};
  GirderSpec girder;
  double max_cable_tilt_rad = 0.0;   //!< phi_h,max: |cable tilt from vertical| [rad]
  double max_girder_tilt_rad = 0.0;  //!< phi_obj,max: |girder slope from horizontal| [rad]
  double anchor_step_m = 1.0;        //!< d_step: most a girder anchor or boom tip moves between edge samples [m]
  double capacity_reduction_pct = 0.0;  //!< tensions x (100 + pct) / 100 against the chart [%]
};

//! The dual-crane configuration's six joints, crane by crane -- swing, boom elevation, cable
//! length (seed 004 Eq. 2 order) -- named "swing_1", "boom_elevation_1", "cable_length_1",
//! "swing_2", ... and taken from the crane's own four mobile-crane joints; the boom length is
//! fixed per lift, and the cable is at most the boom long (seed 004 Table 1: C_max = l_b).
//! Throws std::invalid_argument when `crane_joints` are not a mobile crane's four or a boom
//! length lies outside the crane's boom_length range.
[[nodiscard]] std::vector<JointSpec> dual_crane_joints(const std::vector<JointSpec>& crane_joints,
                                                       const DualCraneSpec& spec);

// ---------------------------------------------------------------------------------------------
// Suspension: the closed chain tip 1 -> cable 1 -> girder -> cable 2 -> tip 2.

//! One suspension query in world coordinates.
struct SuspensionInput {
  Eigen::Vector3d tip_1_m = Eigen::Vector3d::Zero();  //!< boom tip (cable sheave) of crane 1 [m]
  Eigen::Vector3d tip_2_m = Eigen::Vector3d::Zero();  //!< [m]
  double cable_1_m = 0.0;         //!< [m]
  double cable_2_m = 0.0;         //!< [m]
  double girder_length_m = 0.0;   //!< [m]
  double max_cable_tilt_rad = 0.0;  //!< cable 1's tilt is searched within +-this [rad]
};

enum class SuspensionStatus : std::uint8_t {
  Ok = 0,
  NoEquilibrium,  //!< the lowest girder centre within the cable-1 tilt range is not interior
  TipsAligned,    //!< tips (almost) one above the other: no vertical plane through both
};

//! Equilibrium of the chain. In the vertical plane through both tips, a positive cable tilt moves
//! the anchor toward the other crane (seed 004 Eqs. 3-4); a positive girder tilt raises its
//! crane-2 end.
struct Suspension {
  SuspensionStatus status = SuspensionStatus::NoEquilibrium;
  double cable_tilt_1_rad = 0.0;  //!< from vertical [rad]
  double cable_tilt_2_rad = 0.0;  //!< [rad]
  double girder_tilt_rad = 0.0;   //!< from horizontal [rad]
  Eigen::Vector3d anchor_1_m = Eigen::Vector3d::Zero();  //!< B1, girder end under crane 1 [m]
  Eigen::Vector3d anchor_2_m = Eigen::Vector3d::Zero();  //!< [m]
  double tension_share_1 = 0.5;  //!< |F1| / (m g) [-]
  double tension_share_2 = 0.5;  //!< [-]
  //! NoEquilibrium: cable 1's tilt at the lowest centre found, on the edge of the range. [rad]
  double boundary_tilt_rad = 0.0;

  [[nodiscard]] bool ok() const noexcept { return status == SuspensionStatus::Ok; }
};

//! Seed 004's Appendix with the note's two corrections (A4 ends in - l_obj^2; A5's constant term
//! is C^2 - B^2): the sines of cable 2's tilt that close the chain for cable 1 at tilt_1, before
//! squaring's extraneous roots are filtered. In plane coordinates: x along tip 1 -> tip 2
//! horizontally, z up. Returns how many real roots went to `sines` (0, 1 or 2). RT-safe.
int appendix_cable_2_sines(double x1_m, double z1_m, double x2_m, double z2_m, double cable_1_m, double cable_2_m,
                           double girder_length_m, double tilt_1_rad, std::array<double, 2>& sines) noexcept;

//! The equilibrium as the lowest girder centre of gravity (seed 004, Insight 2): a coarse scan of
//! cable 1's tilt over +-max_cable_tilt_rad, then Brent's bracketed minimiser around the lowest
//! sample. For each tilt the Appendix gives cable 2's; a root counts only if it closes the
//! chain with the cable hanging down (cos > 0) and the girder not folded back. A minimum on the
//! edge of the range is NoEquilibrium: the chain would hang with cable 1 tilted beyond the limit.
//! Tensions from vertical force and torque balance. RT-safe.
[[nodiscard]] Suspension solve_suspension(const SuspensionInput& in) noexcept;

// ---------------------------------------------------------------------------------------------

//! Two mobile cranes lifting one girder (seed 004): q = (swing_1, boom_elevation_1,
//! cable_length_1, swing_2, boom_elevation_2, cable_length_2) [rad, rad, m, ...].
//!
//! Swing convention (note 004 §1.1, fitted to the paper's Table 1): the boom heads
//! psi = base_yaw + swing + 90 deg in the world xy plane, i.e. swing 0 points along the base's
//! +y and swing is counter-clockwise positive; elevation is above horizontal. The boom foot sits
//! boom_foot_forward_m ahead of the swing axis and boom_foot_height_m above the ground.
//!
//! Bodies per crane: carrier (fixed), superstructure (swings), boom (box), cable (capsule from
//! tip to anchor); then the girder (capsule from anchor to anchor). Every pair of bodies is
//! checked against each other except those attached (carrier-superstructure-boom of one crane,
//! boom-own cable, cable-girder) and the two fixed carriers.
//!
//! kind() is MobileCrane -- each of the pair is one; tell the pair apart by its type.
class DualCraneModel final : public MachineModel {
 public:
  enum Joint : int { kSwing1 = 0, kElevation1, kCable1, kSwing2, kElevation2, kCable2 };
  enum Frame : int { kFrameBase1 = 0, kFrameBoomTip1, kFrameBase2, kFrameBoomTip2, kFrameGirder };
  enum Body : int {
    kCarrier1 = 0, kSuperstructure1, kBoom1, kCable1Body, kCarrier2, kSuperstructure2, kBoom2, kCable2Body, kGirder
  };
  //! kPointGirderCentre is named "hook": the load's reference point, as on a single crane.
  enum Point : int { kPointBoomTip1 = 0, kPointAnchor1, kPointBoomTip2, kPointAnchor2, kPointGirderCentre };

  //! joints: dual_crane_joints() of the crane's joints. The chart, when given, rates each crane's
  //! cable tension at its radius. Throws std::invalid_argument for other joints or a bad spec.
  DualCraneModel(std::string name, std::vector<JointSpec> joints, const MobileCraneGeometry& geometry,
                 std::optional<LoadChart> chart, const DualCraneSpec& spec);

  [[nodiscard]] MachineKind kind() const noexcept override { return MachineKind::MobileCrane; }
  //! Bodies and key points; without an equilibrium the cables hang straight down and the girder
  //! points from anchor 1 toward anchor 2 (for drawing -- check_constraints rejects q).
  void forward_kinematics(const JointVector& q, Kinematics& out) const noexcept override;
  //! Seed 004's Fig. 4 after the joint ranges, then ours: tip distance, equilibrium, cable and
  //! girder tilt, girder above the ground, each crane's tension against its chart.
  [[nodiscard]] ConstraintVerdict check_constraints(const JointVector& q) const noexcept override;
  //! Seed 004 Eq. 21, stricter: samples enough that neither anchor nor boom tip moves more than
  //! anchor_step_m between two -- the larger anchor displacement (the paper: the mean) or each
  //! tip's arc bound (the chord understates a swing) plus the cable change, whichever is more.
  [[nodiscard]] int edge_min_samples(const JointVector& from, const JointVector& to) const noexcept override;
  //! False: the displacement bound leaves out the girder's own shift as the equilibrium moves.
  [[nodiscard]] bool displacement_bound_is_strict() const noexcept override { return false; }

  //! Boom tip of crane i (0 or 1) at q. [m]
  [[nodiscard]] Eigen::Vector3d boom_tip(const JointVector& q, int crane) const noexcept;
  //! Horizontal distance from crane i's swing axis to its boom tip. [m]
  [[nodiscard]] double radius_m(const JointVector& q, int crane) const noexcept;
  //! The suspension at q (cached per thread for the last q, so a validity check followed by
  //! forward kinematics solves once).
  [[nodiscard]] Suspension suspension(const JointVector& q) const noexcept;
  //! Crane i's rated capacity at radius_m from the chart: the boom-length row at or above the
  //! boom (the thesis's rule), the first rated radius at or beyond radius_m; 0 beyond the row;
  //! infinity without a chart. [lb]
  [[nodiscard]] double rated_capacity_lb(int crane, double radius_m, int* row = nullptr, int* column = nullptr) const noexcept;

  [[nodiscard]] const DualCraneSpec& spec() const noexcept { return spec_; }
  [[nodiscard]] const MobileCraneGeometry& geometry() const noexcept { return geometry_; }

 private:
  [[nodiscard]] SuspensionInput suspension_input(const JointVector& q) const noexcept;
  [[nodiscard]] double heading_rad(const JointVector& q, int crane) const noexcept;

  MobileCraneGeometry geometry_;
  std::optional<LoadChart> chart_;
  DualCraneSpec spec_;
  std::uint64_t cache_id_ = 0;  //!< tells this model's cached suspension from another's
  //! Per crane: the chart row used for its boom length, -1 when no row covers it.
  std::array<int, 2> chart_row_{-1, -1};
};

}  // namespace mgc::planning
