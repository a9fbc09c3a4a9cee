// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/site_member.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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
    const std::vector<planning::MachineTagSpec>& tags = config.site.machines[i].uwb_tags;
    if (tags.size() > planning::kMaxMachineTags) throw std::invalid_argument("site machine " + std::to_string(p.machine_id) + ": too many UWB tags");
    for (const planning::MachineTagSpec& t : tags) {
      const auto k = static_cast<std::size_t>(p.num_tags++);
      p.tag_ids[k] = static_cast<std::uint8_t>(t.id);
      p.tag_mounts[k] = planning::resolve_site_tag_mount(*p.model, t.body);
      if (p.tag_mounts[k].index < 0) {
        throw std::invalid_argument("site machine " + std::to_string(p.machine_id) + " tag " + std::to_string(t.id) + ": no body or frame '" + t.body + "'");
      }
      p.tag_local_m[k] = t.position_m;
    }
    p.tag_pose.q = p.q;
    p.tag_pose.v = planning::JointVector::Zero(p.q.size());
    for (auto& q : p.tag_track.fit_q) q = p.q;
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

namespace {

//! A joint whose unit motion moves the fresh tags by less than this is not seen by them. [m/rad | m/m]
constexpr double kTagSeesJoint = 0.2;
//! Step of the fit's numerical derivative. [rad | m]
constexpr double kTagFitStep = 1e-4;
constexpr int kTagFitIterations = 10;
//! Fits kept for the velocity at least this far apart. [µs]
constexpr std::int64_t kTagRingSpacing_us = 50'000;

using TagResidual = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 3 * static_cast<int>(planning::kMaxMachineTags), 1>;
using TagJacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 3 * static_cast<int>(planning::kMaxMachineTags),
                                  static_cast<int>(kMaxJoints)>;
using JointMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, static_cast<int>(kMaxJoints),
                                  static_cast<int>(kMaxJoints)>;

}  // namespace

