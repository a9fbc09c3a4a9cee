// SPDX-License-Identifier: Apache-2.0
#pragma once

// The stepped rig on a shipped scenario, by file name, as the tests use it.

#include <functional>
#include <string>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/sim/stepped_rig.hpp"

namespace mgc::test {

inline std::string scenario_path(const char* name) { return std::string(MGC_SOURCE_DIR) + "/scenarios/" + name; }

using sim::max_velocities;

inline planning::Scenario load_edited(const char* scenario_file, const std::function<void(planning::Scenario&)>& edit) {
  auto s = planning::io::load_scenario(scenario_path(scenario_file));
  if (edit) edit(s);
  return s;
}

class SimRig : public sim::SteppedRig {
 public:
  //! edit: changes the scenario before the machine is built (a test's own tags on a shipped site).
  explicit SimRig(const char* scenario_file, sim::SimConfig config = quiet_config(), const std::string& bus_name = "rig",
                  const std::function<void(planning::Scenario&)>& edit = {})
      : SteppedRig(load_edited(scenario_file, edit), std::move(config), bus_name) {}
};

}  // namespace mgc::test
