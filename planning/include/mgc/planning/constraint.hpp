// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

namespace mgc::planning {

//! Outcome of a machine's engineering-constraint check. Ok is 0; the rest say which rule failed.
enum class ConstraintStatus : std::int16_t {
  Ok = 0,
  BoomLengthOutsideChart = -301,  //!< no load-chart row (or luff-table row) covers the boom length
  LoadAboveChart = -302,          //!< no radius of the boom-length row rates the load
  BoomBelowChartAngle = -303,     //!< boom elevation below the chart's minimum for the load
  BoomAboveChartAngle = -304,     //!< boom elevation above the chart's (or table's) maximum
  LoadBelowGround = -305,         //!< the suspended load or bucket would go below the ground
  CableTooShort = -306,           //!< hook block drawn into the boom tip / trolley
  // Two cranes on one load (seed 004).
  NoEquilibrium = -340,  //!< the suspension hangs only with a cable tilted beyond its limit
  TipDistance = -341,    //!< boom tips too far apart (or too close) for the chain to close
  CableTilt = -342,      //!< a cable's tilt from vertical above the limit
  GirderTilt = -343,     //!< the load's slope from horizontal above the limit
  CraneOverload = -344,  //!< a crane's cable tension above its rated capacity at its radius
};

[[nodiscard]] const char* to_string(ConstraintStatus status) noexcept;

//! Which rule failed, the value checked and its limit (units as the rule states: elevation in
//! rad, lengths in m, loads in lb), and the load-chart cell used, when one was (-1 otherwise).
struct ConstraintVerdict {
  ConstraintStatus status = ConstraintStatus::Ok;
  double value = 0.0;
  double limit = 0.0;
  int chart_row = -1;     //!< index into the chart's boom lengths
  int chart_column = -1;  //!< index into the chart's radii

  [[nodiscard]] bool ok() const noexcept { return status == ConstraintStatus::Ok; }
};

}  // namespace mgc::planning
