// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/planning/machine_tags.hpp"
#include "mgc/planning/random.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/sim/actuator.hpp"
#include "mgc/sim/faults.hpp"

//! The simulated machine on the bus (docs/simulator.md): hydraulic joints driven by a CANopen
//! valve node, an absolute encoder node per joint, and a UWB gateway reporting tags on the
//! scenario's moving obstacles, with noise, latency, dropouts and injected faults. It speaks the
//! protocol of docs/protocol.md through the same codec as the controller's Hal.
namespace mgc::sim {

//! UWB gateway behaviour, defaults from DOMAIN-FACTS §3.1 (DW1000-class, dynamic, LOS).
struct UwbParams {
  double noise_sigma_m = 0.15;     //!< 1-sigma per axis [m]
  double rate_hz = 10.0;           //!< fixes per tag per second [Hz]
  double latency_ms = 50.0;        //!< fix time to frame on the bus [ms]
  double dropout_probability = 0.02;  //!< a fix that never reaches the bus [-]
};

//! The boom inclinometer (a CANopen node when the bus plan has one, docs/protocol.md): a MEMS
//! sensor's noise and its output filter, as a load moment limiter's angle sensor has them.
struct InclinometerParams {
  double noise_sigma_deg = 0.02;  //!< 1-sigma of each sample [deg]
  double filter_s = 0.02;         //!< first-order output filter's time constant [s]
};

struct SimConfig {
  double physics_rate_hz = 1000.0;   //!< fixed integration rate [Hz]
  double actuator_lag_s = 0.15;      //!< every joint's flow-to-velocity time constant [s]
  double valve_deadband = 0.03;      //!< spool fraction without flow [-]
  double valve_ramp_per_s = 10.0;    //!< the valve node's set-point ramp: full scale in 0.1 s [1/s]
  double encoder_noise_counts = 0.5; //!< 1-sigma encoder noise before quantisation [count]
  UwbParams uwb{};
  InclinometerParams inclinometer{};
  std::vector<Fault> faults;
  std::uint64_t seed = 1;            //!< noise and dropouts; the same seed repeats a run exactly
  double scenario_time_offset_s = 0.0;  //!< scenario time at simulation time 0 [s]
};

//! The machine as it really is, for logs and for tests that compare it with the controller's view.
struct TrueState {
  double t_s = 0.0;                  //!< simulation time [s]
  std::size_t num_joints = 0;
  std::array<double, hal::kMaxBusJoints> position{};  //!< [rad | m], unwrapped
  std::array<double, hal::kMaxBusJoints> velocity{};  //!< [rad/s | m/s]
  std::array<double, hal::kMaxBusJoints> spool{};     //!< applied spool fraction [-]
  hal::pdo::ValveState valve_state = hal::pdo::ValveState::Disabled;
  hal::pdo::ValveReason valve_reason = hal::pdo::ValveReason::None;
  hal::pdo::CutoffState cutoff_state = hal::pdo::CutoffState::Cut;
  //! Pilot pressure reaches the main valve block: without it every spool is neutral, whatever
  //! `spool` (the valve node's set-points) says.
  bool pilot_pressure = false;
};

//! Frames and events since start.
struct SimCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped = 0;     //!< bus-off, or the send queue full [frames]
  std::uint64_t frames_received = 0;
  std::uint64_t syncs = 0;
  std::uint64_t commands_accepted = 0;  //!< valid valve command frames applied [frames]
  std::uint64_t commands_ignored = 0;   //!< not Active, or a valve-ignore fault [frames]
  std::uint64_t tag_fixes = 0;          //!< fixes computed [-]
  std::uint64_t tag_fixes_dropped = 0;  //!< fixes lost on the way (dropout) [-]
  std::uint64_t fail_safe_events = 0;   //!< valve entries into FailSafe [-]
  std::uint64_t pilot_cuts = 0;         //!< the cut-off node went from Enabled to Cut or Fault [-]
  hal::CodecCounters codec{};
};

//! A tag on one of the scenario's dynamic obstacles, or on the machine itself.
struct SimTag {
  std::uint8_t tag_id = 0;
  std::size_t obstacle = 0;                               //!< index into scenario.dynamic_obstacles
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();   //!< in the obstacle's (or mount's) frame [m]
  bool on_machine = false;                                //!< a machine tag: mount, not obstacle
  planning::TagMount mount{};                             //!< resolved by the Simulator
};

//! A tag of the site's RTLS on another machine of a coordinated site (the site file's `uwb_tags`):
//! this simulator's UWB gateway reports it, from that machine's true joints (its own simulator's
//! TrueState) through that machine's model. The model and the truth outlive the simulator.
struct SiteSimTag {
  std::uint8_t tag_id = 0;
  const planning::MachineModel* model = nullptr;
  planning::TagMount mount{};
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  //!< in the mount's frame [m]
  const TrueState* truth = nullptr;
};

