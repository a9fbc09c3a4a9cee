// SPDX-License-Identifier: Apache-2.0
// mgc-sim: the simulated crane or excavator on a CAN bus, in real time. docs/simulator.md; with
// --site and --machine-id, one machine of a coordinated site on its own bus; with --site alone,
// every machine of the site, each on its own bus, under one referee (docs/site.md).
#include <CLI/CLI.hpp>

#include <boost/lockfree/spsc_queue.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cinttypes>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/realtime_loop.hpp"
#include "mgc/sim/simulator.hpp"
#include "mgc/sim/site_simulation.hpp"
#include "mgc/sim/truth_monitor.hpp"
#include "mgc/sim/truth_snapshot.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_signal(int /*signal*/) { g_stop.store(true); }

//! Hands the truth log's bytes to a thread of its own, which writes them to the file at normal
//! priority: the loop only copies a row into a fixed ring, so a file system that stalls (page-cache
//! allocation, writeback, a journal commit) never holds up the answer to a SYNC.
class CsvWriter {
 public:
  //! Opens path, writes header and starts the writer thread. Throws std::runtime_error when the
  //! file cannot be opened.
  CsvWriter(const std::string& path, const std::string& header) : path_(path), file_(std::fopen(path.c_str(), "w")) {
    if (file_ == nullptr) throw std::runtime_error("cannot write the truth log " + path + ": " + std::strerror(errno));
    write(header.data(), header.size());
    // Every byte of the ring touched now: the loop's first pass over it takes no page fault.
    std::vector<char> fill(kRingBytes);
    (void)ring_->push(fill.data(), fill.size());
    (void)ring_->pop(fill.data(), fill.size());
    thread_ = std::thread([this] { run(); });
  }
  ~CsvWriter() { (void)close(); }
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  //! Queues a whole row, or drops it and counts it when the ring is full (the file system has
  //! stalled for minutes). Loop side: no allocation, no lock, no wait. One producer at a time: the
  //! loop's threads push only under the loop's lock, which also orders one's pushes before the next's.
  bool push(const char* row, std::size_t size) noexcept {
    // One producer: the free space can only grow until the push.
    if (ring_->write_available() < size) {
      ++dropped_;
      return false;
    }
    (void)ring_->push(row, size);
    return true;
  }
  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_; }

  //! Writes what is queued, stops the thread and closes the file. Returns an error message, or
  //! an empty string when every byte reached the file.
  std::string close() {
    if (thread_.joinable()) {
      stop_.store(true, std::memory_order_release);
      thread_.join();
    }
    if (file_ != nullptr) {
      if (std::fclose(file_) != 0 && error_ == 0) error_ = errno;
      file_ = nullptr;
    }
    return error_ == 0 ? std::string() : "cannot write the truth log " + path_ + ": " + std::strerror(error_);
  }

 private:
  //! About 2 minutes of rows of a 4-joint machine at the default 10 ms period. [bytes]
  static constexpr std::size_t kRingBytes = std::size_t{4} << 20;
  //! How long the writer sleeps when the ring is empty: rows reach the file within this. [ms]
  static constexpr int kDrainPeriodMs = 100;

  void write(const char* data, std::size_t size) noexcept {
    if (std::fwrite(data, 1, size, file_) != size && error_ == 0) error_ = errno != 0 ? errno : EIO;
  }

  void run() noexcept {
    // Under chrt the thread inherits the loop's SCHED_FIFO; file writes belong below it.
    const sched_param normal{};
    (void)pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
    std::array<char, 64 * 1024> chunk{};
    while (true) {
      // Read before draining: a row pushed before the stop is drained after it.
      const bool stopping = stop_.load(std::memory_order_acquire);
      std::size_t n = 0;
      while ((n = ring_->pop(chunk.data(), chunk.size())) > 0) write(chunk.data(), n);
      if (stopping) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(kDrainPeriodMs));
    }
  }

  std::string path_;
  std::FILE* file_;
  int error_ = 0;  //!< the first write error (errno), 0 for none
  std::unique_ptr<boost::lockfree::spsc_queue<char, boost::lockfree::capacity<kRingBytes>>> ring_ =
      std::make_unique<boost::lockfree::spsc_queue<char, boost::lockfree::capacity<kRingBytes>>>();
  std::uint64_t dropped_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

