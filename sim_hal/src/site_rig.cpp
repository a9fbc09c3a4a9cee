// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/site_rig.hpp"
#include "mgc/sim/site_simulation.hpp"

#include <mgc/alert_t.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mgc::sim {
namespace {

//! The site's CLOCK_REALTIME at simulation clock 0: what the messages are signed and checked with. [µs]
constexpr std::int64_t kRealtimeZero_us = 1'765'000'000'000'000;

firmware::SiteKey key_from_seed(std::uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x5eed5eed5eed5eedULL);
  std::array<std::uint8_t, firmware::kCommandKeyBytes> bytes{};
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng() & 0xffU);
  return firmware::SiteKey(bytes);
}

template <class Msg>
std::vector<std::uint8_t> encode(const Msg& msg) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  (void)msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

}  // namespace

SiteRig::SiteRig(const planning::Site& site, SiteRigConfig config, const std::string& bus_prefix)
    : site_(site),
      config_(std::move(config)),
      key_(key_from_seed(config_.faults.seed)),
      referee_(site_),
      rng_(config_.faults.seed) {
  const firmware::SiteRoster roster = firmware::make_site_roster(site_);
  members_.resize(site_.machines.size());
  last_state_.resize(site_.machines.size());
  muted_.assign(site_.machines.size(), false);
  for (std::size_t i = 0; i < site_.machines.size(); ++i) {
    SiteRigMember& m = members_[i];
    m.machine_id = site_.machines[i].id;
    const planning::Scenario lift = planning::lift_scenario(site_, i, 0);
    SimConfig sim = SteppedRig::quiet_config();
    sim.uwb = config_.uwb;
    m.rig = std::make_unique<SteppedRig>(lift, sim, bus_prefix + "-" + std::to_string(m.machine_id));
    m.rig->calibrate_valves();
    firmware::SiteMemberConfig member;
    member.site = site_;
    member.machine_id = m.machine_id;
    member.rules = config_.rules;
    m.controller = std::make_unique<firmware::Controller>(lift, config_.controller, &member);
    m.verifier = std::make_unique<firmware::SiteVerifier>(key_, roster, m.machine_id);
    m.truth = std::make_unique<TruthMonitor>(lift);
    m.lift_start_s = i < config_.lift_start_s.size() ? config_.lift_start_s[i] : 0.0;
    m.lifts = std::make_unique<firmware::SiteLiftQueue>(site_, m.machine_id);
    m.rig->on_cycle = [this, i](const hal::SensorSnapshot& s) { cycle(i, s); };
  }
  for (const SiteRigMember& m : members_) truths_.push_back(&m.rig->sim->truth());
  std::vector<Simulator*> sims;
  for (const SiteRigMember& m : members_) sims.push_back(m.rig->sim.get());
  tag_models_ = add_site_tags(site_, sims);
}

SiteRig::~SiteRig() = default;

double SiteRig::sim_s() const noexcept {
  return members_.empty() ? 0.0 : static_cast<double>(members_.front().rig->t_us - SteppedRig::kSimZeroUs) * 1e-6;
}

std::int64_t SiteRig::realtime_us() const noexcept { return kRealtimeZero_us + (members_.empty() ? 0 : members_.front().rig->t_us); }

SiteRigMember& SiteRig::member(std::int32_t machine_id) {
  for (SiteRigMember& m : members_) {
    if (m.machine_id == machine_id) return m;
  }
  throw std::invalid_argument("site rig: no machine " + std::to_string(machine_id));
}

bool SiteRig::lift_done(const SiteRigMember& m) const noexcept { return m.lifts->done(); }

double SiteRig::least_between_m() const noexcept { return referee_.least_m(); }

double SiteRig::least_to_site_m() const noexcept {
  double least = std::numeric_limits<double>::infinity();
  for (const SiteRigMember& m : members_) least = std::min(least, m.truth->summary().least_clearance.distance_m);
  return least;
}

void SiteRig::mute(std::int32_t machine_id) {
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (members_[i].machine_id == machine_id) muted_[i] = true;
  }
}

const std::vector<std::uint8_t>& SiteRig::last_state_bytes(std::int32_t sender_id) const {
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (members_[i].machine_id == sender_id) return last_state_[i];
  }
  throw std::invalid_argument("site rig: no machine " + std::to_string(sender_id));
}

