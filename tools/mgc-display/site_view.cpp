// SPDX-License-Identifier: Apache-2.0
#include "site_view.hpp"

#include <cmath>
#include <span>
#include <stdexcept>

#include "mgc/firmware/site_rules.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/planning/obstacle.hpp"

namespace mgc::display {

SiteView::SiteView(const std::string& site_file, std::optional<std::int32_t> own_id, std::optional<firmware::SiteKey> key,
                   std::int64_t (*realtime_us)() noexcept)
    : site_(planning::io::load_site(site_file)),
      own_id_(own_id),
      realtime_us_(realtime_us),
      // The controllers' own rule for a member not heard from (firmware::SiteRulesConfig).
      stale_after_us_(firmware::SiteRulesConfig{}.stale_after_us()) {
  if (own_id_) (void)planning::io::site_machine_index(site_, *own_id_);
  if (key) {
    if (!own_id_) throw std::invalid_argument("a site key needs this display's machine id (--machine-id)");
    verifier_ = std::make_unique<firmware::SiteVerifier>(*key, firmware::make_site_roster(site_), *own_id_);
    key_ = std::move(key);
  }
  for (std::size_t i = 0; i < site_.machines.size(); ++i) {
    const planning::SiteMachine& m = site_.machines[i];
    Member member;
    member.id = m.id;
    member.priority = m.priority;
    member.name = m.machine.name;
    member.model = planning::build_model(planning::lift_scenario(site_, i, 0));
    member.own = own_id_ && *own_id_ == m.id;
    members_.push_back(std::move(member));
  }
}

SiteView::~SiteView() = default;

bool SiteView::on_state(const void* data, int size, std::int64_t now_us, std::int64_t realtime_now_us) {
  const std::lock_guard lock(mutex_);
  site_state_t msg{};
  const char* refusal = nullptr;
  if (verifier_) {
    const firmware::SiteReason reason = verifier_->check_state_bytes(
        std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(data), static_cast<std::size_t>(size)), msg,
        realtime_now_us >= 0 ? realtime_now_us : realtime_us_());
    if (reason == firmware::SiteReason::OwnMachine) {
      ++own_echoes_;
      return true;
    }
    if (reason != firmware::SiteReason::Accepted) refusal = firmware::site_reason_name(reason);
  } else {
    // Unverified: only what the page needs to draw it at all is checked.
    if (size < 0 || msg.decode(data, 0, size) != size) refusal = firmware::site_reason_name(firmware::SiteReason::Undecodable);
  }
  Member* member = nullptr;
  if (!refusal) {
    for (Member& m : members_) member = m.id == msg.machine_id ? &m : member;
    if (!member) {
      refusal = firmware::site_reason_name(firmware::SiteReason::UnknownMachine);
    } else if (member->own) {
      // Its own controller's states, which every member hears too: drawn from the feed instead.
      ++own_echoes_;
      return true;
    } else if (msg.num_joints != member->model->dof()) {
      refusal = firmware::site_reason_name(firmware::SiteReason::JointCount);
    } else {
      for (int j = 0; j < msg.num_joints; ++j) {
        if (!std::isfinite(msg.joint_position[j])) refusal = firmware::site_reason_name(firmware::SiteReason::NotFinite);
      }
    }
  }
  if (refusal) {
    ++refused_[refusal];
    return false;
  }
  member->last = msg;
  member->received_us = now_us;
  return true;
}

void SiteView::clear() {
  const std::lock_guard lock(mutex_);
  for (Member& m : members_) m.received_us = -1;
  if (key_) verifier_ = std::make_unique<firmware::SiteVerifier>(*key_, firmware::make_site_roster(site_), *own_id_);
}

void SiteView::write_json(Json& out, std::int64_t now_us) const {
  const std::lock_guard lock(mutex_);
  out.key("site").begin_object();
  out.key("name").value(site_.name);
  out.key("verified").value(verifier_ != nullptr);
  out.key("stale_after_s").value(static_cast<double>(stale_after_us_) * 1e-6);
  out.key("refused").begin_object();
  for (const auto& [reason, n] : refused_) out.key(reason).value(static_cast<long long>(n));
  out.end_object();
  out.key("own_echoes").value(static_cast<long long>(own_echoes_));
  out.key("members").begin_array();
  planning::Kinematics k;
  for (const Member& m : members_) {
    out.begin_object();
    out.key("id").value(m.id);
    out.key("priority").value(m.priority);
    out.key("name").value(m.name);
    out.key("own").value(m.own);
    if (m.received_us < 0) {
      out.key("age_s").null();
      out.end_object();
      continue;
    }
    out.key("age_s").value(static_cast<double>(now_us - m.received_us) * 1e-6);
    out.key("current").value(now_us - m.received_us <= stale_after_us_);
    out.key("supervisor").value(static_cast<int>(m.last.supervisor_state));
    out.key("joints").begin_array();
    for (int j = 0; j < m.last.num_joints; ++j) out.value(m.last.joint_position[j]);
    out.end_array();
    planning::JointVector q(m.last.num_joints);
    for (int j = 0; j < m.last.num_joints; ++j) q[j] = m.last.joint_position[j];
    m.model->forward_kinematics(q, k);
    out.key("bodies").begin_array();
    for (std::size_t b = 0; b < m.model->bodies().size(); ++b) {
      out.begin_array();
      for (const auto& p : planning::box_corners(k.bodies[b].world_from_body, k.bodies[b].size_m)) out.point(p);
      out.end_array();
    }
    out.end_array();
    out.key("base").point(m.model->world_from_base().translation());
    out.end_object();
  }
  out.end_array();
  out.end_object();
}

}  // namespace mgc::display
