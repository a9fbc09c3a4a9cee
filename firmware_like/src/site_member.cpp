// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/site_member.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mgc::firmware {
namespace {

//! Where a posed body waits when no rule poses it: far below the site, every one apart. [m]
constexpr double kParkedDepth_m = -10'000.0;

std::size_t my_index(const SiteMemberConfig& config) {
  for (std::size_t i = 0; i < config.site.machines.size(); ++i) {
    if (config.site.machines[i].id == config.machine_id) return i;
  }
  throw std::invalid_argument("site " + config.site.name + ": machine id " + std::to_string(config.machine_id) + " is not in the site");
}

//! A machine's model as the site poses it: its first lift's load and rigging.
std::unique_ptr<planning::MachineModel> peer_model(const planning::Site& site, std::size_t i) {
  if (site.machines[i].lifts.empty()) {
    throw std::invalid_argument("site " + site.name + ": machine " + std::to_string(site.machines[i].id) + " has no lift");
  }
  return planning::build_model(planning::lift_scenario(site, i, 0));
}

planning::ShapePart body_part(const planning::BodySpec& spec, const planning::BodyState& state) {
  planning::ShapePart part;
  part.kind = spec.shape == planning::BodyShape::Box ? planning::ShapeKind::Box : planning::ShapeKind::Capsule;
  part.size_m = state.size_m.cwiseMax(Eigen::Vector3d::Constant(0.01));
  return part;
}

//! Which of model's bodies move with its joints, by the collision world's own finding.
//! How many copies of machine i's moving bodies my planning worlds hold (SitePeerModel::copies).
int copies_of(const SiteMemberConfig& config, std::size_t me, std::size_t i) {
  return config.site.machines[i].priority < config.site.machines[me].priority ? config.plan_copies : 1;
}

std::vector<int> moving_bodies(const planning::MachineModel& model) {
  planning::CollisionWorld world(model, 0.0);
  world.finalize();
  std::vector<int> moving;
  for (int b = 0; b < static_cast<int>(model.bodies().size()); ++b) {
    if (world.body_moves(b)) moving.push_back(b);
  }
  return moving;
}

}  // namespace

Eigen::Isometry3d site_parked_pose(int peer, int copy, int body) noexcept {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1000.0 * peer, 1000.0 * copy, kParkedDepth_m - 1000.0 * body);
  return pose;
}

planning::Scenario site_member_scenario(const planning::Scenario& lift, const SiteMemberConfig& config) {
  const std::size_t me = my_index(config);
  if (config.plan_copies < 2) throw std::invalid_argument("site member: plan_copies must be >= 2");
  planning::Scenario s = lift;
  for (std::size_t i = 0; i < config.site.machines.size(); ++i) {
    if (i == me) continue;
    const planning::SiteMachine& m = config.site.machines[i];
    const auto model = peer_model(config.site, i);
    const std::vector<int> moving = moving_bodies(*model);
    planning::Kinematics k;
    planning::JointVector q = planning::lift_scenario(config.site, i, 0).start;
    model->forward_kinematics(q, k);
    for (int b = 0; b < static_cast<int>(model->bodies().size()); ++b) {
      if (std::find(moving.begin(), moving.end(), b) != moving.end()) continue;
      planning::StaticObstacle o;
      o.name = "machine-" + std::to_string(m.id) + "/" + model->bodies()[static_cast<std::size_t>(b)].name;
      o.shape = body_part(model->bodies()[static_cast<std::size_t>(b)], k.bodies[static_cast<std::size_t>(b)]);
      o.shape.pose = k.bodies[static_cast<std::size_t>(b)].world_from_body;
      s.obstacles.push_back(std::move(o));
    }
    for (int c = 0; c < copies_of(config, me, i); ++c) {
      for (std::size_t kb = 0; kb < moving.size(); ++kb) {
        const int b = moving[kb];
        planning::DynamicObstacleSpec d;
        d.obstacle.name = "machine-" + std::to_string(m.id) + "/" + model->bodies()[static_cast<std::size_t>(b)].name;
        d.obstacle.parts.push_back(body_part(model->bodies()[static_cast<std::size_t>(b)], k.bodies[static_cast<std::size_t>(b)]));
        planning::Keyframe key;
        key.position_m = site_parked_pose(static_cast<int>(i), c, static_cast<int>(kb)).translation();
        d.motion.push_back(key);
        s.dynamic_obstacles.push_back(std::move(d));
      }
    }
  }
  return s;
}

planning::Scenario site_stop_check_scenario(planning::Scenario member, std::size_t own_dynamic) {
  if (member.dynamic_obstacles.size() > own_dynamic) member.dynamic_obstacles.resize(own_dynamic);
  return member;
}

