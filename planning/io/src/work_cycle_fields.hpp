// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <functional>

#include "mgc/planning/scenario.hpp"
#include "yaml_fields.hpp"

namespace mgc::planning::io {

//! A scenario's `work_cycle` section (docs/scenario-format.md), read once the machine, start and
//! goal are: `goal` is the goal's value, named when its bucket breaks the move-to-dump hold, and
//! `read_configuration` reads a full configuration the way start and goal are read. Throws
//! InputError.
[[nodiscard]] WorkCycleSpec read_work_cycle(const Value& value, const Scenario& scenario, const Value& goal,
                                            const std::function<JointVector(const Value&)>& read_configuration);

}  // namespace mgc::planning::io
