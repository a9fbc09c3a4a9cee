// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/status.hpp"

//! The controller's side of the bus: one call per cycle turns the frames received since the last
//! call into a SensorSnapshot with per-device health, another writes the valve commands. Policy
//! (when to start the nodes, what to do about a stale joint) belongs to the supervisor; the Hal
//! only reports, flags and sends. docs/protocol.md §Hal facade.
namespace mgc::hal {

//! What the controller knows about one device or one piece of its data.
enum class Health : std::uint8_t {
  Missing,  //!< never heard, or its heartbeat is older than the consumer timeout
  Alive,    //!< heartbeat and data fresh, no fault reported
  Stale,    //!< heartbeat fresh, but its data is older than the stale limit (or there is none yet)
  Faulted,  //!< the device reports a fault (active EMCY, encoder alarm, valve fail-safe or fault)
};
[[nodiscard]] const char* to_string(Health health) noexcept;

//! Heartbeat, NMT state and emergencies of one node.
struct DeviceStatus {
  std::uint8_t node_id = 0;
  Health health = Health::Missing;
  bool heard = false;                       //!< a heartbeat arrived since start
  canopen::NmtState nmt_state = canopen::NmtState::BootUp;  //!< from its last heartbeat
  std::int64_t last_heartbeat_us = 0;       //!< receive time [µs]
  std::uint16_t emcy_code = canopen::kEmcyNoError;  //!< last EMCY code; kEmcyNoError after a reset
  std::uint32_t emcy_count = 0;             //!< EMCY frames received, resets included [frames]
  std::uint32_t boot_count = 0;             //!< boot-up messages seen: a reboot mid-run counts [-]
};

//! One joint as its encoder reported it.
struct JointReading {
  Health health = Health::Missing;
  bool valid = false;            //!< health == Alive: the position may be used this cycle
  double position = 0.0;         //!< last decoded position, kept for display when not valid [rad | m]
  std::int64_t t_us = 0;         //!< receive time of that sample [µs]; 0 = none yet
  std::uint8_t status = 0;       //!< encoder status bits of that sample
  bool updated = false;          //!< a new sample arrived this cycle
  std::uint32_t samples = 0;     //!< samples received since start [-]
};

//! One UWB tag as the gateway last reported it.
struct TagReading {
  std::uint8_t tag_id = 0;
  bool valid = false;                        //!< a fix newer than the stale limit, gateway alive
  std::array<double, 3> position_m{};        //!< site frame [m]
  double sigma_m = 0.0;                      //!< 1-sigma bound from the quality nibble; 0 = unknown [m]
  std::uint8_t quality = 0;                  //!< raw quality 1..15 of that fix
  std::int64_t t_us = 0;                     //!< receive time of that fix [µs]
  bool updated = false;                      //!< a new fix arrived this cycle
  std::uint32_t fixes = 0;                   //!< fixes received [-]
  std::uint32_t missed = 0;                  //!< fixes the sequence numbers say were lost [-]
  std::uint32_t no_fix = 0;                  //!< "no fix" reports received [-]
  std::uint8_t sequence = 0;                 //!< of the last frame, 0..15
};

inline constexpr std::size_t kMaxTags = 32;                 //!< tags one snapshot tracks
inline constexpr std::size_t kHalReceiveBatch = 64;         //!< frames per receive() call
inline constexpr std::size_t kMaxFramesPerRead = 2048;      //!< frames drained per read() at most

//! Everything the controller may know at the start of a cycle. Plain data, fixed size.
struct SensorSnapshot {
  std::int64_t t_us = 0;             //!< the read() time [µs]
  std::uint64_t cycle = 0;           //!< read() calls since construction [-]
  std::uint8_t sync_counter = 0;     //!< the SYNC sent by this read() (0 = none sent)
  BusState bus_state = BusState::ErrorActive;
  bool rx_lost = false;              //!< the transport lost frames since the last read()
  bool rx_backlog = false;           //!< kMaxFramesPerRead reached: frames remain queued
  std::uint32_t frames = 0;          //!< frames drained this cycle [frames]

