// SPDX-License-Identifier: Apache-2.0
#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "mgc/planning/io/scenario_loader.hpp"

namespace mgc::display {
namespace {

void write_points(Json& out, const std::vector<Eigen::Vector3d>& points) {
  out.begin_array();
  for (const auto& p : points) out.point(p);
  out.end_array();
}

}  // namespace

Scene::Scene(const std::string& scenario_file) {
  planning::io::LoadedScenario loaded = planning::io::load_and_build(scenario_file);
  scenario_ = std::move(loaded.scenario);
  model_ = std::move(loaded.model);
  tool_index_ = model_->key_point_index(model_->kind() == planning::MachineKind::Excavator ? "bucket_tip" : "hook");
}

Scene::Scene(planning::Scenario scenario) : scenario_(std::move(scenario)), model_(planning::build_model(scenario_)) {
  tool_index_ = model_->key_point_index(model_->kind() == planning::MachineKind::Excavator ? "bucket_tip" : "hook");
}

std::string Scene::static_json() const {
  Json out;
  out.begin_object();
  out.key("name").value(scenario_.name);
  out.key("file").value(scenario_.file);
  out.key("joints").begin_array();
  for (const auto& j : model_->joints()) {
    out.begin_object();
    out.key("name").value(j.name);
    out.key("unit").value(j.unit());
    out.key("min").value(j.position_min);
    out.key("max").value(j.position_max);
    out.end_object();
  }
  out.end_array();
  const auto write_q = [&](const planning::JointVector& q) {
    out.begin_array();
    for (int i = 0; i < q.size(); ++i) out.value(q[i]);
    out.end_array();
  };
  out.key("start");
  write_q(scenario_.start);
  out.key("goal");
  write_q(scenario_.goal);
  out.key("obstacles").begin_array();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  const auto grow = [&](const std::vector<Eigen::Vector3d>& points) {
    for (const auto& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  };
  for (const auto& o : scenario_.obstacles) {
    const auto corners = planning::outline_points(o.shape);
    grow(corners);
    out.begin_object();
    out.key("name").value(o.name);
    out.key("corners");
    write_points(out, corners);
    out.end_object();
  }
  out.end_array();
  planning::Kinematics k;
  for (const auto* q : {&scenario_.start, &scenario_.goal}) {
    if (q->size() != model_->dof()) continue;
    model_->forward_kinematics(*q, k);
    for (std::size_t b = 0; b < model_->bodies().size(); ++b) grow(planning::box_corners(k.bodies[b].world_from_body, k.bodies[b].size_m));
  }
  lo.z() = std::min(lo.z(), 0.0);
  out.key("bounds_lo").point(lo);
  out.key("bounds_hi").point(hi);
  out.end_object();
  return out.str();
}

void Scene::write_machine(Json& out, const planning::JointVector& q) const {
  planning::Kinematics k;
  model_->forward_kinematics(q, k);
  out.begin_object();
  out.key("bodies").begin_array();
  for (std::size_t b = 0; b < model_->bodies().size(); ++b) {
    write_points(out, planning::box_corners(k.bodies[b].world_from_body, k.bodies[b].size_m));
  }
  out.end_array();
  out.key("tool").point(k.points[static_cast<std::size_t>(tool_index_)]);
  out.key("base").point(model_->world_from_base().translation());
  out.end_object();
}

void Scene::write_dynamic_obstacle(Json& out, int index, const Eigen::Vector3d& position_m, double yaw_rad) const {
  out.begin_array();
  if (index >= 0 && static_cast<std::size_t>(index) < scenario_.dynamic_obstacles.size()) {
    // As DynamicObstacleSpec::pose_at places the obstacle frame: translate, then yaw about z.
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translate(position_m);
    pose.rotate(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
    for (const auto& part : scenario_.dynamic_obstacles[static_cast<std::size_t>(index)].obstacle.parts) {
      write_points(out, planning::outline_points(part, pose));
    }
  }
  out.end_array();
}

std::string Scene::dynamic_name(int index) const {
  if (index < 0 || static_cast<std::size_t>(index) >= scenario_.dynamic_obstacles.size()) return "";
  return scenario_.dynamic_obstacles[static_cast<std::size_t>(index)].obstacle.name;
}

std::vector<Eigen::Vector3d> Scene::tool_path(const std::vector<planning::JointVector>& waypoints) const {
  std::vector<Eigen::Vector3d> path;
  for (const auto& w : waypoints) {
    if (w.size() != model_->dof() || !w.allFinite()) return {};
  }
  planning::Kinematics k;
  const auto tool_at = [&](const planning::JointVector& q) {
    model_->forward_kinematics(q, k);
    return k.points[static_cast<std::size_t>(tool_index_)];
  };
  for (std::size_t e = 0; e + 1 < waypoints.size(); ++e) {
    const planning::JointVector d = model_->difference(waypoints[e], waypoints[e + 1]);
    int n = 1;
    for (int i = 0; i < model_->dof(); ++i) {
      const double step = model_->joints()[static_cast<std::size_t>(i)].type == planning::JointType::Revolute ? 2.0 * M_PI / 180.0 : 0.1;
      n = std::max(n, static_cast<int>(std::ceil(std::abs(d[i]) / step)));
    }
    n = std::min(n, 200);
    for (int s = (e == 0 ? 0 : 1); s <= n; ++s) {
      path.push_back(tool_at(model_->interpolate(waypoints[e], waypoints[e + 1], static_cast<double>(s) / n)));
    }
  }
  if (waypoints.size() == 1) path.push_back(tool_at(waypoints[0]));
  return path;
}

}  // namespace mgc::display