const SiteTagPose& site_fit_tags(SitePeerModel& p, const hal::SensorSnapshot& snapshot, const planning::JointVector& seed_q,
                                 std::int64_t seed_us, std::int64_t now_us, const SiteMemberConfig& config) noexcept {
  SiteTagPose& out = p.tag_pose;
  SiteTagTrack& track = p.tag_track;
  out.valid = false;
  out.tags_used = 0;
  if (p.num_tags == 0) return out;
  const int n = p.model->dof();
  // Every tag's latest fix, when fresh.
  std::array<Eigen::Vector3d, planning::kMaxMachineTags> fix_m{};
  std::array<int, planning::kMaxMachineTags> tag_of{};
  int used = 0;
  double sigma_m = 0.0;
  std::int64_t newest_us = std::numeric_limits<std::int64_t>::min();
  std::int64_t oldest_us = std::numeric_limits<std::int64_t>::max();
  for (int k = 0; k < p.num_tags; ++k) {
    const hal::TagReading* r = snapshot.find_tag(p.tag_ids[static_cast<std::size_t>(k)]);
    if (r == nullptr || !r->valid || now_us - r->t_us > config.tag_max_age_us) continue;
    const auto u = static_cast<std::size_t>(used++);
    fix_m[u] = Eigen::Vector3d(r->position_m[0], r->position_m[1], r->position_m[2]);
    tag_of[u] = k;
    sigma_m = std::max(sigma_m, r->sigma_m);
    newest_us = std::max(newest_us, r->t_us);
    oldest_us = std::min(oldest_us, r->t_us);
  }
  out.tags_used = used;
  if (used == 0) return out;
  const auto last = (track.head + track.fits + SiteTagTrack::kHistory - 1) % SiteTagTrack::kHistory;
  if (!track.seeded) {
    track.fits = 0;
    for (int j = 0; j < n; ++j) track.seen_us[static_cast<std::size_t>(j)] = seed_us;
  }
  planning::JointVector q = track.seeded && track.fits > 0 ? out.q : seed_q;
  const auto residual = [&](const planning::JointVector& at, TagResidual& r) noexcept {
    p.model->forward_kinematics(at, p.tag_kinematics);
    for (int i = 0; i < used; ++i) {
      const auto k = static_cast<std::size_t>(tag_of[static_cast<std::size_t>(i)]);
      r.segment<3>(3 * i) = fix_m[static_cast<std::size_t>(i)] - planning::tag_position(p.tag_kinematics, p.tag_mounts[k], p.tag_local_m[k]);
    }
  };
  TagResidual r(3 * used);
  TagResidual rh(3 * used);
  TagJacobian jac(3 * used, n);
  JointMatrix a(n, n);
  planning::JointVector b(n);
  planning::JointVector qh(n);
  std::array<bool, kMaxJoints> sees{};
  for (int it = 0; it < kTagFitIterations; ++it) {
    residual(q, r);
    for (int j = 0; j < n; ++j) {
      qh = q;
      qh[j] += kTagFitStep;
      residual(qh, rh);
      // The model's tag moves by -(rh - r): d(model)/dq.
      jac.col(j) = (r - rh) / kTagFitStep;
      if (it == 0) sees[static_cast<std::size_t>(j)] = jac.col(j).norm() >= kTagSeesJoint;
    }
    // Normal equations over the joints the tags see; the others keep their value.
    for (int j = 0; j < n; ++j) {
      const bool sj = sees[static_cast<std::size_t>(j)];
      b[j] = sj ? jac.col(j).dot(r) : 0.0;
      for (int k = 0; k < n; ++k) a(j, k) = sj && sees[static_cast<std::size_t>(k)] ? jac.col(j).dot(jac.col(k)) : 0.0;
      a(j, j) += sj ? 1e-9 : 1.0;
    }
    const planning::JointVector dq = a.ldlt().solve(b);
    double step = 0.0;
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& spec = p.model->joints()[static_cast<std::size_t>(j)];
      if (!std::isfinite(dq[j])) return out;
      q[j] += dq[j];
      if (!spec.continuous) q[j] = std::clamp(q[j], spec.position_min, spec.position_max);
      step = std::max(step, std::abs(dq[j]));
    }
    if (step < 1e-7) break;
  }
  residual(q, r);
  double worst_m = 0.0;
  for (int i = 0; i < used; ++i) worst_m = std::max(worst_m, r.segment<3>(3 * i).norm());
  ++track.fits_done;
  const double gate_m = 3.0 * sigma_m + config.tag_residual_gate_m;
  bool plausible = worst_m <= gate_m;
  if (plausible && track.seeded && track.fits > 0) {
    // Not farther from the last fit than the machine can move meanwhile.
    double moved_m = 0.0;
    for (int j = 0; j < n; ++j) moved_m += p.model->displacement_bound(j) * std::abs(q[j] - track.fit_q[last][j]);
    const double dt_s = static_cast<double>(std::max<std::int64_t>(newest_us - track.fit_us[last], 0)) * 1e-6;
    plausible = moved_m <= p.max_point_speed_m_s * dt_s + 2.0 * gate_m;
  }
  if (!plausible) {
    ++track.fits_implausible;
    track.seeded = false;
    track.fits = 0;
    return out;
  }
  track.seeded = true;
  for (int j = 0; j < n; ++j) {
    if (sees[static_cast<std::size_t>(j)]) track.seen_us[static_cast<std::size_t>(j)] = oldest_us;
  }
  // The ring keeps a fit every kTagRingSpacing_us: the velocity is their least-squares slope over
  // the window, which averages the fixes' noise down.
  if (track.fits == 0 || newest_us - track.fit_us[last] >= kTagRingSpacing_us) {
    const auto at = (track.head + track.fits) % SiteTagTrack::kHistory;
    track.fit_us[at] = newest_us;
    track.fit_q[at] = q;
    if (track.fits < SiteTagTrack::kHistory) {
      ++track.fits;
    } else {
      track.head = (track.head + 1) % SiteTagTrack::kHistory;
    }
  }
  out.t_us = newest_us;
  out.q = q;
  out.residual_m = worst_m;
  int count = 0;
  double t_mean_s = 0.0;
  for (std::size_t i = 0; i < track.fits; ++i) {
    const std::size_t at = (track.head + i) % SiteTagTrack::kHistory;
    if (newest_us - track.fit_us[at] > config.tag_velocity_window_us) continue;
    t_mean_s += static_cast<double>(track.fit_us[at] - newest_us) * 1e-6;
    ++count;
  }
  if (count < 3) return out;
  t_mean_s /= count;
  double stt = 0.0;
  double span_s = 0.0;
  for (int j = 0; j < n; ++j) out.v[j] = 0.0;
  for (std::size_t i = 0; i < track.fits; ++i) {
    const std::size_t at = (track.head + i) % SiteTagTrack::kHistory;
    if (newest_us - track.fit_us[at] > config.tag_velocity_window_us) continue;
    const double dt = static_cast<double>(track.fit_us[at] - newest_us) * 1e-6 - t_mean_s;
    span_s = std::max(span_s, static_cast<double>(newest_us - track.fit_us[at]) * 1e-6);
    stt += dt * dt;
    for (int j = 0; j < n; ++j) out.v[j] += dt * track.fit_q[at][j];
  }
  // Not yet half a window of fits: no velocity to carry it at.
  if (span_s < 0.5e-6 * static_cast<double>(config.tag_velocity_window_us) || !(stt > 0.0)) return out;
  for (int j = 0; j < n; ++j) out.v[j] /= stt;
  const double latency_s = static_cast<double>(config.tag_latency_us) * 1e-6;
  double unseen_m = 0.0;
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    if (sees[k]) continue;
    // Unseen since seen_us: anywhere its speed could take it, or anywhere in its range.
    const planning::JointSpec& spec = p.model->joints()[k];
    const double unseen_s = track.seen_us[k] == std::numeric_limits<std::int64_t>::min()
                                ? std::numeric_limits<double>::infinity()
                                : static_cast<double>(now_us - track.seen_us[k]) * 1e-6 + latency_s;
    double travel = spec.max_velocity * unseen_s;
    if (!spec.continuous) travel = std::min(travel, spec.position_max - spec.position_min);
    unseen_m += p.model->displacement_bound(j) * std::min(travel, 1e6);
    out.v[j] = 0.0;
  }
  const double noise_m = worst_m + 3.0 * sigma_m;
  out.grow_m = noise_m + unseen_m + p.max_point_speed_m_s * (static_cast<double>(now_us - oldest_us) * 1e-6 + latency_s);
  // Three sigmas of the slope, a fit's error taken as a third of the noise bound.
  out.speed_error_m_s = noise_m / std::sqrt(stt);
  // The slope is the velocity at the window's mean time.
  out.velocity_lag_s = -t_mean_s + latency_s;
  out.valid = true;
  return out;
}

