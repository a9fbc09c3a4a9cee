// SPDX-License-Identifier: Apache-2.0
#include "trace_view.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include "mgc/planning/io/scenario_loader.hpp"
#include "plan_json.hpp"
#include "svg_view.hpp"

namespace mgc::tools {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) out.push_back(cell);
  return out;
}

int column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace

int run_trace_view(const std::string& scenario_file, const std::string& trace_csv, const std::string& svg) {
  const planning::Scenario scenario = planning::io::load_scenario(scenario_file);
  const std::unique_ptr<planning::MachineModel> model = planning::build_model(scenario);
  std::ifstream in(trace_csv);
  if (!in) {
    std::fprintf(stderr, "%s: cannot read the trace\n", trace_csv.c_str());
    return 2;
  }
  std::string line;
  if (!std::getline(in, line)) {
    std::fprintf(stderr, "%s:1: empty trace, expected the header of mgc --trace-csv\n", trace_csv.c_str());
    return 2;
  }
  const std::vector<std::string> header = split(line);
  std::vector<int> joint_columns;
  for (const auto& j : scenario.machine.joints) {
    const int c = column(header, j.name);
    if (c < 0) {
      std::fprintf(stderr, "%s:1: no column '%s': expected a trace of %s\n", trace_csv.c_str(), j.name.c_str(),
                   scenario.machine.name.c_str());
      return 2;
    }
    joint_columns.push_back(c);
  }
  // The tracked obstacles are the scenario's dynamic obstacles with tags, in order.
  std::vector<std::size_t> tracked;
  for (std::size_t d = 0; d < scenario.dynamic_obstacles.size(); ++d) {
    if (!scenario.dynamic_obstacles[d].tags.empty()) tracked.push_back(d);
  }
  SvgInput view;
  view.scenario = &scenario;
  view.model = model.get();
  view.step = planning::step_sizes(*model, scenario.planner.space_resolution);
  for (std::size_t d = 0; d < scenario.dynamic_obstacles.size(); ++d) view.dynamic_poses.push_back(scenario.dynamic_obstacles[d].pose_at(0.0));
  std::vector<std::string> last;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size()) {
      std::fprintf(stderr, "%s:%d: %zu columns, expected %zu as in the header\n", trace_csv.c_str(), line_no, cells.size(),
                   header.size());
      return 2;
    }
    if (cells[1] == "INIT") continue;  // no valid position yet
    planning::JointVector q(model->dof());
    for (int j = 0; j < model->dof(); ++j) {
      const std::string& cell = cells[static_cast<std::size_t>(joint_columns[static_cast<std::size_t>(j)])];
      char* end = nullptr;
      q[j] = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str() || !std::isfinite(q[j])) {
        std::fprintf(stderr, "%s:%d: column '%s': '%s' is not a number\n", trace_csv.c_str(), line_no,
                     scenario.machine.joints[static_cast<std::size_t>(j)].name.c_str(), cell.c_str());
        return 2;
      }
    }
    view.path.push_back(q);
    last = cells;
  }
  if (view.path.empty()) {
    std::fprintf(stderr, "%s: no row after INIT: the controller never read the machine\n", trace_csv.c_str());
    return 2;
  }
  for (std::size_t i = 0; i < tracked.size(); ++i) {
    const std::string prefix = "obstacle" + std::to_string(i) + "_";
    const int x = column(header, prefix + "x_m");
    const int yaw = column(header, prefix + "yaw_rad");
    if (x < 0 || yaw < 0) continue;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(std::strtod(last[static_cast<std::size_t>(x)].c_str(), nullptr),
                                         std::strtod(last[static_cast<std::size_t>(x) + 1].c_str(), nullptr),
                                         std::strtod(last[static_cast<std::size_t>(x) + 2].c_str(), nullptr));
    pose.linear() = Eigen::AngleAxisd(std::strtod(last[static_cast<std::size_t>(yaw)].c_str(), nullptr), Eigen::Vector3d::UnitZ())
                        .toRotationMatrix();
    view.dynamic_poses[tracked[i]] = pose;
  }
  return write_svg_file(svg, view) ? 0 : 2;
}

}  // namespace mgc::tools
