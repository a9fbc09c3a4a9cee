// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "mgc/firmware/controller.hpp"
#include "mgc/firmware/guidance_snapshot.hpp"
#include "mgc/firmware/site_member.hpp"
#include "mgc/firmware/spsc_queue.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/planning/site.hpp"

//! The black box (docs/black-box.md): what the controller received (every CAN frame with its
//! receive time as the Hal saw it, the operator commands accepted, the refusals counted, a site
//! member's verified site messages as the loop took them) and what
//! it decided (velocity commands, supervisor transitions, alerts) each cycle, in a bounded ring of
//! blocks on disk. The loop pushes fixed-size entries into a lock-free queue; a writer thread
//! encodes them into blocks and writes and syncs them at least once a second. replay() feeds a
//! recording to a fresh Hal and Controller in stepped time and compares each cycle's decisions.
namespace mgc::firmware::black_box {

inline constexpr std::uint32_t kFileMagic = 0x5842474Du;   //!< "MGBX" little-endian
inline constexpr std::uint32_t kBlockMagic = 0x4B4C4247u;  //!< "GBLK" little-endian
//! Version 2 adds the site: the header's machine id and site hash, site records, and each cycle's
//! counts of dropped records and site messages taken. Version 1 files are still read and replayed.
inline constexpr std::uint32_t kFormatVersion = 2;
inline constexpr std::size_t kFileHeaderBytes = 4096;      //!< [bytes]
inline constexpr std::size_t kBlockHeaderBytes = 32;       //!< [bytes]
inline constexpr std::size_t kBlockBytes = 64 * 1024;      //!< header + records, never split [bytes]
inline constexpr std::size_t kRecordHeaderBytes = 8;       //!< crc32, type, payload length [bytes]
//! What the thesis lift records, measured with mgc on mgc-sim over UDP (docs/black-box.md). [bytes/s]
inline constexpr std::size_t kMeasuredBytesPerSecond = 45'000;
//! What each other machine of a site adds to a member's recording: 20 states of 304 bytes and a
//! plan of 4,701 bytes a second (docs/black-box.md). [bytes/s]
inline constexpr std::size_t kSitePeerBytesPerSecond = 10'800;
inline constexpr double kDefaultMinutes = 10.0;            //!< [min]
inline constexpr std::int64_t kFlushPeriodUs = 250'000;    //!< write + fdatasync at least this often [µs]
inline constexpr std::size_t kQueueCapacity = 8192;        //!< entries: about 9 s of the thesis lift [-]
//! Site plans waiting for the writer, beside the entries that mark their place: 4.7 kB each, so
//! they have their own queue. 16 machines' plans at once and as many again. [-]
inline constexpr std::size_t kPlanQueueCapacity = 32;

enum class RecordType : std::uint16_t {
  Frame = 1,      //!< a CAN frame as the Hal received it
  Cycle = 2,      //!< one cycle's other inputs and its decisions
  Command = 3,    //!< an operator command the feed accepted (and the loop took)
  TxFailure = 4,  //!< a send the bus refused (the Hal's n-th send since start)
  Site = 5,       //!< a verified site message (state or plan) as the loop took it
  End = 6,        //!< the writer stopped cleanly
};

struct FrameEntry {
  hal::TimedFrame frame{};
};

struct TxFailureEntry {
  std::uint64_t send_index = 0;  //!< sends since the recording bus was built, from 0 [-]
  hal::Status status = hal::Status::Ok;
};

//! The fields of firmware::AcceptedCommand (lcm_feed.hpp), kept here so the recorder needs no LCM.
struct CommandEntry {
  std::int8_t kind = 0;                 //!< operator_command_t::KIND_* [enum]
  std::int32_t sender_id = 0;           //!< [-]
  std::int64_t sequence = 0;            //!< [-]
  std::int32_t num_joints = 0;          //!< goal entries used [-]
  std::array<double, kMaxJoints> goal_position{};  //!< [rad | m]
  std::int32_t alert_id = 0;            //!< acknowledged alert, 0 = all [-]
  std::int64_t received_us = 0;         //!< monotonic time of receipt [µs]
};

enum class SiteKind : std::uint8_t {
  State = 1,
  Plan = 2,
};

//! A site message the loop took (site_member.hpp, take_site_state / take_site_plan). A plan's
//! content travels beside the entry: in the recorder's plan queue, in Recording::plans once read.
struct SiteEntry {
  SiteKind kind = SiteKind::State;
  std::int8_t roster_index = -1;     //!< the sender's entry in the site's roster [-]
  std::int64_t received_us = 0;      //!< a state's receive time as the controller is given it [µs]
  std::uint32_t plan_index = 0;      //!< a plan's index in Recording::plans (read back only) [-]
  site_state_t state{};              //!< kind State
};

//! One alert as the decision compares it.
struct AlertDigest {
  std::int32_t alert_id = 0;
  std::int8_t severity = 0;
  std::int8_t source = 0;
  double value = 0.0;
  double limit = 0.0;
};

//! One cycle: the inputs that are not frames, and what the controller decided.
struct CycleEntry {
  // Inputs.
  std::uint64_t cycle = 0;             //!< cycles since the controller was built, from 0 [-]
  std::int64_t read_us = 0;            //!< the time Hal::read and Hal::write were given [µs]
  std::int64_t dt_us = 0;              //!< what Controller::step was given [µs]
  bool watchdog_tripped = false;
  bool rx_lost = false;                //!< the bus reported lost frames to this read
  hal::BusState bus_state = hal::BusState::ErrorActive;
  hal::BusCounters bus{};              //!< the bus's counters at this read
  ControllerCommands commands{};       //!< as given to step()
  std::uint64_t refusals_total = 0;    //!< operator commands the feed refused, since start [-]
  // Completeness (version 2), stamped by BlackBox::push_cycle: replay checks what it fed against them.
  std::uint64_t records_dropped = 0;   //!< entries the recorder dropped (full queue) before this one, since start [-]
  std::uint64_t site_taken = 0;        //!< site messages the loop took before this cycle's step, since start [-]
  // Decisions.
  std::uint8_t num_joints = 0;
  std::array<double, kMaxJoints> velocity{};  //!< [rad/s | m/s]
  bool start_nodes = false;
  bool reset_watchdog = false;
  bool pilot_enable = false;
  guidance::SupervisorState state = guidance::SupervisorState::Init;
  guidance::TransitionReason reason = guidance::TransitionReason::None;
  bool transitioned = false;
  std::uint32_t plan_id = 0;
  std::uint8_t num_alerts = 0;
  std::array<AlertDigest, kSnapshotMaxAlerts> alerts{};
};

//! What travels through the queue: a tagged union of fixed size, copied by value.
struct Entry {
  RecordType type = RecordType::Frame;
  union {
    FrameEntry frame;
    TxFailureEntry tx;
    CommandEntry command;
    CycleEntry cycle;
    SiteEntry site;
  };
  Entry() noexcept : frame{} {}
};

//! A cycle's entry from what the loop gave and got (RT-safe).
[[nodiscard]] CycleEntry make_cycle_entry(std::uint64_t cycle, std::int64_t read_us, std::int64_t dt_us, bool watchdog_tripped,
                                          const hal::SensorSnapshot& snapshot, const ControllerCommands& commands,
                                          const ControllerOutput& out, const GuidanceSnapshot& guidance,
                                          std::uint64_t refusals_total) noexcept;

//! Who and what was recorded: the file header.
struct Identity {
  std::string scenario_file;           //!< as given to mgc
  std::string scenario_name;
  std::string machine_name;
  std::uint64_t scenario_hash = 0;     //!< FNV-1a 64 of the scenario file's bytes
  std::uint64_t machine_hash = 0;      //!< FNV-1a 64 of the machine file's bytes
  std::string replanner;               //!< ControllerConfig::replanner
  std::int64_t period_us = 0;          //!< the control period [µs]
  double valve_deadband = 0.0;         //!< Hal::set_valve_deadband [-]
  std::uint8_t num_joints = 0;
  std::array<double, kMaxJoints> plausible_min{};  //!< Hal::set_joint_plausible_range [rad | m]
  std::array<double, kMaxJoints> plausible_max{};
  std::int64_t started_unix_s = 0;     //!< wall clock at start, for the investigator [s]
  //! The file's format: kFormatVersion when written by mgc, as read otherwise. [-]
  std::uint32_t format_version = kFormatVersion;
  //! A site member's machine id (scenario_file is then the site file, the lift its first); 0: one
  //! machine on its scenario. [-]
  std::int32_t site_machine_id = 0;
  //! FNV-1a 64 over the machine files' hashes of every machine of the site, in site order: the
  //! other machines' models enter the member's worlds. [-]
  std::uint64_t site_machines_hash = 0;
};

//! FNV-1a 64 of a file's bytes; throws std::runtime_error naming the file when it cannot be read.
[[nodiscard]] std::uint64_t hash_file(const std::string& path);
//! The identity of a run of this scenario with this Hal set-up (hashes the scenario and machine files).
[[nodiscard]] Identity identity_for(const planning::Scenario& scenario, const std::string& replanner, std::int64_t period_us,
                                    double valve_deadband);
//! The plausible ranges mgc gives its Hal: each non-continuous joint's range with a tenth of its
//! span either side (a joint a little past a soft limit is the diagnostics' business).
void set_plausible_ranges(Identity& identity, const planning::Scenario& scenario);
//! Makes the identity a site member's: its machine id and the hash of the site's machine files
//! (identity_for() of its lift scenario already names and hashes the site file).
void set_site_member(Identity& identity, const planning::Site& site, std::int32_t machine_id);
//! Applies the identity's deadband and plausible ranges to a Hal.
void configure_hal(hal::Hal& hal, const Identity& identity);

//! The file's size for a ring of this many minutes at the measured rates: the lift's, and each
//! other machine's site messages for a site member. [bytes]
[[nodiscard]] std::size_t ring_bytes_for_minutes(double minutes, std::size_t site_peers = 0) noexcept;

struct WriterStats {
  std::uint64_t entries_written = 0;
  std::uint64_t bytes_written = 0;     //!< records, headers excluded [bytes]
  std::uint64_t blocks_started = 0;
  std::uint64_t flushes = 0;
  std::int64_t flush_max_us = 0;       //!< longest write + fdatasync [µs]
  std::int64_t flush_total_us = 0;     //!< [µs]
};

//! The recorder: a queue the loop pushes into and a thread that writes the ring. As a
//! SiteTakeObserver it records the site messages the loop takes.
class BlackBox final : public SiteTakeObserver {
 public:
  //! Creates (or truncates) path with room for num_blocks blocks and writes the header, in
  //! identity.format_version (1 or 2). Start-up: allocates, throws std::runtime_error naming the
  //! file on an I/O error or an unknown version.
  BlackBox(const std::string& path, const Identity& identity, std::size_t file_bytes);
  ~BlackBox() override;
  BlackBox(const BlackBox&) = delete;
  BlackBox& operator=(const BlackBox&) = delete;

