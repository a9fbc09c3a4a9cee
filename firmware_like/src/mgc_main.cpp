// SPDX-License-Identifier: Apache-2.0
// mgc: the machine-guidance controller. Runs the control cycle (docs/controller.md) on a CAN bus
// against the machine (or mgc-sim), publishes the operator feed over LCM and takes operator
// commands from it. With --site, one member of a coordinated site (docs/site.md): it also
// exchanges signed site messages with the other machines' controllers.
#include <CLI/CLI.hpp>
#include <sodium.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sched.h>

#include <mgc/operator_command_t.hpp>

#include "mgc/firmware/black_box.hpp"
#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/controller.hpp"
#include "mgc/firmware/cyclic_executive.hpp"
#include "mgc/firmware/lcm_feed.hpp"
#include "mgc/firmware/site_channel.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int /*signal*/) { g_stop.store(true); }

//! How long after its slot the standby loop thread wakes (at most a quarter period): the first
//! thread runs the cycle when the host lets it, and the standby only when it did not. [µs]
constexpr std::int64_t kStandbyDelay_us = 2'000;

//! The CPUs this process may run on, in order.
std::vector<int> allowed_cpus() {
  std::vector<int> cpus;
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) return cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &allowed)) cpus.push_back(c);
  }
  return cpus;
}

//! Pins the calling thread to one CPU; false when the OS refuses.
bool pin_to_cpu(int cpu) noexcept {
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  return pthread_setaffinity_np(pthread_self(), sizeof one, &one) == 0;
}

//! One row of the trace, recorded in the loop into preallocated storage.
struct TraceRow {
  std::int64_t t_us = 0;
  std::int8_t state = 0;
  std::array<double, mgc::kMaxJoints> q{};
  std::array<double, 3> tool_m{};
  double clearance_m = 0.0;
  std::array<std::array<double, 4>, 4> obstacle{};  //!< x, y, z [m], yaw [rad] of up to 4 tracked obstacles
};

