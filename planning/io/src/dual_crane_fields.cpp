// SPDX-License-Identifier: Apache-2.0
#include "dual_crane_fields.hpp"

#include <numbers>
#include <stdexcept>
#include <string>

namespace mgc::planning::io {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

// Returns the boom length's value, which later checks name.
Value read_mount(const Value& value, CraneMount& m) {
  Fields f = value.fields();
  m.base_position_m = f.required("base_position_m").position_m();
  m.base_yaw_rad = f.required("base_yaw_deg").number_in(-360.0, 360.0) * kDegToRad;
  Value boom = f.required("boom_length_m");
  m.boom_length_m = boom.length_m();
  f.finish();
  return boom;
}

}  // namespace

DualCraneSpec read_dual_crane(const Value& value, MachineDefinition& machine) {
  Fields f = value.fields();
  if (machine.kind != MachineKind::MobileCrane) {
    value.fail_plain("a dual-crane lift needs a mobile_crane machine file (" + machine.file + " is a " +
                     to_string(machine.kind) + ")");
  }
  DualCraneSpec spec;
  const Value crane_2 = f.required("crane_2");
  const Value booms[2] = {read_mount(f.required("crane_1"), spec.cranes[0]), read_mount(crane_2, spec.cranes[1])};
  if ((spec.cranes[0].base_position_m - spec.cranes[1].base_position_m).head<2>().norm() < 1e-6) {
    crane_2.fail_plain("the two cranes stand on the same swing axis");
  }
  {
    Fields g = f.required("girder").fields();
    spec.girder.length_m = g.required("length_m").length_m();
    spec.girder.mass_kg = g.required("mass_kg").positive();
    spec.girder.radius_m = g.required("radius_m").length_m();
    g.finish();
  }
  // Open interval: a tilt limit of 90 deg would let the chain fold.
  spec.max_cable_tilt_rad = f.required("max_cable_tilt_deg").number_in(1e-3, 89.0) * kDegToRad;
  spec.max_girder_tilt_rad = f.required("max_girder_tilt_deg").number_in(1e-3, 89.0) * kDegToRad;
  spec.anchor_step_m = f.required("anchor_step_m").length_m();
  if (auto r = f.optional("capacity_reduction_pct")) spec.capacity_reduction_pct = r->number_in(0.0, 100.0);
  f.finish();
  try {
    machine.joints = dual_crane_joints(machine.joints, spec);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    booms[what.find("crane 2") != std::string::npos ? 1 : 0].fail_plain(what + " (" + machine.file + ")");
  }
  if (machine.load_chart) {
    const double longest_m = machine.load_chart->boom_lengths_ft.back() * kMetresPerFoot;
    for (int crane = 0; crane < 2; ++crane) {
      if (spec.cranes[static_cast<std::size_t>(crane)].boom_length_m > longest_m + 1e-6) {
        booms[crane].fail_plain("longer than every row of the load chart in " + machine.file);
      }
    }
  }
  return spec;
}

}  // namespace mgc::planning::io