  //! Starts the writer thread.
  void start();
  //! Drains the queue, writes an End record, syncs, and joins the writer when it runs. Once.
  void close();
  //! Without the writer thread (rewriting a recording): drains the queue into the file now.
  void write_pending() noexcept;

  // The loop's side: RT-safe (no alloc, no lock, no throw, no wait); a full queue counts a drop.
  void push_frame(const hal::TimedFrame& frame) noexcept;
  void push_tx_failure(std::uint64_t send_index, hal::Status status) noexcept;
  void push_command(const CommandEntry& command) noexcept;
  //! Stamps the entry with the records dropped and the site messages taken so far.
  void push_cycle(const CycleEntry& cycle) noexcept;
  //! As it is, stamps included: rewriting a recording.
  void push_recorded_cycle(const CycleEntry& cycle) noexcept;
  void push_site_state(int roster_index, const site_state_t& state, std::int64_t received_us) noexcept;
  //! The plan into the plan queue, its place into the entries; when either is full, dropped and counted.
  void push_site_plan(int roster_index, const site_plan_t& plan) noexcept;
  void took_site_state(int roster_index, const site_state_t& state, std::int64_t received_us) noexcept override {
    push_site_state(roster_index, state, received_us);
  }
  void took_site_plan(int roster_index, const site_plan_t& plan) noexcept override { push_site_plan(roster_index, plan); }

