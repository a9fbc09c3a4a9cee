// SPDX-License-Identifier: Apache-2.0
// The `loop` suite of mgc-bench: what the controller's whole cycle costs (Hal::read,
// Controller::step, Hal::write, as the mgc binary runs them) over lifts back and forth on the
// thesis site with the second crane swinging into the first, how long the loop takes from the UWB
// frame that shows the intruder to the stop command on the bus, the OS's wake-up lateness of the
// cyclic executive, and how one lift ends over a sweep of the second crane's timing (stop and
// repair, escape, retreat, contact). The controller runs in-process against the simulated crane
// on a manual clock, so the simulator's own cost is outside every timed call. All times are on the
// steady clock of this machine; compare figures within one run, not across runs.

#include "loop_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "timing_report.hpp"
#include "mgc/firmware/controller.hpp"
#include "mgc/firmware/cyclic_executive.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/sim/simulator.hpp"
#include "mgc/sim/stepped_rig.hpp"

namespace mgc::bench {

namespace {

using guidance::SupervisorState;
using guidance::TransitionReason;

constexpr const char* kScenario = "thesis-steel-frame.yaml";
//! The same lift with a working envelope (a wall and a ceiling): the envelope's share of the cycle.
constexpr const char* kEnvelopeScenario = "thesis-steel-frame-road.yaml";
constexpr std::int64_t kPhysicsUs = sim::SteppedRig::kPhysicsUs;  //!< the simulator's step, as mgc-sim runs it
constexpr std::int64_t kSimZeroUs = sim::SteppedRig::kSimZeroUs;  //!< clock time of simulation time 0
constexpr double kComputeOffsetS = 10.0;          //!< crane 2 swings into the first lift's west route
constexpr double kReactionOffsetFirstS = 8.0;     //!< reaction runs: offsets spread over 8..12 s
constexpr double kReactionOffsetLastS = 12.0;
constexpr double kReactionLimitS = 150.0;         //!< a reaction run without a stop ends here [s]

//! This thread's CPU time: what the cycle cost without the time the OS gave to other processes.
std::int64_t thread_cpu_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::int64_t now_ns() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double sim_s(std::int64_t t_us) { return static_cast<double>(t_us - kSimZeroUs) * 1e-6; }

std::string stats_row(const std::string& what, const LatencyStats& s) {
  return fmt("| %s | %zu | %.1f | %.1f | %.1f | %.1f | %.1f |\n", what.c_str(), s.n, s.median, s.p95, s.p99, s.p999, s.max);
}

const char* kStatsHeader =
    "| cycles | n | median µs | p95 µs | p99 µs | p99.9 µs | max µs |\n|---|---|---|---|---|---|---|\n";

//! One timed cycle: the three calls the mgc binary makes, on the steady clock.
struct Cycle {
  std::int64_t t_us = 0;            //!< the read time on the bus clock [µs]
  double read_us = 0.0;             //!< Hal::read [µs]
  double step_us = 0.0;             //!< Controller::step (and the NMT start when it asks) [µs]
  double write_us = 0.0;            //!< Hal::write [µs]
  double cpu_us = 0.0;              //!< this thread's CPU time over the three calls [µs]
  [[nodiscard]] double total_us() const { return read_us + step_us + write_us; }
};

//! The controller as the suite runs it: the thesis's DRRT, whose path takes the west route that
//! crane 2's script swings across, as the controller's intrusion tests do, so that the figures
//! stay comparable with the thesis's re-planning.
firmware::ControllerConfig west_route_config() {
  firmware::ControllerConfig c;
  c.replanner = "drrt";
  return c;
}

//! The controller on sim::SteppedRig: its Hal and the simulated crane on one in-process loop bus
//! with a manual clock. The rig's own run() reads, calls back and writes in one call; the suite
//! times each of the three, so it steps the rig itself, the cycle every cycle_us before the
//! simulator's step of that millisecond, as SteppedRig::run does.
class Rig {
 public:
  Rig(const planning::Scenario& scenario, sim::SimConfig config, std::int64_t cycle_us)
      : stepped(scenario, std::move(config), bus_name()), sim(stepped.sim.get()), hal(stepped.hal.get()) {
    stepped.cycle_us = cycle_us;
    stepped.calibrate_valves();
    controller = std::make_unique<firmware::Controller>(stepped.scenario, west_route_config());
  }

  //! Runs until on_cycle returns false or the clock reaches end_us. commands() gives the cycle's
  //! operator commands before the timed calls; on_cycle(cycle, snapshot, output) sees each cycle.
  template <class Commands, class OnCycle>
  void run(std::int64_t end_us, Commands&& commands, OnCycle&& on_cycle) {
    std::int64_t& t_us = stepped.t_us;
    const std::int64_t cycle_us = stepped.cycle_us;
    while (t_us < end_us) {
      t_us += kPhysicsUs;
      stepped.clock.set_us(t_us);
      if (t_us % cycle_us == 0) {
        const firmware::ControllerCommands cmd = commands(t_us);
        Cycle c;
        c.t_us = t_us;
        const std::int64_t cpu0 = thread_cpu_ns();
        const std::int64_t t0 = now_ns();
        const hal::SensorSnapshot& s = hal->read(t_us);
        const std::int64_t t1 = now_ns();
        const firmware::ControllerOutput out = controller->step(s, cycle_us, cmd, false);
        if (out.start_nodes) (void)hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
        const std::int64_t t2 = now_ns();
        hal->set_pilot_enabled(out.pilot_enable);
        (void)hal->write(out.velocity, t_us);
        const std::int64_t t3 = now_ns();
        c.cpu_us = static_cast<double>(thread_cpu_ns() - cpu0) * 1e-3;
        c.read_us = static_cast<double>(t1 - t0) * 1e-3;
        c.step_us = static_cast<double>(t2 - t1) * 1e-3;
        c.write_us = static_cast<double>(t3 - t2) * 1e-3;
        if (!on_cycle(c, s, out)) return;
      }
      sim->step(t_us);
    }
  }

  sim::SteppedRig stepped;
  sim::Simulator* sim;
  hal::Hal* hal;
  std::unique_ptr<firmware::Controller> controller;

