// SPDX-License-Identifier: Apache-2.0
#pragma once

// Every machine of a site in one simulator (docs/simulator.md, "A whole site"): each machine at
// its first lift's start on a bus of its own, stepped together on one clock, with one referee over
// all of them: each machine's TruthMonitor against the site's obstacles and the ground, and the
// SitePairReferee between every two machines, sampled on one grid. mgc-sim --site without
// --machine-id runs it in real time.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/planning/site.hpp"
#include "mgc/sim/simulator.hpp"
#include "mgc/sim/site_referee.hpp"
#include "mgc/sim/truth_monitor.hpp"
#include "mgc/sim/truth_snapshot.hpp"

namespace mgc::sim {

//! The site's RTLS in every simulator: each machine's `uwb_tags` (site file) reported by every other
//! machine's simulator (sims in site order, none started yet), from the tagged machine's true joints
//! through its model (its first lift's). Returns those models, which the caller keeps as long as
//! the simulators. Start-up only; throws std::invalid_argument for a mount the model lacks.
[[nodiscard]] std::vector<std::unique_ptr<planning::MachineModel>> add_site_tags(const planning::Site& site,
                                                                                 std::span<Simulator* const> sims);

class SiteSimulation {
 public:
  //! One simulator per machine of the site, in site order, on buses[i] (each outlives this), with
  //! config (a site file has no `simulation` section) and the seed plus the machine's index (each
  //! machine its own noise). With a monitor configuration, a TruthMonitor per machine and the pair
  //! referee with its margin, sampled every monitor period; every machine's site tags reported by
  //! the others' simulators (add_site_tags()). Allocates. Throws
  //! std::invalid_argument for a bus count not the site's or a machine the simulator refuses.
  SiteSimulation(const planning::Site& site, std::span<hal::CanBus* const> buses, const SimConfig& config,
                 std::optional<TruthMonitorConfig> monitor);
  ~SiteSimulation();
  SiteSimulation(const SiteSimulation&) = delete;
  SiteSimulation& operator=(const SiteSimulation&) = delete;

  //! Steps every machine to now_us. No allocation.
  void step(std::int64_t now_us) noexcept;
  //! Samples every machine's monitor and the pair referee when a monitor period has passed since
  //! the last sample (the first call always samples). Returns whether it measured. No allocation.
  bool sample() noexcept;
  //! A frame with room for every machine's snapshot. Allocates: before the loop.
  [[nodiscard]] TruthFrame make_frame() const;
  //! Copies every machine's state now into frame.machines (sized by make_frame()). No allocation.
  void capture(TruthFrame& frame) const noexcept;
  //! sample() for a frame capture() filled: the monitors and the referee measure the copy, so
  //! that mgc-sim measures outside its loop's lock. No allocation.
  bool sample(const TruthFrame& frame) noexcept;
  //! The monitor's period; 0 without a monitor. [s]
  [[nodiscard]] double monitor_period_s() const noexcept { return period_s_; }
  //! The earliest next event of any machine. [µs]
  [[nodiscard]] std::int64_t next_event_us() const noexcept;
  //! Simulation time, the same for every machine (all take their first step together). [s]
  [[nodiscard]] double time_s() const noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return sims_.size(); }
  [[nodiscard]] std::int32_t machine_id(std::size_t i) const noexcept { return ids_[i]; }
  [[nodiscard]] const planning::Scenario& scenario(std::size_t i) const noexcept { return *scenarios_[i]; }
  [[nodiscard]] const Simulator& simulator(std::size_t i) const noexcept { return *sims_[i]; }
  //! Null without a monitor.
  [[nodiscard]] const TruthMonitor* monitor(std::size_t i) const noexcept { return monitors_.empty() ? nullptr : monitors_[i].get(); }
  [[nodiscard]] const SitePairReferee* referee() const noexcept { return referee_.get(); }

 private:
  //! The pair referee's sample of these states when its period has passed. Returns whether it measured.
  bool referee_sample(std::span<const TrueState* const> truths) noexcept;

  std::vector<std::int32_t> ids_;
  std::vector<std::unique_ptr<planning::Scenario>> scenarios_;  //!< each simulator keeps a reference
  std::vector<std::unique_ptr<Simulator>> sims_;
  std::vector<std::unique_ptr<planning::MachineModel>> tag_models_;  //!< the site tags' (add_site_tags())
  std::vector<std::unique_ptr<TruthMonitor>> monitors_;
  std::unique_ptr<SitePairReferee> referee_;
  std::vector<const TrueState*> truths_;
  std::vector<const TrueState*> frame_truths_;  //!< sample(frame)'s, into the frame
  double period_s_ = 0.0;
  SampleGrid grid_{0.0};  //!< the pair referee's, on the monitor's period
};

}  // namespace mgc::sim
