// SPDX-License-Identifier: Apache-2.0
// The controller as a site member, on the stepped site rig (docs/site.md): crossing lifts of two
// machines at every offset of a timing sweep without true contact, the priority rule, stale
// members, refused messages, and the site's faults.

#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_rig.hpp"

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <string>

using namespace mgc;

namespace {

planning::Site example_site() { return planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/thesis-steel-frame.yaml"); }
planning::Site crossing_site() { return planning::io::load_site(std::string(MGC_SOURCE_DIR) + "/scenarios/sites/crossing-cranes.yaml"); }

}  // namespace

TEST_CASE("probe: the example site's crossing lifts", "[site][probe]") {
  sim::SiteRigConfig config;
  const char* env = std::getenv("PROBE_OFFSET");
  config.lift_start_s = {0.0, env ? std::atof(env) : 0.0};
  sim::SiteRig rig(std::getenv("PROBE_EXAMPLE") ? example_site() : crossing_site(), config, "probe");
  rig.run_until(200.0, true);
  for (auto& m : rig.members()) {
    const auto& st = m.controller->stats();
    std::printf("machine %d: goals %d plans %d replans %d site stops %d stop cycles %llu slow %llu site replans %d plans published %d min gap %.2f\n%s",
                m.machine_id, st.goals_reached, st.plans, st.replans, st.site_stops, static_cast<unsigned long long>(st.site_stop_cycles),
                static_cast<unsigned long long>(st.site_slow_cycles), st.site_replans, st.site_plans_published, st.site_min_gap_m, m.log.c_str());
  }
  std::printf("t %.1f s least between %.2f m, to site %.2f m\n", rig.sim_s(), rig.least_between_m(), rig.least_to_site_m());
}