void SiteRig::run_until(double t_s, bool stop_when_done) {
  while (sim_s() < t_s) {
    const double now_s = sim_s();
    for (SiteRigMember& m : members_) {
      if (m.killed) continue;
      for (const SiteFaults::Kill& k : config_.faults.kills) {
        if (k.machine_id == m.machine_id && now_s >= k.at_s) m.killed = true;
      }
    }
    // One controller period for every machine, in site order: each reads, steps and writes at the
    // same clock time, and what it publishes is delivered from the next period on.
    for (SiteRigMember& m : members_) m.rig->run(m.rig->cycle_us, !m.killed);
    t_us_ = members_.front().rig->t_us;
    for (std::size_t i = 0; i < members_.size(); ++i) {
      if (!members_[i].killed && !muted_[i]) publish(i);
    }
    referee();
    if (stop_when_done) {
      bool all = true;
      for (const SiteRigMember& m : members_) all = all && (m.killed || m.lift_start_s < 0.0 || lift_done(m));
      if (all) break;
    }
  }
}

void SiteRig::cycle(std::size_t i, const hal::SensorSnapshot& s) {
  SiteRigMember& m = members_[i];
  // Messages due by this cycle reach the member's loop now, as the I/O thread hands them over.
  const std::int64_t receive_from_ns = config_.clock_ns ? config_.clock_ns() : 0;
  m.last_received = 0;
  for (std::size_t k = 0; k < pending_.size();) {
    if (pending_[k].receiver == i && pending_[k].deliver_us <= s.t_us) {
      deliver(i, pending_[k].plan, pending_[k].bytes);
      ++m.last_received;
      pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(k));
    } else {
      ++k;
    }
  }
  if (config_.clock_ns) m.last_receive_ns = config_.clock_ns() - receive_from_ns;
  firmware::ControllerCommands commands;
  const double now_s = static_cast<double>(s.t_us - SteppedRig::kSimZeroUs) * 1e-6;
  if ((!m.goal_sent || m.next_leg) && m.lift_start_s >= 0.0 && now_s >= m.lift_start_s &&
      m.controller->supervisor().state() == guidance::SupervisorState::Hold && m.lifts->goal(commands.goal, commands.goal_joints)) {
    commands.goal_request = true;
    m.goal_sent = true;
    m.next_leg = false;
  }
  const long before = config_.allocation_count ? config_.allocation_count() : 0;
  const std::int64_t step_from_ns = config_.clock_ns ? config_.clock_ns() : 0;
  m.out = m.controller->step(s, m.rig->cycle_us, commands, false, m.inputs);
  if (config_.clock_ns) m.last_step_ns = config_.clock_ns() - step_from_ns;
  if (config_.allocation_count) m.step_allocations += config_.allocation_count() - before;
  ++m.cycles;
  if (m.out.start_nodes) (void)m.rig->hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
  m.rig->hal->set_pilot_enabled(m.out.pilot_enable);
  for (int j = 0; j < m.controller->num_joints(); ++j) m.rig->command[static_cast<std::size_t>(j)] = m.out.velocity[static_cast<std::size_t>(j)];
  if (m.out.supervisor.transitioned && m.out.supervisor.reason == guidance::TransitionReason::GoalReached && m.goal_sent) {
    (void)m.lifts->reached();
    m.next_leg = true;
  }
  if (m.out.supervisor.transitioned) {
    m.log += std::to_string(now_s) + " s " + guidance::to_string(m.out.supervisor.state) + " (" +
             guidance::to_string(m.out.supervisor.reason) + ")\n";
  }
  const firmware::GuidanceSnapshot& g = m.controller->snapshot();
  bool site_alert = false;
  bool stale_alert = false;
  for (int a = 0; a < g.num_alerts; ++a) {
    const firmware::SnapshotAlert& alert = g.alerts[static_cast<std::size_t>(a)];
    // The site alert is the only one of the collision or sensing sources that names a machine id
    // with these units and the horizon as its limit.
    // The rules' (unit s: the meet time) or a stale machine's (unit none: what poses it).
    const bool unit = alert.value_unit == (alert.source == mgc::alert_t::SOURCE_SENSING ? mgc::alert_t::UNIT_NONE : mgc::alert_t::UNIT_SECOND);
    const bool site = unit && alert.index > 0 &&
                      (alert.source == mgc::alert_t::SOURCE_SENSING || alert.source == mgc::alert_t::SOURCE_COLLISION) &&
                      alert.limit == config_.rules.horizon_s;
    site_alert = site_alert || site;
    stale_alert = stale_alert || (site && alert.source == mgc::alert_t::SOURCE_SENSING);
  }
  if (site_alert) ++m.site_alert_cycles;
  if (stale_alert) ++m.stale_alert_cycles;
}

