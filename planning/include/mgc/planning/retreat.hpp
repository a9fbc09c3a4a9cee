// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <vector>

#include "mgc/planning/collision_world.hpp"

namespace mgc::planning {

struct RetreatSettings {
  //! Most any body point moves between two configurations the search measures. [m]
  double step_m = 0.05;
  //! Farthest a body point may travel along one direction before the search gives it up. [m]
  double max_travel_m = 8.0;
  //! How far below the start's the clearance may be at a measured configuration. Between two of
  //! them it may dip by half a step more. [m]
  double tolerance_m = 0.02;
  //! A start nearer than this to anything counts as contact: no way out is searched from there. [m]
  double contact_m = 1e-3;
  //! Once a direction gets out, it goes on this much further while it stays valid: a start on the
  //! very edge of the escape world leaves its planner almost no edge in. [m]
  double beyond_m = 0.5;
};

//! A way out for a machine at rest so near an obstacle that no planner accepts its configuration as
//! a start (docs/controller.md, "Retreat"): one joint moved on its own, in the direction and by the
//! least body travel after which the configuration is valid in `target` (the escape planner's
//! world). Along the way the clearance measured in `measure` (the stop check's world) never falls
//! more than tolerance_m below the start's: the machine only gets away from what it stands next
//! to. Directions are searched breadth first, every joint both ways, a step of at most step_m of
//! body travel at a time, so the first direction to get out is the one with the shortest way; it
//! then goes on beyond_m further while it stays valid.
//!
//! Time-sliced like the planners: begin(), then step() with a budget of configurations until it
//! returns Found or NotFound. Allocation-free after construction, no throw; deterministic.
class RetreatSearch {
 public:
  enum class Status : std::int8_t {
    Idle = 0,
    Running,
    Found,     //!< target() is the way out, joint() the joint that moves
    NotFound,  //!< no single-joint move within max_travel_m gets out without coming nearer
    InContact, //!< the start touches an obstacle (measure's dilated bodies): the machine stays put
  };

  //! Both worlds (and the model behind them) must outlive the search. Allocates its buffers.
  RetreatSearch(CollisionWorld& measure, CollisionWorld& target, const RetreatSettings& settings = {});

  //! Starts a search from q (measures the start: one clearance query).
  Status begin(const JointVector& q) noexcept;
  //! Measures at most `budget` configurations.
  [[nodiscard]] Status step(int budget) noexcept;
  [[nodiscard]] Status status() const noexcept { return status_; }
  [[nodiscard]] const JointVector& target() const noexcept { return found_; }
  [[nodiscard]] int joint() const noexcept { return joint_; }
  [[nodiscard]] double start_clearance_m() const noexcept { return start_clearance_m_; }
  //! Configurations measured since begin().
  [[nodiscard]] int measured() const noexcept { return measured_; }

 private:
  //! q_ = the configuration of `direction` at level_; false if beyond a joint's range.
  bool pose(int direction) noexcept;
  //! pose(), then whether it keeps the clearance and is valid in the target world.
  bool measure(int direction) noexcept;

  CollisionWorld& measure_;
  CollisionWorld& target_;
  RetreatSettings settings_;
  Status status_ = Status::Idle;
  JointVector start_;
  JointVector q_;
  JointVector found_;
  std::vector<double> step_;     //!< per joint, the joint motion of one step [rad | m]
  std::vector<bool> alive_;      //!< per direction (joint * 2 + (negative ? 1 : 0))
  int joint_ = -1;
  int level_ = 1;                //!< steps out from the start being measured
  int max_level_ = 1;
  int beyond_levels_ = 0;
  int direction_ = 0;            //!< next direction at this level
  int out_direction_ = -1;       //!< the direction that got out, now going on beyond_m
  int out_level_ = 0;            //!< the level it goes on to
  int measured_ = 0;
  double start_clearance_m_ = 0.0;
};

}  // namespace mgc::planning
