// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/site_rules.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mgc::firmware {

int SiteRoster::index_of(std::int32_t machine_id) const noexcept {
  for (std::size_t i = 0; i < count; ++i) {
    if (machines[i].machine_id == machine_id) return static_cast<int>(i);
  }
  return -1;
}

SiteRoster make_site_roster(const planning::Site& site) {
  if (site.machines.size() > kMaxSiteMachines) {
    throw std::invalid_argument("site " + site.name + ": " + std::to_string(site.machines.size()) + " machines, at most " +
                                std::to_string(kMaxSiteMachines));
  }
  SiteRoster roster;
  for (std::size_t i = 0; i < site.machines.size(); ++i) {
    const planning::SiteMachine& m = site.machines[i];
    if (m.machine.joints.size() > static_cast<std::size_t>(kMaxJoints)) {
      throw std::invalid_argument("site machine " + std::to_string(m.id) + ": more than " + std::to_string(kMaxJoints) + " joints");
    }
    SiteRosterEntry& e = roster.machines[i];
    e.machine_id = m.id;
    e.priority = m.priority;
    e.num_joints = static_cast<int>(m.machine.joints.size());
    for (std::size_t j = 0; j < m.machine.joints.size(); ++j) {
      const planning::JointSpec& spec = m.machine.joints[j];
      e.position_min[j] = spec.position_min;
      e.position_max[j] = spec.position_max;
      e.max_velocity[j] = spec.max_velocity;
      e.revolute[j] = spec.type == planning::JointType::Revolute;
      e.continuous[j] = spec.continuous;
    }
    e.has_uwb_tags = !m.uwb_tags.empty();
    // The largest over its lifts: a lift's load and rigging can move the farthest body point
    // outward, and with it the bound.
    double speed = 0.0;
    for (std::size_t l = 0; l < m.lifts.size(); ++l) {
      const auto model = planning::build_model(planning::lift_scenario(site, i, l));
      speed = std::max(speed, planning::max_point_speed_m_s(*model));
    }
    e.max_point_speed_m_s = speed;
  }
  roster.count = site.machines.size();
  return roster;
}

namespace {

SiteMotion mutual_stop(double meet_in_s, bool i_am_lower, double horizon_s) noexcept {
  if (std::isnan(meet_in_s)) return SiteMotion::Stop;
  // The lower-priority machine stops one horizon earlier, so that in the usual case its stop
  // clears the way before the higher one has to stop too.
  const double lead_s = i_am_lower ? 2.0 * horizon_s : horizon_s;
  if (meet_in_s <= lead_s) return SiteMotion::Stop;
  if (meet_in_s <= lead_s + horizon_s) return SiteMotion::SlowDown;
  return SiteMotion::Proceed;
}

}  // namespace

SiteDecision decide_site(const SiteRoster& roster, std::int32_t my_id, std::span<const SitePeerInput> peers,
                         std::int64_t now_us, const SiteRulesConfig& config) noexcept {
  SiteDecision out;
  const int me = roster.index_of(my_id);
  if (me < 0 || peers.size() != roster.count) {
    out.invalid_input = true;
    out.motion = SiteMotion::Stop;
    return out;
  }
  const SiteRosterEntry& mine = roster.machines[static_cast<std::size_t>(me)];
  out.count = roster.count;
  for (std::size_t i = 0; i < roster.count; ++i) {
    const SiteRosterEntry& other = roster.machines[i];
    const SitePeerInput& in = peers[i];
    SitePeerDecision& d = out.peers[i];
    d.machine_id = other.machine_id;
    if (static_cast<int>(i) == me) {
      d.link = SiteLink::Self;
      continue;
    }
    if (in.state != nullptr) d.age_us = std::max<std::int64_t>(0, now_us - in.state_received_us);
    const bool live = in.state != nullptr && d.age_us <= config.stale_after_us();
    // What it is worth at worst: received up to max_skew_us after it was sent.
    const double worst_age_s = static_cast<double>(std::max<std::int64_t>(d.age_us, 0) + config.max_skew_us) * 1e-6;
    if (!live) {
      d.link = SiteLink::Stale;
      if (other.has_uwb_tags && in.tags_posed) {
        d.prediction = SitePrediction::UwbTags;
        // Seen by the site's RTLS it is any dynamic obstacle: it may not hear me, so I stop as
        // the lower priority does, a horizon early.
        d.motion = mutual_stop(in.meet_in_s, true, config.horizon_s);
        if (d.motion > out.motion) {
          out.motion = d.motion;
          out.motion_for_id = d.machine_id;
        }
      } else if (in.state != nullptr) {
        d.prediction = SitePrediction::FrozenPose;
        d.grow_m = other.max_point_speed_m_s * worst_age_s;
      } else {
        d.prediction = SitePrediction::WholeReach;
      }
      continue;
    }
    d.link = SiteLink::Live;
    const bool i_am_lower = other.priority < mine.priority;
    d.role = i_am_lower ? SiteRole::PlanAround : SiteRole::CheckEnvelope;
    if (in.plan != nullptr && in.state->plan_id != 0 && in.plan->plan_id == in.state->plan_id) {
      d.prediction = SitePrediction::Plan;
    } else {
      d.prediction = SitePrediction::StoppingEnvelope;
      d.grow_m = other.max_point_speed_m_s * worst_age_s;
    }
    d.motion = mutual_stop(in.meet_in_s, i_am_lower, config.horizon_s);
    if (d.motion > out.motion) {
      out.motion = d.motion;
      out.motion_for_id = d.machine_id;
    }
  }
  return out;
}

const char* to_string(SiteLink link) noexcept {
  switch (link) {
    case SiteLink::Self: return "self";
    case SiteLink::Live: return "live";
    case SiteLink::Stale: return "stale";
  }
  return "unknown";
}

const char* to_string(SiteRole role) noexcept {
  switch (role) {
    case SiteRole::None: return "none";
    case SiteRole::PlanAround: return "plan around";
    case SiteRole::CheckEnvelope: return "check envelope";
  }
  return "unknown";
}

const char* to_string(SitePrediction prediction) noexcept {
  switch (prediction) {
    case SitePrediction::None: return "none";
    case SitePrediction::Plan: return "plan";
    case SitePrediction::StoppingEnvelope: return "stopping envelope";
    case SitePrediction::UwbTags: return "UWB tags";
    case SitePrediction::FrozenPose: return "frozen pose";
    case SitePrediction::WholeReach: return "whole reach";
  }
  return "unknown";
}

const char* to_string(SiteMotion motion) noexcept {
  switch (motion) {
    case SiteMotion::Proceed: return "proceed";
    case SiteMotion::SlowDown: return "slow down";
    case SiteMotion::Stop: return "stop";
  }
  return "unknown";
}

}  // namespace mgc::firmware