//! One CSV row of the true state every period: joints, spools, valve, dynamic obstacle poses, and
//! with a monitor its latest sample (at most one monitor period old). Rows are formatted into a
//! buffer sized for every column and written by a CsvWriter.
class TruthLog {
 public:
  TruthLog(const std::string& path, const mgc::planning::Scenario& scenario, const mgc::sim::TruthMonitor* monitor)
      : monitor_(monitor) {
    // Appended piece by piece: GCC 12 at -O3 misreads a literal + string temporary (-Wrestrict).
    std::string header = "t_s";
    std::size_t columns = 1;
    const auto column = [&](const std::string& name, const char* suffix) {
      header += ',';
      header += name;
      header += suffix;
      ++columns;
    };
    for (const auto& j : scenario.machine.joints) {
      const bool revolute = j.type == mgc::planning::JointType::Revolute;
      column(j.name, revolute ? "_deg" : "_m");
      column(j.name, revolute ? "_velocity_deg_s" : "_velocity_m_s");
      column(j.name, "_spool");
    }
    header += ",valve_state,valve_reason";
    columns += 2;
    for (const auto& d : scenario.dynamic_obstacles) {
      for (const char* axis : {"_x_m", "_y_m", "_z_m", "_yaw_deg"}) column(d.obstacle.name, axis);
    }
    if (monitor_) {
      header += ",clearance_m,moving_clearance_m";
      columns += 2;
      if (monitor_->has_dynamic_obstacles()) {
        header += ",dynamic_clearance_m";
        columns += 1;
      }
      if (monitor_->has_envelope()) {
        header += ",envelope_m";
        columns += 1;
      }
      if (monitor_->has_ground_clearance()) {
        header += ",load_ground_m,hook_ground_m";
        columns += 2;
      }
      if (monitor_->has_load_chart()) {
        header += ",chart_utilisation";
        columns += 1;
      }
    }
    header += '\n';
    // A column is a comma and a number; a number that does not fit (|x| above 1e20) truncates
    // the row, which is then dropped and counted.
    row_.resize(columns * 32 + 2);
    revolute_.reserve(scenario.machine.joints.size());
    for (const auto& j : scenario.machine.joints) revolute_.push_back(j.type == mgc::planning::JointType::Revolute);
    writer_ = std::make_unique<CsvWriter>(path, header);
  }

  //! Formats the row and queues it for the writer thread. No allocation, no I/O.
  void write(const mgc::sim::TruthSnapshot& snapshot) noexcept {
    const mgc::sim::TrueState& t = snapshot.truth;
    length_ = 0;
    fits_ = true;
    put(std::snprintf(at(), room(), "%.4f", t.t_s));
    for (std::size_t j = 0; j < t.num_joints; ++j) {
      const double scale = revolute_[j] ? 180.0 / std::numbers::pi : 1.0;
      put(std::snprintf(at(), room(), ",%.6f,%.6f,%.4f", t.position[j] * scale, t.velocity[j] * scale, t.spool[j]));
    }
    put(std::snprintf(at(), room(), ",%d,%d", static_cast<int>(t.valve_state), static_cast<int>(t.valve_reason)));
    for (const Eigen::Isometry3d& pose : snapshot.obstacle_poses) {
      const double yaw = std::atan2(pose.linear()(1, 0), pose.linear()(0, 0));
      const Eigen::Vector3d& p = pose.translation();
      put(std::snprintf(at(), room(), ",%.4f,%.4f,%.4f,%.4f", p.x(), p.y(), p.z(), yaw * 180.0 / std::numbers::pi));
    }
    if (monitor_) {
      const mgc::sim::TruthSample& m = monitor_->last();
      put(std::snprintf(at(), room(), ",%.4f,%.4f", m.clearance.distance_m, m.moving_clearance.distance_m));
      if (monitor_->has_dynamic_obstacles()) put(std::snprintf(at(), room(), ",%.4f", m.dynamic_clearance.distance_m));
      if (monitor_->has_envelope()) put(std::snprintf(at(), room(), ",%.4f", m.envelope.distance_m));
      if (monitor_->has_ground_clearance()) {
        put(std::snprintf(at(), room(), ",%.4f,%.4f", m.load_ground_clearance_m, m.hook_ground_clearance_m));
      }
      if (monitor_->has_load_chart()) put(std::snprintf(at(), room(), ",%.4f", m.chart_utilisation));
    }
    put(std::snprintf(at(), room(), "\n"));
    if (!fits_) {
      ++truncated_;
      return;
    }
    (void)writer_->push(row_.data(), length_);
  }

