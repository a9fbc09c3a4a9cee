// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <string>

#include "mgc/limits.hpp"

namespace mgc::planning {

//! A configuration: one value per joint, in the joint's SI unit (rad for revolute, m for
//! prismatic). Storage is inline (at most kMaxJoints), so copies never allocate.
using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints, 1>;

enum class JointType : std::uint8_t { Revolute, Prismatic };

//! One actuated joint of a machine model. Positions, velocities, accelerations and jerks are in
//! the joint's unit: rad, rad/s, rad/s^2, rad/s^3 for revolute joints; m, m/s, m/s^2, m/s^3 for
//! prismatic ones (see unit()).
struct JointSpec {
  std::string name;                  //!< e.g. "swing", "boom_elevation"
  JointType type = JointType::Revolute;
  bool continuous = false;           //!< revolute joint without end stops: positions wrap
  double position_min = 0.0;         //!< [rad | m]
  double position_max = 0.0;         //!< [rad | m]
  double max_velocity = 0.0;         //!< [rad/s | m/s]
  double max_acceleration = 0.0;     //!< [rad/s^2 | m/s^2]
  double max_jerk = 0.0;             //!< [rad/s^3 | m/s^3]

  [[nodiscard]] const char* unit() const noexcept { return type == JointType::Revolute ? "rad" : "m"; }
  [[nodiscard]] double range() const noexcept { return position_max - position_min; }
  //! True when value lies within [position_min, position_max]; a continuous joint accepts any
  //! finite value (it is wrapped first).
  [[nodiscard]] bool contains(double value) const noexcept;
};

//! A joint whose acceleration limit reaches max_velocity in accel_ramp_s and whose jerk limit
//! reaches that acceleration in jerk_ramp_s -- how the documented defaults are stated.
[[nodiscard]] JointSpec joint_from_ramps(const char* name, JointType type, bool continuous, double position_min,
                                         double position_max, double max_velocity, double accel_ramp_s,
                                         double jerk_ramp_s);

//! Wraps an angle into [-pi, pi): exactly +-pi (and anything that rounds onto +pi) gives -pi. [rad]
[[nodiscard]] double wrap_angle(double angle_rad) noexcept;

//! How near half a turn a continuous joint's difference must be to count as exactly half a turn:
//! far above the rounding of angles given in degrees (a few 1e-16 rad), far below any motion. [rad]
inline constexpr double kHalfTurnTolerance_rad = 1e-9;

//! The turn a continuous joint makes from one angle to another delta_rad = to - from away: the
//! shorter way round, in [-pi, pi). Half a turn goes the negative way (clockwise seen from above for
//! a swing or a slew), and so does anything within kHalfTurnTolerance_rad of it either side (then the
//! result lies in [-pi - kHalfTurnTolerance_rad, -pi + kHalfTurnTolerance_rad]), so start and goal
//! 180 deg apart are joined the same way whichever way their degrees rounded. [rad]
[[nodiscard]] double shorter_turn(double delta_rad) noexcept;

}  // namespace mgc::planning
