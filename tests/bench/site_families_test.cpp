// SPDX-License-Identifier: Apache-2.0
// The site generator (tools/mgc-bench/site_families.hpp): every family's start and goal are what
// the family promises, in the world mgc-plan builds from the written file.

#include <unistd.h>

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/execution.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/planners/replanner.hpp"
#include "site_families.hpp"

#include "site_files.hpp"

namespace {

using mgc::bench::SiteExpectation;
using mgc::planning::Validity;

using mgc::bench::test::kMachines;
using mgc::bench::test::read;

std::filesystem::path fresh_folder(const std::string& name) { return mgc::bench::test::fresh_folder("site-families-" + name); }
}  // namespace

TEST_CASE("every site family keeps its promise about start and goal, for several seeds") {
  const auto folder = fresh_folder("promise");
  for (const auto& family : mgc::bench::site_families()) {
    for (std::uint64_t seed = 0; seed < 5; ++seed) {
      INFO(family.name << " seed " << seed);
      const auto site = mgc::bench::generate_site(family, seed, kMachines, folder);
      auto loaded = mgc::planning::io::load_and_build(site.file);
      const Validity start = loaded.world->validate(loaded.scenario.start);
      const Validity goal = loaded.world->validate(loaded.scenario.goal);
      INFO("start: " << loaded.world->describe(start) << "; goal: " << loaded.world->describe(goal));
      CHECK(start.valid());
      if (family.expectation == SiteExpectation::ChartInfeasible) {
        // Refused by the chart's row for the 110-ft boom, the last row, not by a collision.
        CHECK(goal.status == Validity::Status::Constraint);
        CHECK(goal.constraint.chart_row == static_cast<int>(loaded.scenario.machine.load_chart->boom_lengths_ft.size()) - 1);
        const auto errors = mgc::planning::io::check_endpoints(loaded);
        REQUIRE(errors.size() == 1);
        CHECK(std::string(errors.front().what()).find("load-chart row 110 ft boom") != std::string::npos);
      } else {
        CHECK(goal.valid());
        CHECK(mgc::planning::io::check_endpoints(loaded).empty());
      }
    }
  }
  std::filesystem::remove_all(folder);
}

TEST_CASE("the same family and seed give the same file byte for byte, another seed another site") {
  const auto a = fresh_folder("a");
  const auto b = fresh_folder("b");
  for (const auto& family : mgc::bench::site_families()) {
    INFO(family.name);
    const auto first = mgc::bench::generate_site(family, 7, kMachines, a);
    const auto again = mgc::bench::generate_site(family, 7, kMachines, b);
    const auto other = mgc::bench::generate_site(family, 8, kMachines, b);
    CHECK(read(first.file) == read(again.file));
    CHECK(first.draws == again.draws);
    CHECK(read(first.file) != read(other.file));
    // The copied machine file is what the scenario names, so the folder replays on its own.
    CHECK(read(a / "machines" / family.machine) == read(kMachines / family.machine));
  }
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

TEST_CASE("families cover the three machines, and the unsolvable ones are marked") {
  int crane = 0, tower = 0, excavator = 0, chart = 0, walled = 0;
  for (const auto& f : mgc::bench::site_families()) {
    crane += f.machine == "grove-tms870.yaml";
    tower += f.machine == "pecco-sk180.yaml";
    excavator += f.machine == "cat-320.yaml";
    chart += f.expectation == SiteExpectation::ChartInfeasible;
    walled += f.expectation == SiteExpectation::WalledIn;
    CHECK(mgc::bench::find_site_family(f.name) == &f);
  }
  CHECK(crane >= 10);
  CHECK(tower >= 4);
  CHECK(excavator >= 5);
  CHECK(chart == 1);
  CHECK(walled == 1);
  CHECK(mgc::bench::find_site_family("no-such-family") == nullptr);
}

TEST_CASE("an intruder site is the same site with a second machine that starts clear of start and goal") {
  const auto folder = fresh_folder("intruder");
  for (const auto& family : mgc::bench::site_families()) {
    if (family.expectation != SiteExpectation::Solvable) continue;
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      INFO(family.name << " seed " << seed);
      const auto plain = mgc::bench::generate_site(family, seed, kMachines, folder);
      const auto site = mgc::bench::generate_intruder_site(family, seed, kMachines, folder);
      CHECK(site.file.filename().string() == family.name + "-s" + std::to_string(seed) + "-intruder.yaml");
      auto loaded = mgc::planning::io::load_and_build(site.file);
      auto base = mgc::planning::io::load_and_build(plain.file);
      REQUIRE(loaded.scenario.dynamic_obstacles.size() == 1);
      CHECK(loaded.world->num_static() == base.world->num_static());
      CHECK(mgc::planning::io::check_endpoints(loaded).empty());
      // It parks somewhere else than it starts: it drives in.
      const auto& motion = loaded.scenario.dynamic_obstacles.front().motion;
      REQUIRE(motion.size() == 3);
      CHECK((motion.back().position_m - motion.front().position_m).norm() > 15.0);
    }
  }
  std::filesystem::remove_all(folder);
}

TEST_CASE("a repair the intruder makes impossible is one where it stands on the machine, and the event says so") {
  // The long-swing site's intruder drives in through the crane's working area and, as the sites
  // suite runs it, onto the crane where it stopped (6 s horizon, predicted copies 1 s apart).
  using namespace mgc::planning;
  const auto folder = fresh_folder("contact");
  const mgc::bench::SiteFamily* family = nullptr;
  for (const auto& f : mgc::bench::site_families()) {
    if (f.name == "crane-long-swing") family = &f;
  }
  REQUIRE(family != nullptr);
  const auto site = mgc::bench::generate_intruder_site(*family, 0, kMachines, folder);
  io::LoadedScenario loaded = io::load_and_build(site.file);
  constexpr double kHorizonS = 6.0;
  loaded.world = build_world(loaded.scenario, *loaded.model, 0.0, static_cast<int>(kHorizonS));
  ReplanSettings replan;
  replan.max_iterations = loaded.scenario.planner.replan_max_iterations;
  replan.goal_bias = loaded.scenario.planner.replan_goal_bias;
  // An independent world without predicted copies: the intruder's present pose only.
  io::LoadedScenario present = io::load_and_build(site.file);
  int in_contact = 0;
  for (std::uint64_t seed = 0; seed < 2; ++seed) {
    PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
    problem.seed = seed;
    ExecutionSettings execution;
    execution.prediction_horizon_s = kHorizonS;
    execution.max_repairs = 10;
    execution.record_trajectory = false;
    auto replanner = make_replanner("drrt-axis-connect");
    const ExecutionResult r = execute_with_replanning(loaded.scenario, problem, *replanner, replan, execution);
    for (const RepairEvent& e : r.repairs) {
      INFO("seed " << seed << " event at " << e.t_s << " s: " << to_string(e.status));
      present.world->set_dynamic_pose(0, loaded.scenario.dynamic_obstacles.front().pose_at(e.t_s));
      CHECK(e.start_in_contact == present.world->hits_dynamic(e.at));
      in_contact += e.start_in_contact ? 1 : 0;
      if (e.status != PlannerStatus::Solved) CHECK((e.start_in_contact || e.predicted_start_conflict));
    }
  }
  CHECK(in_contact > 0);
  std::filesystem::remove_all(folder);
}