  //! Rows lost: truncated, or refused by a full ring. [-]
  [[nodiscard]] std::uint64_t dropped() const noexcept { return truncated_ + writer_->dropped(); }
  //! Writes the rest and closes the file; an error message, or empty when all reached it.
  std::string close() { return writer_->close(); }

 private:
  char* at() noexcept { return row_.data() + length_; }
  [[nodiscard]] std::size_t room() const noexcept { return row_.size() - length_; }
  //! Takes the length snprintf() wrote at at(); a row it truncated is marked not fitting.
  void put(int n) noexcept {
    if (!fits_) return;
    if (n < 0 || static_cast<std::size_t>(n) >= room()) {
      fits_ = false;
      return;
    }
    length_ += static_cast<std::size_t>(n);
  }

  const mgc::sim::TruthMonitor* monitor_;
  std::vector<bool> revolute_;
  std::vector<char> row_;
  std::size_t length_ = 0;
  bool fits_ = true;
  std::uint64_t truncated_ = 0;
  std::unique_ptr<CsvWriter> writer_;
};

//! What lock_memory() obtained; the loop runs either way.
struct MemoryLock {
  bool locked = false;
  std::string detail;  //!< why not (errno text)
};

//! Touches a stack region larger than the loop needs, so that its pages are present (and, with
//! mlockall, locked) before the first SYNC.
[[gnu::noinline]] void prefault_stack() noexcept {
  constexpr std::size_t kBytes = 512 * 1024;
  std::array<unsigned char, kBytes> stack;
  std::memset(stack.data(), 0, stack.size());
  // The writes must happen although nothing reads them.
  asm volatile("" : : "r"(stack.data()) : "memory");
}

//! mlockall(MCL_CURRENT | MCL_FUTURE), and the heap kept rather than returned to the kernel, so
//! the loop never waits for a page: not on a memory lookup, not on a fresh heap page. Start-up only.
MemoryLock lock_memory() {
  MemoryLock lock;
  // Freed memory stays in the process: a later allocation does not fault in new pages.
  (void)mallopt(M_TRIM_THRESHOLD, -1);
  (void)mallopt(M_MMAP_MAX, 0);
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    lock.locked = true;
  } else {
    lock.detail = std::string("mlockall: ") + std::strerror(errno);
  }
  prefault_stack();
  return lock;
}

//! Frames of true state the loop can hand to its observer before it must drop one: 5 s of truth
//! log rows at the default 10 ms, far longer than any stall of a CPU seen on a shared VM. [-]
constexpr std::size_t kTruthFrames = 512;

//! The work of one loop iteration, phase by phase: the simulator's step (reading the bus,
//! answering, the physics), the truth monitor's sample and the truth log's row. Plain maxima and
//! counters, updated under the loop's lock: no allocation in the loop. The loop's gaps, wake-ups
//! and page faults are RealtimeLoop's.
class PhaseTiming {
 public:
  //! The simulator's step at simulation time t_s took duration_us.
  void step(std::int64_t duration_us, double t_s) noexcept {
    if (duration_us > max_step_us_) {
      max_step_us_ = duration_us;
      max_step_t_s_ = t_s;
    }
  }
  //! The truth monitor's first sample, before the loop, took duration_us.
  void warm_up(std::int64_t duration_us) noexcept { warm_up_us_ = duration_us; }
  //! One truth monitor sample in the loop took duration_us, at simulation time t_s.
  void truth_sample(std::int64_t duration_us, double t_s) noexcept {
    ++samples_;
    if (duration_us > max_sample_us_) {
      max_sample_us_ = duration_us;
      max_sample_t_s_ = t_s;
    }
  }
  //! One truth log row took duration_us.
  void log_row(std::int64_t duration_us) noexcept {
    ++log_rows_;
    max_log_us_ = std::max(max_log_us_, duration_us);
  }