  std::uint8_t num_joints = 0;
  std::array<JointReading, kMaxBusJoints> joints{};
  std::array<DeviceStatus, kMaxBusJoints> encoders{};
  //! The boom inclinometer (BusPlan::inclinometer_node_id), when the plan has one: the angle to the
  //! horizontal of the link that joint inclinometer_joint raises, in the joint's unit [rad].
  std::int8_t inclinometer_joint = -1;
  DeviceStatus inclinometer{};
  JointReading inclinometer_angle{};
  DeviceStatus uwb_gateway{};
  DeviceStatus valve{};

  pdo::ValveStatus valve_status{};   //!< last status frame
  bool valve_status_valid = false;   //!< a status frame newer than the encoder stale limit
  std::int64_t valve_status_t_us = 0;  //!< receive time of the last status frame; 0 = none since start [µs]
  std::array<double, kMaxBusJoints> valve_applied_fraction{};  //!< spools in force, -1..1 [-]
  //! What the last write() commanded, in the same scale as valve_applied_fraction (deadband
  //! mapping included), and how many writes have sent commands: the valve's applied spools and
  //! command counter are checked against them (guidance::PlausibilityMonitor).
  std::array<double, kMaxBusJoints> valve_command_fraction{};  //!< -1..1 [-]
  std::uint32_t valve_commands_sent = 0;  //!< write() calls whose command frames all went out [-]

  DeviceStatus cutoff{};             //!< the pilot-pressure cut-off node
  pdo::CutoffStatus cutoff_status{}; //!< its last status frame
  bool cutoff_status_valid = false;  //!< a status frame newer than the encoder stale limit
  bool pilot_enable_sent = false;    //!< the last write() asked the cut-off to keep pilot pressure

  std::size_t num_tags = 0;          //!< tags seen since start, in order of first sight
  std::array<TagReading, kMaxTags> tags{};
  std::uint32_t tags_dropped = 0;    //!< fixes of tags beyond kMaxTags [frames]

  CodecCounters codec{};             //!< since start
  BusCounters bus{};                 //!< the transport's, since open

  //! Every joint has a valid position this cycle.
  [[nodiscard]] bool all_joints_valid() const noexcept {
    for (std::size_t j = 0; j < num_joints; ++j) {
      if (!joints[j].valid) return false;
    }
    return true;
  }
  //! The valve node is alive and following commands.
  [[nodiscard]] bool valve_active() const noexcept {
    return valve.health == Health::Alive && valve_status_valid && valve_status.state == pdo::ValveState::Active;
  }
  //! The tag with this id, or nullptr.
  [[nodiscard]] const TagReading* find_tag(std::uint8_t tag_id) const noexcept {
    for (std::size_t i = 0; i < num_tags; ++i) {
      if (tags[i].tag_id == tag_id) return &tags[i];
    }
    return nullptr;
  }
};

//! Hal::write's answer.
struct WriteResult {
  Status status = Status::Ok;  //!< the first failing send, else OutOfRange for a refused value, else Ok
  std::uint8_t clamped_mask = 0;   //!< bit j: joint j's command exceeded its max velocity and was clamped
  std::uint8_t refused_mask = 0;   //!< bit j: joint j's command was NaN/infinite and was sent as 0
};

//! The controller's bus endpoint for one machine. Construction is start-up code; every other call
//! is RT-safe: no allocation, no exceptions, never blocks. now_us is on the bus's clock.
class Hal {
 public:
  //! max_velocity: each joint's velocity at 100 % valve command [rad/s | m/s], plan.num_joints
  //! values (the machine model's limits, docs/protocol.md §Valve).
  Hal(CanBus& bus, const BusPlan& plan, std::span<const double> max_velocity);

  //! Sends SYNC, then drains the receive queue (at most kMaxFramesPerRead frames) and updates the
  //! snapshot. The samples it holds answer earlier SYNCs; the ones this SYNC triggers arrive for
  //! the next read(). Health is recomputed at now_us; the age of SYNC-triggered data (encoder
  //! samples, the valve status) is measured at most one SYNC period after the previous read(), so
  //! that a late cycle, which delayed the SYNC itself, does not make the devices' answers stale.
  const SensorSnapshot& read(std::int64_t now_us) noexcept;

