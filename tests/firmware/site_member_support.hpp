// SPDX-License-Identifier: Apache-2.0
#pragma once

// The crossing site with the site's UWB tags on its tower crane, for the site member tests.

#include <mgc/planning/io/site_loader.hpp>

#include <Eigen/Core>
#include <string>

namespace mgc::test {

//! crossing-cranes.yaml with the site's RTLS on the tower crane: jib tip, trolley, counterweight, hook.
inline planning::Site tagged_crossing_site() {
  planning::Site site = planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/crossing-cranes.yaml");
  const auto tag = [](int id, const char* body, Eigen::Vector3d at) {
    planning::MachineTagSpec t;
    t.id = id;
    t.body = body;
    t.position_m = at;
    return t;
  };
  site.machines[1].uwb_tags = {tag(1, "jib", {0, 0, 29.85}), tag(2, "trolley", {0, 0, 0}), tag(3, "counter_jib", {0, 0, 10}),
                               tag(4, "hook", {0, 0, 0})};
  return site;
}

}  // namespace mgc::test