  //! e.g. "step max 0.12 ms at 3.20 s; truth sample max 0.35 ms at 42.35 s (the first, before the
  //! nodes boot, 4.12 ms); truth log row max 0.02 ms". Allocates (at the end of the run).
  [[nodiscard]] std::string line() const {
    const auto ms = [](std::int64_t us) { return static_cast<double>(us) * 1e-3; };
    char buf[256];
    std::snprintf(buf, sizeof buf, "step max %.2f ms at %.2f s", ms(max_step_us_), max_step_t_s_);
    std::string line = buf;
    if (samples_ > 0) {
      std::snprintf(buf, sizeof buf, "; truth sample max %.2f ms at %.2f s (the first, before the nodes boot, %.2f ms)",
                    ms(max_sample_us_), max_sample_t_s_, ms(warm_up_us_));
      line += buf;
    }
    if (log_rows_ > 0) {
      std::snprintf(buf, sizeof buf, "; truth log row max %.2f ms", ms(max_log_us_));
      line += buf;
    }
    return line;
  }

 private:
  std::int64_t max_step_us_ = 0;
  double max_step_t_s_ = 0.0;
  std::uint64_t samples_ = 0;
  std::int64_t warm_up_us_ = 0;
  std::int64_t max_sample_us_ = 0;
  double max_sample_t_s_ = 0.0;
  std::uint64_t log_rows_ = 0;
  std::int64_t max_log_us_ = 0;
};

//! What mgc-sim --site without --machine-id needs of the command line.
struct WholeSiteOptions {
  double duration_s = 0.0;
  double monitor_period_ms = 50.0;
  double monitor_margin_m = 0.5;
  bool quiet = false;
  bool mlock = false;
  std::size_t loop_threads = 1;
};

