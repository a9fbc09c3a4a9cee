// SPDX-License-Identifier: Apache-2.0
#include "plan_json.hpp"

#include <cstdio>
#include <fstream>
#include <numbers>

namespace mgc::tools {

using namespace mgc::planning;

void write_configuration(JsonWriter& j, const MachineModel& model, const JointVector& q) {
  j.begin_array();
  for (int i = 0; i < model.dof(); ++i) {
    const JointSpec& spec = model.joints()[static_cast<std::size_t>(i)];
    j.value(spec.type == JointType::Revolute ? q[i] * 180.0 / std::numbers::pi : q[i]);
  }
  j.end_array();
}

void write_joints(JsonWriter& j, const MachineModel& model) {
  j.key("joint_names").begin_array();
  for (const auto& joint : model.joints()) j.value(joint.name);
  j.end_array();
  j.key("joint_units").begin_array();
  for (const auto& joint : model.joints()) j.value(joint.type == JointType::Revolute ? "deg" : "m");
  j.end_array();
}

void write_path(JsonWriter& j, const MachineModel& model, const std::vector<JointVector>& path) {
  j.key("path").begin_array();
  for (const JointVector& q : path) write_configuration(j, model, q);
  j.end_array();
  j.key("moving_joint").begin_array();
  for (std::size_t e = 0; e + 1 < path.size(); ++e) j.value(moving_joint(model, path[e], path[e + 1]));
  j.end_array();
}

void write_metrics(JsonWriter& j, const PathMetrics& m) {
  j.key("path_nodes").value(m.path_nodes);
  j.key("dof_switches").value(m.dof_switches);
  j.key("multi_joint_edges").value(m.multi_joint_edges);
  j.key("length_normalized").value(m.length_normalized);
  j.key("roughness").value(m.roughness);
  j.key("exec_time_sequential_s").value(m.exec_time_sequential_s);
  j.key("exec_time_simultaneous_s").value(m.exec_time_simultaneous_s);
  j.key("cost").value(m.cost);
  j.key("min_clearance_m").value(m.min_clearance_m);
  j.key("min_clearance_sampled_m").value(m.min_clearance_sampled_m);
}

bool write_svg_file(const std::string& file, const SvgInput& view) {
  std::ofstream out(file);
  if (!out) {
    std::fprintf(stderr, "%s: cannot write the file\n", file.c_str());
    return false;
  }
  out << render_svg(view);
  return true;
}

}  // namespace mgc::tools
