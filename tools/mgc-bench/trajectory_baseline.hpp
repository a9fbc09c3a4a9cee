// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>

#include "mgc/guidance/trajectory.hpp"

//! Bench only: the trajectory generator before the exact braking (trajectory_baseline.cpp), timed
//! against the current one by the trajectory suite.
namespace mgc::bench::baseline {

[[nodiscard]] guidance::CalculationResult calculate_time_optimal(const guidance::JointState& start,
                                                                 double target_position,
                                                                 const guidance::JointLimits& limits,
                                                                 guidance::Profile& out) noexcept;

[[nodiscard]] guidance::SynchronizedResult calculate_synchronized(const guidance::JointState* start,
                                                                  const double* target_position,
                                                                  const guidance::JointLimits* limits,
                                                                  std::size_t joint_count,
                                                                  guidance::Profile* out) noexcept;

}  // namespace mgc::bench::baseline
