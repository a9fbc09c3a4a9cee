// SPDX-License-Identifier: Apache-2.0
// mgc-plan: offline tool over the planning library. `--check` loads a scenario, validates every
// field, and reports whether start and goal are feasible and, if not, why.
//
// Exit status: 0 feasible, 1 the job could not be done, 2 bad input (one line on stderr naming
// the file, the line, the field and what was expected).

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>

#include "mgc/planning/io/scenario_loader.hpp"

namespace {

using mgc::planning::JointType;
using mgc::planning::JointVector;
using mgc::planning::MachineModel;

std::string format_configuration(const MachineModel& model, const JointVector& q) {
  std::ostringstream s;
  s.precision(4);
  for (int i = 0; i < model.dof(); ++i) {
    const auto& j = model.joints()[static_cast<std::size_t>(i)];
    const bool revolute = j.type == JointType::Revolute;
    s << (i > 0 ? ", " : "") << j.name << " " << (revolute ? q[i] * 180.0 / std::numbers::pi : q[i])
      << (revolute ? " deg" : " m");
  }
  return s.str();
}

int run_check(const std::string& scenario_file) {
  auto loaded = mgc::planning::io::load_and_build(scenario_file);
  const auto& s = loaded.scenario;
  const MachineModel& model = *loaded.model;
  auto& world = *loaded.world;

  std::printf("scenario   %s (%s)\n", s.name.c_str(), s.file.c_str());
  std::printf("machine    %s, %s, %d joints (%s)\n", model.name().c_str(), to_string(model.kind()), model.dof(),
              s.machine.file.c_str());
  if (s.task && model.kind() == mgc::planning::MachineKind::MobileCrane) {
    std::printf("task       load %.0f lb, capacity reduction %.0f %%, rigging %s / %.0f lb counterweight\n",
                s.task->load_lb, s.task->capacity_reduction_pct, s.task->outriggers.c_str(), s.task->counterweight_lb);
  }
  std::printf("obstacles  %d static, %d dynamic; dilation %.2f m\n", world.num_static(), world.num_dynamic(),
              world.dilation_m());

  const auto errors = mgc::planning::io::check_endpoints(loaded);
  const auto report = [&](const char* label, const JointVector& q) {
    std::printf("%-10s %s\n", label, format_configuration(model, q).c_str());
    const auto v = world.validate(q);
    if (!v.valid()) {
      std::printf("           infeasible: %s\n", world.describe(v).c_str());
      return;
    }
    const auto c = world.clearance(q);
    const std::string nearest = c.with == mgc::planning::Contact::With::Static    ? world.static_name(c.other)
                                : c.with == mgc::planning::Contact::With::Dynamic ? world.dynamic_name(c.other)
                                                                                  : std::string("-");
    std::printf("           feasible, clearance %.2f m (%s to '%s')\n", c.distance_m,
                c.body >= 0 ? model.bodies()[static_cast<std::size_t>(c.body)].name.c_str() : "-", nearest.c_str());
  };
  report("start", s.start);
  report("goal", s.goal);

  if (errors.empty()) {
    JointVector at;
    const auto steps = mgc::planning::step_sizes(model, s.planner.space_resolution);
    const auto edge = world.validate_edge(s.start, s.goal, steps, &at);
    if (edge.valid()) {
      std::printf("straight   the joint-space line from start to goal is free (no planning needed)\n");
    } else {
      std::printf("straight   the joint-space line from start to goal is blocked at %s: %s\n",
                  format_configuration(model, at).c_str(), world.describe(edge).c_str());
    }
  }
  for (const auto& e : errors) std::fprintf(stderr, "%s\n", e.what());
  return errors.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-plan: load, check and plan crane and excavator lifts on a scenario file"};
  std::string scenario;
  bool check = false;
  app.add_option("--scenario", scenario, "scenario file (YAML, docs/scenario-format.md)")->required();
  app.add_flag("--check", check, "validate the scenario and report whether start and goal are feasible");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::fprintf(stderr, "mgc-plan: %s (see --help)\n", e.what());
    return 2;
  }
  if (!check) {
    std::fprintf(stderr, "mgc-plan: nothing to do: give --check (this build has no planner yet)\n");
    return 2;
  }
  try {
    return run_check(scenario);
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
}