//! Every machine of the site, each on the bus the site file gives it, stepped by one real-time
//! loop that waits on all their buses, with one referee over them (docs/site.md). Returns the exit
//! status.
int run_whole_site(const mgc::planning::Site& site, const mgc::sim::SimConfig& config, const WholeSiteOptions& o) {
  const mgc::hal::SteadyClock& clock = mgc::hal::SteadyClock::instance();
  std::vector<std::unique_ptr<mgc::hal::CanBus>> owned;
  std::vector<mgc::hal::CanBus*> buses;
  for (const mgc::planning::SiteMachine& m : site.machines) {
    mgc::hal::OpenResult opened = mgc::hal::open_can_bus(m.bus.machine_url(), &clock);
    if (!opened) {
      std::fprintf(stderr, "%s:%d: %s: machine %d's bus does not open: %s\n", m.bus.ref.file.c_str(), m.bus.ref.line,
                   m.bus.ref.field.c_str(), static_cast<int>(m.id), opened.error.c_str());
      return 2;
    }
    buses.push_back(opened.bus.get());
    owned.push_back(std::move(opened.bus));
  }

  std::optional<mgc::sim::TruthMonitorConfig> monitor_config;
  if (o.monitor_period_ms > 0.0) {
    monitor_config = mgc::sim::TruthMonitorConfig{.period_s = o.monitor_period_ms * 1e-3, .clearance_margin_m = o.monitor_margin_m};
  }
  mgc::sim::SiteSimulation site_sim(site, buses, config, monitor_config);
  if (!o.quiet) {
    for (std::size_t i = 0; i < site_sim.size(); ++i) {
      const mgc::planning::Scenario& s = site_sim.scenario(i);
      std::printf("mgc-sim: machine %d: %s on %s, bus %s, %zu joints\n", static_cast<int>(site_sim.machine_id(i)),
                  s.machine.name.c_str(), s.name.c_str(), buses[i]->url().c_str(), s.machine.joints.size());
    }
    std::fflush(stdout);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  PhaseTiming timing;
  // The first samples, of the start states, taken before the nodes boot: they pay for what a first
  // distance query touches for the first time, so the loop does not.
  if (monitor_config) {
    const std::int64_t before_us = clock.now_us();
    (void)site_sim.sample();
    timing.warm_up(clock.now_us() - before_us);
  }
  const MemoryLock locked = o.mlock ? lock_memory() : MemoryLock{};
  if (o.mlock && !o.quiet) {
    std::printf("mgc-sim: real-time: memory lock %s%s%s\n", locked.locked ? "yes" : "no", locked.detail.empty() ? "" : ": ",
                locked.detail.c_str());
    std::fflush(stdout);
  }
  // The shortest SYNC period and staleness limit of the machines: the loop's gaps are judged by
  // the strictest.
  std::int64_t sync_period_us = INT64_MAX;
  std::int64_t stale_after_us = INT64_MAX;
  for (std::size_t i = 0; i < site_sim.size(); ++i) {
    sync_period_us = std::min(sync_period_us, site_sim.simulator(i).plan().timing.sync_period_us);
    stale_after_us = std::min(stale_after_us, site_sim.simulator(i).plan().timing.encoder_stale_after_us);
  }
  const std::int64_t start_us = clock.now_us();
  const std::int64_t end_us = o.duration_s > 0.0 ? start_us + static_cast<std::int64_t>(o.duration_s * 1e6) : INT64_MAX;
  mgc::sim::TruthFrameRing frames(kTruthFrames, site_sim.make_frame());
  mgc::sim::SampleGrid monitor_grid(site_sim.monitor_period_s());
  mgc::sim::RealtimeLoop loop(clock, buses,
                              {.threads = o.loop_threads, .sync_period_us = sync_period_us, .stale_after_us = stale_after_us});
  const auto observe = [&] {
    while (const mgc::sim::TruthFrame* frame = frames.front()) {
      const std::int64_t before_us = clock.now_us();
      if (site_sim.sample(*frame)) timing.truth_sample(clock.now_us() - before_us, frame->machines.front().truth.t_s);
      frames.pop();
    }
  };
  loop.run(
      [&](std::int64_t now_us) -> std::int64_t {
        site_sim.step(now_us);
        timing.step(clock.now_us() - now_us, site_sim.time_s());
        if (monitor_config && monitor_grid.take(site_sim.time_s())) {
          if (mgc::sim::TruthFrame* frame = frames.begin_push()) {
            site_sim.capture(*frame);
            frame->monitor_due = true;
            frames.end_push();
          }
        }
        if (now_us >= end_us) return -1;
        return std::min(site_sim.next_event_us(), end_us);
      },
      observe, g_stop);
  observe();
  if (!o.quiet) {
    for (std::size_t i = 0; i < site_sim.size(); ++i) {
      const mgc::sim::Simulator& sim = site_sim.simulator(i);
      const mgc::sim::SimCounters& c = sim.counters();
      std::printf("mgc-sim: machine %d stopped at %.3f s: %" PRIu64 " frames sent, %" PRIu64 " received, %" PRIu64
                  " SYNC, %" PRIu64 " commands applied, %" PRIu64 " ignored, %" PRIu64 " fail-safe events, %" PRIu64
                  " malformed, %" PRIu64 " unknown ids\n",
                  static_cast<int>(site_sim.machine_id(i)), sim.time_s(), c.frames_sent, c.frames_received, c.syncs,
                  c.commands_accepted, c.commands_ignored, c.fail_safe_events, c.codec.malformed(), c.codec.unknown_id);
    }
  }
  std::string timing_line = "timing: " + loop.line() + "; " + timing.line();
  timing_line += locked.locked ? "; memory locked" : "; memory not locked";
  if (frames.dropped() > 0) timing_line += "; " + std::to_string(frames.dropped()) + " truth frames lost (the observer fell behind)";
  std::printf("mgc-sim: %s\n", timing_line.c_str());
  if (monitor_config) {
    // One line per machine against the site, then the one between the machines: the run's referee,
    // printed with --quiet too.
    for (std::size_t i = 0; i < site_sim.size(); ++i) {
      std::printf("mgc-sim: truth: machine %d: %s\n", static_cast<int>(site_sim.machine_id(i)),
                  site_sim.monitor(i)->summary_line().c_str());
    }
    std::printf("mgc-sim: truth: between the machines: %s\n", site_sim.referee()->summary_line().c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-sim: a simulated crane or excavator on a CAN bus (docs/simulator.md)"};
  std::string scenario_file;
  std::string bus_url = "udp:127.0.0.1:47010,peer=127.0.0.1:47011";
  double duration_s = 0.0;
  std::string truth_csv;
  double truth_period_ms = 10.0;
  double monitor_period_ms = 50.0;
  double monitor_margin_m = 0.5;
  std::vector<std::string> fault_texts;
  std::uint64_t seed = 1;
  double uwb_noise_m = -1.0;
  double uwb_rate_hz = -1.0;
  double uwb_latency_ms = -1.0;
  double uwb_dropout_pct = -1.0;
  double time_offset_s = -1.0;
  bool quiet = false;
  bool mlock = false;
  std::string site_file;
  std::int32_t machine_id = 0;
  auto* scenario_opt = app.add_option("--scenario", scenario_file, "scenario file (YAML, docs/scenario-format.md)");
  app.add_option("--site", site_file,
                 "site file (docs/site.md): simulate every machine of the site (or with --machine-id one), each at its "
                 "first lift's start on the bus the site file gives it; instead of --scenario")
      ->excludes(scenario_opt);
  app.add_option("--machine-id", machine_id, "with --site: simulate only this machine of the site file");
  std::size_t loop_threads = 1;
  app.add_option("--bus", bus_url, "CAN bus URL: loop:, udp:HOST:PORT,peer=HOST:PORT, socketcan:IFNAME (docs/protocol.md)")
      ->capture_default_str();
  app.add_option("--duration", duration_s, "stop after this many seconds (default: until SIGINT/SIGTERM)")
      ->check(mgc::tools::nonnegative_number());
  app.add_option("--truth-csv", truth_csv, "write the true machine state here (CSV)");
  app.add_option("--truth-period-ms", truth_period_ms, "truth log period [ms]")->capture_default_str()->check(CLI::Range(1.0, 10'000.0));
  app.add_option("--monitor-period-ms", monitor_period_ms,
                 "measure the true clearance and envelope distance this often; 0: off [ms]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10'000.0));
  app.add_option("--monitor-margin-m", monitor_margin_m, "count the samples whose true clearance is below this [m]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--fault", fault_texts, "inject a fault: " + mgc::sim::fault_syntax());
  app.add_option("--seed", seed, "noise and dropout seed")->capture_default_str();
  app.add_option("--uwb-noise-m", uwb_noise_m, "UWB 1-sigma noise per axis [m]")->check(CLI::Range(0.0, 10.0));
  app.add_option("--uwb-rate-hz", uwb_rate_hz, "fixes per tag per second [Hz]")->check(CLI::Range(0.1, 100.0));
  app.add_option("--uwb-latency-ms", uwb_latency_ms, "fix-to-bus latency [ms]")->check(CLI::Range(0.0, 5000.0));
  app.add_option("--uwb-dropout-pct", uwb_dropout_pct, "fixes lost [%]")->check(CLI::Range(0.0, 100.0));
  app.add_option("--scenario-time-offset", time_offset_s, "start the scenario's scripted motion at this time [s]")
      ->check(CLI::Range(0.0, 1e6));
  app.add_flag("--mlock", mlock, "lock the process's memory (mlockall) when permitted");
  app.add_option("--loop-threads", loop_threads,
                 "threads that run the loop, each on a CPU of its own (at most the CPUs it may use): one answers "
                 "while another is not run")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{1}, mgc::sim::RealtimeLoop::kMaxThreads));
  app.add_flag("--quiet", quiet, "print only errors, the timing line and the truth summary");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-sim: %s (see --help)\n", e.what());
    return 2;
  }

  mgc::planning::Scenario scenario;
  std::optional<mgc::planning::Site> whole_site;
  mgc::sim::SimConfig config;
  config.seed = seed;
  try {
    if (scenario_file.empty() == site_file.empty()) {
      std::fprintf(stderr, "mgc-sim: --scenario or --site is required (see --help)\n");
      return 2;
    }
    if (site_file.empty() && app.count("--machine-id") > 0) {
      std::fprintf(stderr, "mgc-sim: --machine-id goes with --site (see --help)\n");
      return 2;
    }
    if (!site_file.empty() && app.count("--machine-id") == 0) {
      // Every machine of the site: each takes the bus the site file gives it, and the options that
      // name one machine's joints or file would be ambiguous.
      for (const char* option : {"--bus", "--truth-csv", "--fault"}) {
        if (app.count(option) > 0) {
          std::fprintf(stderr, "mgc-sim: %s takes one machine: with --site, give --machine-id too (see --help)\n", option);
          return 2;
        }
      }
      whole_site = mgc::planning::io::load_site(site_file);
    } else if (site_file.empty()) {
      scenario = mgc::planning::io::load_scenario(scenario_file);
    } else {
      // The machine alone: the other machines of the site are not in this simulator (docs/site.md).
      const mgc::planning::Site site = mgc::planning::io::load_site(site_file);
      const std::size_t index = mgc::planning::io::site_machine_index(site, machine_id);
      scenario = mgc::planning::lift_scenario(site, index, 0);
      if (app.count("--bus") == 0) bus_url = site.machines[index].bus.machine_url();
    }
    mgc::sim::apply_simulation_spec(scenario, config);
    for (const std::string& text : fault_texts) config.faults.push_back(mgc::sim::parse_machine_fault(text, scenario.machine.joints));
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "mgc-sim: --fault: %s\n", e.what());
    return 2;
  }
  if (uwb_noise_m >= 0.0) config.uwb.noise_sigma_m = uwb_noise_m;
  if (uwb_rate_hz > 0.0) config.uwb.rate_hz = uwb_rate_hz;
  if (uwb_latency_ms >= 0.0) config.uwb.latency_ms = uwb_latency_ms;
  if (uwb_dropout_pct >= 0.0) config.uwb.dropout_probability = uwb_dropout_pct / 100.0;
  if (time_offset_s >= 0.0) config.scenario_time_offset_s = time_offset_s;
  if (whole_site) {
    try {
      return run_whole_site(*whole_site, config,
                            {.duration_s = duration_s,
                             .monitor_period_ms = monitor_period_ms,
                             .monitor_margin_m = monitor_margin_m,
                             .quiet = quiet,
                             .mlock = mlock,
                             .loop_threads = loop_threads});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mgc-sim: %s\n", e.what());
      return 2;
    }
  }

  const mgc::hal::SteadyClock& clock = mgc::hal::SteadyClock::instance();
  mgc::hal::OpenResult opened = mgc::hal::open_can_bus(bus_url, &clock);
  if (!opened) {
    std::fprintf(stderr, "mgc-sim: --bus: %s\n", opened.error.c_str());
    return 2;
  }

  try {
    mgc::sim::Simulator sim(scenario, *opened.bus, config);
    std::unique_ptr<mgc::sim::TruthMonitor> monitor;
    if (monitor_period_ms > 0.0) {
      monitor = std::make_unique<mgc::sim::TruthMonitor>(
          scenario, mgc::sim::TruthMonitorConfig{.period_s = monitor_period_ms * 1e-3, .clearance_margin_m = monitor_margin_m});
    }
    std::unique_ptr<TruthLog> log;
    if (!truth_csv.empty()) log = std::make_unique<TruthLog>(truth_csv, scenario, monitor.get());
    if (!quiet) {
      std::printf("mgc-sim: %s on %s, bus %s, %zu joints, %zu UWB tags, %zu faults\n", scenario.machine.name.c_str(),
                  scenario.name.c_str(), opened.bus->url().c_str(), scenario.machine.joints.size(), sim.tags().size(),
                  config.faults.size());
      for (const auto& f : config.faults) {
        std::printf("mgc-sim: fault %s at %.3f s for %.3f s\n", mgc::sim::to_string(f.kind), f.start_s, f.duration_s);
      }
      std::fflush(stdout);
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);

    PhaseTiming timing;
    // The first sample, of the start state (the same as the first step's), taken before the nodes
    // boot: it pays for what a first distance query touches for the first time, so the loop does not.
    if (monitor) {
      const std::int64_t before_us = clock.now_us();
      (void)monitor->sample(sim);
      timing.warm_up(clock.now_us() - before_us);
    }
    const MemoryLock locked = mlock ? lock_memory() : MemoryLock{};
    if (mlock && !quiet) {
      std::printf("mgc-sim: real-time: memory lock %s%s%s\n", locked.locked ? "yes" : "no",
                  locked.detail.empty() ? "" : ": ", locked.detail.c_str());
      std::fflush(stdout);
    }

    const auto log_period_us = static_cast<std::int64_t>(truth_period_ms * 1e3);
    const std::int64_t start_us = clock.now_us();
    const std::int64_t end_us = duration_s > 0.0 ? start_us + static_cast<std::int64_t>(duration_s * 1e6) : INT64_MAX;
    std::int64_t next_log_us = start_us;
    // The state is copied in the loop and measured and logged outside its lock (TruthFrameRing).
    mgc::sim::TruthFrame prototype;
    prototype.machines.resize(1);
    prototype.machines[0].resize_for(sim);
    mgc::sim::TruthFrameRing frames(kTruthFrames, prototype);
    // The monitor's own grid, so that every frame handed over for a sample is one it takes.
    mgc::sim::SampleGrid monitor_grid(monitor ? monitor->config().period_s : 0.0);
    mgc::sim::RealtimeLoop loop(clock, *opened.bus,
                                {.threads = loop_threads,
                                 .sync_period_us = sim.plan().timing.sync_period_us,
                                 .stale_after_us = sim.plan().timing.encoder_stale_after_us});
    const auto observe = [&] {
      while (const mgc::sim::TruthFrame* frame = frames.front()) {
        // The sample before the log row, so that the row's clearance columns are never older than
        // a monitor period.
        if (frame->monitor_due) {
          const std::int64_t before_us = clock.now_us();
          if (monitor->sample(frame->machines[0])) timing.truth_sample(clock.now_us() - before_us, frame->machines[0].truth.t_s);
        }
        if (frame->log_due) {
          const std::int64_t before_us = clock.now_us();
          log->write(frame->machines[0]);
          timing.log_row(clock.now_us() - before_us);
        }
        frames.pop();
      }
    };
    loop.run(
        [&](std::int64_t now_us) -> std::int64_t {
          sim.step(now_us);
          timing.step(clock.now_us() - now_us, sim.time_s());
          const bool monitor_due = monitor && monitor_grid.take(sim.time_s());
          const bool log_due = log && now_us >= next_log_us;
          if (monitor_due || log_due) {
            if (mgc::sim::TruthFrame* frame = frames.begin_push()) {
              frame->machines[0].capture(sim);
              frame->monitor_due = monitor_due;
              frame->log_due = log_due;
              frames.end_push();
            }
          }
          if (log_due) {
            next_log_us += log_period_us;
            if (next_log_us <= now_us) next_log_us = now_us + log_period_us;
          }
          if (now_us >= end_us) return -1;
          std::int64_t next_us = std::min(sim.next_event_us(), end_us);
          if (log) next_us = std::min(next_us, next_log_us);
          return next_us;
        },
        observe, g_stop);
    observe();
    std::string log_error;
    if (log) log_error = log->close();
    if (!quiet) {
      const mgc::sim::SimCounters& c = sim.counters();
      std::printf("mgc-sim: stopped at %.3f s: %" PRIu64 " frames sent, %" PRIu64 " received, %" PRIu64
                  " SYNC, %" PRIu64 " commands applied, %" PRIu64 " ignored, %" PRIu64
                  " fail-safe events, %" PRIu64 " tag fixes (%" PRIu64 " dropped), %" PRIu64 " malformed, %" PRIu64
                  " unknown ids\n",
                  sim.time_s(), c.frames_sent, c.frames_received, c.syncs, c.commands_accepted, c.commands_ignored,
                  c.fail_safe_events, c.tag_fixes, c.tag_fixes_dropped, c.codec.malformed(), c.codec.unknown_id);
    }
    // With --quiet too: a late answer to a SYNC is the first thing to rule out when mgc faults.
    std::string timing_line = "timing: " + loop.line() + "; " + timing.line();
    timing_line += locked.locked ? "; memory locked" : "; memory not locked";
    if (frames.dropped() > 0) timing_line += "; " + std::to_string(frames.dropped()) + " truth frames lost (the observer fell behind)";
    if (log && log->dropped() > 0) timing_line += "; truth log: " + std::to_string(log->dropped()) + " rows lost";
    std::printf("mgc-sim: %s\n", timing_line.c_str());
    // The run's referee: printed with --quiet too, it is what the demo's summary quotes.
    if (monitor) std::printf("mgc-sim: truth: %s\n", monitor->summary_line().c_str());
    if (!log_error.empty()) {
      std::fprintf(stderr, "mgc-sim: %s\n", log_error.c_str());
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-sim: %s\n", e.what());
    return 2;
  }
  return 0;
}