  //! Entries dropped since start, site plans included. [-]
  [[nodiscard]] std::uint64_t dropped() const noexcept { return queue_->dropped() + plans_dropped_.load(std::memory_order_relaxed); }
  //! Site plans dropped since start (counted in dropped() too). [-]
  [[nodiscard]] std::uint64_t site_plans_dropped() const noexcept { return plans_dropped_.load(std::memory_order_relaxed); }
  //! Site messages the loop took since start, recorded or dropped. [-]
  [[nodiscard]] std::uint64_t site_taken() const noexcept { return site_taken_; }
  //! Entries waiting for the writer. [-]
  [[nodiscard]] std::size_t pending() const noexcept { return queue_->size(); }
  //! Valid after close().
  [[nodiscard]] const WriterStats& stats() const noexcept { return stats_; }
  [[nodiscard]] std::size_t num_blocks() const noexcept { return num_blocks_; }

 private:
  void run() noexcept;
  void finish() noexcept;
  void drain() noexcept;
  void append(const Entry& e) noexcept;
  void write_block(bool sync) noexcept;

  using Queue = SpscQueue<Entry, kQueueCapacity>;
  using PlanQueue = SpscQueue<site_plan_t, kPlanQueueCapacity>;
  std::unique_ptr<Queue> queue_;
  std::unique_ptr<PlanQueue> plans_;
  std::atomic<std::uint64_t> plans_dropped_{0};  //!< written by the loop, read by any thread
  std::uint64_t site_taken_ = 0;                 //!< the loop's
  std::uint32_t version_ = kFormatVersion;
  std::vector<std::uint8_t> record_;  //!< the writer's scratch: one record
  site_plan_t plan_{};                //!< the writer's scratch: the plan an entry marks
  std::string path_;
  int fd_ = -1;
  std::size_t num_blocks_ = 0;
  std::vector<std::uint8_t> block_;
  std::size_t used_ = kBlockHeaderBytes;
  std::uint64_t block_seq_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  bool started_ = false;
  bool closed_ = false;
  WriterStats stats_{};
  std::atomic<int> io_errno_{0};

