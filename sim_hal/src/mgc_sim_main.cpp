// SPDX-License-Identifier: Apache-2.0
// mgc-sim: the simulated crane or excavator on a CAN bus, in real time. docs/simulator.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include <sys/resource.h>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/sim/simulator.hpp"
#include "mgc/sim/truth_monitor.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_signal(int /*signal*/) { g_stop.store(true); }

//! One CSV row of the true state every period: joints, spools, valve, dynamic obstacle poses, and
//! with a monitor its latest sample (at most one monitor period old).
class TruthLog {
 public:
  TruthLog(const std::string& path, const mgc::planning::Scenario& scenario, const mgc::sim::TruthMonitor* monitor)
      : out_(path), monitor_(monitor) {
    if (!out_) throw std::runtime_error("cannot write the truth log " + path);
    out_ << "t_s";
    for (const auto& j : scenario.machine.joints) {
      const std::string unit = j.type == mgc::planning::JointType::Revolute ? "deg" : "m";
      out_ << ',' << j.name << '_' << unit << ',' << j.name << "_velocity_" << unit << "_s," << j.name << "_spool";
    }
    out_ << ",valve_state,valve_reason";
    for (const auto& d : scenario.dynamic_obstacles) {
      out_ << ',' << d.obstacle.name << "_x_m," << d.obstacle.name << "_y_m," << d.obstacle.name << "_z_m,"
           << d.obstacle.name << "_yaw_deg";
    }
    if (monitor_) {
      out_ << ",clearance_m,moving_clearance_m";
      if (monitor_->has_dynamic_obstacles()) out_ << ",dynamic_clearance_m";
      if (monitor_->has_envelope()) out_ << ",envelope_m";
      if (monitor_->has_ground_clearance()) out_ << ",load_ground_m,hook_ground_m";
      if (monitor_->has_load_chart()) out_ << ",chart_utilisation";
    }
    out_ << '\n';
    revolute_.reserve(scenario.machine.joints.size());
    for (const auto& j : scenario.machine.joints) revolute_.push_back(j.type == mgc::planning::JointType::Revolute);
  }

  void write(const mgc::sim::Simulator& sim, std::size_t num_obstacles) {
    const mgc::sim::TrueState& t = sim.truth();
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4f", t.t_s);
    out_ << buf;
    for (std::size_t j = 0; j < t.num_joints; ++j) {
      const double scale = revolute_[j] ? 180.0 / std::numbers::pi : 1.0;
      std::snprintf(buf, sizeof buf, ",%.6f,%.6f,%.4f", t.position[j] * scale, t.velocity[j] * scale, t.spool[j]);
      out_ << buf;
    }
    out_ << ',' << static_cast<int>(t.valve_state) << ',' << static_cast<int>(t.valve_reason);
    for (std::size_t i = 0; i < num_obstacles; ++i) {
      const Eigen::Isometry3d pose = sim.obstacle_pose(i);
      const double yaw = std::atan2(pose.linear()(1, 0), pose.linear()(0, 0));
      std::snprintf(buf, sizeof buf, ",%.4f,%.4f,%.4f,%.4f", pose.translation().x(), pose.translation().y(),
                    pose.translation().z(), yaw * 180.0 / std::numbers::pi);
      out_ << buf;
    }
    if (monitor_) {
      const mgc::sim::TruthSample& m = monitor_->last();
      std::snprintf(buf, sizeof buf, ",%.4f,%.4f", m.clearance.distance_m, m.moving_clearance.distance_m);
      out_ << buf;
      if (monitor_->has_dynamic_obstacles()) {
        std::snprintf(buf, sizeof buf, ",%.4f", m.dynamic_clearance.distance_m);
        out_ << buf;
      }
      if (monitor_->has_envelope()) {
        std::snprintf(buf, sizeof buf, ",%.4f", m.envelope.distance_m);
        out_ << buf;
      }
      if (monitor_->has_ground_clearance()) {
        std::snprintf(buf, sizeof buf, ",%.4f,%.4f", m.load_ground_clearance_m, m.hook_ground_clearance_m);
        out_ << buf;
      }
      if (monitor_->has_load_chart()) {
        std::snprintf(buf, sizeof buf, ",%.4f", m.chart_utilisation);
        out_ << buf;
      }
    }
    out_ << '\n';
  }

  void flush() { out_.flush(); }

 private:
  std::ofstream out_;
  const mgc::sim::TruthMonitor* monitor_;
  std::vector<bool> revolute_;
};

//! The real-time loop's own timing: a SYNC that arrives while an iteration is busy (or the process
//! is not scheduled) waits for it, and the controller marks a device stale after 3 SYNC periods
//! without its answer, so the longest gap between two iterations is the figure that matters.
//! Plain maxima and counters: no allocation in the loop.
class LoopTiming {
 public:
  explicit LoopTiming(std::int64_t sync_period_us) noexcept : sync_period_us_(sync_period_us) {}

