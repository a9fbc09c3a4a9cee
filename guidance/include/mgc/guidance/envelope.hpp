// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::guidance {

//! Which working-envelope limit a distance or a cut refers to (docs/safety.md).
enum class EnvelopeLimit : std::int8_t {
  None = 0,
  HeightCeiling,  //!< point height above the world's z = 0 must stay <= ceiling
  DepthFloor,     //!< point height must stay >= floor
  SlewLeft,       //!< point azimuth about the base z axis must stay <= left (counter-clockwise)
  SlewRight,      //!< point azimuth must stay >= right
  RadiusMin,      //!< horizontal distance of the point from the base z axis >= min
  RadiusMax,      //!< ... <= max
  Wall,           //!< point on the allowed side of a virtual wall (a half-space)
};

[[nodiscard]] const char* to_string(EnvelopeLimit limit) noexcept;

//! A virtual wall: the allowed side is where normal . p - offset_m >= 0 (world frame). normal is a
//! unit vector pointing into the allowed side.
struct EnvelopeWall {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  double offset_m = 0.0;  //!< [m]
};

//! Working-envelope limits as the commercial limiters have them (DOMAIN-FACTS §4.4): height, depth,
//! slew left/right, min/max radius, virtual walls. Each applies to every monitored point (key points
//! of the machine model: the hook or bucket tip and the boom tip, say). Distances are in metres,
//! slew included (arc length at the point's radius), so one slowdown band fits every limit.
struct EnvelopeConfig {
  static constexpr int kMaxPoints = kMaxKeyPoints;
  static constexpr int kMaxWalls = 8;

  std::array<int, kMaxPoints> points{};  //!< key-point indices into MachineModel::key_point_names()
  int point_count = 0;

  bool height_ceiling_enabled = false;
  double height_ceiling_m = 0.0;  //!< world z [m]
  bool depth_floor_enabled = false;
  double depth_floor_m = 0.0;     //!< world z [m]
  bool slew_enabled = false;
  double slew_left_rad = 0.0;     //!< most counter-clockwise allowed azimuth in the base frame [rad]
  double slew_right_rad = 0.0;    //!< most clockwise allowed azimuth in the base frame [rad]
  bool radius_min_enabled = false;
  double radius_min_m = 0.0;      //!< [m] from the base z axis
  bool radius_max_enabled = false;
  double radius_max_m = 0.0;      //!< [m]
  std::array<EnvelopeWall, kMaxWalls> walls{};
  int wall_count = 0;

  //! Inside this distance of a limit a joint motion that approaches it is scaled down linearly, to
  //! zero at the limit. 2 m is Prolec PMERail's slowdown distance (DOMAIN-FACTS §4.4). [m]
  double slowdown_band_m = 2.0;
  //! Below this radius a point's azimuth is not defined well enough to limit slew. [m]
  double min_slew_radius_m = 0.5;
  //! Step of the central differences that give d(point)/dq: small against the machine, large
  //! against rounding. [rad | m]
  double gradient_step = 1e-5;
};

//! The nearest (or acting) limit: which, at which monitored point, and its signed distance, positive
//! inside the envelope. [m]
struct EnvelopeDistance {
  EnvelopeLimit limit = EnvelopeLimit::None;
  int point = -1;  //!< key-point index
  int wall = -1;   //!< Wall only: index into EnvelopeConfig::walls
  double distance_m = 0.0;
};

//! Result of Envelope::limit_velocity.
struct EnvelopeResult {
  planning::JointVector allowed_velocity;  //!< [rad/s | m/s] per joint
  std::array<double, kMaxJoints> joint_scale{};  //!< allowed / commanded per joint, in [0, 1]
  EnvelopeDistance nearest;  //!< nearest limit over all points, whatever the motion
  EnvelopeDistance acting;   //!< the limit behind the strongest cut (None: nothing cut)
  bool violated = false;     //!< a point is already outside the envelope
};

//! Working-envelope limiter. Cuts, per joint, only the velocity component that moves a monitored
//! point toward a limit (d(distance)/dq_j * v_j < 0) inside the slowdown band, scaling it to zero at
//! the limit; motion away from a limit stays allowed, even outside the envelope. RT-safe after
//! construction: no allocation, no throw.
class Envelope {
 public:
  //! The model must outlive the envelope.
  Envelope(const planning::MachineModel& model, const EnvelopeConfig& config) noexcept;

  //! The allowed joint velocity at q for the commanded velocity (both dof() entries).
  [[nodiscard]] EnvelopeResult limit_velocity(const planning::JointVector& q,
                                              const planning::JointVector& commanded_velocity) noexcept;

  //! Nearest limit at q (for the stop check's sweep). Uses the cached kinematics.
  [[nodiscard]] EnvelopeDistance nearest(const planning::JointVector& q) noexcept;

  [[nodiscard]] const EnvelopeConfig& config() const noexcept { return config_; }

 private:
  //! nearest() at the configuration kinematics_ holds.
  [[nodiscard]] EnvelopeDistance nearest_posed() const noexcept;
  //! Every enabled limit at one point: distance and its gradient over the joints, via `visit`.
  template <typename Visit>
  void for_each_limit(const Eigen::Vector3d& p_world, const std::array<Eigen::Vector3d, kMaxJoints>* dp, int point,
                      Visit&& visit) const noexcept;

  const planning::MachineModel& model_;
  EnvelopeConfig config_;
  planning::Kinematics kinematics_{};
  planning::Kinematics kinematics_step_{};
};

//! The limiter's configuration for a scenario's `envelope` section on its model: key points by name,
//! angles and lengths as given, the band if given. Throws std::invalid_argument naming the file,
//! line and field for a key point the model does not have or more points than kMaxPoints.
[[nodiscard]] EnvelopeConfig envelope_config(const planning::EnvelopeSpec& spec, const planning::MachineModel& model);

//! The envelope as a planning rule (planning::CollisionWorld::set_rule): a configuration is allowed
//! when every monitored point keeps margin_m inside every limit, so that a planned path stays clear
//! of the limiter's cut and the stop check's envelope stop. Owns its Envelope (and so its
//! kinematics cache): one rule per world. RT-safe after construction.
class EnvelopeRule final : public planning::ConfigurationRule {
 public:
  //! The model must outlive the rule.
  EnvelopeRule(const planning::MachineModel& model, const EnvelopeConfig& config, double margin_m) noexcept;

  [[nodiscard]] bool allows(const planning::JointVector& q, int* limit) noexcept override;
  [[nodiscard]] std::string describe(int limit) const override;
  [[nodiscard]] double margin_m() const noexcept { return margin_m_; }

 private:
  const planning::MachineModel& model_;
  Envelope envelope_;
  double margin_m_;
};

}  // namespace mgc::guidance
