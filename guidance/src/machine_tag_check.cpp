// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "mgc/guidance/diagnostics.hpp"

namespace mgc::guidance {
namespace {

//! Quality 1..14 stands for a 1-sigma of at most quality × 10 cm; 0 is no fix, 15 unknown.
constexpr std::uint8_t kQualityUnknown = 15;
constexpr double kMetresPerQuality = 0.1;
//! Step of the numerical lever of each joint on the tag. [rad | m]
constexpr double kLeverStep = 1e-4;
//! A joint moves its tag by more than this per unit of its motion: the tag sees it. [m/rad | m/m]
constexpr double kSeesJoint = 0.01;

}  // namespace

MachineTagCheck::MachineTagCheck(const planning::MachineModel& model, std::span<const MachineTag> tags,
                                 const MachineTagCheckConfig& config)
    : model_(model), config_(config) {
  if (tags.size() > planning::kMaxMachineTags) {
    throw std::invalid_argument("machine tags: at most " + std::to_string(planning::kMaxMachineTags) + ", got " +
                                std::to_string(tags.size()));
  }
  if (!(config.sigma_factor > 0.0) || !(config.model_allowance_m >= 0.0) || config.disagree_fixes < 1 ||
      config.fix_age_min_us < 0 || config.fix_age_max_us < config.fix_age_min_us || config.encoder_age_us < 0 ||
      config.stale_us <= 0) {
    throw std::invalid_argument("machine tags: a check setting out of range (MachineTagCheckConfig)");
  }
  for (const MachineTag& t : tags) {
    const auto frames = static_cast<int>(model.frame_names().size());
    const auto bodies = static_cast<int>(model.bodies().size());
    if (t.mount.index < 0 || t.mount.index >= (t.mount.frame ? frames : bodies)) {
      throw std::invalid_argument("machine tag " + std::to_string(t.id) + ": its mount is not a body or frame of the model");
    }
    tags_[n_++].tag = t;
  }
  for (Sample& s : history_) s.q = planning::JointVector::Zero(model.dof());
}

void MachineTagCheck::reset() noexcept {
  result_ = {};
  for (std::size_t k = 0; k < n_; ++k) {
    tags_[k].disagreeing = 0;
    tags_[k].last_fix_us = 0;
  }
  head_ = 0;
  count_ = 0;
  started_ = false;
  stale_count_ = 0;
  stale_tag_ = -1;
  peak_ratio_ = 0.0;
}

bool MachineTagCheck::judge(TagState& tag, const MachineTagFix& fix, std::int64_t now_us) noexcept {
  if (fix.quality == 0 || fix.quality >= kQualityUnknown || count_ == 0) return false;
  // The encoders' sample nearest the middle of the time the tag may have been ranged.
  const std::int64_t ranged_us = fix.t_us - (config_.fix_age_min_us + config_.fix_age_max_us) / 2;
  const Sample* nearest = nullptr;
  std::int64_t gap_us = std::numeric_limits<std::int64_t>::max();
  for (std::size_t i = 0; i < count_; ++i) {
    const Sample& s = history_[(head_ + kHistory - 1 - i) % kHistory];
    const std::int64_t d = s.t_us > ranged_us ? s.t_us - ranged_us : ranged_us - s.t_us;
    if (d < gap_us) {
      gap_us = d;
      nearest = &s;
    }
  }
  // No sample within a history's reach of it (a gap in the encoder data): nothing to compare with.
  const std::int64_t offset_us = (config_.fix_age_max_us - config_.fix_age_min_us) / 2 + config_.encoder_age_us;
  if (nearest == nullptr || gap_us > offset_us) return false;

  model_.forward_kinematics(nearest->q, kinematics_);
  const Eigen::Vector3d predicted = planning::tag_position(kinematics_, tag.tag.mount, tag.tag.local_m);
  // The tag point's speed bound: each joint's lever on it at this configuration times its speed limit.
  double speed_m_s = 0.0;
  std::uint32_t seen = 0;
  planning::JointVector q = nearest->q;
  for (int j = 0; j < model_.dof(); ++j) {
    q[j] += kLeverStep;
    model_.forward_kinematics(q, kinematics_);
    q[j] = nearest->q[j];
    const double lever = (planning::tag_position(kinematics_, tag.tag.mount, tag.tag.local_m) - predicted).norm() / kLeverStep;
    speed_m_s += lever * model_.joints()[static_cast<std::size_t>(j)].max_velocity;
    if (lever > kSeesJoint) seen |= 1u << static_cast<unsigned>(j);
  }
  const double sigma_m = kMetresPerQuality * static_cast<double>(fix.quality);
  const double threshold_m = config_.sigma_factor * sigma_m + static_cast<double>(offset_us) * 1e-6 * speed_m_s +
                             config_.model_allowance_m;
  const Eigen::Vector3d measured(fix.position_m[0], fix.position_m[1], fix.position_m[2]);
  const double residual_m = (measured - predicted).norm();
  peak_ratio_ = std::max(peak_ratio_, residual_m / threshold_m);
  if (!(residual_m <= threshold_m)) {
    ++tag.disagreeing;
  } else {
    tag.disagreeing = 0;
  }
  if (tag.disagreeing >= config_.disagree_fixes && !result_.disagrees) {
    result_.disagrees = true;
    result_.tag_id = tag.tag.id;
    result_.joints_seen = seen;
    result_.detected_us = now_us;
    result_.residual_m = residual_m;
    result_.threshold_m = threshold_m;
  }
  return true;
}

const MachineTagResult& MachineTagCheck::update(const MachineTagInputs& in) noexcept {
  if (!started_) {
    started_ = true;
    start_us_ = in.now_us;
  }
  if (in.joints_valid) {
    const std::size_t newest = (head_ + kHistory - 1) % kHistory;
    // One entry per new sample time: a cycle without new samples adds nothing.
    if (count_ == 0 || in.joints_t_us != history_[newest].t_us) {
      Sample& s = history_[head_];
      s.t_us = in.joints_t_us;
      for (int j = 0; j < model_.dof(); ++j) s.q[j] = in.position[static_cast<std::size_t>(j)];
      head_ = (head_ + 1) % kHistory;
      count_ = std::min(count_ + 1, kHistory);
    }
  } else {
    // Samples across a gap would be compared with fixes from its other side.
    count_ = 0;
  }
  stale_count_ = 0;
  stale_tag_ = -1;
  for (std::size_t k = 0; k < n_; ++k) {
    TagState& tag = tags_[k];
    for (const MachineTagFix& fix : in.fixes) {
      if (fix.id != tag.tag.id || !fix.updated) continue;
      if (fix.quality > 0) tag.last_fix_us = fix.t_us;
      if (judge(tag, fix, in.now_us)) {
        ++judged_;
      } else {
        ++not_judged_;
      }
    }
    const std::int64_t since_us = in.now_us - (tag.last_fix_us > 0 ? tag.last_fix_us : start_us_);
    if (since_us > config_.stale_us) {
      // Not judged while stale, and a disagreement must build up again from fresh fixes.
      tag.disagreeing = 0;
      if (stale_tag_ < 0) stale_tag_ = tag.tag.id;
      ++stale_count_;
    }
  }
  return result_;
}

}  // namespace mgc::guidance
