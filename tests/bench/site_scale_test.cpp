// SPDX-License-Identifier: Apache-2.0
// The generated N-machine site of the site-scale suite (tools/mgc-bench/site_scale.hpp): it loads
// through the ordinary site loader, its bases stand apart, and on the site rig every member hears
// every other.

#include <unistd.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/firmware/site_rules.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/planning/site.hpp"
#include "mgc/sim/site_rig.hpp"
#include "site_scale.hpp"

#include "site_files.hpp"

namespace {

using mgc::bench::test::kMachines;
using mgc::bench::test::read;

std::filesystem::path fresh_folder(const std::string& name) { return mgc::bench::test::fresh_folder("site-scale-" + name); }
}  // namespace

TEST_CASE("the generated site of 4 machines loads, its bases stand apart and every member hears every other on the rig") {
  const auto folder = fresh_folder("four");
  const auto generated = mgc::bench::generate_scale_site(4, 0, kMachines, folder);
  const mgc::planning::Site site = mgc::planning::io::load_site(generated.file);
  REQUIRE(site.machines.size() == 4);
  CHECK(generated.tower_cranes == 1);

  std::vector<int> priorities;
  int towers = 0;
  for (std::size_t a = 0; a < site.machines.size(); ++a) {
    const auto& m = site.machines[a];
    priorities.push_back(m.priority);
    towers += m.machine.kind == mgc::planning::MachineKind::TowerCrane ? 1 : 0;
    CHECK(m.lifts.size() == 1);
    const auto fa = mgc::planning::base_footprint(m.machine, m.world_from_base);
    for (std::size_t b = a + 1; b < site.machines.size(); ++b) {
      INFO("machines " << m.id << " and " << site.machines[b].id);
      const auto& o = site.machines[b];
      CHECK_FALSE(mgc::planning::footprints_overlap(fa, mgc::planning::base_footprint(o.machine, o.world_from_base)));
      // The grid keeps every two bases at least a spacing less the jitter apart.
      const double apart_m = (m.world_from_base.translation() - o.world_from_base.translation()).norm();
      CHECK(apart_m > 0.5 * mgc::bench::kScaleSpacing_m);
    }
  }
  std::sort(priorities.begin(), priorities.end());
  CHECK(priorities == std::vector<int>{1, 2, 3, 4});
  CHECK(towers == 1);

  mgc::sim::SiteRigConfig config;
  config.lift_start_s.assign(site.machines.size(), 0.0);
  mgc::sim::SiteRig rig(site, config, "site-scale-test-" + std::to_string(::getpid()));
  rig.run_until(0.5);
  for (mgc::sim::SiteRigMember& m : rig.members()) {
    INFO("receiver " << m.machine_id);
    CHECK(m.states_sent >= 9);
    CHECK(m.verifier->refused() == 0);
    const mgc::firmware::SiteDecision& d = m.controller->site_decision();
    REQUIRE(d.count == site.machines.size());
    for (std::size_t k = 0; k < site.machines.size(); ++k) {
      if (site.machines[k].id == m.machine_id) continue;
      INFO("sender " << site.machines[k].id);
      CHECK(m.inputs.peers[k].has_state);
      CHECK(m.inputs.peers[k].state.machine_id == site.machines[k].id);
      CHECK(d.peers[k].link == mgc::firmware::SiteLink::Live);
    }
  }
  // Every lift's start keeps the machines apart, as the generator promises.
  CHECK(rig.least_between_m() >= mgc::bench::kScaleEndClearance_m);
  std::filesystem::remove_all(folder);
}

TEST_CASE("the same size and seed give the same site file byte for byte, another seed another site") {
  const auto a = fresh_folder("a");
  const auto b = fresh_folder("b");
  const auto first = mgc::bench::generate_scale_site(4, 3, kMachines, a);
  const auto again = mgc::bench::generate_scale_site(4, 3, kMachines, b);
  const auto other = mgc::bench::generate_scale_site(4, 4, kMachines, b);
  CHECK(read(first.file) == read(again.file));
  CHECK(first.redraws == again.redraws);
  CHECK(read(first.file) != read(other.file));
  CHECK(read(a / "machines" / "grove-tms870.yaml") == read(kMachines / "grove-tms870.yaml"));
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

TEST_CASE("the generator refuses a size outside 1 to 16 machines") {
  const auto folder = fresh_folder("refuse");
  CHECK_THROWS_AS(mgc::bench::generate_scale_site(0, 0, kMachines, folder), std::invalid_argument);
  CHECK_THROWS_AS(mgc::bench::generate_scale_site(17, 0, kMachines, folder), std::invalid_argument);
  std::filesystem::remove_all(folder);
}
