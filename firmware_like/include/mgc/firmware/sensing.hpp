// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "mgc/guidance/supervisor.hpp"
#include "mgc/hal/hal.hpp"

namespace mgc::firmware {

//! The supervisor's sensing inputs from the Hal's snapshot of this cycle, as docs/supervisor.md
//! §Inputs maps them: joint health one to one, the valve from its heartbeat, fresh status frame and
//! health, bus-off, the UWB gateway's health and the newest tag fix. Joints beyond the snapshot's
//! stay Missing. RT-safe.
[[nodiscard]] guidance::SensingInputs sensing_inputs(const hal::SensorSnapshot& snapshot) noexcept;

}  // namespace mgc::firmware
