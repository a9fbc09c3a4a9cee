// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>

#include "mgc/guidance/trajectory.hpp"

namespace mgc::guidance {

//! Online trajectory of one joint in the control cycle (Ruckig's OTG style): each cycle is given the
//! current state, the target and the limits, and returns the state one cycle later. The profile is
//! recalculated only when the input differs from what it last planned (a new target or limits, or
//! a current state other than the last `next`, e.g. a measured one); otherwise the stored profile
//! is sampled further, which costs a few nanoseconds instead of a calculation. RT-safe: no
//! allocation, no throw.
class JointTrajectory {
 public:
  //! Writes the planned state dt_s [s] after `current` into `next`. Working while moving; Finished
  //! once the profile's end is reached (`next` is then the target at rest); ErrorInvalidInput
  //! (field in invalid_field(), `next` untouched) for a bad limit, state, target or dt_s;
  //! ErrorNoSolution if the calculation fails.
  [[nodiscard]] TrajectoryStatus update(const JointState& current, double target_position, const JointLimits& limits,
                                        double dt_s, JointState& next) noexcept;

  //! Forgets the profile, so that the next update() recalculates.
  void reset() noexcept { planned_ = false; }

  [[nodiscard]] const Profile& profile() const noexcept { return profile_; }
  [[nodiscard]] double time_s() const noexcept { return time_s_; }  //!< [s] into profile() of the last `next`
  [[nodiscard]] InvalidField invalid_field() const noexcept { return invalid_field_; }
  [[nodiscard]] std::size_t calculation_count() const noexcept { return calculation_count_; }

 private:
  Profile profile_;
  JointState last_next_{};
  JointLimits limits_{};
  double target_position_ = 0.0;
  double time_s_ = 0.0;
  bool planned_ = false;
  InvalidField invalid_field_ = InvalidField::None;
  std::size_t calculation_count_ = 0;
};

//! The controller's one-joint-at-a-time execution for up to kMaxJoints joints: the selected joint
//! moves time-optimally to its target, every other joint brakes time-optimally to rest where that
//! stop ends and stays there. A joint leaving the selection keeps the stop position latched when
//! it leaves, so it does not drift back. RT-safe: no allocation, no throw.
class OneJointAtATime {
 public:
  static constexpr std::size_t kMaxJoints = 8;

  //! `current`, `limits` and `next` hold joint_count entries (1..kMaxJoints); `moving_joint` <
  //! joint_count. Finished when every joint has reached its target or hold position at rest;
  //! errors as JointTrajectory::update, with the joint in invalid_joint().
  [[nodiscard]] TrajectoryStatus update(const JointState* current, const JointLimits* limits, std::size_t joint_count,
                                        std::size_t moving_joint, double target_position, double dt_s,
                                        JointState* next) noexcept;

  [[nodiscard]] const JointTrajectory& joint(std::size_t i) const noexcept { return joints_[i]; }
  //! The joint whose input was refused, or joint_count for the joint count or moving_joint itself.
  [[nodiscard]] std::size_t invalid_joint() const noexcept { return invalid_joint_; }
  [[nodiscard]] InvalidField invalid_field() const noexcept { return invalid_field_; }
  //! Where joint i holds while not selected [m or rad]; valid once it has been unselected.
  [[nodiscard]] double hold_position(std::size_t i) const noexcept { return hold_position_[i]; }

 private:
  std::array<JointTrajectory, kMaxJoints> joints_{};
  std::array<double, kMaxJoints> hold_position_{};
  std::array<bool, kMaxJoints> holding_{};
  std::size_t invalid_joint_ = 0;
  InvalidField invalid_field_ = InvalidField::None;
};

}  // namespace mgc::guidance