 public:
  //! The first write or sync error (errno), 0 when none. [-]
  [[nodiscard]] int io_error() const noexcept { return io_errno_.load(); }
};

//! A CanBus that passes everything to another and records, on the way, every frame it receives
//! and every send it sees refused. Used by the loop thread only (as the bus it wraps).
class RecordingBus final : public hal::CanBus {
 public:
  RecordingBus(hal::CanBus& bus, BlackBox& box) noexcept : bus_(bus), box_(box) {}
  [[nodiscard]] hal::Status send(const hal::CanFrame& frame) noexcept override;
  [[nodiscard]] hal::ReceiveResult receive(std::span<hal::TimedFrame> out) noexcept override;
  [[nodiscard]] hal::Status wait_readable(std::int64_t timeout_us) noexcept override { return bus_.wait_readable(timeout_us); }
  [[nodiscard]] hal::Status set_filters(std::span<const hal::CanFilter> filters) noexcept override { return bus_.set_filters(filters); }
  [[nodiscard]] hal::Status set_error_mask(std::uint32_t class_mask) noexcept override { return bus_.set_error_mask(class_mask); }
  [[nodiscard]] hal::BusState state() const noexcept override { return bus_.state(); }
  [[nodiscard]] hal::BusCounters counters() const noexcept override { return bus_.counters(); }
  [[nodiscard]] std::string url() const override { return bus_.url(); }

