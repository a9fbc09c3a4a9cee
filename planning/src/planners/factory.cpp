// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/planner.hpp"
#include "mgc/planning/planners/anytime.hpp"
#include "mgc/planning/planners/axis_connect.hpp"
#include "mgc/planning/planners/bidirectional.hpp"
#include "mgc/planning/planners/cart_rrt.hpp"
#include "mgc/planning/planners/multi_rrt.hpp"
#include "mgc/planning/planners/nonuniform.hpp"
#include "mgc/planning/planners/single_axis_tree.hpp"

namespace mgc::planning {

std::unique_ptr<Planner> make_planner(std::string_view name) {
  if (name == "axis-connect") return std::make_unique<AxisConnectPlanner>();
  if (name == "limcon") return std::make_unique<LimConPlanner>();
  if (name == "rrt") return std::make_unique<GoalBiasedRrtPlanner>();
  using Variant = BidirectionalPlanner::Variant;
  if (name == "rrt-connect") return std::make_unique<BidirectionalPlanner>(Variant::ConCon);
  if (name == "rrt-ext-con") return std::make_unique<BidirectionalPlanner>(Variant::ExtCon);
  if (name == "rrt-ext-ext") return std::make_unique<BidirectionalPlanner>(Variant::ExtExt);
  if (name == "con-con-mod") return std::make_unique<BidirectionalPlanner>(Variant::ConConMod);
  if (name == "anytime") return std::make_unique<AnytimePlanner>();
  if (name == "nonuniform") return std::make_unique<NonUniformRrtPlanner>();
  if (name == "rrt-basic") return std::make_unique<NonUniformRrtPlanner>(true);
  if (name == "cart-rrt") return std::make_unique<CartRrtPlanner>();
  if (name == "multi-rrt") return std::make_unique<MultiRrtPlanner>();
  return nullptr;
}

std::vector<std::string_view> planner_names() { return {"axis-connect", "limcon", "rrt", "rrt-connect", "rrt-ext-con", "rrt-ext-ext", "con-con-mod", "anytime", "nonuniform", "rrt-basic", "cart-rrt", "multi-rrt"}; }

}  // namespace mgc::planning