  //! The valves' deadband, a fraction of spool travel (docs/protocol.md §Valve): a proportional
  //! valve passes no flow below it and flow linear in the spool beyond. write() then maps a
  //! velocity v to the spool sign(v) (deadband + (1 - deadband) |v| / max) and zero to zero, so
  //! that a small correction moves the joint instead of leaving it short of its target. 0 (the
  //! default): v / max. Start-up only; throws std::invalid_argument outside [0, 0.5].
  void set_valve_deadband(double fraction);
  [[nodiscard]] double valve_deadband() const noexcept { return valve_deadband_; }

  //! The positions joint j's encoder can plausibly report [rad | m]: a decoded sample outside
  //! [min, max] is counted in the snapshot's codec.implausible (and still decoded: judging the
  //! joint is the diagnostics' job). Default: every representable value. Start-up only; throws
  //! std::invalid_argument for a joint beyond the plan, NaN, or min > max.
  void set_joint_plausible_range(std::size_t joint, double min, double max);

  //! Sends the valve command frames for every joint (velocities in SI, clamped to the max
  //! velocity), the cut-off command (enable or cut, see set_pilot_enabled), and the controller
  //! heartbeat when it is due.
  WriteResult write(std::span<const double> velocity, std::int64_t now_us) noexcept;

  //! Whether write() asks the cut-off node to keep pilot pressure on. Off until set: a harness
  //! that never enables it leaves the machine unable to move, never the other way round.
  void set_pilot_enabled(bool enabled) noexcept { pilot_enabled_ = enabled; }
  [[nodiscard]] bool pilot_enabled() const noexcept { return pilot_enabled_; }

  //! Sends an NMT command (node 0 = all nodes).
  Status send_nmt(canopen::NmtCommand command, std::uint8_t node_id) noexcept;

  //! Sends the controller heartbeat if one is due at now_us (write() does this too; for cycles
  //! that write nothing, e.g. before start).
  Status heartbeat(std::int64_t now_us) noexcept;

  //! Stops sending SYNC (a stopped master); read() still drains. Default on.
  void enable_sync(bool on) noexcept { sync_enabled_ = on; }

  [[nodiscard]] const SensorSnapshot& snapshot() const noexcept { return snap_; }
  [[nodiscard]] const BusPlan& plan() const noexcept { return plan_; }
  [[nodiscard]] CanBus& bus() noexcept { return bus_; }

 private:
  void handle(const TimedFrame& frame) noexcept;
  void handle_heartbeat(const canopen::HeartbeatMessage& hb, std::int64_t t_us) noexcept;
  void handle_emcy(const canopen::EmcyMessage& emcy) noexcept;
  void handle_tag(const pdo::UwbTagPosition& fix, std::int64_t t_us) noexcept;
  [[nodiscard]] DeviceStatus* device(std::uint8_t node_id) noexcept;
  //! data_age_ref_us: the time the PDO data's age is measured at (see read()).
  void update_health(std::int64_t now_us, std::int64_t data_age_ref_us) noexcept;

  CanBus& bus_;
  BusPlan plan_;
  std::array<double, kMaxBusJoints> max_velocity_{};
  double valve_deadband_ = 0.0;
  std::array<double, kMaxBusJoints> plausible_min_{};  //!< [rad | m]
  std::array<double, kMaxBusJoints> plausible_max_{};  //!< [rad | m]
  SensorSnapshot snap_{};
  std::array<TimedFrame, kHalReceiveBatch> rx_{};
  std::array<std::int8_t, 256> tag_slot_{};  //!< tag id → index in snap_.tags, -1 = unseen
  std::int64_t valve_status_t_us_ = 0;
  std::int64_t cutoff_status_t_us_ = 0;
  bool pilot_enabled_ = false;
  std::uint8_t sync_counter_ = 0;
  bool sync_enabled_ = true;
  std::int64_t previous_read_us_ = 0;
  bool have_previous_read_ = false;
  std::int64_t next_heartbeat_us_ = 0;
  bool heartbeat_sent_ = false;
};

}  // namespace mgc::hal
