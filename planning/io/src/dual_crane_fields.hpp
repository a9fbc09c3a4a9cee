// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "mgc/planning/scenario.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {

//! A scenario's `dual_crane` section (docs/scenario-format.md): two cranes of `machine`'s type
//! and the girder they carry. `machine` must be a mobile crane; its joints become the six
//! dual-crane joints. Throws InputError naming the field.
[[nodiscard]] DualCraneSpec read_dual_crane(const Value& value, MachineDefinition& machine);

}  // namespace mgc::planning::io
