// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>

#include "mgc/guidance/envelope.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::sim {

class Simulator;

struct TruthMonitorConfig {
  //! Least simulation time between two samples: an FCL distance pass over a steel frame costs
  //! tens to hundreds of microseconds, and mgc-sim answers SYNCs in real time. [s]
  double period_s = 0.05;
  //! A sample whose true clearance is below this counts as close. 0.5 m is the controller's
  //! default stop margin (guidance::StopCheckConfig). [m]
  double clearance_margin_m = 0.5;
};

//! One measurement of the true machine in the true site.
struct TruthSample {
  double t_s = std::numeric_limits<double>::quiet_NaN();  //!< simulation time [s]
  //! The real (undilated) machine to the nearest obstacle, static or dynamic; 0 in contact. [m]
  planning::Clearance clearance;
  //! The same for the bodies the joints move (boom, cable, sling, load; an excavator's upper structure
  //! and arm): what the motion brings near, without a parked carrier's fixed distance to the
  //! site; 0 when the machine is in contact anywhere. [m]
  planning::Clearance moving_clearance;
  //! To the dynamic obstacles alone (the static site left out); With::Nothing and +inf without
  //! dynamic obstacles. [m]
  planning::Clearance dynamic_clearance;
  //! Nearest working-envelope limit of the monitored points, negative outside; limit None
  //! without an envelope. [m]
  guidance::EnvelopeDistance envelope;
};

//! The least of each measure over every sample so far, and when it was seen.
struct TruthSummary {
  std::uint64_t samples = 0;
  std::uint64_t samples_below_margin = 0;     //!< clearance < TruthMonitorConfig::clearance_margin_m
  std::uint64_t samples_outside_envelope = 0; //!< envelope distance < 0
  planning::Clearance least_clearance{std::numeric_limits<double>::infinity()};
  double least_clearance_t_s = std::numeric_limits<double>::quiet_NaN();  //!< [s]
  planning::Clearance least_moving{std::numeric_limits<double>::infinity()};
  double least_moving_t_s = std::numeric_limits<double>::quiet_NaN();     //!< [s]
  planning::Clearance least_dynamic{std::numeric_limits<double>::infinity()};
  double least_dynamic_t_s = std::numeric_limits<double>::quiet_NaN();    //!< [s]
  guidance::EnvelopeDistance least_envelope{guidance::EnvelopeLimit::None, -1, -1,
                                            std::numeric_limits<double>::infinity()};
  double least_envelope_t_s = std::numeric_limits<double>::quiet_NaN();   //!< [s]
};

//! Measures what the simulated machine really comes near (docs/simulator.md, "The truth
//! monitor"): the true joint positions against the scenario's site with its dynamic obstacles at
//! their true poses, the machine's bodies undilated, as the controller tests measure it; and,
//! when the scenario has an `envelope` section, the monitored points' distance to its limits.
//! Nothing here reaches the controller: it is the referee's view, for the run's summary and logs.
class TruthMonitor {
 public:
  //! Builds the machine model, a world with the whole site, one with the dynamic obstacles alone
  //! (so that their distance is not hidden by a contact with the static site), and the envelope,
  //! and measures the fixed bodies' distance to the static site, which no joint changes. Allocates.
  //! Throws std::invalid_argument with the reason for a scenario whose model, world or envelope
  //! cannot be built, or for a period or margin that is negative or not finite.
  TruthMonitor(const planning::Scenario& scenario, TruthMonitorConfig config = {});
  ~TruthMonitor();
  TruthMonitor(const TruthMonitor&) = delete;
  TruthMonitor& operator=(const TruthMonitor&) = delete;

  //! Measures the simulator's true state if a period has passed since the last sample (the first
  //! call always measures). Returns whether it measured. No allocation.
  bool sample(const Simulator& sim) noexcept;

  //! Places dynamic obstacle i (scenario order) for the next measure(). No allocation.
  void set_obstacle_pose(std::size_t i, const Eigen::Isometry3d& world_from_obstacle) noexcept;
  //! Measures configuration q (unwrapped: continuous joints may be any number of turns round) at
  //! simulation time t_s, whatever the period, and adds it to the summary. No allocation.
  const TruthSample& measure(double t_s, const planning::JointVector& q) noexcept;

  [[nodiscard]] const TruthSample& last() const noexcept { return last_; }
  [[nodiscard]] const TruthSummary& summary() const noexcept { return summary_; }
  [[nodiscard]] const TruthMonitorConfig& config() const noexcept { return config_; }
  [[nodiscard]] bool has_envelope() const noexcept { return envelope_ != nullptr; }
  [[nodiscard]] bool has_dynamic_obstacles() const noexcept { return num_dynamic_ > 0; }

  //! The summary in one line, e.g. "least clearance 1.30 m at 0.00 s (carrier to frame/column[0,2,0]),
  //! of the moving bodies 2.41 m at 50.20 s (load to frame/beam[1,2,3]); to the dynamic obstacles
  //! 3.10 m at 61.20 s (boom to crane-2); 0 of 1240 samples below 0.50 m; envelope: least distance
  //! 1.20 m at 80.05 s (hook to virtual wall 0), 0 samples outside". Allocates.
  [[nodiscard]] std::string summary_line() const;

 private:
  TruthMonitorConfig config_;
  std::size_t num_dynamic_ = 0;
  std::unique_ptr<planning::MachineModel> model_;
  std::unique_ptr<planning::CollisionWorld> world_;          //!< static and dynamic obstacles
  std::unique_ptr<planning::CollisionWorld> dynamic_world_;  //!< dynamic obstacles only
  std::unique_ptr<guidance::Envelope> envelope_;
  //! The fixed bodies (Bodies::Fixed) to the static obstacles, measured once. [m]
  planning::Clearance fixed_static_;
  planning::JointVector q_wrapped_;
  double next_sample_t_s_ = -std::numeric_limits<double>::infinity();
  TruthSample last_{};
  TruthSummary summary_{};
};

}  // namespace mgc::sim