class Simulator {
 public:
  //! The scenario's machine starts at rest at its start configuration, every node booting. The
  //! bus must outlive the simulator. Throws std::invalid_argument for a machine without a bus
  //! plan or a configuration out of range.
  Simulator(const planning::Scenario& scenario, hal::CanBus& bus, SimConfig config);

  //! Adds tags on the other machines of a site, reported with the same noise, rate, latency and
  //! dropouts as the scenario's tags, from a noise stream of their own (every other fix stays as it
  //! was), in slots of their own between the scenario's. Before the first step() only.
  void add_site_tags(std::vector<SiteSimTag> tags);
  [[nodiscard]] const std::vector<SiteSimTag>& site_tags() const noexcept { return site_tags_; }
  //! World position of a site tag now, from its machine's latest true joints [m].
  [[nodiscard]] Eigen::Vector3d site_tag_position(const SiteSimTag& tag) const noexcept;

  //! Runs the machine up to now_us (on the bus's clock): physics in fixed steps, then every
  //! received frame, then every frame due. The first call fixes simulation time 0.
  void step(std::int64_t now_us) noexcept;

  //! Earliest time step() has work that is not triggered by a received frame [µs].
  [[nodiscard]] std::int64_t next_event_us() const noexcept;

  [[nodiscard]] const TrueState& truth() const noexcept { return truth_; }
  [[nodiscard]] const planning::Scenario& scenario() const noexcept { return scenario_; }
  [[nodiscard]] const SimCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const hal::BusPlan& plan() const noexcept { return plan_; }
  [[nodiscard]] const SimConfig& config() const noexcept { return config_; }
  [[nodiscard]] const std::vector<SimTag>& tags() const noexcept { return tags_; }
  //! Pose of dynamic obstacle i at the current simulation time.
  [[nodiscard]] Eigen::Isometry3d obstacle_pose(std::size_t i) const noexcept;
  //! World position of a tag at the current simulation time; a machine tag's from the true joint
  //! positions, not from what the encoders report [m].
  [[nodiscard]] Eigen::Vector3d tag_position(const SimTag& tag) const noexcept;
  [[nodiscard]] const HydraulicActuator& actuator(std::size_t joint) const noexcept { return actuators_[joint]; }
  [[nodiscard]] double time_s() const noexcept { return truth_.t_s; }

 private:
  struct Node {
    std::uint8_t node_id = 0;
    hal::canopen::NmtState state = hal::canopen::NmtState::BootUp;
    std::int64_t next_heartbeat_us = 0;
    bool booted = false;
  };
  struct Pending {
    std::int64_t release_us = 0;
    std::uint64_t order = 0;
    hal::CanFrame frame{};
  };
  static constexpr std::size_t kPendingCapacity = 1024;

  void advance_physics(std::int64_t now_us) noexcept;
  void handle(const hal::TimedFrame& frame, std::int64_t now_us) noexcept;
  void on_nmt(const hal::canopen::NmtMessage& nmt, std::int64_t now_us) noexcept;
  void on_sync(std::int64_t now_us) noexcept;
  void on_valve_command(const hal::pdo::ValveCommand& cmd, std::int64_t now_us) noexcept;
  void on_cutoff_command(const hal::pdo::CutoffCommand& cmd, std::int64_t now_us) noexcept;
  void supervise_cutoff(std::int64_t now_us) noexcept;
  void set_cutoff(hal::pdo::CutoffState state, hal::pdo::CutoffReason reason) noexcept;
  //! The pilot pressure the hydraulics deliver now: the node's state, unless its dump valve sticks.
  [[nodiscard]] bool pilot_pressure() const noexcept;
  void supervise_valve(std::int64_t now_us) noexcept;
  void enter_fail_safe(hal::pdo::ValveReason reason, std::int64_t now_us) noexcept;
  void emit_heartbeats(std::int64_t now_us) noexcept;
  //! The inclinometer's answer to a SYNC: its filtered angle with noise, or its fault's.
  void emit_inclinometer(std::int64_t now_us) noexcept;
  void emit_uwb(std::int64_t now_us) noexcept;
  //! One fix of a tag at truth: noise, range, dropout, queued with the latency.
  void emit_fix(std::uint8_t tag_id, std::uint8_t sequence, const Eigen::Vector3d& truth, planning::Random& random,
                std::int64_t now_us, std::int64_t latency_us) noexcept;
  void queue(const hal::CanFrame& frame, std::int64_t now_us, std::int64_t extra_delay_us = 0) noexcept;
  void flush(std::int64_t now_us) noexcept;
  void boot(Node& node, std::int64_t now_us) noexcept;
  [[nodiscard]] bool fault_active(FaultKind kind, FaultTarget::Kind target = FaultTarget::Kind::None,
                                  int index = -1) const noexcept;
  [[nodiscard]] const Fault* find_fault(FaultKind kind, FaultTarget::Kind target, int index) const noexcept;
  [[nodiscard]] double sim_time_s(std::int64_t now_us) const noexcept;
  [[nodiscard]] double gaussian() noexcept { return gaussian(random_); }
  [[nodiscard]] static double gaussian(planning::Random& random) noexcept;
  [[nodiscard]] Node* node(std::uint8_t node_id) noexcept;