void SiteRig::publish(std::size_t i) {
  SiteRigMember& m = members_[i];
  const std::int64_t now_us = m.rig->t_us;
  const std::int64_t real_us = realtime_us();
  if (m.state_sequence == 0) {
    m.state_sequence = real_us;
    m.plan_sequence = real_us;
  }
  // A changed plan goes out with a state of the same cycle, which names it, the plan first.
  const std::uint64_t version = m.controller->site_plan_version();
  const bool plan_changed = version > 0 && version != m.plan_version_sent;
  if (plan_changed || (version > 0 && now_us - m.plan_sent_us >= firmware::kSitePlanPeriod_us)) {
    site_plan_t msg = m.controller->site_plan();
    msg.utime = now_us;
    msg.sequence = ++m.plan_sequence;
    msg.sender_time_us = real_us;
    firmware::sign_site_plan(msg, key_);
    m.plan_version_sent = version;
    m.plan_sent_us = now_us;
    ++m.plans_sent;
    send(i, true, encode(msg));
  }
  if (plan_changed || now_us % firmware::kSiteStatePeriod_us == 0) {
    site_state_t msg = m.controller->site_state();
    msg.utime = now_us;
    msg.sequence = ++m.state_sequence;
    msg.sender_time_us = real_us;
    firmware::sign_site_state(msg, key_);
    last_state_[i] = encode(msg);
    ++m.states_sent;
    send(i, false, last_state_[i]);
  }
}

void SiteRig::send(std::size_t from, bool plan, const std::vector<std::uint8_t>& bytes) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t r = 0; r < members_.size(); ++r) {
    if (r == from) continue;
    if (config_.faults.loss_probability > 0.0 && unit(rng_) < config_.faults.loss_probability) {
      ++members_[from].messages_lost;
      continue;
    }
    std::int64_t delay_us = 0;
    if (config_.faults.max_delay_us > 0) {
      delay_us = std::uniform_int_distribution<std::int64_t>(0, config_.faults.max_delay_us)(rng_);
    }
    Pending p;
    p.deliver_us = members_[from].rig->t_us + delay_us;
    p.receiver = r;
    p.plan = plan;
    p.bytes = bytes;
    pending_.push_back(std::move(p));
  }
}

void SiteRig::deliver(std::size_t receiver, bool plan, const std::vector<std::uint8_t>& bytes) {
  SiteRigMember& m = members_[receiver];
  const std::span<const std::uint8_t> span(bytes.data(), bytes.size());
  const std::int64_t real_us = realtime_us();
  if (plan) {
    if (m.verifier->check_plan_bytes(span, scratch_plan_, real_us) != firmware::SiteReason::Accepted) return;
    const int index = m.verifier->roster().index_of(scratch_plan_.machine_id);
    firmware::SitePeerMessages& peer = m.inputs.peers[static_cast<std::size_t>(index)];
    peer.plan = scratch_plan_;
    peer.has_plan = true;
  } else {
    if (m.verifier->check_state_bytes(span, scratch_state_, real_us) != firmware::SiteReason::Accepted) return;
    const int index = m.verifier->roster().index_of(scratch_state_.machine_id);
    firmware::SitePeerMessages& peer = m.inputs.peers[static_cast<std::size_t>(index)];
    peer.state = scratch_state_;
    peer.has_state = true;
    peer.state_received_us = m.rig->t_us;
  }
}

void SiteRig::inject_state(std::int32_t receiver_id, const std::vector<std::uint8_t>& bytes) {
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (members_[i].machine_id == receiver_id) deliver(i, false, bytes);
  }
}

void SiteRig::inject_plan(std::int32_t receiver_id, const std::vector<std::uint8_t>& bytes) {
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (members_[i].machine_id == receiver_id) deliver(i, true, bytes);
  }
}

void SiteRig::referee() {
  const double now_s = sim_s();
  for (SiteRigMember& m : members_) (void)m.truth->sample(*m.rig->sim);
  if (now_s < next_truth_s_) return;
  next_truth_s_ = now_s + config_.truth_period_s;
  referee_.measure(now_s, truths_);
}

}  // namespace mgc::sim
