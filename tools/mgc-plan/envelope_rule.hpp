// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <memory>

#include "mgc/guidance/envelope.hpp"
#include "mgc/planning/io/scenario_loader.hpp"

namespace mgc::tools {

//! mgc keeps the working envelope by this much when it plans (ControllerConfig). [m]
inline constexpr double kControllerEnvelopeMarginM = 1.25;

//! Makes the scenario's working envelope (its `envelope` section) the world's rule, kept by
//! margin_m, so that --check and every planner see it as mgc does; null when the scenario has
//! none. The rule must outlive the world's use. Throws std::invalid_argument naming the file,
//! line and field for a key point the machine does not have.
inline std::unique_ptr<guidance::EnvelopeRule> keep_envelope(planning::io::LoadedScenario& loaded, double margin_m) {
  if (!loaded.scenario.envelope) return nullptr;
  auto rule = std::make_unique<guidance::EnvelopeRule>(
      *loaded.model, guidance::envelope_config(*loaded.scenario.envelope, *loaded.model), margin_m);
  loaded.world->set_rule(rule.get());
  return rule;
}

}  // namespace mgc::tools
