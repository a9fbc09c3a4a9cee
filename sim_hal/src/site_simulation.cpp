// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/site_simulation.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace mgc::sim {

std::vector<std::unique_ptr<planning::MachineModel>> add_site_tags(const planning::Site& site, std::span<Simulator* const> sims) {
  if (sims.size() != site.machines.size()) throw std::invalid_argument("site tags: a simulator per machine expected");
  std::vector<std::unique_ptr<planning::MachineModel>> models;
  std::vector<std::vector<SiteSimTag>> seen(sims.size());
  for (std::size_t k = 0; k < site.machines.size(); ++k) {
    const planning::SiteMachine& m = site.machines[k];
    if (m.uwb_tags.empty()) continue;
    models.push_back(planning::build_model(planning::lift_scenario(site, k, 0)));
    for (const planning::MachineTagSpec& t : m.uwb_tags) {
      SiteSimTag tag;
      tag.tag_id = static_cast<std::uint8_t>(t.id);
      tag.model = models.back().get();
      tag.mount = planning::resolve_site_tag_mount(*tag.model, t.body);
      if (tag.mount.index < 0) {
        throw std::invalid_argument("site machine " + std::to_string(m.id) + " tag " + std::to_string(t.id) + ": no body or frame '" + t.body + "'");
      }
      tag.position_m = t.position_m;
      tag.truth = &sims[k]->truth();
      for (std::size_t i = 0; i < sims.size(); ++i) {
        if (i != k) seen[i].push_back(tag);
      }
    }
  }
  for (std::size_t i = 0; i < sims.size(); ++i) sims[i]->add_site_tags(std::move(seen[i]));
  return models;
}

SiteSimulation::SiteSimulation(const planning::Site& site, std::span<hal::CanBus* const> buses, const SimConfig& config,
                               std::optional<TruthMonitorConfig> monitor) {
  if (buses.size() != site.machines.size()) {
    throw std::invalid_argument("site simulation: " + std::to_string(buses.size()) + " buses for " +
                                std::to_string(site.machines.size()) + " machines");
  }
  for (std::size_t i = 0; i < site.machines.size(); ++i) {
    ids_.push_back(site.machines[i].id);
    scenarios_.push_back(std::make_unique<planning::Scenario>(planning::lift_scenario(site, i, 0)));
    SimConfig c = config;
    c.seed = config.seed + i;
    sims_.push_back(std::make_unique<Simulator>(*scenarios_.back(), *buses[i], c));
    truths_.push_back(&sims_.back()->truth());
    frame_truths_.push_back(&sims_.back()->truth());
    if (monitor) monitors_.push_back(std::make_unique<TruthMonitor>(*scenarios_.back(), *monitor));
  }
  std::vector<Simulator*> sims;
  for (const auto& sim : sims_) sims.push_back(sim.get());
  tag_models_ = add_site_tags(site, sims);
  if (monitor) {
    period_s_ = monitor->period_s;
    grid_ = SampleGrid(monitor->period_s);
    referee_ = std::make_unique<SitePairReferee>(site, monitor->clearance_margin_m);
  }
}

SiteSimulation::~SiteSimulation() = default;

void SiteSimulation::step(std::int64_t now_us) noexcept {
  for (const auto& sim : sims_) sim->step(now_us);
}

bool SiteSimulation::sample() noexcept {
  bool measured = false;
  for (std::size_t i = 0; i < monitors_.size(); ++i) measured = monitors_[i]->sample(*sims_[i]) || measured;
  return referee_sample(truths_) || measured;
}

TruthFrame SiteSimulation::make_frame() const {
  TruthFrame frame;
  frame.machines.resize(sims_.size());
  for (std::size_t i = 0; i < sims_.size(); ++i) frame.machines[i].resize_for(*sims_[i]);
  return frame;
}

void SiteSimulation::capture(TruthFrame& frame) const noexcept {
  for (std::size_t i = 0; i < std::min(sims_.size(), frame.machines.size()); ++i) frame.machines[i].capture(*sims_[i]);
}

bool SiteSimulation::sample(const TruthFrame& frame) noexcept {
  if (frame.machines.size() != sims_.size()) return false;
  bool measured = false;
  for (std::size_t i = 0; i < monitors_.size(); ++i) measured = monitors_[i]->sample(frame.machines[i]) || measured;
  for (std::size_t i = 0; i < frame_truths_.size(); ++i) frame_truths_[i] = &frame.machines[i].truth;
  return referee_sample(frame_truths_) || measured;
}

bool SiteSimulation::referee_sample(std::span<const TrueState* const> truths) noexcept {
  if (!referee_ || truths.empty()) return false;
  const double t_s = truths.front()->t_s;
  if (!grid_.take(t_s)) return false;
  referee_->measure(t_s, truths);
  return true;
}

std::int64_t SiteSimulation::next_event_us() const noexcept {
  std::int64_t next_us = std::numeric_limits<std::int64_t>::max();
  for (const auto& sim : sims_) next_us = std::min(next_us, sim->next_event_us());
  return next_us;
}

double SiteSimulation::time_s() const noexcept { return sims_.empty() ? 0.0 : sims_.front()->time_s(); }

}  // namespace mgc::sim