  const planning::Scenario& scenario_;
  hal::CanBus& bus_;
  SimConfig config_;
  hal::BusPlan plan_;
  planning::Random random_;
  std::array<HydraulicActuator, hal::kMaxBusJoints> actuators_{};
  std::vector<SimTag> tags_;
  //! For the machine's own tags (none: null): the model's forward kinematics, and a noise stream
  //! of their own, so that adding them leaves every other noise sample as it was.
  std::unique_ptr<planning::MachineModel> model_;
  mutable planning::Kinematics kinematics_{};
  planning::Random machine_tag_random_;
  //! The inclinometer's noise, a stream of its own for the same reason; its filtered angle [rad].
  planning::Random inclinometer_random_;
  double inclinometer_filtered_rad_ = 0.0;
  std::size_t inclinometer_node_ = 0;  //!< index in nodes_; 0: none (the first nodes are encoders)
  bool inclinometer_stuck_ = false;
  std::int32_t inclinometer_stuck_counts_ = 0;

  bool started_ = false;
  std::int64_t start_us_ = 0;
  std::int64_t physics_us_ = 0;        //!< physics has run up to here [µs on the bus clock]
  std::int64_t physics_step_us_ = 1000;
  TrueState truth_{};
  SimCounters counters_{};

  // Nodes: encoders 0..n-1, then the UWB gateway, the valve, the cut-off and the inclinometer.
  std::array<Node, hal::kMaxBusJoints + 4> nodes_{};
  std::size_t num_nodes_ = 0;
  std::size_t valve_node_ = 0;   //!< index in nodes_
  std::size_t cutoff_node_ = 0;  //!< index in nodes_
  std::array<std::int32_t, hal::kMaxBusJoints> stuck_counts_{};
  std::array<bool, hal::kMaxBusJoints> stuck_{};

  // Valve node.
  hal::pdo::ValveState valve_state_ = hal::pdo::ValveState::Disabled;
  hal::pdo::ValveReason valve_reason_ = hal::pdo::ValveReason::None;
  std::array<double, hal::kMaxBusJoints> commanded_{};  //!< accepted set-points [-]
  std::uint8_t command_counter_ = 0;
  bool heartbeat_armed_ = false;
  std::int64_t last_controller_heartbeat_us_ = 0;
  bool command_armed_ = false;
  std::int64_t last_command_us_ = 0;

  // Cut-off node: de-energised (cut) until an enable command reaches it while Operational.
  hal::pdo::CutoffState cutoff_state_ = hal::pdo::CutoffState::Cut;
  hal::pdo::CutoffReason cutoff_reason_ = hal::pdo::CutoffReason::NotOperational;
  bool cutoff_heartbeat_armed_ = false;
  std::int64_t cutoff_last_heartbeat_us_ = 0;
  bool cutoff_command_armed_ = false;
  std::int64_t cutoff_last_command_us_ = 0;
  bool cutoff_latched_ = false;  //!< cut after a loss: only an NMT Start re-arms it

  // UWB gateway: per tag, the next fix time and sequence.
  std::vector<std::int64_t> next_fix_us_;
  std::vector<std::uint8_t> tag_sequence_;
  // The other machines' tags (add_site_tags()), likewise, with their own noise stream.
  std::vector<SiteSimTag> site_tags_;
  std::vector<std::int64_t> next_site_fix_us_;
  std::vector<std::uint8_t> site_tag_sequence_;
  planning::Random site_tag_random_;
  mutable planning::Kinematics site_kinematics_{};

  // Outgoing frames, each with its release time (latency, delay faults).
  std::array<Pending, kPendingCapacity> pending_{};
  std::size_t num_pending_ = 0;
  std::uint64_t pending_order_ = 0;
  bool bus_off_ = false;
  std::array<hal::TimedFrame, 64> rx_{};
};

//! The tags of a scenario's dynamic obstacles, then its machine tags, in file order.
[[nodiscard]] std::vector<SimTag> scenario_tags(const planning::Scenario& scenario);

//! The bus plan of a scenario's machine kind, checked against its joint names.
[[nodiscard]] hal::BusPlan bus_plan_for(const planning::Scenario& scenario);

}  // namespace mgc::sim

namespace mgc::sim {

//! Applies a scenario's `simulation` section over config: present fields replace the defaults,
//! faults are appended. Throws planning::io::InputError at the fault's file and line for a fault
//! that does not parse.
void apply_simulation_spec(const planning::Scenario& scenario, SimConfig& config);

}  // namespace mgc::sim