SiteLiftQueue::SiteLiftQueue(const planning::Site& site, std::int32_t machine_id) {
  const planning::SiteMachine* machine = nullptr;
  for (const planning::SiteMachine& m : site.machines) {
    if (m.id == machine_id) machine = &m;
  }
  if (machine == nullptr) throw std::invalid_argument("site " + site.name + ": machine id " + std::to_string(machine_id) + " is not in the site");
  lifts_ = machine->lifts.size();
  for (std::size_t l = 0; l < lifts_; ++l) {
    const planning::SiteLift& lift = machine->lifts[l];
    const auto n = static_cast<int>(std::min<Eigen::Index>(lift.goal.size(), static_cast<Eigen::Index>(kMaxJoints)));
    if (l == 0) {
      legs_.push_back({{}, 0, 0, true});
      continue;
    }
    const planning::JointVector& before = machine->lifts[l - 1].goal;
    if (!(before.size() == lift.start.size() && before.isApprox(lift.start, 0.0))) {
      Leg to_start{{}, n, l, false};
      for (int j = 0; j < n; ++j) to_start.goal[static_cast<std::size_t>(j)] = lift.start[j];
      legs_.push_back(to_start);
    }
    Leg to_goal{{}, n, l, true};
    for (int j = 0; j < n; ++j) to_goal.goal[static_cast<std::size_t>(j)] = lift.goal[j];
    legs_.push_back(to_goal);
  }
}

bool SiteLiftQueue::goal(std::array<double, kMaxJoints>& goal, int& goal_joints) const noexcept {
  if (done()) return false;
  goal = legs_[leg_].goal;
  goal_joints = legs_[leg_].joints;
  return true;
}

bool SiteLiftQueue::reached() noexcept {
  if (done()) return false;
  const bool lift_done = legs_[leg_].ends_lift;
  if (lift_done) ++lifts_done_;
  ++leg_;
  return lift_done;
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
