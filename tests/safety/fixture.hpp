// SPDX-License-Identifier: Apache-2.0
// The thesis scenario (Grove TMS870, 20,000 lb, steel frame, crane-2) for the safety-function tests.
#pragma once

#include <cmath>
#include <numbers>
#include <string>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"

namespace mgc::test {

inline constexpr double kDeg = std::numbers::pi / 180.0;

struct ThesisCrane {
  planning::io::LoadedScenario loaded = planning::io::load_and_build(std::string(MGC_SOURCE_DIR) +
                                                                     "/scenarios/thesis-steel-frame.yaml");
  const planning::MobileCrane& crane = dynamic_cast<const planning::MobileCrane&>(*loaded.model);

  //! (swing, boom elevation, boom length, cable length) in deg and m.
  static planning::JointVector q(double swing_deg, double elevation_deg, double boom_m, double cable_m) {
    planning::JointVector v(4);
    v << swing_deg * kDeg, elevation_deg * kDeg, boom_m, cable_m;
    return v;
  }
  static planning::JointVector v(double a, double b, double c, double d) {
    planning::JointVector out(4);
    out << a, b, c, d;
    return out;
  }
};

}  // namespace mgc::test
