// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/planners/single_axis_tree.hpp"

namespace mgc::planning {

std::unique_ptr<Planner> make_planner(std::string_view name) {
  if (name == "limcon") return std::make_unique<LimConPlanner>();
  if (name == "rrt") return std::make_unique<GoalBiasedRrtPlanner>();
  return nullptr;
}

std::vector<std::string_view> planner_names() { return {"limcon", "rrt"}; }

}  // namespace mgc::planning
