// SPDX-License-Identifier: Apache-2.0
#pragma once

// A coordinated site in stepped time (docs/site.md, "The site rig"): every machine of a site file
// on its own in-process loop bus (a SteppedRig) with its own Controller, all on one manual clock,
// the site messages passed between them in memory through the real path (encode, sign, decode and
// verify with SiteVerifier), with the site's faults (loss, delay, a controller killed), and one
// referee over all: the least true clearance between any two machines, every body included, and
// of each machine to the site. Deterministic: the same seed gives the same run.
//
// It sits above both the controller (mgc_firmware, mgc_feed) and the simulator (mgc_sim): its own
// library, mgc_site_rig, that neither of them includes.

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "mgc/firmware/controller.hpp"
#include "mgc/firmware/site_auth.hpp"
#include "mgc/firmware/site_member.hpp"
#include "mgc/planning/site.hpp"
#include "mgc/sim/site_referee.hpp"
#include "mgc/sim/stepped_rig.hpp"
#include "mgc/sim/truth_monitor.hpp"

namespace mgc::sim {

struct SiteFaults {
  //! Each site message is lost with this probability, independently (seeded). [-]
  double loss_probability = 0.0;
  //! Each delivered message is late by a uniform delay in [0, max_delay_us]. [µs]
  std::int64_t max_delay_us = 0;
  std::uint64_t seed = 1;
  //! A member's controller killed (its Hal silent, its site messages stop) at a simulation time.
  struct Kill {
    std::int32_t machine_id = 0;
    double at_s = 0.0;  //!< [s]
  };
  std::vector<Kill> kills;
};

struct SiteRigConfig {
  firmware::ControllerConfig controller{};
  firmware::SiteRulesConfig rules{};
  SiteFaults faults{};
  //! Per machine in site order, when its first lift's goal is requested (simulation time); a
  //! negative time never. Each later lift of its queue follows when the previous one is done.
  //! Missing entries: 0. [s]
  std::vector<double> lift_start_s;
  //! Every machine's UWB gateway (the site's tags on the other machines): quiet by default, like
  //! the rest of the rig's sensors; UwbParams{} is the single-machine scenarios' noise model. [-]
  UwbParams uwb = SteppedRig::quiet_config().uwb;
  //! The referee's period. [s]
  double truth_period_s = 0.05;
  //! When set, the rig reads it before and after each Controller::step and adds the difference to
  //! the member's step_allocations (the tests' allocation counter).
  std::function<long()> allocation_count;
  //! When set, the rig reads it around each member's Controller::step and around the checks of the
  //! messages delivered to the member in a cycle, and keeps both durations in the member
  //! (last_step_ns, last_receive_ns): the benchmarks' wall clock. [ns]
  std::function<std::int64_t()> clock_ns;
};

//! One machine of the site on the rig.
struct SiteRigMember {
  std::int32_t machine_id = 0;
  std::unique_ptr<SteppedRig> rig;
  std::unique_ptr<firmware::Controller> controller;
  std::unique_ptr<firmware::SiteVerifier> verifier;
  std::unique_ptr<TruthMonitor> truth;  //!< this machine against the site
  firmware::SiteInputs inputs{};
  firmware::ControllerOutput out{};
  double lift_start_s = 0.0;
  //! Its queue of lifts, run one after another from lift_start_s on.
  std::unique_ptr<firmware::SiteLiftQueue> lifts;
  bool goal_sent = false;
  bool next_leg = false;  //!< a leg's goal was reached: the next is requested once in HOLD
  bool killed = false;
  std::int64_t state_sequence = 0;
  std::int64_t plan_sequence = 0;
  std::uint64_t plan_version_sent = 0;
  std::int64_t plan_sent_us = 0;
  std::uint64_t states_sent = 0;
  std::uint64_t plans_sent = 0;
  std::uint64_t messages_lost = 0;  //!< of those it sent
  //! Cycles in which its snapshot carried a site alert (alert_t SOURCE_SENSING: a stale machine).
  std::uint64_t stale_alert_cycles = 0;
  std::uint64_t site_alert_cycles = 0;  //!< cycles with any site alert
  std::uint64_t cycles = 0;             //!< steps of its controller
  long step_allocations = 0;            //!< inside Controller::step, when SiteRigConfig::allocation_count is set
  std::int64_t last_step_ns = 0;        //!< its last Controller::step, when SiteRigConfig::clock_ns is set [ns]
  std::int64_t last_receive_ns = 0;     //!< checking the messages delivered in its last cycle, likewise [ns]
  int last_received = 0;                //!< messages delivered (checked) in its last cycle
  std::string log;  //!< supervisor transitions, one a line
};

class SiteRig {
 public:
  //! Builds every machine's rig, controller and verifier (the site key is made from the seed: the
  //! rig never reads a key file). Throws std::invalid_argument for a site the controller refuses.
  SiteRig(const planning::Site& site, SiteRigConfig config, const std::string& bus_prefix);
  ~SiteRig();
  SiteRig(const SiteRig&) = delete;
  SiteRig& operator=(const SiteRig&) = delete;

