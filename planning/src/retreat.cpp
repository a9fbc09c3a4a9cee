// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/retreat.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mgc::planning {

RetreatSearch::RetreatSearch(CollisionWorld& measure, CollisionWorld& target, const RetreatSettings& settings)
    : measure_(measure), target_(target), settings_(settings) {
  const MachineModel& model = measure_.model();
  const int n = model.dof();
  start_ = JointVector::Zero(n);
  q_ = start_;
  found_ = start_;
  step_.assign(static_cast<std::size_t>(n), 0.0);
  alive_.assign(static_cast<std::size_t>(2 * n), false);
  settings_.step_m = std::max(settings_.step_m, 1e-3);
  for (int j = 0; j < n; ++j) {
    const double bound = model.displacement_bound(j);
    step_[static_cast<std::size_t>(j)] = bound > 0.0 ? settings_.step_m / bound : 0.0;
  }
  max_level_ = std::max(1, static_cast<int>(std::ceil(settings_.max_travel_m / settings_.step_m)));
  beyond_levels_ = std::max(0, static_cast<int>(std::ceil(settings_.beyond_m / settings_.step_m)));
}

RetreatSearch::Status RetreatSearch::begin(const JointVector& q) noexcept {
  start_ = q;
  found_ = q;
  joint_ = -1;
  level_ = 1;
  direction_ = 0;
  out_direction_ = -1;
  out_level_ = 0;
  measured_ = 1;
  start_clearance_m_ = measure_.clearance(q).distance_m;
  if (start_clearance_m_ < settings_.contact_m) return status_ = Status::InContact;
  for (std::size_t d = 0; d < alive_.size(); ++d) alive_[d] = step_[d / 2] > 0.0;
  return status_ = Status::Running;
}

RetreatSearch::Status RetreatSearch::step(int budget) noexcept {
  if (status_ != Status::Running) return status_;
  const int directions = static_cast<int>(alive_.size());
  while (budget > 0) {
    if (out_direction_ >= 0) {
      // Going on beyond the first valid configuration: stop at the first that is not.
      if (level_ >= out_level_) return status_ = Status::Found;
      ++level_;
      --budget;
      if (!measure(out_direction_)) return status_ = Status::Found;
      found_ = q_;
      continue;
    }
    if (direction_ >= directions) {
      direction_ = 0;
      ++level_;
      bool any = false;
      for (std::size_t d = 0; d < alive_.size(); ++d) any = any || alive_[d];
      if (!any || level_ > max_level_) return status_ = Status::NotFound;
    }
    const int d = direction_++;
    if (!alive_[static_cast<std::size_t>(d)]) continue;
    --budget;
    if (!pose(d)) {
      alive_[static_cast<std::size_t>(d)] = false;
      continue;
    }
    ++measured_;
    if (measure_.clearance(q_).distance_m < start_clearance_m_ - settings_.tolerance_m) {
      alive_[static_cast<std::size_t>(d)] = false;
      continue;
    }
    if (target_.validate(q_).valid()) {
      found_ = q_;
      joint_ = d / 2;
      out_direction_ = d;
      out_level_ = level_ + beyond_levels_;
    }
  }
  return status_;
}

bool RetreatSearch::pose(int direction) noexcept {
  const int j = direction / 2;
  const JointSpec& spec = measure_.model().joints()[static_cast<std::size_t>(j)];
  q_ = start_;
  q_[j] += (direction % 2 == 0 ? 1.0 : -1.0) * level_ * step_[static_cast<std::size_t>(j)];
  if (spec.continuous) {
    q_[j] = std::remainder(q_[j], 2.0 * std::numbers::pi);
    return true;
  }
  return q_[j] >= spec.position_min && q_[j] <= spec.position_max;
}

bool RetreatSearch::measure(int direction) noexcept {
  if (!pose(direction)) return false;
  ++measured_;
  return measure_.clearance(q_).distance_m >= start_clearance_m_ - settings_.tolerance_m && target_.validate(q_).valid();
}

}  // namespace mgc::planning
