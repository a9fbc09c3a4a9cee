// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/site.hpp"

#include <cmath>

namespace mgc::planning {

std::string SiteBus::controller_url() const {
  if (kind == Kind::SocketCan) return "socketcan:" + interface;
  return "udp:127.0.0.1:" + std::to_string(controller_port) + ",peer=127.0.0.1:" + std::to_string(machine_port);
}

std::string SiteBus::machine_url() const {
  if (kind == Kind::SocketCan) return "socketcan:" + interface;
  return "udp:127.0.0.1:" + std::to_string(machine_port) + ",peer=127.0.0.1:" + std::to_string(controller_port);
}

std::array<Eigen::Vector2d, 4> base_footprint(const MachineDefinition& machine,
                                              const Eigen::Isometry3d& world_from_base) noexcept {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  switch (machine.kind) {
    case MachineKind::MobileCrane:
      centre = machine.mobile_crane.carrier_centre_m;
      size = machine.mobile_crane.carrier_size_m;
      break;
    case MachineKind::TowerCrane:
      size = Eigen::Vector3d(machine.tower_crane.mast_width_m, machine.tower_crane.mast_width_m, 0.0);
      break;
    case MachineKind::Excavator:
      centre = machine.excavator.undercarriage_centre_m;
      size = machine.excavator.undercarriage_size_m;
      break;
  }
  const double hx = 0.5 * size.x();
  const double hy = 0.5 * size.y();
  const std::array<Eigen::Vector2d, 4> local = {Eigen::Vector2d(-hx, -hy), Eigen::Vector2d(hx, -hy),
                                                Eigen::Vector2d(hx, hy), Eigen::Vector2d(-hx, hy)};
  std::array<Eigen::Vector2d, 4> out;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector3d p = world_from_base * Eigen::Vector3d(centre.x() + local[i].x(), centre.y() + local[i].y(), 0.0);
    out[i] = p.head<2>();
  }
  return out;
}

namespace {

// Whether some edge normal of `edges_of` separates the two polygons (strictly: touching is overlap).
bool separated_by_edges_of(const std::array<Eigen::Vector2d, 4>& edges_of, const std::array<Eigen::Vector2d, 4>& other) noexcept {
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector2d edge = edges_of[(i + 1) % 4] - edges_of[i];
    const Eigen::Vector2d normal(edge.y(), -edge.x());
    double min_a = normal.dot(edges_of[0]);
    double max_a = min_a;
    for (const Eigen::Vector2d& p : edges_of) {
      min_a = std::min(min_a, normal.dot(p));
      max_a = std::max(max_a, normal.dot(p));
    }
    double min_b = normal.dot(other[0]);
    double max_b = min_b;
    for (const Eigen::Vector2d& p : other) {
      min_b = std::min(min_b, normal.dot(p));
      max_b = std::max(max_b, normal.dot(p));
    }
    if (max_a < min_b || max_b < min_a) return true;
  }
  return false;
}

}  // namespace

bool footprints_overlap(const std::array<Eigen::Vector2d, 4>& a, const std::array<Eigen::Vector2d, 4>& b) noexcept {
  // Separating axis theorem: two convex polygons are apart exactly when an edge normal of one of
  // them separates their projections.
  return !separated_by_edges_of(a, b) && !separated_by_edges_of(b, a);
}

Scenario lift_scenario(const Site& site, std::size_t machine, std::size_t lift) {
  const SiteMachine& m = site.machines.at(machine);
  const SiteLift& l = m.lifts.at(lift);
  Scenario s;
  s.file = site.file;
  s.name = site.name + "/" + std::to_string(m.id) + "/" + l.name;
  s.description = site.description;
  s.machine = m.machine;
  s.world_from_base = m.world_from_base;
  s.task = l.task;
  s.obstacles = site.obstacles;
  s.start = l.start;
  s.goal = l.goal;
  s.start_ref = l.start_ref;
  s.goal_ref = l.goal_ref;
  s.planner = site.planner;
  return s;
}

double max_point_speed_m_s(const MachineModel& model) noexcept {
  double speed = 0.0;
  for (int j = 0; j < model.dof(); ++j) {
    speed += model.displacement_bound(j) * model.joints()[static_cast<std::size_t>(j)].max_velocity;
  }
  return speed;
}

}  // namespace mgc::planning
