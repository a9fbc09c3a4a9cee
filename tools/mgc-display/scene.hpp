// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "json.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::display {

//! The site and the machine the page draws: the scenario's static obstacles, and the machine's
//! bodies and tool point at any joint values through the project's machine model.
class Scene {
 public:
  //! Loads the scenario (planning::io::load_scenario) and builds its machine model. Throws
  //! planning::io::InputError with a one-line message on a bad file.
  explicit Scene(const std::string& scenario_file);
  //! The scenario as loaded already (a site machine's lift: planning::lift_scenario).
  explicit Scene(planning::Scenario scenario);

  [[nodiscard]] const planning::Scenario& scenario() const noexcept { return scenario_; }
  [[nodiscard]] const planning::MachineModel& model() const noexcept { return *model_; }
  [[nodiscard]] int dof() const noexcept { return model_->dof(); }

  //! The static part for the page: name, machine kind, joints (name, unit, range), start and goal,
  //! the static obstacles' corners, and the bounds of everything at start and goal [m].
  [[nodiscard]] std::string static_json() const;

  //! The machine's bodies (8 corners each) and tool point at q (dof() values) into out.
  void write_machine(Json& out, const planning::JointVector& q) const;

  //! The outlines of dynamic obstacle `index` (of the scenario's dynamic_obstacles) placed at the
  //! position and yaw about z, one list of points per part, as an array into out; an index the
  //! scenario does not have writes an empty array. [m]
  void write_dynamic_obstacle(Json& out, int index, const Eigen::Vector3d& position_m, double yaw_rad) const;
  //! The name of dynamic obstacle `index`, or "" when the scenario has no such obstacle.
  [[nodiscard]] std::string dynamic_name(int index) const;

  //! The tool point along a joint-space path, each segment sampled in steps of at most 2 deg or
  //! 0.1 m per joint; waypoints with another joint count than the model's give an empty path.
  [[nodiscard]] std::vector<Eigen::Vector3d> tool_path(const std::vector<planning::JointVector>& waypoints) const;

 private:
  planning::Scenario scenario_;
  std::unique_ptr<planning::MachineModel> model_;
  int tool_index_ = 0;
};

}  // namespace mgc::display
