// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>

#include "mgc/planning/mobile_crane.hpp"

namespace mgc::guidance {

//! Stages of a rated capacity limiter as EN 13000 cranes show them (DOMAIN-FACTS §4.1).
enum class RclStage : std::int8_t {
  Normal = 0,    //!< utilisation below the warning threshold
  Warning,       //!< at or above the warning threshold (90 %): alarm, no cut
  Overload,      //!< at or above the cut-off (100 %), or latched there: load-moment-increasing motions cut
  OutsideChart,  //!< no chart cell rates this boom length and angle: treated as overload
};

[[nodiscard]] const char* to_string(RclStage stage) noexcept;

//! The rated capacity at one configuration, read from the chart the way an operator reads it: the
//! boom-length row is the first chart boom length at or above the actual one (the thesis's LVA rule),
//! and in that row the first cell whose boom angle from vertical reaches the actual angle (the next
//! larger radius). Never interpolated, so never above the chart.
struct RatedCapacity {
  bool in_chart = false;
  double capacity_lb = 0.0;  //!< [lb]; 0 when not in_chart
  int chart_row = -1;
  int chart_column = -1;
};

//! Reads the chart at boom_length_m [m] and boom_elevation_rad [rad above horizontal]. RT-safe.
[[nodiscard]] RatedCapacity rated_capacity(const planning::LoadChart& chart, double boom_length_m,
                                           double boom_elevation_rad) noexcept;

//! The lowest rated capacity anywhere on the straight motion from (from_boom_m, from_elevation_rad)
//! to (to_boom_m, to_elevation_rad), both linear: over every row whose span of boom lengths the
//! motion enters, every cell its boom angle passes while there (the ends of each row's stretch
//! bound the angle, a linear function). Not in_chart when any part of the motion is outside the
//! chart. A stretch's end on a row boundary is taken with the row after it too, which can only
//! lower the capacity. Equal to rated_capacity() for a motion that stays put. RT-safe.
[[nodiscard]] RatedCapacity rated_capacity_along(const planning::LoadChart& chart, double from_boom_m,
                                                 double from_elevation_rad, double to_boom_m,
                                                 double to_elevation_rad) noexcept;

struct RatedCapacityConfig {
  //! Early warning at 90 % of rated capacity (Grove GMK6300L, Maeda; DOMAIN-FACTS §4.1). [-]
  double warning_utilisation = 0.9;
  //! Shut-off of the load-moment-increasing motions at 100 %. [-]
  double cutoff_utilisation = 1.0;
  //! Cut hoist raising in overload. At a fixed radius raising a free-hanging load does not change
  //! its moment, but while a load is lifted off the ground the hook load grows; EN 13000 cranes cut
  //! "raise hoisting gear" with the other moment-increasing motions (GMK5250L lock list), so do we.
  bool cut_hoist_raise = true;
  //! Central-difference step for d(radius)/dq. [rad | m]
  double gradient_step = 1e-5;
};

struct RatedCapacityResult {
  RclStage stage = RclStage::Normal;
  double utilisation = 0.0;   //!< hook load / rated capacity [-]; +inf outside the chart
  double load_lb = 0.0;       //!< hook load used [lb]
  RatedCapacity rated;        //!< chart cell used
  double load_radius_m = 0.0; //!< [m]
  planning::JointVector allowed_velocity;     //!< [rad/s | m/s]
  std::array<bool, kMaxJoints> cut{};         //!< joint velocity cut to zero
  std::array<double, kMaxJoints> radius_gradient{};  //!< d(load radius)/dq_j [m/rad | m/m]
};

//! Rated capacity limiter for a mobile crane: utilisation of the load chart at the current boom
//! length and angle, a warning from 90 %, and from 100 % every joint velocity that increases the load
//! moment (load x radius) is cut: boom down, telescope out (both increase the radius; the sign comes
//! from the numerical derivative of the radius), and hoist raising. Motions that reduce the moment or
//! leave it unchanged (boom up, telescope in, hoist lowering, slew on level ground) stay allowed. Once
//! at the cut-off the limiter stays in Overload until utilisation drops below the warning threshold
//! (Maeda's recovery rule). RT-safe: no allocation, no throw.
class RatedCapacityLimiter {
 public:
  //! The crane must outlive the limiter.
  RatedCapacityLimiter(const planning::MobileCrane& crane, const RatedCapacityConfig& config) noexcept;

  //! hook_load_lb is the measured hook load (rope force) [lb], incl. hook block and rigging.
  [[nodiscard]] RatedCapacityResult limit_velocity(const planning::JointVector& q, double hook_load_lb,
                                                   const planning::JointVector& commanded_velocity) noexcept;
  //! The same over the motion of the next horizon_s at the commanded velocity: the chart is read
  //! along the straight segment q -> q + commanded_velocity x horizon_s (rated_capacity_along), so
  //! a chart row or cell boundary crossed within the period is limited before the machine crosses
  //! it, not a cycle after. horizon_s = 0 reads the chart at q alone. [s]
  [[nodiscard]] RatedCapacityResult limit_velocity(const planning::JointVector& q, double hook_load_lb,
                                                   const planning::JointVector& commanded_velocity,
                                                   double horizon_s) noexcept;

  //! The lift task's load with its capacity reduction, as the load-chart rule rates it. [lb]
  [[nodiscard]] double task_load_lb() const noexcept;
  [[nodiscard]] bool overload_latched() const noexcept { return latched_; }
  void reset() noexcept { latched_ = false; }

 private:
  const planning::MobileCrane& crane_;
  RatedCapacityConfig config_;
  bool latched_ = false;
};

}  // namespace mgc::guidance