  //! Runs every rig in lockstep, cycle by cycle (each controller starts its nodes itself), until
  //! simulation time t_s, or until every living member's lift is done when stop_when_done.
  void run_until(double t_s, bool stop_when_done = false);

  //! Hands bytes to a member's receiving side as if they came off the site channel now: verified
  //! (and refused or taken) exactly as a published message.
  void inject_state(std::int32_t receiver_id, const std::vector<std::uint8_t>& bytes);
  void inject_plan(std::int32_t receiver_id, const std::vector<std::uint8_t>& bytes);
  //! The last bytes a member sent (signed), for replay and forgery tests.
  [[nodiscard]] const std::vector<std::uint8_t>& last_state_bytes(std::int32_t sender_id) const;
  //! Silences a member's sending from now (its controller runs on): a stale member.
  void mute(std::int32_t machine_id);

  [[nodiscard]] double sim_s() const noexcept;
  [[nodiscard]] std::int64_t realtime_us() const noexcept;
  [[nodiscard]] SiteRigMember& member(std::int32_t machine_id);
  [[nodiscard]] std::vector<SiteRigMember>& members() noexcept { return members_; }
  [[nodiscard]] const std::vector<SitePairTruth>& pairs() const noexcept { return referee_.pairs(); }
  //! Least of every pair's least clearance. [m]
  [[nodiscard]] double least_between_m() const noexcept;
  //! Least of every member's true clearance to the site. [m]
  [[nodiscard]] double least_to_site_m() const noexcept;
  //! Whether member's lifts are done: every lift of its queue.
  [[nodiscard]] bool lift_done(const SiteRigMember& m) const noexcept;
  [[nodiscard]] const firmware::SiteKey& key() const noexcept { return key_; }

 private:
  struct Pending {
    std::int64_t deliver_us = 0;
    std::size_t receiver = 0;
    bool plan = false;
    std::vector<std::uint8_t> bytes;
  };
  void cycle(std::size_t i, const hal::SensorSnapshot& s);
  void publish(std::size_t i);
  void send(std::size_t from, bool plan, const std::vector<std::uint8_t>& bytes);
  void deliver(std::size_t receiver, bool plan, const std::vector<std::uint8_t>& bytes);
  void referee();

  planning::Site site_;
  SiteRigConfig config_;
  firmware::SiteKey key_;
  std::vector<SiteRigMember> members_;
  std::vector<Pending> pending_;
  std::vector<std::vector<std::uint8_t>> last_state_;
  std::vector<bool> muted_;
  SitePairReferee referee_;
  std::vector<const TrueState*> truths_;  //!< each member's simulator's, in site order, for the referee
  std::vector<std::unique_ptr<planning::MachineModel>> tag_models_;  //!< the site tags' (add_site_tags())
  std::mt19937_64 rng_;
  std::int64_t t_us_ = 0;
  double next_truth_s_ = 0.0;
  site_state_t scratch_state_{};
  site_plan_t scratch_plan_{};
};

}  // namespace mgc::sim