  //! At the top of an iteration, at now_us, simulation time t_s.
  void iteration(std::int64_t now_us, double t_s) noexcept {
    ++iterations_;
    if (previous_us_ >= 0) {
      const std::int64_t gap_us = now_us - previous_us_;
      if (gap_us > max_gap_us_) {
        max_gap_us_ = gap_us;
        max_gap_t_s_ = t_s;
      }
      if (gap_us > sync_period_us_) ++gaps_over_sync_;
    }
    previous_us_ = now_us;
  }
  //! One truth monitor sample took duration_us, at simulation time t_s.
  void truth_sample(std::int64_t duration_us, double t_s) noexcept {
    if (samples_++ == 0) first_sample_us_ = duration_us;
    if (duration_us > max_sample_us_) {
      max_sample_us_ = duration_us;
      max_sample_t_s_ = t_s;
    }
  }
  //! One truth log row took duration_us.
  void log_row(std::int64_t duration_us) noexcept { max_log_us_ = std::max(max_log_us_, duration_us); }
  //! The loop woke at now_us for an event due at due_us (earlier when a frame arrived).
  void woke(std::int64_t now_us, std::int64_t due_us) noexcept { max_late_us_ = std::max(max_late_us_, now_us - due_us); }
  //! The page faults of the whole process from here on are the loop's.
  void start_faults() noexcept { faults(major_start_, minor_start_); }

  //! One line for the summary: "timing: ...". Allocates (at the end of the run).
  [[nodiscard]] std::string line() const {
    long major = 0;
    long minor = 0;
    faults(major, minor);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "timing: %" PRIu64 " loop iterations, longest gap between two %.2f ms at %.2f s, %" PRIu64
                  " gaps over the %.0f ms SYNC period, wake-up lateness max %.2f ms; truth sample max %.2f ms at %.2f s"
                  " (first %.2f ms); truth log row max %.2f ms; %ld major and %ld minor page faults in the loop",
                  iterations_, static_cast<double>(max_gap_us_) * 1e-3, max_gap_t_s_, gaps_over_sync_,
                  static_cast<double>(sync_period_us_) * 1e-3, static_cast<double>(max_late_us_) * 1e-3,
                  static_cast<double>(max_sample_us_) * 1e-3, max_sample_t_s_, static_cast<double>(first_sample_us_) * 1e-3,
                  static_cast<double>(max_log_us_) * 1e-3, major - major_start_, minor - minor_start_);
    return buf;
  }

 private:
  static void faults(long& major, long& minor) noexcept {
    rusage usage{};
    if (getrusage(RUSAGE_SELF, &usage) != 0) return;
    major = usage.ru_majflt;
    minor = usage.ru_minflt;
  }

  std::int64_t sync_period_us_;
  std::int64_t previous_us_ = -1;
  std::uint64_t iterations_ = 0;
  std::int64_t max_gap_us_ = 0;
  double max_gap_t_s_ = 0.0;
  std::uint64_t gaps_over_sync_ = 0;
  std::int64_t max_late_us_ = 0;
  std::uint64_t samples_ = 0;
  std::int64_t first_sample_us_ = 0;
  std::int64_t max_sample_us_ = 0;
  double max_sample_t_s_ = 0.0;
  std::int64_t max_log_us_ = 0;
  long major_start_ = 0;
  long minor_start_ = 0;
};

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
  app.add_option("--scenario", scenario_file, "scenario file (YAML, docs/scenario-format.md)")->required();
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
  app.add_flag("--quiet", quiet, "print only errors and the truth summary");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-sim: %s (see --help)\n", e.what());
    return 2;
  }

  mgc::planning::Scenario scenario;
  mgc::sim::SimConfig config;
  config.seed = seed;
  try {
    scenario = mgc::planning::io::load_scenario(scenario_file);
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

    const auto log_period_us = static_cast<std::int64_t>(truth_period_ms * 1e3);
    const std::int64_t start_us = clock.now_us();
    const std::int64_t end_us = duration_s > 0.0 ? start_us + static_cast<std::int64_t>(duration_s * 1e6) : INT64_MAX;
    std::int64_t next_log_us = start_us;
    LoopTiming timing(sim.plan().timing.sync_period_us);
    timing.start_faults();
    while (!g_stop.load()) {
      const std::int64_t now_us = clock.now_us();
      timing.iteration(now_us, sim.time_s());
      sim.step(now_us);
      // Before the log row, so that its clearance columns are never older than a monitor period.
      if (monitor) {
        const std::int64_t before_us = clock.now_us();
        if (monitor->sample(sim)) timing.truth_sample(clock.now_us() - before_us, sim.time_s());
      }
      if (log && now_us >= next_log_us) {
        const std::int64_t before_us = clock.now_us();
        log->write(sim, scenario.dynamic_obstacles.size());
        timing.log_row(clock.now_us() - before_us);
        next_log_us += log_period_us;
        if (next_log_us <= now_us) next_log_us = now_us + log_period_us;
      }
      if (now_us >= end_us) break;
      std::int64_t next_us = std::min(sim.next_event_us(), end_us);
      if (log) next_us = std::min(next_us, next_log_us);
      const std::int64_t wait_us = next_us - clock.now_us();
      if (wait_us > 0) {
        (void)opened.bus->wait_readable(wait_us);
        timing.woke(clock.now_us(), next_us);
      }
    }
    if (log) log->flush();
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
    std::printf("mgc-sim: %s\n", timing.line().c_str());
    // The run's referee: printed with --quiet too, it is what the demo's summary quotes.
    if (monitor) std::printf("mgc-sim: truth: %s\n", monitor->summary_line().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-sim: %s\n", e.what());
    return 2;
  }
  return 0;
}
