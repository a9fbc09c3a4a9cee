// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mgc/limits.hpp"
#include "mgc/planning/constraint.hpp"
#include "mgc/planning/joint.hpp"

namespace mgc::planning {

enum class MachineKind : std::uint8_t { MobileCrane, TowerCrane, Excavator };

[[nodiscard]] const char* to_string(MachineKind kind) noexcept;

enum class BodyShape : std::uint8_t {
  Box,      //!< size_m = full extents along the body's x, y, z axes
  Capsule,  //!< size_m = (2 r, 2 r, length of the cylindrical part along body z)
};

//! A collision body of a machine. Bodies whose size depends on the configuration (a telescopic
//! boom, a hoist cable) are `resizable`; the collision world resizes their shapes in place.
struct BodySpec {
  std::string name;
  BodyShape shape = BodyShape::Box;
  bool resizable = false;
};

//! Pose and current size of one body. [m]
struct BodyState {
  Eigen::Isometry3d world_from_body = Eigen::Isometry3d::Identity();  //!< body centre and axes
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();                   //!< see BodyShape [m]
};

//! Two bodies of the same machine that may hit each other (a load swung into its own carrier).
struct SelfPair {
  int body_a = 0;
  int body_b = 0;
};

//! Everything forward kinematics gives for one configuration: the kinematic frames of the chain,
//! the collision bodies and the named key points, all in world coordinates. Fixed capacity.
struct Kinematics {
  std::array<Eigen::Isometry3d, kMaxFrames> frames{};
  std::array<BodyState, kMaxBodies> bodies{};
  std::array<Eigen::Vector3d, kMaxKeyPoints> points{};
};

//! A machine: its joints with limits, its kinematic chain, its collision bodies and its
//! engineering constraints. Immutable after construction; every const member is thread-safe and
//! RT-safe (no allocation, no throw) unless it says otherwise.
class MachineModel {
 public:
  virtual ~MachineModel() = default;
  MachineModel(const MachineModel&) = delete;
  MachineModel& operator=(const MachineModel&) = delete;

  [[nodiscard]] virtual MachineKind kind() const noexcept = 0;
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

  [[nodiscard]] int dof() const noexcept { return static_cast<int>(joints_.size()); }
  [[nodiscard]] std::span<const JointSpec> joints() const noexcept { return joints_; }
  [[nodiscard]] std::span<const std::string> frame_names() const noexcept { return frame_names_; }
  [[nodiscard]] std::span<const BodySpec> bodies() const noexcept { return bodies_; }
  [[nodiscard]] std::span<const std::string> key_point_names() const noexcept { return key_point_names_; }
  [[nodiscard]] std::span<const SelfPair> self_pairs() const noexcept { return self_pairs_; }
  //! Index of the named joint, frame, body or key point, or -1.
  [[nodiscard]] int joint_index(std::string_view name) const noexcept;
  [[nodiscard]] int body_index(std::string_view name) const noexcept;
  [[nodiscard]] int key_point_index(std::string_view name) const noexcept;

  //! Pose of the machine's base (carrier, crane foundation, undercarriage) on the site.
  [[nodiscard]] const Eigen::Isometry3d& world_from_base() const noexcept { return world_from_base_; }

  //! Frames, bodies and key points for q, in world coordinates. q must have dof() entries.
  virtual void forward_kinematics(const JointVector& q, Kinematics& out) const noexcept = 0;

  //! The machine's engineering constraints at q (load chart, luff range, load above ground, ...),
  //! joint ranges excluded. The default has none.
  [[nodiscard]] virtual ConstraintVerdict check_constraints(const JointVector& q) const noexcept;

  //! The machine's constraints along the whole straight edge from -> to (MachineModel::interpolate),
  //! between its samples too: ok only if check_constraints() holds at every configuration of the
  //! edge that the model's rules can tell apart. Otherwise t_first receives the first fraction of
  //! the edge at which they fail (on the boundary of the failing stretch). The default makes no
  //! check beyond the samples; a model whose constraints can fail between samples overrides it.
  [[nodiscard]] virtual ConstraintVerdict check_edge_constraints(const JointVector& from, const JointVector& to,
                                                                 double& t_first) const noexcept;

