// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <span>

#include "mgc/guidance/diagnostics.hpp"
#include "mgc/guidance/supervisor.hpp"
#include "mgc/hal/hal.hpp"

namespace mgc::firmware {

//! The supervisor's sensing inputs from the Hal's snapshot of this cycle, as docs/supervisor.md
//! §Inputs maps them: joint health one to one, the valve from its heartbeat, fresh status frame and
//! health, bus-off, the UWB gateway's health and the newest tag fix. Joints beyond the snapshot's
//! stay Missing. The machine's own tags (machine_tag_ids) are no obstacle's: their fixes do not
//! count as the obstacles' UWB being alive. RT-safe.
[[nodiscard]] guidance::SensingInputs sensing_inputs(const hal::SensorSnapshot& snapshot,
                                                     std::span<const std::uint8_t> machine_tag_ids = {}) noexcept;

//! The cut-off node's health from the snapshot (docs/supervisor.md §Inputs). RT-safe.
[[nodiscard]] guidance::CutoffHealth cutoff_health(const hal::SensorSnapshot& snapshot) noexcept;

//! The plausibility monitor's inputs from the snapshot and the velocity the loop commanded in its
//! previous cycle (what the valve applies now); pilot_enabled: the loop keeps pilot pressure on.
//! RT-safe.
[[nodiscard]] guidance::PlausibilityInputs plausibility_inputs(const hal::SensorSnapshot& snapshot,
                                                               std::span<const double> commanded_velocity,
                                                               bool pilot_enabled) noexcept;

}  // namespace mgc::firmware