const char* state_name(std::int8_t code) {
  return mgc::guidance::to_string(static_cast<mgc::guidance::SupervisorState>(code - 1));
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mgc;
  CLI::App app{"mgc: the machine-guidance controller (docs/controller.md)"};
  std::string scenario_file;
  std::string bus_url = "udp:127.0.0.1:47011,peer=127.0.0.1:47010";
  double rate_hz = 100.0;
  std::string lcm_url = firmware::kDefaultLcmUrl;
  std::string key_file;
  std::string command_state_file;
  bool goal_on_start = false;
  bool exit_when_done = false;
  double duration_s = 0.0;
  int fifo_priority = 0;
  bool lock_memory = false;
  int loop_threads = 1;
  std::string trace_csv;
  std::string replanner{mgc::planning::kDefaultReplanner};
  //! mgc-sim's valves have a 3 % deadband (docs/simulator.md); a real machine's is its valve calibration. [%]
  double valve_deadband_pct = 3.0;
  bool quiet = false;
  int watchdog_misses = 10;
  std::string black_box_file;
  double black_box_minutes = firmware::black_box::kDefaultMinutes;
  std::string site_file;
  std::int32_t machine_id = 0;
  std::string site_key_file;
  auto* scenario_opt = app.add_option("--scenario", scenario_file, "scenario file (YAML, docs/scenario-format.md)");
  auto* site_opt = app.add_option("--site", site_file,
                                  "site file (docs/scenario-format.md, Site file): drive one machine of the site, its first "
                                  "lift, as a member of the site channel (docs/site.md); instead of --scenario");
  site_opt->excludes(scenario_opt);
  app.add_option("--machine-id", machine_id, "with --site: this machine's id in the site file")->needs(site_opt);
  app.add_option("--site-key", site_key_file,
                 "with --site: the site key (32 raw bytes; default: the site file's site_key_file)")
      ->needs(site_opt);
  std::string site_lcm_url = firmware::kDefaultSiteLcmUrl;
  app.add_option("--site-lcm-url", site_lcm_url, "with --site: LCM provider of the site channel, shared by the site's controllers")
      ->capture_default_str()
      ->needs(site_opt);
  app.add_option("--bus", bus_url, "CAN bus URL: udp:HOST:PORT,peer=HOST:PORT, socketcan:IFNAME, loop:NAME (docs/protocol.md)")
      ->capture_default_str();
  app.add_option("--rate-hz", rate_hz, "control rate [Hz]")->capture_default_str()->check(CLI::Range(10.0, 1000.0));
  app.add_option("--lcm-url", lcm_url, "LCM provider for the operator feed")->capture_default_str();
  app.add_option("--key", key_file,
                 "shared command key (32 raw bytes); without it a random key is used and no goal or "
                 "acknowledgement from LCM can be accepted");
  app.add_option("--command-state", command_state_file,
                 "replay counters of accepted operator commands, kept across restarts (default: the key file "
                 "+ '.state'; none without --key, docs/operator-feed.md)");
  app.add_flag("--goal-on-start", goal_on_start, "request the scenario's goal as soon as the machine is ready (HOLD)");
  app.add_flag("--exit-when-done", exit_when_done, "exit once the goal is reached (0) or the lift ends in FAULT/ESTOP or is dropped (1)");
  app.add_option("--duration", duration_s, "stop after this many seconds (default: until SIGINT/SIGTERM)")->check(mgc::tools::nonnegative_number());
  app.add_option("--fifo-priority", fifo_priority, "SCHED_FIFO priority 1..99 when permitted (0: off)")->check(CLI::Range(0, 99));
  app.add_flag("--mlock", lock_memory, "lock the process's memory (mlockall) when permitted");
  app.add_option("--loop-threads", loop_threads,
                 "control loop threads: 2 adds a standby thread on another CPU that runs a cycle the first thread "
                 "woke too late for (docs/control-loop.md)")
      ->check(CLI::Range(1, 2))
      ->capture_default_str();
  app.add_option("--trace-csv", trace_csv, "write the controller's view at 10 Hz here (CSV; mgc-plan --trace draws it)");
  std::string replanners;
  for (auto n : mgc::planning::replanner_names()) replanners += (replanners.empty() ? "" : ", ") + std::string(n);
  app.add_option("--replanner", replanner, "re-planner: " + replanners)->capture_default_str();
  app.add_option("--valve-deadband-pct", valve_deadband_pct,
                 "the valves' deadband as calibrated, % of spool travel: commands are mapped past it (docs/protocol.md)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 50.0));
  app.add_flag("--quiet", quiet, "print only errors and the summary");
  app.add_option("--watchdog-misses", watchdog_misses, "deadline misses in a row that trip the watchdog (a stop and FAULT)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--black-box", black_box_file,
                 "record what the loop received and decided into this ring file (docs/black-box.md; mgc-replay replays it)");
  app.add_option("--black-box-minutes", black_box_minutes, "the ring holds about this many minutes of the thesis lift, and of a site member's site messages")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1440.0));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc: %s (see --help)\n", e.what());
    return 2;
  }

  if (scenario_file.empty() && site_file.empty()) {
    std::fprintf(stderr, "mgc: --scenario or --site is required (see --help)\n");
    return 2;
  }
  if (!site_file.empty() && app.count("--machine-id") == 0) {
    std::fprintf(stderr, "mgc: --machine-id is required with --site (see --help)\n");
    return 2;
  }
  planning::Scenario scenario;
  std::unique_ptr<firmware::SiteMemberConfig> site_member;
  std::unique_ptr<firmware::SiteKey> site_key;
  try {
    if (site_file.empty()) {
      scenario = planning::io::load_scenario(scenario_file);
    } else {
      site_member = std::make_unique<firmware::SiteMemberConfig>();
      site_member->site = planning::io::load_site(site_file);
      site_member->machine_id = machine_id;
      const std::size_t index = planning::io::site_machine_index(site_member->site, machine_id);
      scenario = planning::lift_scenario(site_member->site, index, 0);
      if (app.count("--bus") == 0) bus_url = site_member->site.machines[index].bus.controller_url();
    }
  } catch (const planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  if (site_member) {
    if (site_key_file.empty() && site_member->site.key_file) site_key_file = *site_member->site.key_file;
    if (site_key_file.empty()) {
      std::fprintf(stderr, "mgc: --site-key: required with --site, as %s names no site_key_file; expected a 32-byte key file\n",
                   site_file.c_str());
      return 2;
    }
    try {
      site_key = std::make_unique<firmware::SiteKey>(firmware::load_site_key(site_key_file));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mgc: --site-key: %s\n", e.what());
      return 2;
    }
  }
  if (scenario.dual_crane) {
    std::fprintf(stderr, "mgc: %s: a dual-crane lift has no bus plan; mgc drives one machine\n", scenario_file.c_str());
    return 2;
  }

  std::unique_ptr<firmware::CommandKey> key;
  try {
    if (!key_file.empty()) {
      key = std::make_unique<firmware::CommandKey>(firmware::load_command_key(key_file));
    } else {
      if (sodium_init() < 0) throw std::runtime_error("libsodium: sodium_init failed");
      std::array<std::uint8_t, firmware::kCommandKeyBytes> bytes{};
      randombytes_buf(bytes.data(), bytes.size());
      key = std::make_unique<firmware::CommandKey>(bytes);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc: --key: %s\n", e.what());
    return 2;
  }

  const hal::SteadyClock& bus_clock = hal::SteadyClock::instance();
  hal::OpenResult opened = hal::open_can_bus(bus_url, &bus_clock);
  if (!opened) {
    std::fprintf(stderr, "mgc: --bus: %s\n", opened.error.c_str());
    return 2;
  }
  (void)opened.bus->set_error_mask(hal::kCanErrBusOff | hal::kCanErrRestarted);

  try {
    firmware::ControllerConfig config;
    config.replanner = replanner;
    firmware::Controller controller(scenario, config, site_member.get());
    std::vector<double> vmax;
    for (const auto& j : scenario.machine.joints) vmax.push_back(j.max_velocity);
    std::vector<std::string> joint_names;
    for (const auto& j : scenario.machine.joints) joint_names.push_back(j.name);
    const auto period_us = static_cast<std::int64_t>(1e6 / rate_hz);
    firmware::black_box::Identity identity = firmware::black_box::identity_for(scenario, replanner, period_us, valve_deadband_pct / 100.0);
    firmware::black_box::set_plausible_ranges(identity, scenario);
    if (site_member) firmware::black_box::set_site_member(identity, site_member->site, machine_id);
    std::unique_ptr<firmware::black_box::BlackBox> black_box;
    std::unique_ptr<firmware::black_box::RecordingBus> recording_bus;
    if (!black_box_file.empty()) {
      const std::size_t site_peers = site_member ? site_member->site.machines.size() - 1 : 0;
      black_box = std::make_unique<firmware::black_box::BlackBox>(black_box_file, identity,
                                                                  firmware::black_box::ring_bytes_for_minutes(black_box_minutes, site_peers));
      recording_bus = std::make_unique<firmware::black_box::RecordingBus>(*opened.bus, *black_box);
    }
    hal::CanBus& hal_bus = recording_bus ? static_cast<hal::CanBus&>(*recording_bus) : *opened.bus;
    hal::Hal hal(hal_bus, hal::bus_plan_for(planning::to_string(scenario.machine.kind), joint_names), vmax);
    firmware::black_box::configure_hal(hal, identity);

    firmware::SnapshotQueue snapshots;
    firmware::CommandQueue commands;

    firmware::FeedConfig feed_config;
    feed_config.lcm_url = lcm_url;
    // Commands signed before this start, less the tolerated skew, are stale (docs/operator-feed.md).
    feed_config.sequence_floor = firmware::realtime_clock_us() - feed_config.max_skew_us;
    if (command_state_file.empty() && !key_file.empty()) command_state_file = key_file + ".state";
    feed_config.command_state_path = command_state_file;
    firmware::FeedPublisher feed(feed_config, *key, snapshots, commands);

    // The site channel: its own LCM instance and thread; the loop reads what it verified from
    // fixed-size inputs, filled from lock-free queues (docs/site.md, "mgc on a site").
    std::unique_ptr<firmware::SiteChannel> site_channel;
    std::unique_ptr<firmware::SiteInputs> site_inputs;
    std::int32_t site_priority = 0;
    if (site_member) {
      firmware::SiteChannelConfig channel_config;
      channel_config.lcm_url = site_lcm_url;
      channel_config.alert_lcm_url = lcm_url;
      channel_config.max_skew_us = site_member->rules.max_skew_us;
      const firmware::SiteRoster roster = firmware::make_site_roster(site_member->site);
      site_channel = std::make_unique<firmware::SiteChannel>(channel_config, *site_key, roster, machine_id);
      site_inputs = std::make_unique<firmware::SiteInputs>();
      site_priority = roster.machines[static_cast<std::size_t>(roster.index_of(machine_id))].priority;
    }
    std::int64_t next_site_state_us = 0;
    std::int64_t site_plan_posted_us = 0;
    std::uint64_t site_plan_version_posted = 0;

    firmware::MonotonicLoopClock loop_clock;
    firmware::CyclicExecutive executive(loop_clock, {period_us, watchdog_misses});

    std::vector<TraceRow> trace;
    const double trace_s = duration_s > 0.0 ? duration_s : 3600.0;
    if (!trace_csv.empty()) trace.reserve(static_cast<std::size_t>(trace_s * 10.0) + 16);
    std::uint64_t trace_dropped = 0;
    // The supervisor's transitions, drained every cycle and printed at the end (no I/O in the loop).
    std::vector<guidance::TransitionRecord> transitions;
    transitions.reserve(4096);
    std::array<guidance::TransitionRecord, guidance::TransitionLog::kCapacity> drained{};
    const std::int64_t trace_every = std::max<std::int64_t>(1, 100'000 / period_us);

    const firmware::RealtimeReport rt = firmware::enable_realtime(fifo_priority, lock_memory);
    if (!quiet) {
      std::printf("mgc: %s on %s, bus %s, %.0f Hz, re-planner %s, LCM %s%s\n", scenario.machine.name.c_str(),
                  scenario.name.c_str(), opened.bus->url().c_str(), rate_hz, replanner.c_str(), lcm_url.c_str(),
                  key_file.empty() ? " (no key: LCM goals refused)" : "");
      if (site_member) {
        std::printf("mgc: site %s: machine %d, priority %d, %zu machines, site channel on %s\n", site_member->site.name.c_str(), machine_id,
                    site_priority, site_member->site.machines.size(), site_lcm_url.c_str());
      }
      if (fifo_priority > 0 || lock_memory) {
        std::printf("mgc: real-time: fifo %s, memory lock %s%s%s\n", rt.fifo ? "yes" : "no", rt.memory_locked ? "yes" : "no",
                    rt.detail.empty() ? "" : ": ", rt.detail.c_str());
      }
      std::fflush(stdout);
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    feed.start();
    if (site_channel) site_channel->start();
    if (black_box) black_box->start();
    std::uint64_t cycles_run = 0;

    bool goal_requested = false;
    // A site member with --goal-on-start runs its whole queue of lifts, each leg requested in HOLD
    // once the previous one's goal was reached (docs/site.md, "Later lifts").
    std::unique_ptr<firmware::SiteLiftQueue> lift_queue;
    if (site_member && goal_on_start) lift_queue = std::make_unique<firmware::SiteLiftQueue>(site_member->site, machine_id);
    bool next_leg = false;
    std::int64_t goal_request_us = -1;
    std::int64_t done_us = -1;
    std::uint64_t stops_seen = 0;
    int exit_code = 0;
    bool finished = false;
    std::int64_t start_us = -1;
    std::array<bool, 64> alert_seen{};
    int alerts_raised = 0;

    // The cycle, run by whichever loop thread holds cycle_mutex when its slot comes: the first
    // thread wakes at the slot; with --loop-threads 2 a standby thread on another CPU wakes a little
    // after it and runs the cycle when the first has not (its CPU taken away by the host), so a
    // stall of one CPU does not silence the valve's commands. Returns false when the loop ends.
    std::mutex cycle_mutex;
    std::atomic<std::int64_t> published_slot_us{-1};
    std::atomic<bool> loop_over{false};
    std::uint64_t standby_cycles = 0;
    const auto run_cycle = [&]() -> bool {
      const firmware::CycleTiming timing = executive.wait_next();
      if (start_us < 0) start_us = timing.start_us;
      const hal::SensorSnapshot& s = hal.read(timing.start_us);

      firmware::ControllerCommands cmd;
      firmware::AcceptedCommand accepted;
      while (commands.try_pop(accepted)) {
        if (black_box) {
          black_box->push_command({accepted.kind, accepted.sender_id, accepted.sequence, accepted.num_joints, accepted.goal_position,
                                   accepted.alert_id, accepted.received_us});
        }
        if (accepted.kind == operator_command_t::KIND_STOP) cmd.stop = true;
        if (accepted.kind == operator_command_t::KIND_ACKNOWLEDGE) cmd.acknowledge = true;
        if (accepted.kind == operator_command_t::KIND_GOAL) {
          cmd.goal_request = true;
          cmd.goal_joints = accepted.num_joints;
          cmd.goal = accepted.goal_position;
        }
      }
      // A stop is obeyed even when the command queue was full.
      const std::uint64_t stops = feed.stops_received();
      if (stops != stops_seen) cmd.stop = true;
      stops_seen = stops;
      if (goal_on_start && controller.supervisor().state() == guidance::SupervisorState::Hold) {
        if (lift_queue) {
          if ((!goal_requested || next_leg) && lift_queue->goal(cmd.goal, cmd.goal_joints)) {
            cmd.goal_request = true;
            goal_requested = true;
            next_leg = false;
          }
        } else if (!goal_requested) {
          cmd.goal_request = true;
          goal_requested = true;
        }
      }

      const std::int64_t step_dt_us = timing.index == 0 ? period_us : timing.dt_us;
      const bool watchdog_tripped = executive.watchdog_tripped();
      if (site_channel) site_channel->take(*site_inputs, timing.start_us, black_box.get());
      const firmware::ControllerOutput out = site_channel ? controller.step(s, step_dt_us, cmd, watchdog_tripped, *site_inputs)
                                                       : controller.step(s, step_dt_us, cmd, watchdog_tripped);
      if (site_channel) {
        // The state at 20 Hz on the loop's grid, the plan when it changes and again every second.
        // A changed plan goes out with a state of the same cycle, which names it, the plan first.
        // Not before the machine's pose is known (INIT): a state of zeros is no pose, and the
        // others keep treating this machine as never heard until then.
        const bool pose_known = controller.supervisor().state() != guidance::SupervisorState::Init;
        const std::uint64_t version = controller.site_plan_version();
        bool plan_changed = false;
        if (version > 0 && (version != site_plan_version_posted || timing.start_us - site_plan_posted_us >= firmware::kSitePlanPeriod_us)) {
          if (site_channel->post_plan(controller.site_plan())) {
            plan_changed = version != site_plan_version_posted;
            site_plan_version_posted = version;
            site_plan_posted_us = timing.start_us;
          }
        }
        if (pose_known && timing.start_us >= next_site_state_us) {
          (void)site_channel->post_state(controller.site_state());
          next_site_state_us = std::max(next_site_state_us + firmware::kSiteStatePeriod_us, timing.start_us);
        } else if (pose_known && plan_changed) {
          (void)site_channel->post_state(controller.site_state());
        }
      }
      if (out.start_nodes) (void)hal.send_nmt(hal::canopen::NmtCommand::Start, 0);
      if (out.reset_watchdog) executive.reset_watchdog();
      hal.set_pilot_enabled(out.pilot_enable);
      (void)hal.write(out.velocity, timing.start_us);
      if (black_box) {
        black_box->push_cycle(firmware::black_box::make_cycle_entry(cycles_run, timing.start_us, step_dt_us, watchdog_tripped, s, cmd, out,
                                                                    controller.snapshot(), feed.refusals().total()));
      }
      ++cycles_run;

      if (out.supervisor.transitioned) {
        using R = guidance::TransitionReason;
        if (out.supervisor.reason == R::GoalRequested && goal_request_us < 0) goal_request_us = timing.start_us;
        if (out.supervisor.reason == R::GoalReached) {
          done_us = timing.start_us;
          if (lift_queue && goal_requested) {
            (void)lift_queue->reached();
            next_leg = true;
          }
          if (exit_when_done && (!lift_queue || lift_queue->done())) finished = true;
        }
        const bool dropped = out.supervisor.reason == R::RetryLimitReached || out.supervisor.reason == R::ReplanFailed ||
                             out.supervisor.reason == R::PlanFailed || out.supervisor.reason == R::PlanTimeout;
        if (exit_when_done && (out.supervisor.state == guidance::SupervisorState::Fault ||
                               out.supervisor.state == guidance::SupervisorState::Estop || dropped)) {
          finished = true;
          exit_code = 1;
        }
      }
      const std::size_t n_drained = controller.supervisor().log().drain(drained);
      for (std::size_t i = 0; i < n_drained && transitions.size() < transitions.capacity(); ++i) transitions.push_back(drained[i]);
      firmware::GuidanceSnapshot& g = controller.snapshot();
      for (int i = 0; i < g.num_alerts; ++i) {
        const auto id = static_cast<std::size_t>(g.alerts[static_cast<std::size_t>(i)].alert_id);
        if (id < alert_seen.size() && !alert_seen[id]) {
          alert_seen[id] = true;
          ++alerts_raised;
        }
      }
      const firmware::ExecutiveStats& es = executive.stats();
      g.timing.period_us = period_us;
      g.timing.cycles = es.cycles;
      g.timing.deadline_misses = es.deadline_misses;
      g.timing.skipped_periods = es.skipped_periods;
      g.timing.watchdog_trips = es.watchdog_trips;
      g.timing.compute_p99_us = es.compute.percentile_us(0.99);
      g.timing.compute_max_us = es.compute.max_us();
      g.timing.lateness_p99_us = es.lateness.percentile_us(0.99);
      g.timing.lateness_max_us = es.lateness.max_us();
      g.timing.snapshots_dropped = snapshots.dropped();
      g.bus = {s.codec.decoded,       s.codec.unknown_id,    s.codec.wrong_length, s.codec.wrong_id,
               s.codec.out_of_range,  s.codec.reserved_bits, s.codec.other,        s.codec.implausible};
      (void)snapshots.try_push(g);

      if (!trace_csv.empty() && static_cast<std::int64_t>(timing.index) % trace_every == 0) {
        if (trace.size() < trace.capacity()) {
          TraceRow row;
          row.t_us = timing.start_us - start_us;
          row.state = g.supervisor_state;
          for (int j = 0; j < controller.num_joints(); ++j) row.q[static_cast<std::size_t>(j)] = g.joint_position[static_cast<std::size_t>(j)];
          row.tool_m = g.tool_position_m;
          row.clearance_m = g.obstacle_clearance_m;
          for (std::size_t i = 0; i < std::min<std::size_t>(controller.num_trackers(), 4); ++i) {
            const firmware::ObstacleTracker& t = controller.tracker(i);
            row.obstacle[i] = {t.position_m().x(), t.position_m().y(), t.position_m().z(), t.yaw_rad()};
          }
          trace.push_back(row);
        } else {
          ++trace_dropped;
        }
      }
      executive.end_cycle();
      published_slot_us.store(executive.next_slot_us());
      if (duration_s > 0.0 && static_cast<double>(timing.start_us - start_us) * 1e-6 >= duration_s) return false;
      return !finished;
    };
    const std::vector<int> loop_cpus = loop_threads > 1 ? allowed_cpus() : std::vector<int>{};
    std::thread standby;
    if (loop_threads > 1) {
      const std::int64_t standby_delay_us = std::min<std::int64_t>(kStandbyDelay_us, period_us / 4);
      standby = std::thread([&, standby_delay_us] {
        if (loop_cpus.size() > 1) (void)pin_to_cpu(loop_cpus[1]);
        while (!loop_over.load()) {
          const std::int64_t slot = published_slot_us.load();
          if (slot < 0) {
            loop_clock.sleep_until_us(loop_clock.now_us() + period_us);
            continue;
          }
          loop_clock.sleep_until_us(slot + standby_delay_us);
          const std::lock_guard<std::mutex> lock(cycle_mutex);
          if (loop_over.load() || executive.next_slot_us() != slot) continue;
          ++standby_cycles;
          if (!run_cycle()) loop_over.store(true);
        }
      });
      if (!loop_cpus.empty()) (void)pin_to_cpu(loop_cpus[0]);
    }
    while (!g_stop.load() && !loop_over.load()) {
      const std::int64_t slot = published_slot_us.load();
      if (slot >= 0) loop_clock.sleep_until_us(slot);
      const std::lock_guard<std::mutex> lock(cycle_mutex);
      if (loop_over.load()) break;
      if (slot >= 0 && executive.next_slot_us() != slot) continue;  // the standby thread ran it
      if (!run_cycle()) loop_over.store(true);
    }
    loop_over.store(true);
    if (standby.joinable()) standby.join();
    // Leave the machine with the valves at neutral.
    const std::vector<double> zero(static_cast<std::size_t>(controller.num_joints()), 0.0);
    (void)hal.write(zero, bus_clock.now_us());
    feed.run_once(0);
    feed.stop();
    if (site_channel) site_channel->stop();
    if (black_box) black_box->close();

    if (!trace_csv.empty()) {
      std::ofstream out(trace_csv);
      if (!out) throw std::runtime_error("cannot write the trace " + trace_csv);
      out << "t_s,state";
      for (const auto& j : scenario.machine.joints) out << ',' << j.name;
      out << ",tool_x_m,tool_y_m,tool_z_m,clearance_m";
      for (std::size_t i = 0; i < std::min<std::size_t>(controller.num_trackers(), 4); ++i) {
        out << ",obstacle" << i << "_x_m,obstacle" << i << "_y_m,obstacle" << i << "_z_m,obstacle" << i << "_yaw_rad";
      }
      out << '\n';
      char buf[64];
      for (const TraceRow& row : trace) {
        std::snprintf(buf, sizeof buf, "%.3f,%s", static_cast<double>(row.t_us) * 1e-6, state_name(row.state));
        out << buf;
        for (int j = 0; j < controller.num_joints(); ++j) {
          std::snprintf(buf, sizeof buf, ",%.6f", row.q[static_cast<std::size_t>(j)]);
          out << buf;
        }
        std::snprintf(buf, sizeof buf, ",%.3f,%.3f,%.3f,%.3f", row.tool_m[0], row.tool_m[1], row.tool_m[2], row.clearance_m);
        out << buf;
        for (std::size_t i = 0; i < std::min<std::size_t>(controller.num_trackers(), 4); ++i) {
          std::snprintf(buf, sizeof buf, ",%.3f,%.3f,%.3f,%.5f", row.obstacle[i][0], row.obstacle[i][1], row.obstacle[i][2],
                        row.obstacle[i][3]);
          out << buf;
        }
        out << '\n';
      }
    }

    if (!quiet) {
      for (const guidance::TransitionRecord& r : transitions) {
        std::printf("mgc: %8.2f s  %-10s -> %-10s %s%s%s\n", static_cast<double>(r.t_us - start_us) * 1e-6, guidance::to_string(r.from),
                    guidance::to_string(r.to), guidance::to_string(r.reason), r.detail[0] != '\0' ? ": " : "", r.detail.data());
      }
    }
    const firmware::ControllerStats& st = controller.stats();
    const firmware::ExecutiveStats& es = executive.stats();
    const bool completed = lift_queue ? lift_queue->done() : st.goals_reached > 0;
    std::printf("mgc: summary: lift %s", completed ? "completed" : "not completed");
    if (completed && goal_request_us >= 0) std::printf(" in %.1f s", static_cast<double>(done_us - goal_request_us) * 1e-6);
    std::printf(", state %s (%s), %d re-plans (%d escapes, %d retreats), %d safety stops, least clearance while moving %.2f m, "
                "%d alerts, %d commands refused\n",
                guidance::to_string(controller.supervisor().state()), guidance::to_string(controller.supervisor().reason()),
                st.replans, st.escapes, st.retreats, st.safety_stops, st.min_clearance_m, alerts_raised, st.commands_rejected);
    if (lift_queue) std::printf("mgc: site lifts: %zu of %zu done\n", lift_queue->lifts_done(), lift_queue->lifts());
    if (st.approach_warnings > 0) {
      std::printf("mgc: approach warnings: %d (a moving obstacle predicted within the stop margin of the machine at rest)\n",
                  st.approach_warnings);
    }
    if (st.retreats_refused > 0 || st.retreats_in_contact > 0) {
      std::printf("mgc: retreats: %d found no way out, %d not searched (the machine in contact)\n", st.retreats_refused,
                  st.retreats_in_contact);
    }
    if (st.paths_shortened > 0) std::printf("mgc: paths: %d repaired or escape paths shortened by %d waypoints\n", st.paths_shortened, st.waypoints_removed);
    {
      std::printf("mgc: diagnostics: %s", guidance::to_string(st.plausibility_fault));
      if (st.plausibility_fault == guidance::PlausibilityFault::PoseDisagrees) {
        std::printf(" (uwb tag %d, joints", st.plausibility_joint);
        for (int j = 0; j < controller.num_joints(); ++j) {
          if ((st.pose_joints_seen >> static_cast<unsigned>(j)) & 1u) std::printf(" %s", scenario.machine.joints[static_cast<std::size_t>(j)].name.c_str());
        }
        std::printf(") at %.2f s", static_cast<double>(st.plausibility_detected_us - start_us) * 1e-6);
      } else if (st.plausibility_fault != guidance::PlausibilityFault::None) {
        std::printf(" (joint %d) at %.2f s", st.plausibility_joint, static_cast<double>(st.plausibility_detected_us - start_us) * 1e-6);
      }
      std::printf(", motion checks' peak %.0f %% of their threshold, pilot pressure cut %d times", 100.0 * st.plausibility_peak_ratio,
                  st.pilot_cuts);
      if (controller.machine_tags().num_tags() > 0) {
        std::printf(", machine tags: %" PRIu64 " fixes judged, peak %.0f %% of their threshold, stale in %" PRIu64 " cycles",
                    st.machine_tag_fixes_judged, 100.0 * st.machine_tag_peak_ratio, st.machine_tag_stale_cycles);
      }
      if (controller.inclinometer_joint() >= 0) {
        std::printf(", boom inclinometer: %" PRIu64 " samples judged, peak %.0f %% of its threshold, unavailable in %" PRIu64 " cycles",
                    st.inclinometer_judged, 100.0 * st.inclinometer_peak_ratio, st.inclinometer_unavailable_cycles);
      }
      std::printf("\n");
    }
    if (controller.has_envelope()) {
      std::printf("mgc: envelope: least distance of a monitored point to a limit while moving %.2f m, motions slowed toward a "
                  "limit in %" PRIu64 " cycles\n",
                  st.min_envelope_m, st.envelope_cut_cycles);
    }
    std::printf("mgc: loop: %" PRIu64 " cycles at %" PRId64 " us, compute p99 %" PRId64 " us max %" PRId64
                " us, wake-up lateness p99 %" PRId64 " us max %" PRId64 " us, %" PRIu64 " deadline misses, %" PRIu64
                " watchdog trips, %" PRIu64 " snapshots dropped%s%s\n",
                es.cycles, period_us, es.compute.percentile_us(0.99), es.compute.max_us(), es.lateness.percentile_us(0.99),
                es.lateness.max_us(), es.deadline_misses, es.watchdog_trips, snapshots.dropped(),
                trace_dropped > 0 ? ", trace full" : "",
                loop_threads > 1 ? (", " + std::to_string(standby_cycles) + " cycles run by the standby thread").c_str() : "");
    if (black_box) {
      const firmware::black_box::WriterStats& bs = black_box->stats();
      char site_text[128] = "";
      if (site_channel) {
        std::snprintf(site_text, sizeof site_text, " (%" PRIu64 " of them site plans), %" PRIu64 " site messages taken",
                      black_box->site_plans_dropped(), black_box->site_taken());
      }
      const double run_s = std::max(1e-6, static_cast<double>(es.cycles) * static_cast<double>(period_us) * 1e-6);
      std::printf("mgc: black box: %s, %zu blocks of %zu KiB, %" PRIu64 " records, %" PRIu64 " bytes (%.0f B/s), %" PRIu64
                  " flushes (write + fdatasync) mean %.0f us max %" PRId64 " us, %" PRIu64 " records dropped%s%s\n",
                  black_box_file.c_str(), black_box->num_blocks(), firmware::black_box::kBlockBytes / 1024, bs.entries_written,
                  bs.bytes_written, static_cast<double>(bs.bytes_written) / run_s, bs.flushes,
                  bs.flushes > 0 ? static_cast<double>(bs.flush_total_us) / static_cast<double>(bs.flushes) : 0.0, bs.flush_max_us,
                  black_box->dropped(), site_text, black_box->io_error() != 0 ? ", write errors" : "");
    }
    const firmware::RefusalCounter& refusals = feed.refusals();
    std::printf("mgc: operator commands on LCM: %" PRIu64 " accepted, %" PRIu64 " refused", feed.counters().commands_accepted.load(),
                refusals.total());
    const char* sep = " (";
    for (std::int8_t r = 0; r < static_cast<std::int8_t>(firmware::RefusalCounter::kReasons); ++r) {
      if (refusals.count(r) == 0) continue;
      std::printf("%s%s %" PRIu64, sep, firmware::command_reason_name(r), refusals.count(r));
      sep = ", ";
    }
    std::printf("%s, %" PRIu64 " refusal alerts\n", sep[0] == ',' ? ")" : "", refusals.alerts());
    if (site_channel) {
      const firmware::SiteChannelCounters& lc = site_channel->counters();
      const firmware::SiteVerifier& v = site_channel->verifier();
      std::printf("mgc: site: machine %d (priority %d) of %s: %" PRIu64 " states and %" PRIu64 " plans published, %" PRIu64
                  " messages accepted, %" PRIu64 " refused",
                  machine_id, site_priority, site_member->site.name.c_str(), lc.states_published.load(), lc.plans_published.load(),
                  v.count(firmware::SiteReason::Accepted), v.refused());
      const char* site_sep = " (";
      for (std::size_t r = 1; r < firmware::kNumSiteReasons; ++r) {
        const auto reason = static_cast<firmware::SiteReason>(r);
        if (v.count(reason) == 0) continue;
        std::printf("%s%s %" PRIu64, site_sep, firmware::site_reason_name(reason), v.count(reason));
        site_sep = ", ";
      }
      std::printf("%s, %" PRIu64 " refusal alerts, %" PRIu64 " own echoes, %" PRIu64 " queue drops, %" PRIu64 " publish errors\n",
                  site_sep[0] == ',' ? ")" : "", lc.refusal_alerts.load(), lc.own_echoes.load(), site_channel->queue_drops(),
                  lc.publish_errors.load());
      std::printf("mgc: site rules: %d stops (%" PRIu64 " cycles), slowed %" PRIu64 " cycles, %d re-plans for a higher-priority machine, "
                  "%d stale alerts, least gap %.2f m\n",
                  st.site_stops, st.site_stop_cycles, st.site_slow_cycles, st.site_replans, st.site_stale_alerts, st.site_min_gap_m);
    }
    const hal::CodecCounters& codec = hal.snapshot().codec;
    std::printf("mgc: bus: %" PRIu64 " frames decoded, %" PRIu64 " unknown COB-ids, %" PRIu64 " malformed (wrong length %" PRIu64
                ", wrong id %" PRIu64 ", out of range %" PRIu64 ", reserved bits %" PRIu64 ", other %" PRIu64 "), %" PRIu64
                " implausible encoder values\n",
                codec.decoded, codec.unknown_id, codec.malformed(), codec.wrong_length, codec.wrong_id, codec.out_of_range,
                codec.reserved_bits, codec.other, codec.implausible);
    if (!completed && exit_when_done) exit_code = 1;
    return exit_code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc: %s\n", e.what());
    return 2;
  }
}