  //! First joint outside its range, or -1. Continuous joints accept any finite value.
  [[nodiscard]] int joint_out_of_range(const JointVector& q) const noexcept;

  //! Upper bound on how far any point of any body moves per unit of motion of `joint`, the
  //! others held, anywhere in the joint ranges: m per rad for a revolute joint (the farthest body
  //! point from its axis), m per m for a prismatic one.
  [[nodiscard]] double displacement_bound(int joint) const noexcept {
    return displacement_bound_[static_cast<std::size_t>(joint)];
  }
  //! Whether displacement_bound() bounds every body point's motion along any straight joint-space
  //! motion, so that a clearance from one configuration certifies those within that travel
  //! (CollisionWorld::certify_edges). Default: true.
  [[nodiscard]] virtual bool displacement_bound_is_strict() const noexcept { return true; }
  //! The same bound, valid only along the straight edge from -> to and so possibly tighter. Edge
  //! checks use it to bound how far the machine moves between samples. Default: the global one.
  [[nodiscard]] virtual double edge_displacement_bound(const JointVector& from, const JointVector& to,
                                                       int joint) const noexcept;
  //! The same bound, valid anywhere in the joint box lo <= q <= hi (per joint; a continuous
  //! joint's interval may run past +-pi). It may not be lower anywhere in the box than at any of
  //! its points. Clearance balls take it over a box around their centre. Default: the global one.
  [[nodiscard]] virtual double box_displacement_bound(const JointVector& lo, const JointVector& hi,
                                                      int joint) const noexcept;
  //! Fewest samples the straight edge from -> to needs by the model's own rule (the dual crane's:
  //! girder anchors move at most its anchor step between samples); edge checks take at least this
  //! many. Default: 1.
  [[nodiscard]] virtual int edge_min_samples(const JointVector& from, const JointVector& to) const noexcept;

  //! to - from per joint; continuous joints take the shorter way round, half a turn the negative
  //! way (shorter_turn()). [rad | m]
  [[nodiscard]] JointVector difference(const JointVector& from, const JointVector& to) const noexcept;
  //! from + t (to - from) along difference(); continuous joints are re-wrapped into [-pi, pi).
  [[nodiscard]] JointVector interpolate(const JointVector& from, const JointVector& to, double t) const noexcept;

 protected:
  MachineModel(std::string name, std::vector<JointSpec> joints, const Eigen::Isometry3d& world_from_base);

  std::string name_;
  std::vector<JointSpec> joints_;
  std::vector<std::string> frame_names_;
  std::vector<BodySpec> bodies_;
  std::vector<std::string> key_point_names_;
  std::vector<SelfPair> self_pairs_;
  std::vector<double> displacement_bound_;  //!< per joint, set by each model [m/rad | m/m]
  Eigen::Isometry3d world_from_base_ = Eigen::Isometry3d::Identity();
};

//! Poses the hoist rope (a vertical capsule from `top` down to `hook`), the rigging (a box with
//! the load's footprint from the hook down to the load's top face: it holds every sling from the
//! hook to lifting points on that face; the load's own box when the sling length is 0) and the
//! load box hung `sling_length_m` under the hook, all turned like `heading`; returns the load's
//! bottom centre. Shared by the cranes. RT-safe.
Eigen::Vector3d hang_load(const Eigen::Matrix3d& heading, const Eigen::Vector3d& top, const Eigen::Vector3d& hook,
                          const Eigen::Vector3d& up, double cable_radius_m, double cable_length_m,
                          const Eigen::Vector3d& load_size_m, double sling_length_m, BodyState& cable,
                          BodyState& sling, BodyState& load) noexcept;

//! Craig's (modified) Denavit–Hartenberg link transform, the form of the thesis's Eq. 2.1:
//! RotX(alpha_prev) * TransX(a_prev) * RotZ(theta) * TransZ(d).
[[nodiscard]] Eigen::Isometry3d dh_modified(double alpha_prev_rad, double a_prev_m, double theta_rad,
                                            double d_m) noexcept;

}  // namespace mgc::planning