 private:
  hal::CanBus& bus_;
  BlackBox& box_;
  std::uint64_t sends_ = 0;
};

//! A file that is not a recording, or a record in its middle that is corrupt: the message names the
//! file, the byte offset and what was expected.
class BadRecording : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

//! A recording as read back, entries oldest first.
struct Recording {
  Identity identity;
  std::vector<Entry> entries;
  std::vector<site_plan_t> plans;   //!< the site plans, which SiteEntry::plan_index names
  std::size_t num_blocks = 0;       //!< the ring's size [blocks]
  std::size_t blocks_used = 0;      //!< blocks holding this run's records [blocks]
  bool wrapped = false;             //!< the oldest blocks were overwritten
  bool ended = false;               //!< an End record: the writer stopped cleanly
  //! Bytes at the end of the newest block that are not a whole record (a write torn by a power
  //! loss); a kill leaves none, it loses the records not yet written. [bytes]
  std::size_t torn_tail_bytes = 0;
};

//! Reads path; throws BadRecording.
[[nodiscard]] Recording read_recording(const std::string& path);

//! Writes a recording back (same block layout, entries re-encoded, in identity.format_version;
//! version 1 has no site records): the tests' way of altering one.
void write_recording(const std::string& path, const Recording& recording, std::size_t file_bytes);

//! A supervisor transition as the recording holds it, read without replaying: a cycle whose
//! transition flag is set, with the state it ended in and its reason. Readable from any recording,
//! a wrapped ring's included. A cycle that transitioned twice shows its last transition.
struct RecordedTransition {
  std::uint64_t cycle = 0;
  std::int64_t t_us = 0;  //!< the cycle's recorded time [µs]
  //! The previous cycle's state; unknown (false) for the oldest cycle kept and after a gap.
  bool from_known = false;
  guidance::SupervisorState from = guidance::SupervisorState::Init;
  guidance::SupervisorState to = guidance::SupervisorState::Init;
  guidance::TransitionReason reason = guidance::TransitionReason::None;
};
[[nodiscard]] std::vector<RecordedTransition> recorded_transitions(const Recording& recording);

struct ReplayResult {
  bool replayable = true;            //!< false: the ring no longer holds the run's first cycle
  std::string why_not;
  bool identical = true;
  std::uint64_t cycles = 0;          //!< cycles compared [-]
  std::uint64_t first_cycle = 0;     //!< the first differing cycle
  std::int64_t first_read_us = 0;    //!< its time [µs]
  std::string field;                 //!< the first differing field, e.g. "velocity[2]"
  std::string recorded;
  std::string replayed;
  std::int64_t last_read_us = 0;     //!< the last recorded cycle's time [µs]
  std::uint64_t frames = 0;          //!< frames fed [-]
  std::uint64_t transitions = 0;     //!< supervisor transitions recorded [-]
  //! The replayed supervisor's transitions, in order: what the recorded run did and why, as mgc
  //! prints it (times are the recorded cycle times).
  std::vector<guidance::TransitionRecord> transition_log;
  std::int64_t first_cycle_read_us = 0;  //!< the first replayed cycle's time, the log's origin [µs]
  std::uint64_t site_messages = 0;   //!< site states and plans fed [-]
  //! The recording lacks inputs of a cycle (records dropped by a full queue, site records missing):
  //! replay stopped before it; identical then speaks of the cycles before.
  bool incomplete = false;
  std::uint64_t incomplete_cycle = 0;
  std::string why_incomplete;
};

//! Feeds the recording's frames and inputs to a fresh Hal (over a bus that plays the frames back)
//! and a fresh Controller for scenario, cycle by cycle, and compares every decision bit for bit.
//! A site member's recording needs site, the member's configuration (as mgc builds it; its
//! recorded site messages then go to the controller in the cycles that took them); without it,
//! one that holds site messages is not replayable.
[[nodiscard]] ReplayResult replay(const Recording& recording, const planning::Scenario& scenario, const SiteMemberConfig* site = nullptr);

}  // namespace mgc::firmware::black_box