 private:
  //! Each rig on a loop bus of its own.
  static std::string bus_name() {
    static int serial = 0;
    return "bench-loop-" + std::to_string(serial++);
  }
};

// --- 1. Cycle compute time --------------------------------------------------------------------

enum class StateClass : std::uint8_t { Executing, Planning, Other };

StateClass classify(SupervisorState s) {
  if (s == SupervisorState::Executing) return StateClass::Executing;
  if (s == SupervisorState::Planning || s == SupervisorState::Replanning) return StateClass::Planning;
  return StateClass::Other;
}

struct CycleRecord {
  Cycle cycle;
  SupervisorState state = SupervisorState::Init;  //!< after the step: the state the cycle worked in
  bool planner_slice = false;
  int stop_samples = 0;      //!< configurations the stop check took
};

struct ComputeResult {
  std::vector<CycleRecord> cycles;
  int lifts_completed = 0;
  int goal_requests = 0;
  int acknowledgements = 0;
  firmware::ControllerStats stats{};
  std::vector<double> lift_s;            //!< each completed lift, goal request accepted to goal reached [s]
  std::vector<std::string> transitions;  //!< the first few, for the report
  double wall_s = 0.0;
};

ComputeResult measure_compute(const planning::Scenario& scenario, int cycles, std::uint64_t seed) {
  sim::SimConfig config;  // the simulator's defaults: UWB noise and dropouts, encoder noise
  config.seed = seed;
  config.scenario_time_offset_s = kComputeOffsetS;
  Rig rig(scenario, std::move(config), 10'000);
  firmware::Controller& controller = *rig.controller;
  const int n = controller.num_joints();

  ComputeResult r;
  r.cycles.reserve(static_cast<std::size_t>(cycles));
  bool to_goal = true;
  std::int64_t last_request_us = -1;
  std::int64_t last_ack_us = -1;
  std::uint64_t planner_cycles = 0;
  std::int64_t lift_start_us = -1;
  const auto commands = [&](std::int64_t t_us) {
    firmware::ControllerCommands c;
    const SupervisorState state = controller.supervisor().state();
    // A lift that ended in HOLD: the other end. A request the supervisor did not take (a retry
    // scheduled, a plan that failed) is repeated every 2 s.
    if (state == SupervisorState::Hold && (last_request_us < 0 || t_us - last_request_us >= 2'000'000)) {
      const planning::JointVector& target = to_goal ? scenario.goal : scenario.start;
      c.goal_request = true;
      c.goal_joints = n;
      for (int j = 0; j < n; ++j) c.goal[static_cast<std::size_t>(j)] = target[j];
      last_request_us = t_us;
      ++r.goal_requests;
    }
    if ((state == SupervisorState::Fault || state == SupervisorState::Estop) && (last_ack_us < 0 || t_us - last_ack_us >= 1'000'000)) {
      c.acknowledge = true;
      last_ack_us = t_us;
      ++r.acknowledgements;
    }
    return c;
  };
  const std::int64_t wall0 = now_ns();
  rig.run(
      std::numeric_limits<std::int64_t>::max(), commands, [&](const Cycle& c, const hal::SensorSnapshot& /*s*/, const firmware::ControllerOutput& out) {
        CycleRecord rec;
        rec.cycle = c;
        rec.state = out.supervisor.state;
        rec.planner_slice = controller.stats().planner_cycles != planner_cycles;
        planner_cycles = controller.stats().planner_cycles;
        rec.stop_samples = controller.stop_check().samples;
        r.cycles.push_back(rec);
        if (out.supervisor.transitioned) {
          if (r.transitions.size() < 40) {
            r.transitions.push_back(fmt("%.2f s %s (%s)", sim_s(c.t_us), guidance::to_string(out.supervisor.state),
                                        guidance::to_string(out.supervisor.reason)));
          }
          if (out.supervisor.reason == TransitionReason::GoalRequested) lift_start_us = c.t_us;
          if (out.supervisor.reason == TransitionReason::GoalReached) {
            if (lift_start_us >= 0) r.lift_s.push_back(static_cast<double>(c.t_us - lift_start_us) * 1e-6);
            lift_start_us = -1;
            ++r.lifts_completed;
            to_goal = !to_goal;
            last_request_us = -1;
          }
        }
        return static_cast<int>(r.cycles.size()) < cycles;
      });
  r.wall_s = static_cast<double>(now_ns() - wall0) * 1e-9;
  r.stats = controller.stats();
  return r;
}

//! A run's operator: the scenario's goal requested once, in HOLD.
auto goal_once(firmware::Controller& controller, bool& requested) {
  return [&controller, &requested](std::int64_t /*t_us*/) {
    firmware::ControllerCommands c;
    if (!requested && controller.supervisor().state() == SupervisorState::Hold) {
      c.goal_request = true;
      requested = true;
    }
    return c;
  };
}

// --- 2. Reaction time -------------------------------------------------------------------------

struct Reaction {
  double offset_s = 0.0;
  std::uint64_t seed = 0;
  bool stopped = false;
  bool goal_reached = false;     //!< the lift completed without a safety stop
  double stop_sim_s = 0.0;       //!< simulation time of the stop cycle [s]
  double frame_age_us = 0.0;     //!< the stop cycle's read time - the newest tag fix's receive time [µs]
  double compute_us = 0.0;       //!< the stop cycle's read -> write [µs]
  double reaction_us = 0.0;      //!< frame_age_us + compute_us [µs]
  bool fix_this_cycle = false;   //!< the newest fix arrived for this cycle's read
  //! The first frame showing the intrusion: the oldest of the frames (encoder samples and tag
  //! fixes) that arrived for the stop cycle's read. The cycle before, with every older frame, did
  //! not stop, so the intrusion was first shown by frames of this read; of them the oldest is the
  //! conservative choice. The stop cycle's read time - its receive time [µs]
  double first_frame_age_us = 0.0;
  double first_reaction_us = 0.0;  //!< first_frame_age_us + compute_us [µs]
  bool first_frame_is_fix = false; //!< that oldest new frame is a tag fix (else an encoder sample)
  bool new_frames = false;         //!< any frame arrived for the stop cycle's read
  double clearance_m = 0.0;      //!< the stop check's least clearance in the stop cycle [m]
  double obstacle_speed_m_s = 0.0;
};

//! One intrusion run: the scenario's goal requested once at HOLD; ends at the first
//! EXECUTING -> STOPPING for SafetyStopZone, at the goal, or at kReactionLimitS.
Reaction measure_reaction(const planning::Scenario& scenario, std::int64_t cycle_us, double uwb_rate_hz, double offset_s,
                          std::uint64_t seed) {
  sim::SimConfig config;
  config.seed = seed;
  config.uwb.rate_hz = uwb_rate_hz;
  config.scenario_time_offset_s = offset_s;
  Rig rig(scenario, std::move(config), cycle_us);
  firmware::Controller& controller = *rig.controller;
  Reaction r;
  r.offset_s = offset_s;
  r.seed = seed;
  bool requested = false;
  rig.run(
      kSimZeroUs + static_cast<std::int64_t>(kReactionLimitS * 1e6),
      goal_once(controller, requested),
      [&](const Cycle& c, const hal::SensorSnapshot& s, const firmware::ControllerOutput& out) {
        if (!out.supervisor.transitioned) return true;
        if (out.supervisor.reason == TransitionReason::GoalReached) {
          r.goal_reached = true;
          return false;
        }
        if (out.supervisor.state != SupervisorState::Stopping || out.supervisor.reason != TransitionReason::SafetyStopZone) return true;
        std::int64_t newest_us = 0;
        bool updated = false;
        for (std::size_t i = 0; i < s.num_tags; ++i) {
          const hal::TagReading& tag = s.tags[i];
          if (tag.valid && tag.t_us > newest_us) {
            newest_us = tag.t_us;
            updated = tag.updated;
          }
        }
        std::int64_t oldest_new_us = std::numeric_limits<std::int64_t>::max();
        for (std::size_t i = 0; i < s.num_tags; ++i) {
          const hal::TagReading& tag = s.tags[i];
          if (tag.updated && tag.t_us < oldest_new_us) {
            oldest_new_us = tag.t_us;
            r.first_frame_is_fix = true;
          }
        }
        for (std::size_t j = 0; j < s.num_joints; ++j) {
          const hal::JointReading& joint = s.joints[j];
          if (joint.updated && joint.t_us < oldest_new_us) {
            oldest_new_us = joint.t_us;
            r.first_frame_is_fix = false;
          }
        }
        r.stopped = true;
        r.stop_sim_s = sim_s(c.t_us);
        r.frame_age_us = static_cast<double>(c.t_us - newest_us);
        r.compute_us = c.total_us();
        r.reaction_us = r.frame_age_us + r.compute_us;
        r.fix_this_cycle = updated;
        r.new_frames = oldest_new_us != std::numeric_limits<std::int64_t>::max();
        // Without a new frame nothing the simulator sent shows the intrusion first in this cycle:
        // count the newest fix, as the UWB figure does.
        r.first_frame_age_us = r.new_frames ? static_cast<double>(c.t_us - oldest_new_us) : r.frame_age_us;
        r.first_reaction_us = r.first_frame_age_us + r.compute_us;
        r.clearance_m = controller.stop_check().min_clearance_m;
        r.obstacle_speed_m_s = controller.obstacle_speed_m_s();
        return false;
      });
  return r;
}

// --- 3. Live wake-up lateness -----------------------------------------------------------------

struct Live {
  std::int64_t period_us = 0;
  double seconds = 0.0;
  firmware::ExecutiveStats stats{};
};

Live measure_live(std::int64_t period_us, double seconds) {
  firmware::MonotonicLoopClock clock;
  firmware::CyclicExecutive executive(clock, {period_us, 3});
  Live live;
  live.period_us = period_us;
  live.seconds = seconds;
  std::int64_t start_us = -1;
  for (;;) {
    const firmware::CycleTiming timing = executive.wait_next();
    if (start_us < 0) start_us = timing.start_us;
    executive.end_cycle();
    if (static_cast<double>(timing.start_us - start_us) * 1e-6 >= seconds) break;
  }
  live.stats = executive.stats();
  return live;
}

// --- 4. Intrusion timing sweep ----------------------------------------------------------------

//! One lift with crane 2's script shifted by offset_s: how it ended and what it took.
struct SweepRun {
  double offset_s = 0.0;
  bool goal_reached = false;
  bool held_in_contact = false;      //!< HOLD after StartBlocked (retrying or out of retries), touching crane 2 (below)
  SupervisorState state = SupervisorState::Init;  //!< at the end of the run
  TransitionReason reason = TransitionReason::None;
  bool retry_pending = false;
  TransitionReason hold_cause = TransitionReason::None;  //!< the last transition into HOLD other than RetryLimitReached
  double end_s = 0.0;                //!< simulation time at the end of the run [s]
  double lift_s = 0.0;               //!< goal request accepted -> goal reached [s]
  firmware::ControllerStats stats{};
  double min_true_clearance_m = std::numeric_limits<double>::infinity();  //!< to the site and crane 2 [m]
  double min_true_dynamic_m = std::numeric_limits<double>::infinity();    //!< to crane 2 alone [m]
  double end_true_dynamic_m = std::numeric_limits<double>::infinity();    //!< to crane 2 at the last sample [m]
  //! To crane 2 in the cycle of the last HOLD for StartBlocked (NaN: none) [m]
  double blocked_true_dynamic_m = std::numeric_limits<double>::quiet_NaN();
  //! When the approach warning first rose and what it predicted then; when the true crane first
  //! touched crane 2 (true clearance under 1 mm). NaN: never. [s]
  double approach_at_s = std::numeric_limits<double>::quiet_NaN();
  double approach_said_s = std::numeric_limits<double>::quiet_NaN();
  double contact_at_s = std::numeric_limits<double>::quiet_NaN();
  double compute_max_us = 0.0;       //!< the slowest cycle's read -> write (steady clock) [µs]
  double compute_max_at_s = 0.0;     //!< its simulation time [s]
  SupervisorState compute_max_state = SupervisorState::Init;  //!< the state its step ended in
  double cpu_max_us = 0.0;           //!< the most thread CPU time a cycle took over the same calls [µs]
  double cpu_max_at_s = 0.0;         //!< its simulation time [s]
  SupervisorState cpu_max_state = SupervisorState::Init;
  std::string transitions;           //!< the supervisor's transitions, "t s STATE (Reason); ..."
  double wall_s = 0.0;
};

//! The scenario's goal requested once in HOLD with quiet sensors (no UWB noise or dropouts, no
//! encoder noise, as tests/sim/sim_rig.hpp's quiet_config()); runs until the goal is reached or
//! limit_s of simulated time. The true crane's clearance to the true site and crane 2 is measured
//! every 50 ms of simulated time in a world without dilation, as tests/firmware/controller_test.cpp
//! does.
SweepRun measure_sweep_run(const planning::Scenario& scenario, double offset_s, double limit_s) {
  sim::SimConfig config;
  config.encoder_noise_counts = 0.0;
  config.uwb.noise_sigma_m = 0.0;
  config.uwb.dropout_probability = 0.0;
  config.scenario_time_offset_s = offset_s;
  constexpr std::int64_t kCycleUs = 10'000;
  Rig rig(scenario, std::move(config), kCycleUs);
  firmware::Controller& controller = *rig.controller;
  const int n = controller.num_joints();
  planning::Scenario bare = scenario;
  bare.planner.dilation_m = 0.0;
  const std::unique_ptr<planning::MachineModel> truth_model = planning::build_model(bare);
  const std::unique_ptr<planning::CollisionWorld> truth_world = planning::build_world(bare, *truth_model);
  planning::JointVector q(n);
  //! The true crane's clearance to the true site and crane 2, and to crane 2 alone. [m]
  const auto true_clearance = [&]() {
    const auto& truth = rig.sim->truth();
    for (int j = 0; j < n; ++j) q[j] = truth.position[static_cast<std::size_t>(j)];
    for (std::size_t d = 0; d < scenario.dynamic_obstacles.size(); ++d) {
      truth_world->set_dynamic_pose(static_cast<int>(d), rig.sim->obstacle_pose(d));
    }
    const double all_m = truth_world->clearance(q).distance_m;
    const double dynamic_m =
        scenario.dynamic_obstacles.empty()
            ? std::numeric_limits<double>::infinity()
            : truth_world->clearance(q, planning::CollisionWorld::Bodies::All, planning::CollisionWorld::Obstacles::Dynamic).distance_m;
    return std::pair<double, double>{all_m, dynamic_m};
  };

  SweepRun r;
  r.offset_s = offset_s;
  bool requested = false;
  std::int64_t lift_start_us = -1;
  const std::int64_t wall0 = now_ns();
  rig.run(
      kSimZeroUs + static_cast<std::int64_t>(limit_s * 1e6),
      goal_once(controller, requested),
      [&](const Cycle& c, const hal::SensorSnapshot& s, const firmware::ControllerOutput& out) {
        if (c.total_us() > r.compute_max_us) {
          r.compute_max_us = c.total_us();
          r.compute_max_at_s = sim_s(c.t_us);
          r.compute_max_state = out.supervisor.state;
        }
        if (c.cpu_us > r.cpu_max_us) {
          r.cpu_max_us = c.cpu_us;
          r.cpu_max_at_s = sim_s(c.t_us);
          r.cpu_max_state = out.supervisor.state;
        }
        r.end_s = sim_s(c.t_us);
        if (s.cycle % static_cast<std::uint64_t>(50'000 / kCycleUs) == 0) {
          const auto [all_m, dynamic_m] = true_clearance();
          r.min_true_clearance_m = std::min(r.min_true_clearance_m, all_m);
          r.end_true_dynamic_m = dynamic_m;
          r.min_true_dynamic_m = std::min(r.min_true_dynamic_m, dynamic_m);
          if (dynamic_m < 1e-3 && std::isnan(r.contact_at_s)) r.contact_at_s = sim_s(c.t_us);
        }
        if (std::isfinite(controller.approach_s()) && std::isnan(r.approach_at_s)) {
          r.approach_at_s = sim_s(c.t_us);
          r.approach_said_s = controller.approach_s();
        }
        if (!out.supervisor.transitioned) return true;
        r.transitions += fmt("%s%.2f s %s (%s)", r.transitions.empty() ? "" : "; ", sim_s(c.t_us), guidance::to_string(out.supervisor.state),
                             guidance::to_string(out.supervisor.reason));
        if (out.supervisor.state == SupervisorState::Hold && out.supervisor.reason != TransitionReason::RetryLimitReached) {
          r.hold_cause = out.supervisor.reason;
          if (r.hold_cause == TransitionReason::StartBlocked) r.blocked_true_dynamic_m = true_clearance().second;
        }
        if (out.supervisor.reason == TransitionReason::GoalRequested) lift_start_us = c.t_us;
        if (out.supervisor.reason == TransitionReason::GoalReached) {
          r.goal_reached = true;
          if (lift_start_us >= 0) r.lift_s = static_cast<double>(c.t_us - lift_start_us) * 1e-6;
          return false;
        }
        return true;
      });
  r.wall_s = static_cast<double>(now_ns() - wall0) * 1e-9;
  r.stats = controller.stats();
  r.state = controller.supervisor().state();
  r.reason = controller.supervisor().reason();
  r.retry_pending = controller.supervisor().retry_pending();
  // Contact as the controller means it (docs/controller.md §Retreat): its bodies, grown by the
  // scenario's dilation, touch crane 2; measured here on the true poses when the repair was last
  // refused. The supervisor retries the blocked repair every second, 30 times, then drops the goal
  // (RetryLimitReached) and holds.
  r.held_in_contact = !r.goal_reached && r.state == SupervisorState::Hold && r.hold_cause == TransitionReason::StartBlocked &&
                      (r.retry_pending || r.reason == TransitionReason::RetryLimitReached) &&
                      r.blocked_true_dynamic_m <= scenario.planner.dilation_m;
  return r;
}

std::string sweep_outcome(const SweepRun& r) {
  if (r.goal_reached) return "goal reached";
  if (r.held_in_contact) {
    return r.retry_pending ? std::string("holding in contact, retry pending")
                           : fmt("holding in contact, retries done (%s, goal dropped)", guidance::to_string(r.reason));
  }
  return fmt("other: %s (%s)%s", guidance::to_string(r.state), guidance::to_string(r.reason), r.retry_pending ? ", retry pending" : "");
}

}  // namespace

int run_loop_suite(const LoopBenchOptions& options) {
  try {
    const planning::Scenario scenario =
        planning::io::load_scenario((std::filesystem::path(options.scenarios_dir) / kScenario).string());
    const std::int64_t wall_start_ns = now_ns();
    const std::string load_before = load_average();
    std::string md = "### loop\n\nThe controller's cycle on `" + std::string(kScenario) +
                     "` in-process against the simulated crane (loop bus, manual clock: the simulator's cost is not in any figure). `--loop-cycles " +
                     std::to_string(options.cycles) + " --reaction-runs " + std::to_string(options.reaction_runs) +
                     fmt(" --loop-seconds %g --seed %llu --sweep-first %g --sweep-last %g --sweep-step %g --sweep-limit %g`.\n\n",
                         options.loop_seconds, static_cast<unsigned long long>(options.first_seed), options.sweep_first_s,
                         options.sweep_last_s, options.sweep_step_s, options.sweep_limit_s);
    std::string csv = "index,t_s,state,planner_slice,stop_samples,read_us,step_us,write_us,total_us,cpu_us\n";
    std::string reaction_csv = "rate_hz,uwb_rate_hz,offset_s,seed,stopped,goal_reached,stop_sim_s,frame_age_us,compute_us,reaction_us,fix_this_cycle,first_frame_age_us,first_reaction_us,first_frame_is_fix,new_frames,clearance_m,obstacle_speed_m_s\n";

    // 1. Cycle compute time.
    std::fprintf(stderr, "[loop] cycle compute time, %d cycles\n", options.cycles);
    const ComputeResult cr = measure_compute(scenario, options.cycles, options.first_seed + 1);
    // Stop-check samples bands of the EXECUTING cycles: the check's cost grows with its samples,
    // which it takes finely only near an obstacle (within the warning margin).
    struct Band {
      int lo, hi;
      const char* name;
      std::vector<double> wall, cpu;
    };
    std::vector<Band> bands = {{0, 2, "1-2", {}, {}}, {3, 4, "3-4", {}, {}}, {5, 9, "5-9", {}, {}}, {10, 19, "10-19", {}, {}},
                               {20, 1 << 30, "≥ 20", {}, {}}};
    std::vector<double> all, executing, planning_cycles, other, slice, no_slice, read, step, write;
    std::vector<double> cpu_all, cpu_executing, cpu_planning, cpu_other, preempted_by;
    std::size_t preempted = 0;
    for (std::size_t i = 0; i < cr.cycles.size(); ++i) {
      const CycleRecord& rec = cr.cycles[i];
      const double total = rec.cycle.total_us();
      const double cpu = rec.cycle.cpu_us;
      all.push_back(total);
      cpu_all.push_back(cpu);
      read.push_back(rec.cycle.read_us);
      step.push_back(rec.cycle.step_us);
      write.push_back(rec.cycle.write_us);
      if (total - cpu > 200.0) {
        ++preempted;
        preempted_by.push_back(total - cpu);
      }
      switch (classify(rec.state)) {
        case StateClass::Executing:
          executing.push_back(total);
          cpu_executing.push_back(cpu);
          for (Band& b : bands) {
            if (rec.stop_samples >= b.lo && rec.stop_samples <= b.hi) {
              b.wall.push_back(total);
              b.cpu.push_back(cpu);
            }
          }
          break;
        case StateClass::Planning:
          planning_cycles.push_back(total);
          cpu_planning.push_back(cpu);
          break;
        case StateClass::Other:
          other.push_back(total);
          cpu_other.push_back(cpu);
          break;
      }
      (rec.planner_slice ? slice : no_slice).push_back(total);
      csv += fmt("%zu,%.3f,%s,%d,%d,%.2f,%.2f,%.2f,%.2f,%.2f\n", i, sim_s(rec.cycle.t_us), guidance::to_string(rec.state),
                 rec.planner_slice ? 1 : 0, rec.stop_samples, rec.cycle.read_us, rec.cycle.step_us, rec.cycle.write_us, total,
                 cpu);
    }
    const LatencyStats s_all = latency_stats(all);
    const LatencyStats s_cpu = latency_stats(cpu_all);
    md += "#### Cycle compute time: Hal::read + Controller::step + Hal::write at 100 Hz\n\n";
    std::string lifts;
    for (std::size_t i = 0; i < cr.lift_s.size(); ++i) lifts += fmt("%s%.0f s", i ? ", " : "", cr.lift_s[i]);
    md += fmt("%zu cycles (%.0f s of simulated time, %.1f s wall), lifts back and forth between the scenario's start and goal, "
              "crane 2 swinging into the first (scenario time offset %.0f s), the simulator's default UWB and encoder noise (seed %llu): "
              "%d lifts completed (%s from request to goal), %d plans, %d re-plans (%d escapes), %d safety stops, %d goal requests, "
              "%d acknowledgements, %llu cycles ran a planner slice. Wall time is steady_clock around the three calls, as asked of "
              "the loop; thread CPU time (CLOCK_THREAD_CPUTIME_ID) over the same calls leaves out what the OS gave to other "
              "processes meanwhile.\n\n",
              cr.cycles.size(), static_cast<double>(cr.cycles.size()) * 0.01, cr.wall_s, kComputeOffsetS,
              static_cast<unsigned long long>(options.first_seed + 1), cr.lifts_completed, lifts.empty() ? "none" : lifts.c_str(),
              cr.stats.plans, cr.stats.replans, cr.stats.escapes, cr.stats.safety_stops, cr.goal_requests, cr.acknowledgements,
              static_cast<unsigned long long>(cr.stats.planner_cycles));
    md += "Wall time (steady_clock):\n\n";
    md += kStatsHeader;
    md += stats_row("all", s_all);
    md += stats_row("EXECUTING", latency_stats(executing));
    md += stats_row("PLANNING / REPLANNING", latency_stats(planning_cycles));
    md += stats_row("other (INIT, HOLD, STOPPING, FAULT, ESTOP)", latency_stats(other));
    md += stats_row("with a planner slice", latency_stats(slice));
    md += stats_row("without a planner slice", latency_stats(no_slice));
    for (const Band& b : bands) md += stats_row(std::string("EXECUTING, stop check took ") + b.name + " samples", latency_stats(b.wall));
    md += stats_row("part: Hal::read", latency_stats(read));
    md += stats_row("part: Controller::step", latency_stats(step));
    md += stats_row("part: Hal::write", latency_stats(write));
    md += "\nThread CPU time over the same calls:\n\n";
    md += kStatsHeader;
    md += stats_row("all", s_cpu);
    md += stats_row("EXECUTING", latency_stats(cpu_executing));
    md += stats_row("PLANNING / REPLANNING", latency_stats(cpu_planning));
    md += stats_row("other (INIT, HOLD, STOPPING, FAULT, ESTOP)", latency_stats(cpu_other));
    for (const Band& b : bands) md += stats_row(std::string("EXECUTING, stop check took ") + b.name + " samples", latency_stats(b.cpu));
    md += fmt("\n%zu cycles (%.2f %%) lost more than 200 µs of wall time to other processes (wall − CPU; median of those %.0f µs, "
              "max %.0f µs).\n",
              preempted, 100.0 * static_cast<double>(preempted) / static_cast<double>(std::max<std::size_t>(1, all.size())),
              percentile(preempted_by, 0.5), preempted_by.empty() ? 0.0 : *std::max_element(preempted_by.begin(), preempted_by.end()));
    // The slowest 1 %: where they come from.
    {
      std::vector<std::size_t> order(cr.cycles.size());
      for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
      const std::size_t k = std::max<std::size_t>(1, order.size() / 100);
      std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(),
                        [&](std::size_t a, std::size_t b) { return cr.cycles[a].cycle.total_us() > cr.cycles[b].cycle.total_us(); });
      std::size_t n_exec = 0, n_fine = 0, n_slice = 0, n_other = 0, n_preempted = 0;
      double step_share = 0.0;
      for (std::size_t i = 0; i < k; ++i) {
        const CycleRecord& rec = cr.cycles[order[i]];
        if (rec.planner_slice) {
          ++n_slice;
        } else if (rec.state == SupervisorState::Executing) {
          ++n_exec;
          if (rec.stop_samples >= 5) ++n_fine;
        } else {
          ++n_other;
        }
        if (rec.cycle.total_us() - rec.cycle.cpu_us > 200.0) ++n_preempted;
        step_share += rec.cycle.step_us / rec.cycle.total_us();
      }
      md += fmt("The slowest 1 %% by wall time (%zu cycles): %zu ran a planner slice, %zu were EXECUTING without one (%zu of them "
                "with 5 or more stop-check samples), %zu other; %zu of them lost more than 200 µs to other processes; "
                "Controller::step is %.0f %% of their time on average.\n",
                k, n_slice, n_exec, n_fine, n_other, n_preempted, 100.0 * step_share / static_cast<double>(k));
    }
    md += fmt("\nTarget (cycle compute budget): p99 < 200 µs and max < 1 ms. Wall: p99 %.1f µs %s, max %.1f µs %s. Thread CPU: p99 %.1f µs %s, "
              "max %.1f µs %s.\n\n",
              s_all.p99, s_all.p99 < 200.0 ? "met" : "NOT met", s_all.max, s_all.max < 1000.0 ? "met" : "NOT met", s_cpu.p99,
              s_cpu.p99 < 200.0 ? "met" : "NOT met", s_cpu.max, s_cpu.max < 1000.0 ? "met" : "NOT met");

    // 1b. The working envelope's share: the same lifts on the site with a wall and a ceiling, whose
    // limiter runs twice a cycle, whose sweep is in the stop check and whose rule is in every plan.
    {
      std::fprintf(stderr, "[loop] cycle compute time with a working envelope, %d cycles\n", options.cycles);
      const planning::Scenario road =
          planning::io::load_scenario((std::filesystem::path(options.scenarios_dir) / kEnvelopeScenario).string());
      const ComputeResult er = measure_compute(road, options.cycles, options.first_seed + 1);
      std::vector<double> e_all, e_cpu, e_executing;
      for (const CycleRecord& rec : er.cycles) {
        e_all.push_back(rec.cycle.total_us());
        e_cpu.push_back(rec.cycle.cpu_us);
        if (classify(rec.state) == StateClass::Executing) e_executing.push_back(rec.cycle.total_us());
      }
      const LatencyStats e_wall = latency_stats(e_all);
      const LatencyStats e_thread = latency_stats(e_cpu);
      const LatencyStats plain_exec = latency_stats(executing);
      const LatencyStats e_exec = latency_stats(e_executing);
      md += "#### The same with a working envelope\n\n";
      md += fmt("`%s` (the same site and lift, a wall 8 m west and a 40 m ceiling on the boom tip, hook and load): %zu cycles, "
                "%d lifts completed, %llu cycles slowed toward a limit, least envelope distance while moving %.2f m.\n\n",
                kEnvelopeScenario, er.cycles.size(), er.lifts_completed, static_cast<unsigned long long>(er.stats.envelope_cut_cycles),
                er.stats.min_envelope_m);
      md += kStatsHeader;
      md += stats_row("plain site, all (wall)", s_all);
      md += stats_row("with envelope, all (wall)", e_wall);
      md += stats_row("plain site, EXECUTING (wall)", plain_exec);
      md += stats_row("with envelope, EXECUTING (wall)", e_exec);
      md += stats_row("plain site, all (thread CPU)", s_cpu);
      md += stats_row("with envelope, all (thread CPU)", e_thread);
      md += fmt("\nWith / without, medians in this run: all %.2f×, EXECUTING %.2f×, thread CPU %.2f×. Target (cycle compute budget) with the "
                "envelope: wall p99 %.1f µs %s, max %.1f µs %s.\n\n",
                e_wall.median / std::max(s_all.median, 1e-9), e_exec.median / std::max(plain_exec.median, 1e-9),
                e_thread.median / std::max(s_cpu.median, 1e-9), e_wall.p99, e_wall.p99 < 200.0 ? "met" : "NOT met", e_wall.max,
                e_wall.max < 1000.0 ? "met" : "NOT met");
    }

    // 2. Reaction time.
    md += "#### Reaction time: the first frame that shows the intrusion → the stop command on the bus\n\n"
          "Per run: the first cycle whose supervisor goes EXECUTING → STOPPING for SafetyStopZone. The cycle before, with every "
          "earlier frame, did not stop, so the intrusion is first shown by the frames that arrived for this cycle's read: encoder "
          "samples (JointReading::updated) and UWB tag fixes (TagReading::updated). Reaction = (the cycle's read time − the receive "
          "time of the oldest of them, on the bus clock) + the cycle's measured read → write time (steady clock); the oldest is "
          "the conservative choice, as the frames that made the difference may be newer. Beside it, the figure of earlier runs: "
          "from the newest UWB fix in the snapshot, which also counts how long a fix that showed no intrusion lay while our own "
          "machine moved on toward it; and the stops in a cycle whose read brought a new fix (TagReading::updated on the newest), "
          "with their reaction from that fix: how fast a fix that shows the intrusion is acted on. Offsets spread evenly over 8-12 s, seeds " +
          fmt("%llu..%llu", static_cast<unsigned long long>(options.first_seed + 1),
              static_cast<unsigned long long>(options.first_seed + static_cast<std::uint64_t>(options.reaction_runs))) +
          ", the simulator's default noise and dropouts; the UWB system's own 50 ms from fix to frame is before the frame and not in "
          "the figure.\n\n"
          "| loop | UWB per tag | runs | stopped | completed without a stop | compute median µs | compute max µs | "
          "reaction median ms | p95 ms | max ms | target (period + 1 ms) | first frame: a fix / an encoder sample | "
          "from the newest fix: its age median ms | reaction median ms | p95 ms | max ms | stops with a fresh fix | "
          "their reaction from it median ms | max ms |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    struct ReactionCase {
      std::int64_t cycle_us;
      double uwb_rate_hz;
    };
    for (const ReactionCase rc : {ReactionCase{10'000, 10.0}, ReactionCase{2'000, 10.0}, ReactionCase{10'000, 100.0}}) {
      const double rate_hz = 1e6 / static_cast<double>(rc.cycle_us);
      std::vector<double> reaction_ms, age_ms, compute, first_ms, fresh_ms;
      int stopped = 0, completed = 0, first_fix = 0;
      for (int i = 0; i < options.reaction_runs; ++i) {
        const double offset = options.reaction_runs > 1
                                  ? kReactionOffsetFirstS + (kReactionOffsetLastS - kReactionOffsetFirstS) * i / (options.reaction_runs - 1)
                                  : kComputeOffsetS;
        const std::uint64_t seed = options.first_seed + 1 + static_cast<std::uint64_t>(i);
        std::fprintf(stderr, "[loop] reaction %.0f Hz, UWB %.0f Hz, run %d/%d (offset %.2f s, seed %llu)\n", rate_hz, rc.uwb_rate_hz,
                     i + 1, options.reaction_runs, offset, static_cast<unsigned long long>(seed));
        const Reaction r = measure_reaction(scenario, rc.cycle_us, rc.uwb_rate_hz, offset, seed);
        reaction_csv += fmt("%.0f,%.0f,%.3f,%llu,%d,%d,%.3f,%.1f,%.1f,%.1f,%d,%.1f,%.1f,%d,%d,%.3f,%.3f\n", rate_hz, rc.uwb_rate_hz,
                            r.offset_s, static_cast<unsigned long long>(r.seed), r.stopped ? 1 : 0, r.goal_reached ? 1 : 0,
                            r.stop_sim_s, r.frame_age_us, r.compute_us, r.reaction_us, r.fix_this_cycle ? 1 : 0,
                            r.first_frame_age_us, r.first_reaction_us, r.first_frame_is_fix ? 1 : 0, r.new_frames ? 1 : 0,
                            r.clearance_m, r.obstacle_speed_m_s);
        if (r.goal_reached) ++completed;
        if (!r.stopped) continue;
        ++stopped;
        if (r.first_frame_is_fix) ++first_fix;
        first_ms.push_back(r.first_reaction_us * 1e-3);
        if (r.fix_this_cycle) fresh_ms.push_back(r.reaction_us * 1e-3);
        reaction_ms.push_back(r.reaction_us * 1e-3);
        age_ms.push_back(r.frame_age_us * 1e-3);
        compute.push_back(r.compute_us);
      }
      const LatencyStats first = latency_stats(first_ms);
      const LatencyStats s = latency_stats(reaction_ms);
      const double target_ms = static_cast<double>(rc.cycle_us) * 1e-3 + 1.0;
      md += fmt("| %.0f Hz | %.0f Hz | %d | %d | %d | %.0f | %.0f | %.2f | %.2f | %.2f | %.0f ms: %s | %d / %d | %.2f | %.2f | %.2f | %.2f | "
                "%zu | %s | %s |\n",
                rate_hz, rc.uwb_rate_hz, options.reaction_runs, stopped, completed, percentile(compute, 0.5),
                compute.empty() ? 0.0 : *std::max_element(compute.begin(), compute.end()), first.median, first.p95, first.max,
                target_ms, stopped == 0 ? "no stops" : (first.median < target_ms ? "median met" : "median NOT met"), first_fix,
                stopped - first_fix, percentile(age_ms, 0.5), s.median, s.p95, s.max, fresh_ms.size(),
                fresh_ms.empty() ? "–" : fmt("%.2f", percentile(fresh_ms, 0.5)).c_str(),
                fresh_ms.empty() ? "–" : fmt("%.2f", *std::max_element(fresh_ms.begin(), fresh_ms.end())).c_str());
    }

    // 3. Live wake-up lateness.
    if (options.loop_seconds > 0.0) {
      std::fprintf(stderr, "[loop] live executive, %.0f s\n", options.loop_seconds);
      const Live live = measure_live(10'000, options.loop_seconds);
      const firmware::ExecutiveStats& es = live.stats;
      md += fmt("\n#### Wake-up lateness of the cyclic executive (OS figures)\n\n"
                "CyclicExecutive on MonotonicLoopClock (clock_nanosleep, TIMER_ABSTIME) at 100 Hz for %.0f s with an empty body, "
                "normal scheduling (no SCHED_FIFO, no mlock): what this OS adds between a slot's time and the wake-up. Histogram "
                "bins: 1 µs up to 1 ms, 100 µs above.\n\n"
                "| cycles | lateness p50 µs | p99 µs | p99.9 µs | max µs | deadline misses | skipped periods | watchdog trips |\n"
                "|---|---|---|---|---|---|---|---|\n"
                "| %llu | %lld | %lld | %lld | %lld | %llu | %llu | %llu |\n",
                live.seconds, static_cast<unsigned long long>(es.cycles), static_cast<long long>(es.lateness.percentile_us(0.5)),
                static_cast<long long>(es.lateness.percentile_us(0.99)), static_cast<long long>(es.lateness.percentile_us(0.999)),
                static_cast<long long>(es.lateness.max_us()), static_cast<unsigned long long>(es.deadline_misses),
                static_cast<unsigned long long>(es.skipped_periods), static_cast<unsigned long long>(es.watchdog_trips));
    }

    // 4. Intrusion timing sweep.
    std::string sweep_csv;
    if (options.sweep_step_s > 0.0) {
      std::vector<double> offsets;
      for (int i = 0;; ++i) {
        const double offset = options.sweep_first_s + options.sweep_step_s * i;
        if (offset > options.sweep_last_s + 1e-9) break;
        offsets.push_back(offset);
      }
      md += fmt("\n#### Intrusion timing sweep\n\n"
                "The lift (the scenario's goal requested once in HOLD) with crane 2's script %g, %g, ... %g s ahead (%zu runs), quiet "
                "sensors (no UWB noise or dropouts, no encoder noise), until the goal is reached or %.0f s of simulated time. Lift: goal "
                "request accepted → goal reached. Holding in contact: HOLD after StartBlocked, with a retry pending or with the retries "
                "done (after 30 a second apart the supervisor drops the goal, RetryLimitReached, and the crane stays in HOLD), the "
                "true crane within the scenario's dilation (%.2f m) of the true crane 2 when the repair was last refused. Repairs "
                "count every repair started, the "
                "supervisor's retries included. Least true clearance: the true crane to the true site and crane 2 in a world without "
                "dilation, every 50 ms of simulated time. Approach warnings: how often the controller warned of crane 2 predicted within the "
                "stop margin of the crane at rest (docs/controller.md), when it first did and in how many seconds it predicted it then; "
                "contact: when the true crane first came within 1 mm of crane 2. Compute max: the run's slowest Hal::read + Controller::step + Hal::write "
                "(steady clock), with the most thread CPU time a cycle of the run took beside it.\n\n"
                "| offset s | outcome | lift s | safety stops | repairs | escapes | retreats found / no way out / in contact | retreat cycles | "
                "paths shortened / waypoints removed | least true clearance m | to crane 2 m | approach warnings: count, first at s (in s) | "
                "contact at s | compute max µs | thread CPU max µs |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
                options.sweep_first_s, options.sweep_first_s + options.sweep_step_s, offsets.empty() ? 0.0 : offsets.back(), offsets.size(),
                options.sweep_limit_s, scenario.planner.dilation_m);
      sweep_csv = "offset_s,outcome,goal_reached,held_in_contact,state,reason,retry_pending,end_s,lift_s,safety_stops,replans,escapes,"
                  "retreats,retreats_refused,retreats_in_contact,retreat_cycles,paths_shortened,waypoints_removed,trajectory_errors,min_true_clearance_m,"
                  "min_true_dynamic_m,end_true_dynamic_m,blocked_true_dynamic_m,approach_warnings,approach_at_s,approach_said_s,contact_at_s,compute_max_us,compute_max_at_s,compute_max_state,cpu_max_us,cpu_max_at_s,cpu_max_state,wall_s,transitions\n";
      std::vector<double> lift_times;
      int held = 0;
      const std::int64_t sweep_wall0 = now_ns();
      for (std::size_t i = 0; i < offsets.size(); ++i) {
        std::fprintf(stderr, "[loop] intrusion sweep, run %zu/%zu (offset %.0f s)\n", i + 1, offsets.size(), offsets[i]);
        const SweepRun r = measure_sweep_run(scenario, offsets[i], options.sweep_limit_s);
        const firmware::ControllerStats& st = r.stats;
        if (r.goal_reached) lift_times.push_back(r.lift_s);
        if (r.held_in_contact) ++held;
        const std::string outcome = sweep_outcome(r);
        const std::string approach = st.approach_warnings == 0 ? std::string("0")
                                                               : fmt("%d, %.2f (%.1f)", st.approach_warnings, r.approach_at_s, r.approach_said_s);
        const std::string contact = std::isnan(r.contact_at_s) ? std::string("–") : fmt("%.2f", r.contact_at_s);
        md += fmt("| %.0f | %s | %s | %d | %d | %d | %d / %d / %d | %llu | %d / %d | %.2f | %.2f | %s | %s | %.0f | %.0f |\n", r.offset_s, outcome.c_str(),
                  r.goal_reached ? fmt("%.1f", r.lift_s).c_str() : "–", st.safety_stops, st.replans, st.escapes, st.retreats,
                  st.retreats_refused, st.retreats_in_contact, static_cast<unsigned long long>(st.retreat_cycles), st.paths_shortened,
                  st.waypoints_removed, r.min_true_clearance_m, r.min_true_dynamic_m, approach.c_str(), contact.c_str(), r.compute_max_us,
                  r.cpu_max_us);
        sweep_csv += fmt("%.3f,\"%s\",%d,%d,%s,%s,%d,%.2f,%.2f,%d,%d,%d,%d,%d,%d,%llu,%d,%d,%llu,%.4f,%.4f,%.4f,%.4f,%d,%.2f,%.2f,%.2f,%.1f,%.2f,%s,%.1f,%.2f,%s,%.2f,\"%s\"\n", r.offset_s,
                         outcome.c_str(), r.goal_reached ? 1 : 0, r.held_in_contact ? 1 : 0, guidance::to_string(r.state),
                         guidance::to_string(r.reason), r.retry_pending ? 1 : 0, r.end_s, r.lift_s, st.safety_stops, st.replans,
                         st.escapes, st.retreats, st.retreats_refused, st.retreats_in_contact, static_cast<unsigned long long>(st.retreat_cycles),
                         st.paths_shortened, st.waypoints_removed, static_cast<unsigned long long>(st.trajectory_errors),
                         r.min_true_clearance_m, r.min_true_dynamic_m, r.end_true_dynamic_m, r.blocked_true_dynamic_m, st.approach_warnings,
                         r.approach_at_s, r.approach_said_s, r.contact_at_s, r.compute_max_us, r.compute_max_at_s,
                         guidance::to_string(r.compute_max_state), r.cpu_max_us, r.cpu_max_at_s, guidance::to_string(r.cpu_max_state), r.wall_s, r.transitions.c_str());
      }
      md += fmt("\n%zu of %zu offsets reached the goal (median lift %s), %d held in contact, %zu other; %.1f s wall.\n",
                lift_times.size(), offsets.size(), lift_times.empty() ? "none" : fmt("%.1f s", percentile(lift_times, 0.5)).c_str(), held,
                offsets.size() - lift_times.size() - static_cast<std::size_t>(held), static_cast<double>(now_ns() - sweep_wall0) * 1e-9);
    }

    md += "\nThe first lift's transitions: ";
    for (std::size_t i = 0; i < cr.transitions.size() && i < 12; ++i) md += (i ? "; " : "") + cr.transitions[i];
    md += fmt(".\n\nWhole suite: %.1f s; load average (1, 5, 15 min) before %s, after %s.\n",
              static_cast<double>(now_ns() - wall_start_ns) * 1e-9, load_before.c_str(), load_average().c_str());

    std::printf("%s\n", md.c_str());
    if (!options.out_dir.empty()) {
      std::filesystem::create_directories(options.out_dir);
      std::ofstream(options.out_dir + "/loop.md") << md;
      std::ofstream(options.out_dir + "/loop.csv") << csv;
      std::ofstream(options.out_dir + "/loop_reaction.csv") << reaction_csv;
      if (!sweep_csv.empty()) std::ofstream(options.out_dir + "/loop_sweep.csv") << sweep_csv;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-bench: loop: %s\n", e.what());
    return 2;
  }
}

}  // namespace mgc::bench
