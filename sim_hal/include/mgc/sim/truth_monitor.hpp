// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>

#include "mgc/guidance/envelope.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/machine_model.hpp"
#include "mgc/planning/scenario.hpp"

namespace mgc::sim {

class Simulator;
struct TrueState;
struct TruthSnapshot;

//! When a sample is due on a period of simulation time: on the grid of the first sample while the
//! caller keeps up, on a new grid from the late sample once it fell a period behind. The first
//! call is always due. Shared by the truth monitor, the site's pair referee and mgc-sim's loop,
//! which must agree on which steps are sampled.
class SampleGrid {
 public:
  explicit SampleGrid(double period_s) noexcept : period_s_(period_s) {}
  //! A sample is due at simulation time t_s. A sample due at 0.05 s does not wait a physics step
  //! for a rounding error of the microsecond clock.
  [[nodiscard]] bool due(double t_s) const noexcept { return t_s >= next_t_s_ - 1e-9; }
  //! A sample was taken at t_s: the grid moves on.
  void taken(double t_s) noexcept {
    next_t_s_ = std::isfinite(next_t_s_) ? next_t_s_ + period_s_ : t_s + period_s_;
    if (next_t_s_ <= t_s) next_t_s_ = t_s + period_s_;
  }
  //! due(), and if so taken().
  bool take(double t_s) noexcept {
    if (!due(t_s)) return false;
    taken(t_s);
    return true;
  }

 private:
  double period_s_;
  double next_t_s_ = -std::numeric_limits<double>::infinity();
};

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
  //! The bottom of the load body above the ground (the base's plane, as planning's load-above-
  //! ground rule has it), negative below; NaN where has_ground_clearance() is false. [m]
  double load_ground_clearance_m = std::numeric_limits<double>::quiet_NaN();
  //! The hook point above the ground, negative below; NaN as the load's. [m]
  double hook_ground_clearance_m = std::numeric_limits<double>::quiet_NaN();
  //! The lifted load (incl. rigging and the task's capacity reduction, as the controller's rated
  //! capacity limiter takes it) over the chart's rated capacity at the true boom length and
  //! elevation; +inf outside the chart, NaN without a chart. [-]
  double chart_utilisation = std::numeric_limits<double>::quiet_NaN();
  //! The chart cell read (guidance::rated_capacity); not in_chart outside it or without a chart.
  guidance::RatedCapacity chart;
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

  //! Samples whose load's bottom was below the ground by more than rounding. Machines without a
  //! hung load count none (TruthMonitor::has_ground_clearance).
  std::uint64_t samples_below_ground = 0;
  //! The least ground clearance of the load's bottom, the lowest of what hangs from the hook;
  //! negative below the ground. [m]
  double least_ground_clearance_m = std::numeric_limits<double>::infinity();
  double least_ground_clearance_t_s = std::numeric_limits<double>::quiet_NaN();  //!< [s]
  double least_hook_ground_clearance_m = std::numeric_limits<double>::infinity();  //!< [m]
  double least_hook_ground_clearance_t_s = std::numeric_limits<double>::quiet_NaN();  //!< [s]

  //! Samples above 100 % of the chart, those outside it (utilisation +inf) included. Machines
  //! without a chart count none (TruthMonitor::has_load_chart).
  std::uint64_t samples_chart_exceeded = 0;
  std::uint64_t samples_outside_chart = 0;  //!< no chart cell rated the true boom length and angle
  //! The highest chart utilisation; +inf once a sample was outside the chart; 0 without one. [-]
  double peak_chart_utilisation = 0.0;
  double peak_chart_utilisation_t_s = std::numeric_limits<double>::quiet_NaN();  //!< [s]
  double peak_chart_boom_length_m = std::numeric_limits<double>::quiet_NaN();     //!< at the peak [m]
  double peak_chart_elevation_rad = std::numeric_limits<double>::quiet_NaN();     //!< at the peak [rad]
};

//! Measures what the simulated machine really comes near (docs/simulator.md, "The truth
//! monitor"): the true joint positions against the scenario's site with its dynamic obstacles at
//! their true poses, the machine's bodies undilated, as the controller tests measure it; and,
//! when the scenario has an `envelope` section, the monitored points' distance to its limits; for a
//! crane, the load's and the hook's height above the ground; for a mobile crane with a load chart
//! and a lift task, the chart's utilisation at the true boom length and elevation. Nothing here
//! reaches the controller: it is the referee's view, for the run's summary and logs.
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
  //! The same for a copy of a simulator's state (mgc-sim measures outside its loop's lock).
  bool sample(const TruthSnapshot& snapshot) noexcept;

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
  //! A single crane (mobile or tower): its hook and load are measured against the ground. Not an
  //! excavator, whose bucket digs below it by design, nor the dual crane's girder.
  [[nodiscard]] bool has_ground_clearance() const noexcept { return hook_point_ >= 0; }
  //! A mobile crane with a lift task and a load chart of at least one cell: its utilisation is
  //! measured. A tower crane has no chart (the thesis applies none).
  [[nodiscard]] bool has_load_chart() const noexcept { return crane_ != nullptr; }
  //! The load the chart is read against, as the controller's limiter takes it; 0 without a chart. [lb]
  [[nodiscard]] double chart_load_lb() const noexcept { return chart_load_lb_; }

  //! The summary in one line, e.g. "least clearance 1.30 m at 0.00 s (carrier to frame/column[0,2,0]),
  //! of the moving bodies 2.41 m at 50.20 s (load to frame/beam[1,2,3]); to the dynamic obstacles
  //! 3.10 m at 61.20 s (boom to crane-2); 0 of 1240 samples below 0.50 m; envelope: least distance
  //! 1.20 m at 80.05 s (hook to virtual wall 0), 0 samples outside; ground: least clearance 0.50 m at
  //! 0.00 s (load bottom), of the hook 3.50 m at 0.00 s, 0 samples below; load chart: peak
  //! utilisation 27.3 % at 0.00 s (boom 20.00 m at 50.0 deg), 0 samples above 100 %, 0 outside the
  //! chart". A part that does not apply reads "n/a". Allocates.
  [[nodiscard]] std::string summary_line() const;

 private:
  //! Fills s's ground clearances and chart reading for q. No allocation.
  void measure_ground_and_chart(TruthSample& s, const planning::JointVector& q) noexcept;

  TruthMonitorConfig config_;
  std::size_t num_dynamic_ = 0;
  std::unique_ptr<planning::MachineModel> model_;
  std::unique_ptr<planning::CollisionWorld> world_;          //!< static and dynamic obstacles
  std::unique_ptr<planning::CollisionWorld> dynamic_world_;  //!< dynamic obstacles only
  std::unique_ptr<guidance::Envelope> envelope_;
  //! The fixed bodies (Bodies::Fixed) to the static obstacles, measured once. [m]
  planning::Clearance fixed_static_;
  planning::JointVector q_wrapped_;
  //! Key points of the hook and the load's bottom centre; both -1 without ground clearance.
  int hook_point_ = -1;
  int load_bottom_point_ = -1;
  //! The mobile crane whose chart is read (owned by model_), or null.
  const planning::MobileCrane* crane_ = nullptr;
  double chart_load_lb_ = 0.0;  //!< [lb]
  planning::Kinematics kinematics_{};  //!< a member: forward kinematics fill it at every sample
  //! Measures the true joints and moves the sampling grid on.
  void sample_truth(const TrueState& truth) noexcept;
  SampleGrid grid_{0.0};  //!< on the configured period, set by the constructor
  TruthSample last_{};
  TruthSummary summary_{};
};

}  // namespace mgc::sim