std::vector<SitePeerModel> make_site_peers(const SiteMemberConfig& config, const planning::MachineModel& my_model, int first_dynamic) {
  const std::size_t me = my_index(config);
  const SiteRoster roster = make_site_roster(config.site);
  std::vector<SitePeerModel> peers;
  int next = first_dynamic;
  for (std::size_t i = 0; i < config.site.machines.size(); ++i) {
    if (i == me) continue;
    SitePeerModel p;
    p.roster_index = static_cast<int>(i);
    p.machine_id = config.site.machines[i].id;
    p.max_point_speed_m_s = roster.machines[i].max_point_speed_m_s;
    p.model = peer_model(config.site, i);
    p.moving_bodies = moving_bodies(*p.model);
    p.meet_world = std::make_unique<planning::CollisionWorld>(my_model, 0.0);
    p.q = planning::lift_scenario(config.site, i, 0).start;
    p.model->forward_kinematics(p.q, p.kinematics);
    for (std::size_t kb = 0; kb < p.moving_bodies.size(); ++kb) {
      const auto b = static_cast<std::size_t>(p.moving_bodies[kb]);
      planning::DynamicObstacle d;
      d.name = "machine-" + std::to_string(p.machine_id) + "/" + p.model->bodies()[b].name;
      d.parts.push_back(body_part(p.model->bodies()[b], p.kinematics.bodies[b]));
      (void)p.meet_world->add_dynamic(std::move(d));
    }
    p.meet_world->finalize();
    for (int kb = 0; kb < static_cast<int>(p.moving_bodies.size()); ++kb) {
      p.meet_world->set_dynamic_pose(kb, site_parked_pose(static_cast<int>(i), 0, kb));
    }
    p.higher = config.site.machines[i].priority < config.site.machines[me].priority;
    p.copies = copies_of(config, me, i);
    // Nothing known parked yet: the first park sets every copy.
    p.parked_from = p.copies;
    p.world_first = next;
    next += p.copies * static_cast<int>(p.moving_bodies.size());
    peers.push_back(std::move(p));
  }
  return peers;
}

bool site_same_motion(const site_plan_t& a, const site_plan_t& b) noexcept {
  if (a.num_joints != b.num_joints || a.num_waypoints != b.num_waypoints) return false;
  const int n = std::clamp<int>(a.num_joints, 0, site_plan_t::MAX_JOINTS);
  const int w = std::clamp<int>(a.num_waypoints, 0, site_plan_t::MAX_WAYPOINTS);
  for (int i = 0; i < w; ++i) {
    if (a.waypoint_time_s[i] != b.waypoint_time_s[i]) return false;
    for (int j = 0; j < n; ++j) {
      if (a.positions[i][j] != b.positions[i][j]) return false;
    }
  }
  return true;
}

double site_plan_copy_time_s(const site_plan_t& plan, int w, int c, int copies) noexcept {
  const double first_s = plan.waypoint_time_s[0];
  const double last_s = plan.waypoint_time_s[std::clamp<int>(w, 1, site_plan_t::MAX_WAYPOINTS) - 1];
  return first_s + (last_s - first_s) * static_cast<double>(c) / static_cast<double>(std::max(copies, 1));
}

void site_plan_at(const site_plan_t& plan, double t_s, planning::JointVector& q) noexcept {
  const int n = std::min<int>(plan.num_joints, static_cast<int>(q.size()));
  const int w = std::clamp<int>(plan.num_waypoints, 0, site_plan_t::MAX_WAYPOINTS);
  if (w <= 0) return;
  int i = 0;
  while (i + 1 < w && plan.waypoint_time_s[i + 1] <= t_s) ++i;
  if (i + 1 >= w || t_s <= plan.waypoint_time_s[0]) {
    const int at = t_s <= plan.waypoint_time_s[0] ? 0 : w - 1;
    for (int j = 0; j < n; ++j) q[j] = plan.positions[at][j];
    return;
  }
  const double span_s = plan.waypoint_time_s[i + 1] - plan.waypoint_time_s[i];
  const double f = span_s > 0.0 ? std::clamp((t_s - plan.waypoint_time_s[i]) / span_s, 0.0, 1.0) : 1.0;
  for (int j = 0; j < n; ++j) q[j] = plan.positions[i][j] + f * (plan.positions[i + 1][j] - plan.positions[i][j]);
}

void take_site_state(SiteInputs& inputs, int roster_index, const site_state_t& state, std::int64_t received_us,
                     SiteTakeObserver* observer) noexcept {
  if (roster_index < 0 || static_cast<std::size_t>(roster_index) >= inputs.peers.size()) return;
  SitePeerMessages& peer = inputs.peers[static_cast<std::size_t>(roster_index)];
  peer.state = state;
  peer.has_state = true;
  peer.state_received_us = received_us;
  if (observer != nullptr) observer->took_site_state(roster_index, state, received_us);
}

void take_site_plan(SiteInputs& inputs, int roster_index, const site_plan_t& plan, SiteTakeObserver* observer) noexcept {
  if (roster_index < 0 || static_cast<std::size_t>(roster_index) >= inputs.peers.size()) return;
  SitePeerMessages& peer = inputs.peers[static_cast<std::size_t>(roster_index)];
  peer.plan = plan;
  peer.has_plan = true;
  if (observer != nullptr) observer->took_site_plan(roster_index, plan);
}

}  // namespace mgc::firmware
