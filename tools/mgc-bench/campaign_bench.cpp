// SPDX-License-Identifier: Apache-2.0
// The `campaign` suite of mgc-bench: randomized lifts on the shipped sites and on generated ones
// (site_families.hpp) in stepped simulated time, each drawn from its seed (the site, a feasible
// goal near the scenario's, at most one
// disturbance: an intruding crane, truck or worker, or a sensing or bus fault during motion), run
// beside its undisturbed twin and judged in the simulator's true state (sim::TruthMonitor and the
// true joints), never in what the controller believes. docs/safety.md "The campaign" describes
// what is drawn and measured and the targets.

#include "campaign_bench.hpp"
#include "site_families.hpp"
#include "timing_report.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <unistd.h>

#include "mgc/firmware/controller.hpp"
#include "mgc/planning/collision_world.hpp"
#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/random.hpp"
#include "mgc/planning/scenario.hpp"
#include "mgc/sim/faults.hpp"
#include "mgc/sim/stepped_rig.hpp"
#include "mgc/sim/truth_monitor.hpp"

namespace mgc::bench {

namespace {

using guidance::SupervisorState;
using guidance::TransitionReason;
using sim::SteppedRig;

constexpr double kDeg = std::numbers::pi / 180.0;

//! The shipped sites the campaign draws from, with what can intrude on each.
struct Site {
  const char* file;
  bool has_crane;       //!< its first dynamic obstacle is a crane that can swing in
  double truck_min_m;   //!< a truck parks this far from the machine's base at least [m]
  double truck_max_m;   //!< and at most [m]
  double worker_min_m;  //!< a worker's line passes the base at least this far [m]
  double worker_max_m;  //!< and at most [m]
};

constexpr Site kSites[] = {
    {"thesis-steel-frame.yaml", true, 10.0, 28.0, 8.0, 18.0},
    {"thesis-steel-frame-road.yaml", true, 10.0, 28.0, 8.0, 18.0},
    {"thesis-steel-frame-tower.yaml", true, 8.0, 32.0, 4.0, 24.0},
    {"excavator-truck.yaml", false, 6.0, 14.0, 3.5, 10.0},
    {"excavator-cycle.yaml", false, 6.0, 14.0, 3.5, 10.0},
    {"excavator-pipelines.yaml", false, 6.0, 14.0, 3.5, 10.0},
};
constexpr int kNumSites = static_cast<int>(sizeof(kSites) / sizeof(kSites[0]));

//! Tag ids of the obstacles the campaign adds: above every id the shipped sites use.
constexpr int kTruckTagA = 61;
constexpr int kTruckTagB = 62;
constexpr int kWorkerTag = 71;

//! True motion below this is rest: the controller's own rest speed. [rad/s | m/s]
constexpr double kRestSpeed = 0.005;
//! The approach warning's target lead before an intruder sweeps into the machine at rest. [s]
constexpr double kApproachLeadS = 4.0;

//! The machine at rest after a fault: every joint below this. [rad/s | m/s]
constexpr double kStillSpeed = 1e-4;
//! A joint counts as moving in the twin's timeline above this share of its speed limit. [-]
constexpr double kMovingShare = 0.3;
//! The twin's timeline of which joints move, sampled this often. [s]
constexpr double kTimelineStepS = 0.1;
//! An undisturbed lift that has not ended by then is ended. [s]
constexpr double kTwinLimitS = 400.0;
//! The same on a generated site: a crane's path there may telescope the boom in and out by tens of
//! metres at 0.1 m/s round a tower or a frame. [s]
constexpr double kGeneratedTwinLimitS = 1200.0;
//! A disturbed lift may take this much longer than its twin before it is ended. [s]
constexpr double kExtraLimitS = 150.0;
//! After FAULT: the run goes on until the machine is at rest for this long, at most kFaultTailS. [s]
constexpr double kFaultRestS = 1.0;
constexpr double kFaultTailS = 15.0;
//! The approach warning counts as one warning across gaps shorter than this. [s]
constexpr double kWarningGapS = 1.0;

double sim_s(std::int64_t t_us) { return static_cast<double>(t_us - SteppedRig::kSimZeroUs) * 1e-6; }

//! The scenario's dynamic obstacles stand where they are at time 0 for the whole lift: the
//! campaign scripts every motion itself.
void freeze_obstacles(planning::Scenario& s) {
  for (auto& d : s.dynamic_obstacles) {
    planning::Keyframe k = d.motion.front();
    k.t_s = 0.0;
    d.motion = {k};
  }
}

//! A truck of excavator-truck.yaml's size (tipper, cab, chassis) with two tags.
planning::DynamicObstacleSpec make_truck() {
  planning::DynamicObstacleSpec t;
  t.obstacle.name = "truck-intruder";
  const auto box = [](Eigen::Vector3d size_m, Eigen::Vector3d at_m) {
    planning::ShapePart p;
    p.kind = planning::ShapeKind::Box;
    p.size_m = size_m;
    p.pose = Eigen::Isometry3d::Identity();
    p.pose.translation() = at_m;
    return p;
  };
  t.obstacle.parts = {box({4.6, 2.5, 2.6}, {-1.0, 0, 1.9}), box({2.0, 2.5, 3.2}, {2.4, 0, 1.6}), box({6.8, 2.3, 0.6}, {0.0, 0, 0.6})};
  t.tags = {{kTruckTagA, {2.4, 0, 3.3}}, {kTruckTagB, {-3.2, 0, 3.3}}};
  return t;
}

//! A worker: 0.6 m across, 1.8 m tall, a tag on the helmet.
planning::DynamicObstacleSpec make_worker() {
  planning::DynamicObstacleSpec w;
  w.obstacle.name = "worker";
  planning::ShapePart p;
  p.kind = planning::ShapeKind::Cylinder;
  p.size_m = {0.6, 0.6, 1.8};
  p.pose = Eigen::Isometry3d::Identity();
  p.pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.9);
  w.obstacle.parts = {p};
  w.tags = {{kWorkerTag, {0.0, 0.0, 1.75}}};
  return w;
}

bool has_tags(const planning::Scenario& s) {
  for (const auto& d : s.dynamic_obstacles) {
    if (!d.tags.empty()) return true;
  }
  return false;
}

//! What a goal must be to be drawn: valid in the controller's planning world (ranges, the
//! machine's constraints, the scenario's dilation grown by the planning margin), 3 m beyond that
//! from the dynamic obstacles; in the true state, the load 0.3 m above the ground, the chart
//! at most 90 %, the envelope's planning margin kept.
bool goal_feasible(const planning::Scenario& s, const planning::JointVector& q) {
  for (int j = 0; j < q.size(); ++j) {
    const planning::JointSpec& spec = s.machine.joints[static_cast<std::size_t>(j)];
    if (!spec.contains(q[j])) return false;
  }
  // The controller's planning world: the scenario's dilation grown by its planning margin.
  const double margin_m = s.guidance && s.guidance->planning_margin_m ? *s.guidance->planning_margin_m : 1.0;
  planning::Scenario grown = s;
  grown.planner.dilation_m += margin_m;
  const std::unique_ptr<planning::MachineModel> model = planning::build_model(grown);
  const std::unique_ptr<planning::CollisionWorld> world = planning::build_world(grown, *model);
  planning::JointVector qq = q;
  if (world->validate(qq).status != planning::Validity::Status::Valid) return false;
  sim::TruthMonitor truth(s);
  for (std::size_t i = 0; i < s.dynamic_obstacles.size(); ++i) truth.set_obstacle_pose(i, s.dynamic_obstacles[i].pose_at(0.0));
  const sim::TruthSample& t = truth.measure(0.0, q);
  // The controller grows a dynamic obstacle further, by how far it may come while the machine
  // stops: a few metres at most.
  if (t.dynamic_clearance.distance_m < s.planner.dilation_m + margin_m + 3.0) return false;
  if (!std::isnan(t.load_ground_clearance_m) && t.load_ground_clearance_m < 0.3) return false;
  if (!std::isnan(t.chart_utilisation) && !(t.chart_utilisation <= 0.9)) return false;
  if (t.envelope.limit != guidance::EnvelopeLimit::None && t.envelope.distance_m < 1.5) return false;
  return true;
}

//! A goal near the scenario's: the first (slewing) joint within ±20°, other revolute joints ±6°,
//! prismatic joints ±10 % of their range (at most 3 m); an excavator's bucket keeps its angle to
//! the ground. Drawn until feasible, 30 times at most; then the scenario's own goal (draws 0).
planning::JointVector draw_goal(const planning::Scenario& s, planning::Random& rng, int& draws) {
  const int n = static_cast<int>(s.machine.joints.size());
  for (draws = 1; draws <= 30; ++draws) {
    planning::JointVector q = s.goal;
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& spec = s.machine.joints[static_cast<std::size_t>(j)];
      const double u = rng.uniform(-1.0, 1.0);
      if (spec.type == planning::JointType::Revolute) {
        q[j] += u * (j == 0 ? 20.0 : 6.0) * kDeg;
      } else {
        q[j] += u * std::min(0.1 * spec.range(), 3.0);
      }
    }
    if (s.machine.kind == planning::MachineKind::Excavator && n >= 4) q[3] -= (q[1] - s.goal[1]) + (q[2] - s.goal[2]);
    if (goal_feasible(s, q)) return q;
  }
  draws = 0;
  return s.goal;
}

//! Site draws a generated lift may take before it gives up (each one a site of its own). [-]
constexpr int kMaxSiteDraws = 20;
//! Generated sites are named by a site seed below this, short enough to read in a file name. [-]
constexpr std::uint64_t kSiteSeeds = 100000;

//! The intruders' distances on a generated site, by machine: as on the shipped sites of the same
//! machine (kSites). No crane swings in: a generated site has no dynamic obstacles.
Site generated_site_distances(planning::MachineKind kind) {
  switch (kind) {
    case planning::MachineKind::TowerCrane: return {nullptr, false, 8.0, 32.0, 4.0, 24.0};
    case planning::MachineKind::Excavator: return {nullptr, false, 6.0, 14.0, 3.5, 10.0};
    case planning::MachineKind::MobileCrane: break;
  }
  return {nullptr, false, 10.0, 28.0, 8.0, 18.0};
}

//! generate_site writes a family's machine file beside the sites each time, and the loader reads
//! it: one site at a time across the campaign's threads.
std::mutex& site_mutex() {
  static std::mutex m;
  return m;
}

//! A generated lift's site, drawn from the lift's stream: a solvable family (every machine), a site
//! seed, the site written and loaded, then a feasible goal near the site's own (draw_goal). A site
//! that cannot be set up (no draw of the family's met its promise, or no feasible goal and the
//! site's own goal not feasible either) is counted and the next drawn from the same stream.
void draw_generated_site(const CampaignOptions& options, planning::Random& rng, LiftRecord& rec, Site& site, planning::Scenario& base,
                         planning::JointVector& goal) {
  std::vector<const SiteFamily*> solvable;
  for (const SiteFamily& f : site_families()) {
    if (f.expectation == SiteExpectation::Solvable) solvable.push_back(&f);
  }
  const std::filesystem::path machines = std::filesystem::path(options.scenarios_dir) / "machines";
  const std::filesystem::path folder = campaign_sites_dir(options);
  std::string why;
  for (rec.site_redraws = 0; rec.site_redraws < kMaxSiteDraws; ++rec.site_redraws) {
    const SiteFamily& family = *solvable[static_cast<std::size_t>(rng.uniform() * static_cast<double>(solvable.size())) % solvable.size()];
    const std::uint64_t site_seed = rng.next() % kSiteSeeds;
    GeneratedSite generated;
    try {
      const std::lock_guard lock(site_mutex());
      generated = generate_site(family, site_seed, machines, folder);
      base = planning::io::load_scenario(generated.file.string());
    } catch (const planning::io::InputError&) {
      throw;
    } catch (const std::runtime_error& e) {
      why = e.what();
      continue;
    }
    freeze_obstacles(base);
    goal = draw_goal(base, rng, rec.goal_draws);
    if (rec.goal_draws == 0 && !goal_feasible(base, goal)) {
      why = generated.file.filename().string() + ": no feasible goal in 30 draws, nor the site's own";
      continue;
    }
    rec.site = generated.file.filename().string();
    rec.family = family.name;
    rec.site_seed = site_seed;
    site = generated_site_distances(base.machine.kind);
    site.has_crane = !base.dynamic_obstacles.empty() && base.dynamic_obstacles.front().obstacle.name.find("crane") != std::string::npos;
    return;
  }
  throw std::runtime_error(fmt("no generated site of %d could be set up; the last: %s", kMaxSiteDraws, why.c_str()));
}

//! Which joints move fast in the undisturbed twin, every kTimelineStepS.
struct Timeline {
  std::vector<double> t_s;
  std::vector<std::uint32_t> moving;  //!< bit j: joint j above kMovingShare of its speed limit
};

//! What a fault's finding must be (docs/diagnostics.md, docs/protocol.md).
struct Expectation {
  std::vector<TransitionReason> reasons;
  int value = -2;        //!< -2: any
  double budget_s = std::numeric_limits<double>::quiet_NaN();
};

//! One run on the stepped rig with the controller, the referee watching the true state.
struct RunSetup {
  const planning::Scenario* scenario = nullptr;
  sim::SimConfig config;
  planning::JointVector goal;
  double limit_s = kTwinLimitS;
  std::string bus_name;
  double fault_s = std::numeric_limits<double>::quiet_NaN();
  const Expectation* expect = nullptr;
  Timeline* timeline = nullptr;  //!< filled when not null
};

struct FaultFinding {
  double detect_s = std::numeric_limits<double>::quiet_NaN();
  bool detected = false;
};

//! How long the obstacle has been moving without a pause at t_s, to 0.05 s. [s]
double moving_for_s(const planning::DynamicObstacleSpec& d, double t_s) {
  constexpr double kStepS = 0.05;
  double since_s = t_s;
  while (since_s > 0.0 && d.moves_between(std::max(0.0, since_s - kStepS), since_s)) since_s -= kStepS;
  return t_s - std::max(0.0, since_s);
}

LiftRun run_lift(const RunSetup& setup, FaultFinding* finding) {
  const auto wall0 = std::chrono::steady_clock::now();
  const planning::Scenario& scenario = *setup.scenario;
  SteppedRig rig(scenario, setup.config, setup.bus_name);
  rig.calibrate_valves();
  firmware::Controller controller(rig.scenario, firmware::ControllerConfig{});
  sim::TruthMonitor truth(rig.scenario);
  const int n = controller.num_joints();
  std::vector<double> vmax(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) vmax[static_cast<std::size_t>(j)] = scenario.machine.joints[static_cast<std::size_t>(j)].max_velocity;

  LiftRun r;
  bool goal_sent = false;
  bool done = false;
  std::int64_t request_us = -1;
  double fault_entered_s = std::numeric_limits<double>::quiet_NaN();
  double still_since_s = std::numeric_limits<double>::quiet_NaN();
  bool stopped_after_fault = false;
  double last_rise_s = std::numeric_limits<double>::quiet_NaN();
  double last_warn_s = std::numeric_limits<double>::quiet_NaN();
  double next_timeline_s = 0.0;
  const double fault_s = setup.fault_s;

  const auto machine_at_rest = [&](double speed) {
    for (int j = 0; j < n; ++j) {
      if (std::abs(rig.sim->truth().velocity[static_cast<std::size_t>(j)]) >= speed) return false;
    }
    return true;
  };

  rig.on_cycle = [&](const hal::SensorSnapshot& s) {
    const double t = sim_s(s.t_us);
    firmware::ControllerCommands commands;
    if (!goal_sent && controller.supervisor().state() == SupervisorState::Hold) {
      commands.goal_request = true;
      commands.goal_joints = n;
      for (int j = 0; j < n; ++j) commands.goal[static_cast<std::size_t>(j)] = setup.goal[j];
      goal_sent = true;
    }
    const firmware::ControllerOutput out = controller.step(s, rig.cycle_us, commands, false);
    if (out.start_nodes) (void)rig.hal->send_nmt(hal::canopen::NmtCommand::Start, 0);
    rig.hal->set_pilot_enabled(out.pilot_enable);
    for (int j = 0; j < n; ++j) rig.command[static_cast<std::size_t>(j)] = out.velocity[static_cast<std::size_t>(j)];

    // The approach warning: since when it has been on, gaps under 1 s bridged (its scan of the
    // horizon takes cycles and may lose an obstacle between two scans), and when it was last on.
    if (std::isfinite(controller.approach_s())) {
      if (std::isnan(last_warn_s) || t - last_warn_s > kWarningGapS) last_rise_s = t;
      last_warn_s = t;
    }

    if (out.supervisor.transitioned) {
      const SupervisorState state = out.supervisor.state;
      const TransitionReason reason = out.supervisor.reason;
      const int value = controller.supervisor().reason_value();
      r.transitions += fmt("%s%.2f s %s (%s%s)", r.transitions.empty() ? "" : "; ", t, guidance::to_string(state), guidance::to_string(reason),
                           value != -1 ? fmt(" %d", value).c_str() : "");
      if (reason == TransitionReason::GoalRequested && request_us < 0) request_us = s.t_us;
      if (state == SupervisorState::Executing && std::isnan(r.motion_start_s)) r.motion_start_s = t;
      if (goal_sent && (state == SupervisorState::Stopping || state == SupervisorState::Fault)) {
        ++r.stops;
        if (std::isnan(r.first_stop_s)) {
          r.first_stop_s = t;
          r.first_stop_reason = guidance::to_string(reason);
          r.first_stop_value = value;
        }
        if (!std::isnan(fault_s) && t >= fault_s) stopped_after_fault = true;
      }
      if (finding != nullptr && setup.expect != nullptr && !finding->detected && !std::isnan(fault_s) && t >= fault_s &&
          (state == SupervisorState::Stopping || state == SupervisorState::Fault)) {
        for (const TransitionReason expected : setup.expect->reasons) {
          if (reason == expected && (setup.expect->value == -2 || setup.expect->value == value)) {
            finding->detected = true;
            finding->detect_s = t - fault_s;
          }
        }
      }
      if (reason == TransitionReason::GoalReached) {
        r.completed = true;
        if (request_us >= 0) r.lift_s = static_cast<double>(s.t_us - request_us) * 1e-6;
        done = true;
      }
      if (state == SupervisorState::Fault && std::isnan(fault_entered_s)) fault_entered_s = t;
      if (state == SupervisorState::Hold && goal_sent && !controller.supervisor().retry_pending() &&
          (reason == TransitionReason::RetryLimitReached || reason == TransitionReason::PlanFailed ||
           reason == TransitionReason::PlanTimeout || reason == TransitionReason::ReplanFailed)) {
        done = true;
      }
    }

    // From the fault to the true machine at rest, once the controller has stopped it.
    if (stopped_after_fault && std::isnan(r.rest_after_fault_s) && machine_at_rest(kStillSpeed)) r.rest_after_fault_s = t - fault_s;
    if (!std::isnan(fault_entered_s)) {
      if (machine_at_rest(kStillSpeed)) {
        if (std::isnan(still_since_s)) still_since_s = t;
      } else {
        still_since_s = std::numeric_limits<double>::quiet_NaN();
      }
      if ((!std::isnan(still_since_s) && t - still_since_s >= kFaultRestS) || t - fault_entered_s >= kFaultTailS) done = true;
    }

    if (setup.timeline != nullptr && t >= next_timeline_s) {
      std::uint32_t mask = 0;
      for (int j = 0; j < n; ++j) {
        if (std::abs(rig.sim->truth().velocity[static_cast<std::size_t>(j)]) > kMovingShare * vmax[static_cast<std::size_t>(j)]) mask |= 1u << j;
      }
      setup.timeline->t_s.push_back(t);
      setup.timeline->moving.push_back(mask);
      next_timeline_s = t + kTimelineStepS;
    }

    if (truth.sample(*rig.sim)) {
      const sim::TruthSample& ts = truth.last();
      const bool contact = ts.clearance.distance_m <= 1e-3;
      if (contact && std::isnan(r.contact_s)) {
        r.contact_s = t;
        const bool dynamic = ts.dynamic_clearance.distance_m <= 1e-3;
        const int other = dynamic ? ts.dynamic_clearance.other : ts.clearance.other;
        if (dynamic && other >= 0 && static_cast<std::size_t>(other) < scenario.dynamic_obstacles.size()) {
          const planning::DynamicObstacleSpec& d = scenario.dynamic_obstacles[static_cast<std::size_t>(other)];
          r.contact_with = "dynamic " + d.obstacle.name;
          r.contact_intruder_moving = d.moves_between(std::max(0.0, t - 0.1), t);
          if (r.contact_intruder_moving) r.intruder_moving_for_s = moving_for_s(d, t);
        } else if (other >= 0 && static_cast<std::size_t>(other) < scenario.obstacles.size()) {
          r.contact_with = "static " + scenario.obstacles[static_cast<std::size_t>(other)].name;
        } else {
          r.contact_with = "other";
        }
        // The machine's body in contact: the truth monitor's model is built as the controller's.
        const int body = dynamic ? ts.dynamic_clearance.body : ts.clearance.body;
        const auto bodies = controller.model().bodies();
        if (body >= 0 && static_cast<std::size_t>(body) < bodies.size()) r.contact_with += " (" + bodies[static_cast<std::size_t>(body)].name + ")";
        r.contact_machine_at_rest = machine_at_rest(kRestSpeed);
        if (!std::isnan(last_warn_s) && t - last_warn_s <= kWarningGapS) r.approach_lead_s = t - last_rise_s;
      }
    }
  };

  const std::int64_t end_us = SteppedRig::at_sim_s(setup.limit_s);
  while (!done && rig.t_us < end_us) rig.run(rig.cycle_us);

  r.end_s = sim_s(rig.t_us);
  r.state = guidance::to_string(controller.supervisor().state());
  r.reason = guidance::to_string(controller.supervisor().reason());
  const firmware::ControllerStats& st = controller.stats();
  r.safety_stops = st.safety_stops;
  r.replans = st.replans;
  r.approach_warnings = st.approach_warnings;
  const sim::TruthSummary& sum = truth.summary();
  r.samples = sum.samples;
  r.least_clearance_m = sum.least_clearance.distance_m;
  r.least_dynamic_m = sum.least_dynamic.distance_m;
  r.least_static_m = sum.least_clearance.with == planning::Contact::With::Dynamic ? std::numeric_limits<double>::quiet_NaN()
                                                                                   : sum.least_clearance.distance_m;
  if (truth.has_ground_clearance()) r.least_ground_m = sum.least_ground_clearance_m;
  if (truth.has_load_chart()) r.peak_chart = sum.peak_chart_utilisation;
  r.samples_chart_exceeded = sum.samples_chart_exceeded;
  r.samples_below_ground = sum.samples_below_ground;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return r;
}

//! Keys of a script: the obstacle stands at `from` until t0_s, then moves linearly to `to` by t1_s.
std::vector<planning::Keyframe> script(const planning::Keyframe& from, const planning::Keyframe& to, double t0_s, double t1_s) {
  std::vector<planning::Keyframe> keys;
  planning::Keyframe a = from;
  a.t_s = 0.0;
  keys.push_back(a);
  if (t0_s > 1e-3) {
    a.t_s = t0_s;
    keys.push_back(a);
  }
  planning::Keyframe b = to;
  b.t_s = std::max(t1_s, keys.back().t_s + 1e-3);
  keys.push_back(b);
  return keys;
}

std::string run_text(const LiftRun& r) {
  std::string t = fmt("%s (%s) at %.2f s; %s", r.state.c_str(), r.reason.c_str(), r.end_s,
                      r.completed ? fmt("completed, lift %.2f s", r.lift_s).c_str() : "not completed");
  t += fmt("; stops %d (safety %d), repairs %d, approach warnings %d", r.stops, r.safety_stops, r.replans, r.approach_warnings);
  if (!std::isnan(r.first_stop_s)) t += fmt("; first stop %.2f s %s (%d)", r.first_stop_s, r.first_stop_reason.c_str(), r.first_stop_value);
  t += fmt("\n    truth (%llu samples): least clearance %.3f m, to the dynamic obstacles %.3f m, load above ground %.3f m, peak chart %.3f, "
           "samples over the chart %llu, below ground %llu",
           static_cast<unsigned long long>(r.samples), r.least_clearance_m, r.least_dynamic_m, r.least_ground_m, r.peak_chart,
           static_cast<unsigned long long>(r.samples_chart_exceeded), static_cast<unsigned long long>(r.samples_below_ground));
  if (!std::isnan(r.contact_s)) {
    t += fmt("\n    CONTACT at %.2f s with %s, machine %s, obstacle %s, approach warning lead %.2f s", r.contact_s, r.contact_with.c_str(),
             r.contact_machine_at_rest ? "at rest" : "moving", r.contact_intruder_moving ? "moving" : "standing", r.approach_lead_s);
    if (r.contact_intruder_moving) t += fmt(" (the obstacle moving for %.2f s)", r.intruder_moving_for_s);
  }
  if (!std::isnan(r.rest_after_fault_s)) t += fmt("\n    true machine at rest %.2f s after the fault", r.rest_after_fault_s);
  t += "\n    transitions: " + r.transitions;
  return t;
}

}  // namespace

const char* to_string(Disturbance d) noexcept {
  switch (d) {
    case Disturbance::None: return "none";
    case Disturbance::Crane: return "crane";
    case Disturbance::Truck: return "truck";
    case Disturbance::Worker: return "worker";
    case Disturbance::Fault: return "fault";
  }
  return "?";
}

std::string campaign_sites_dir(const CampaignOptions& options) {
  if (!options.sites_dir.empty()) return options.sites_dir;
  if (!options.out_dir.empty()) return (std::filesystem::path(options.out_dir) / "campaign-sites").string();
  return (std::filesystem::temp_directory_path() / ("mgc-bench-campaign-" + std::to_string(::getpid()))).string();
}

LiftRecord run_campaign_lift(const CampaignOptions& options, int index) {
  LiftRecord rec;
  rec.index = index;
  rec.seed = options.first_seed + 1 + static_cast<std::uint64_t>(index);
  planning::Random rng(rec.seed);
  planning::Scenario base;
  planning::JointVector goal;
  Site site{};
  if (index < kShippedLifts) {
    site = kSites[static_cast<int>(rng.uniform() * kNumSites) % kNumSites];
    rec.site = site.file;
    base = planning::io::load_scenario((std::filesystem::path(options.scenarios_dir) / site.file).string());
    freeze_obstacles(base);
    goal = draw_goal(base, rng, rec.goal_draws);
  } else {
    draw_generated_site(options, rng, rec, site, base, goal);
  }
  const int n = static_cast<int>(base.machine.joints.size());
  rec.goal.assign(goal.data(), goal.data() + n);

  // The disturbance: none 20 %, an intrusion 40 %, a fault 40 %; its numbers are drawn now, so
  // that the draw does not depend on the twin, and mapped onto the twin's motion below.
  const double kind_u = rng.uniform();
  const double u[8] = {rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform()};
  if (kind_u < 0.2) {
    rec.disturbance = Disturbance::None;
  } else if (kind_u < 0.6) {
    const int k = static_cast<int>((kind_u - 0.2) / 0.4 * (site.has_crane ? 3.0 : 2.0));
    rec.disturbance = site.has_crane ? (k == 0 ? Disturbance::Crane : k == 1 ? Disturbance::Truck : Disturbance::Worker)
                                     : (k == 0 ? Disturbance::Truck : Disturbance::Worker);
  } else {
    rec.disturbance = Disturbance::Fault;
  }

  sim::SimConfig config;  // mgc-sim's defaults: UWB noise and dropouts, encoder noise
  config.seed = rec.seed;
  const std::string bus = fmt("campaign-%d", index);

  Timeline timeline;
  RunSetup twin_setup;
  twin_setup.scenario = &base;
  twin_setup.config = config;
  twin_setup.goal = goal;
  twin_setup.bus_name = bus + "-twin";
  twin_setup.limit_s = rec.family.empty() ? kTwinLimitS : kGeneratedTwinLimitS;
  twin_setup.timeline = &timeline;
  rec.twin = run_lift(twin_setup, nullptr);
  if (rec.disturbance == Disturbance::None) {
    rec.what = "nothing";
    rec.run = rec.twin;
    return rec;
  }

  // The twin's motion: from its first EXECUTING to its end (or 60 s when it never moved).
  const double move0_s = std::isnan(rec.twin.motion_start_s) ? 5.0 : rec.twin.motion_start_s;
  const double move_span_s = std::max(5.0, (rec.twin.completed ? rec.twin.end_s : move0_s + 60.0) - move0_s);

  planning::Scenario s = base;
  Expectation expect;
  RunSetup setup;
  setup.config = config;
  const Eigen::Vector3d base_m = s.world_from_base.translation();
  switch (rec.disturbance) {
    case Disturbance::Crane: {
      planning::DynamicObstacleSpec& crane = s.dynamic_obstacles.front();
      const planning::Keyframe from = crane.motion.front();
      const double t0 = move0_s - 10.0 + u[0] * (0.8 * move_span_s + 10.0);
      const double swing_deg = (u[1] < 0.5 ? -1.0 : 1.0) * (45.0 + 75.0 * u[2]);
      const double rate_deg_s = 3.0 + 7.0 * u[3];
      planning::Keyframe to = from;
      to.yaw_rad += swing_deg * kDeg;
      crane.motion = script(from, to, std::max(0.0, t0), std::max(0.0, t0) + std::abs(swing_deg) / rate_deg_s);
      rec.what = fmt("%s swings %+.1f deg at %.1f deg/s from %.2f s", crane.obstacle.name.c_str(), swing_deg, rate_deg_s, std::max(0.0, t0));
      break;
    }
    case Disturbance::Truck: {
      planning::DynamicObstacleSpec truck = make_truck();
      // A parking place clear of the lift's start and goal by 3 m, drawn from the lift's stream.
      planning::Random park_rng(rec.seed ^ 0x7472756B);
      Eigen::Vector3d park = base_m;
      double heading = 0.0;
      int tries = 0;
      for (tries = 1; tries <= 30; ++tries) {
        const double r_m = site.truck_min_m + park_rng.uniform() * (site.truck_max_m - site.truck_min_m);
        const double angle = park_rng.uniform(-std::numbers::pi, std::numbers::pi);
        heading = park_rng.uniform(-std::numbers::pi, std::numbers::pi);
        park = base_m + r_m * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0);
        park.z() = 0.0;
        planning::Scenario probe = s;
        truck.motion = {planning::Keyframe{0.0, park, heading}};
        probe.dynamic_obstacles.push_back(truck);
        sim::TruthMonitor check(probe);
        for (std::size_t i = 0; i < probe.dynamic_obstacles.size(); ++i) check.set_obstacle_pose(i, probe.dynamic_obstacles[i].pose_at(0.0));
        const bool clear_start = check.measure(0.0, probe.start).dynamic_clearance.distance_m >= 3.0;
        const bool clear_goal = check.measure(0.0, goal).dynamic_clearance.distance_m >= 3.0;
        if (clear_start && clear_goal) break;
      }
      const double speed = 2.0 + 3.0 * u[0];
      const double drive_m = 35.0;
      const double arrive_s = move0_s + u[1] * 0.8 * move_span_s;
      const Eigen::Vector3d dir(std::cos(heading), std::sin(heading), 0.0);
      const planning::Keyframe from{0.0, park - drive_m * dir, heading};
      const planning::Keyframe to{0.0, park, heading};
      const double t0 = std::max(0.0, arrive_s - drive_m / speed);
      truck.motion = script(from, to, t0, t0 + drive_m / speed);
      s.dynamic_obstacles.push_back(truck);
      rec.what = fmt("a truck drives %.0f m at %.1f m/s from %.2f s and parks at (%.1f, %.1f) heading %.0f deg (place drawn %d times)",
                     drive_m, speed, t0, park.x(), park.y(), heading / kDeg, tries > 30 ? 30 : tries);
      break;
    }
    case Disturbance::Worker: {
      planning::DynamicObstacleSpec worker = make_worker();
      const double pass_m = site.worker_min_m + u[0] * (site.worker_max_m - site.worker_min_m);
      const double dir_rad = u[1] * 2.0 * std::numbers::pi;
      const double speed = 0.8 + 0.8 * u[2];
      const double cross_s = move0_s + u[3] * 0.8 * move_span_s;
      const double half_m = 30.0;
      const Eigen::Vector3d dir(std::cos(dir_rad), std::sin(dir_rad), 0.0);
      const Eigen::Vector3d side(-dir.y(), dir.x(), 0.0);
      Eigen::Vector3d nearest = base_m + pass_m * side;
      nearest.z() = 0.0;
      const double t_begin = cross_s - half_m / speed;
      const double t0 = std::max(0.0, t_begin);
      const planning::Keyframe from{0.0, nearest + (speed * (t0 - cross_s)) * dir, dir_rad};
      const planning::Keyframe to{0.0, nearest + half_m * dir, dir_rad};
      worker.motion = script(from, to, t0, cross_s + half_m / speed);
      s.dynamic_obstacles.push_back(worker);
      rec.what = fmt("a worker walks at %.2f m/s heading %.0f deg, passing %.1f m from the base at %.2f s", speed, dir_rad / kDeg, pass_m, cross_s);
      break;
    }
    case Disturbance::Fault: {
      // A time at which some joint moves fast in the twin, and for a joint's fault one of those joints.
      // Before the twin's first stop, if it had one: up to the fault, the lift is its twin.
      std::vector<std::size_t> moving;
      for (std::size_t i = 0; i < timeline.t_s.size(); ++i) {
        const bool before_stop = std::isnan(rec.twin.first_stop_s) || timeline.t_s[i] < rec.twin.first_stop_s;
        if (timeline.moving[i] != 0 && before_stop) moving.push_back(i);
      }
      if (moving.empty()) {
        rec.what = "a fault, not injected: the undisturbed lift never moved";
        rec.run = rec.twin;
        return rec;
      }
      const std::size_t pick = moving[static_cast<std::size_t>(u[0] * static_cast<double>(moving.size())) % moving.size()];
      rec.fault_s = timeline.t_s[pick];
      const std::uint32_t mask = timeline.moving[pick];
      std::vector<int> joints;
      for (int j = 0; j < n; ++j) {
        if ((mask >> j) & 1u) joints.push_back(j);
      }
      const int joint = joints[static_cast<std::size_t>(u[1] * static_cast<double>(joints.size())) % joints.size()];
      const planning::JointSpec& spec = s.machine.joints[static_cast<std::size_t>(joint)];
      const bool revolute = spec.type == planning::JointType::Revolute;
      const bool tagged = has_tags(s);
      std::vector<std::string> kinds = {"encoder-stuck", "encoder-step", "encoder-drift", "encoder-dropout", "heartbeat-lost:joint",
                                        "heartbeat-lost:valve", "heartbeat-lost:cutoff", "bus-off", "valve-ignore"};
      if (tagged) {
        kinds.push_back("heartbeat-lost:uwb");
        kinds.push_back("uwb-silent");
        kinds.push_back("tag-noise");
      }
      const std::string kind = kinds[static_cast<std::size_t>(u[2] * static_cast<double>(kinds.size())) % kinds.size()];
      const std::string at = fmt("@%.3f", rec.fault_s);
      // A lying encoder: the monitor's findings, the boom inclinometer's disagreement (on the joint
      // it measures), or a lie that cancels the joint's motion and so repeats the encoder's value.
      const std::vector<TransitionReason> lie = {TransitionReason::EncoderImplausible, TransitionReason::JointRunaway,
                                                 TransitionReason::JointNotFollowing, TransitionReason::AngleDisagrees,
                                                 TransitionReason::EncoderStuck};
      std::string text;
      if (kind == "encoder-stuck") {
        text = "encoder-stuck:" + spec.name + at;
        // On the boom the inclinometer may see it first.
        expect = {{TransitionReason::EncoderStuck, TransitionReason::AngleDisagrees}, joint, 0.3};
      } else if (kind == "encoder-step") {
        // A step the monitor can tell from motion (docs/diagnostics.md, EncoderStep): 1.5 to 4
        // times 1.5 × the joint's speed limit × 30 ms (two SYNCs apart and 10 ms), at least
        // 0.3° or 3 cm; smaller ones are among what it cannot see.
        const double bound = 1.5 * spec.max_velocity * 0.03 / (revolute ? kDeg : 1.0);
        const double step = (u[3] < 0.5 ? -1.0 : 1.0) * std::max((1.5 + 2.5 * u[4]) * bound, revolute ? 0.3 : 0.03);
        text = "encoder-offset:" + spec.name + at + fmt(",offset=%.4f", step);
        expect = {lie, joint, 0.3};
      } else if (kind == "encoder-drift") {
        // A drift faster than the actuator model's bracket widens: 0.6 to 1.2 times the joint's
        // speed limit (the bracket is ±25 % of the commanded speed and a ±5 % deadband).
        const double rate = (u[3] < 0.5 ? -1.0 : 1.0) * (0.6 + 0.6 * u[4]) * spec.max_velocity / (revolute ? kDeg : 1.0);
        text = "encoder-offset:" + spec.name + at + fmt(",rate=%.4f", rate);
        expect = {lie, joint, 0.3};
      } else if (kind == "encoder-dropout") {
        text = "encoder-dropout:" + spec.name + at;
        // Stale 30 ms after the last sample, seen at the next cycle's read, acted on in that cycle.
        expect = {{TransitionReason::EncoderStale}, joint, 0.05};
      } else if (kind == "heartbeat-lost:joint") {
        text = "heartbeat-lost:" + spec.name + at;
        // Missing 250 ms after the last heartbeat, which came before the fault; one cycle to read it.
        expect = {{TransitionReason::EncoderMissing}, joint, 0.27};
      } else if (kind == "heartbeat-lost:valve") {
        text = "heartbeat-lost:valve" + at;
        expect = {{TransitionReason::ValveHeartbeatLost}, -2, 0.27};
      } else if (kind == "heartbeat-lost:cutoff") {
        text = "heartbeat-lost:cutoff" + at;
        expect = {{TransitionReason::CutoffLost}, -2, 0.27};
      } else if (kind == "heartbeat-lost:uwb") {
        text = "heartbeat-lost:uwb" + at;
        expect = {{TransitionReason::UwbGatewayLost}, -2, 0.27};
      } else if (kind == "bus-off") {
        text = "bus-off" + at;
        // The transport reports bus-off at once: the next cycle.
        expect = {{TransitionReason::BusOff}, -2, 0.02};
      } else if (kind == "valve-ignore") {
        text = "valve-ignore" + at;
        expect = {{TransitionReason::ValveNotObeying}, -2, 0.3};
      } else if (kind == "uwb-silent") {
        text = "uwb-silent" + at;
        // No fix from any tag for 1 s; the last fix was sent up to 50 ms (its latency) after it was made.
        expect = {{TransitionReason::UwbSilent}, -2, 1.07};
      } else {
        int tag = 0;
        std::vector<int> ids;
        for (const auto& d : s.dynamic_obstacles) {
          for (const auto& t : d.tags) ids.push_back(t.id);
        }
        tag = ids[static_cast<std::size_t>(u[3] * static_cast<double>(ids.size())) % ids.size()];
        text = fmt("tag-noise:%d", tag) + at + fmt(",sigma_m=%.2f", 1.0 + 2.0 * u[4]);
        expect = {};
      }
      rec.fault_text = text;
      setup.config.faults.push_back(sim::parse_machine_fault(text, s.machine.joints));
      for (const TransitionReason r : expect.reasons) rec.expected_reasons.emplace_back(guidance::to_string(r));
      rec.expected_value = expect.value;
      rec.detect_budget_s = expect.budget_s;
      rec.what = "fault " + text;
      setup.fault_s = rec.fault_s;
      setup.expect = expect.reasons.empty() ? nullptr : &expect;
      break;
    }
    case Disturbance::None: break;
  }

  setup.scenario = &s;
  setup.goal = goal;
  setup.bus_name = bus;
  setup.limit_s = rec.twin.end_s + kExtraLimitS;
  FaultFinding finding;
  rec.run = run_lift(setup, &finding);
  rec.detected = finding.detected;
  rec.detect_s = finding.detect_s;
  return rec;
}

std::string lift_record_text(const LiftRecord& rec) {
  const std::string generated = rec.family.empty() ? std::string()
                                                   : fmt(" (generated: family %s, site seed %llu, %d site%s redrawn before it)", rec.family.c_str(),
                                                         static_cast<unsigned long long>(rec.site_seed), rec.site_redraws,
                                                         rec.site_redraws == 1 ? "" : "s");
  std::string t = fmt("lift %d (seed %llu): %s%s, goal %s (%s)\n", rec.index, static_cast<unsigned long long>(rec.seed), rec.site.c_str(),
                      generated.c_str(),
                      [&] {
                        std::string g;
                        for (std::size_t j = 0; j < rec.goal.size(); ++j) g += fmt("%s%.5f", j == 0 ? "" : " ", rec.goal[j]);
                        return g;
                      }().c_str(),
                      rec.goal_draws == 0 ? "the scenario's own" : fmt("feasible at draw %d", rec.goal_draws).c_str());
  t += fmt("  disturbance: %s: %s\n", to_string(rec.disturbance), rec.what.c_str());
  if (!rec.expected_reasons.empty()) {
    std::string reasons;
    for (const auto& r : rec.expected_reasons) reasons += (reasons.empty() ? "" : " or ") + r;
    t += fmt("  fault at %.3f s: expected %s%s within %.2f s; %s\n", rec.fault_s, reasons.c_str(),
             rec.expected_value >= 0 ? fmt(" naming %d", rec.expected_value).c_str() : "", rec.detect_budget_s,
             rec.detected ? fmt("found after %.3f s", rec.detect_s).c_str() : "NOT found");
  }
  t += "  twin: " + run_text(rec.twin) + "\n";
  t += "  lift: " + run_text(rec.run) + "\n";
  return t;
}

std::vector<LiftRecord> run_campaign(const CampaignOptions& options) {
  const int first = std::max(options.first_lift, 0);
  const int lifts = std::max(options.lifts - first, 0);
  std::vector<LiftRecord> records(static_cast<std::size_t>(lifts));
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  std::string error;
  int finished = 0;
  const auto wall0 = std::chrono::steady_clock::now();
  const auto worker = [&] {
    for (;;) {
      const int i = next.fetch_add(1);
      if (i >= lifts || failed.load()) return;
      try {
        records[static_cast<std::size_t>(i)] = run_campaign_lift(options, first + i);
      } catch (const std::exception& e) {
        const std::lock_guard lock(mutex);
        if (!failed.exchange(true)) error = fmt("lift %d: %s", first + i, e.what());
        return;
      }
      const std::lock_guard lock(mutex);
      ++finished;
      if (options.progress) {
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        const int width = 40;
        const int filled = finished * width / std::max(lifts, 1);
        std::fprintf(stderr, "\r[campaign] [%s%s] %d/%d lifts, %.0f s", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                     std::string(static_cast<std::size_t>(width - filled), '.').c_str(), finished, lifts, wall);
        if (finished == lifts) std::fprintf(stderr, "\n");
      }
    }
  };
  const int threads = std::max(1, options.threads);
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (failed.load()) throw std::runtime_error(error);
  return records;
}

namespace {

std::string csv_text(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string csv_row(const LiftRecord& rec) {
  const LiftRun& r = rec.run;
  const LiftRun& w = rec.twin;
  std::string reasons;
  for (const auto& e : rec.expected_reasons) reasons += (reasons.empty() ? "" : "|") + e;
  return fmt("%d,%llu,%s,%s,%s,%s,%.3f,%s,%.3f,%d,%.3f,%d,%s,%s,%.3f,%.3f,%.3f,%d,%d,%d,%s,%d,%.3f,%.4f,%.4f,%.4f,%.4f,%llu,%llu,%.3f,%s,%d,%d,%.3f,%.3f,"
             "%.3f,%d,%.3f,%d,%d,%s\n",
             rec.index, static_cast<unsigned long long>(rec.seed), rec.site.c_str(), to_string(rec.disturbance), csv_text(rec.what).c_str(),
             csv_text(rec.fault_text).c_str(), rec.fault_s, reasons.c_str(), rec.detect_budget_s, rec.detected ? 1 : 0, rec.detect_s,
             r.completed ? 1 : 0, r.state.c_str(), r.reason.c_str(), r.end_s, r.lift_s, w.lift_s, r.stops, r.safety_stops, r.replans,
             r.first_stop_reason.empty() ? "" : r.first_stop_reason.c_str(), r.approach_warnings, r.first_stop_s, r.least_clearance_m,
             r.least_dynamic_m, r.least_ground_m, r.peak_chart, static_cast<unsigned long long>(r.samples_chart_exceeded),
             static_cast<unsigned long long>(r.samples_below_ground), r.contact_s, csv_text(r.contact_with).c_str(),
             r.contact_machine_at_rest ? 1 : 0, r.contact_intruder_moving ? 1 : 0, r.approach_lead_s, r.intruder_moving_for_s, r.rest_after_fault_s,
             w.completed ? 1 : 0,
             w.end_s, w.stops, w.safety_stops, csv_text(r.transitions).c_str());
}

constexpr const char* kCsvHeader =
    "lift,seed,site,disturbance,what,fault,fault_s,expected_reasons,detect_budget_s,detected,detect_s,completed,state,reason,end_s,"
    "lift_s,twin_lift_s,stops,safety_stops,repairs,first_stop_reason,approach_warnings,first_stop_s,least_clearance_m,least_dynamic_m,"
    "least_load_above_ground_m,peak_chart_utilisation,samples_over_chart,samples_below_ground,contact_s,contact_with,contact_machine_at_rest,"
    "contact_intruder_moving,approach_lead_s,intruder_moving_for_s,rest_after_fault_s,twin_completed,twin_end_s,twin_stops,twin_safety_stops,transitions\n";

//! "3, 17, 240" (at most `most`, then "…").
std::string lift_list(const std::vector<int>& lifts, std::size_t most = 30) {
  if (lifts.empty()) return "none";
  std::string t;
  for (std::size_t i = 0; i < lifts.size() && i < most; ++i) t += fmt("%s%d", i == 0 ? "" : ", ", lifts[i]);
  if (lifts.size() > most) t += fmt(", … (%zu in all)", lifts.size());
  return t;
}

//! The campaign's tallies over a set of lifts, each with the lifts behind it so that any one
//! replays with --lift N.
struct Tally {
  std::size_t lifts = 0;
  std::vector<int> contact_bad, contact_apart, contact_moving, not_completed_contact, not_injected, lead_short, chart_over, below_ground,
      not_completed, false_stops, twin_incomplete, missed, late, sudden, redrawn;
  std::vector<double> ratios_disturbed, leads, sudden_leads;
  int judged_completion = 0, completed = 0, faults_judged = 0, faults_found = 0, site_redraws = 0;
  std::map<std::string, std::vector<double>> detect_by_kind;
  std::map<std::string, double> budget_by_kind;
  std::map<std::string, int> faults_by_kind;
  std::map<std::string, int> count_by_kind;
  //! Lifts completed of those judged: per shipped site file, per generated site family.
  std::map<std::string, std::pair<int, int>> completion_by_site, completion_by_family;
  std::vector<double> twin_lift_s, wall_per_lift;
  double min_clearance = std::numeric_limits<double>::infinity(), min_ground = std::numeric_limits<double>::infinity(), peak_chart = 0.0;
};

void add(Tally& t, const LiftRecord& rec) {
  const LiftRun& r = rec.run;
  ++t.lifts;
  ++t.count_by_kind[to_string(rec.disturbance)];
  t.site_redraws += rec.site_redraws;
  if (rec.site_redraws > 0) t.redrawn.push_back(rec.index);
  t.wall_per_lift.push_back(r.wall_s + (rec.disturbance == Disturbance::None ? 0.0 : rec.twin.wall_s));
  for (const LiftRun* run : {&rec.twin, &rec.run}) {
    if (run->samples_chart_exceeded > 0 && (t.chart_over.empty() || t.chart_over.back() != rec.index)) t.chart_over.push_back(rec.index);
    if (run->samples_below_ground > 0 && (t.below_ground.empty() || t.below_ground.back() != rec.index)) t.below_ground.push_back(rec.index);
    if (!std::isnan(run->contact_s)) {
      // A moving intruder that touches the machine did not cooperate: into a machine at rest
      // it is counted apart with its warning; into one still moving, listed apart as well.
      // Anything else (a standing obstacle, the static site) is the machine's own contact.
      if (run->contact_intruder_moving && run->contact_machine_at_rest) {
        if (t.contact_apart.empty() || t.contact_apart.back() != rec.index) {
          t.contact_apart.push_back(rec.index);
          // No warning can come before the intruder starts to move: one that set off less than
          // the lead before the contact is listed with its lead, not judged by the target.
          if (run->intruder_moving_for_s >= kApproachLeadS) {
            t.leads.push_back(run->approach_lead_s);
            if (!(run->approach_lead_s >= kApproachLeadS)) t.lead_short.push_back(rec.index);
          } else {
            t.sudden.push_back(rec.index);
            t.sudden_leads.push_back(std::isnan(run->approach_lead_s) ? 0.0 : run->approach_lead_s);
          }
        }
      } else if (run->contact_intruder_moving) {
        if (t.contact_moving.empty() || t.contact_moving.back() != rec.index) t.contact_moving.push_back(rec.index);
      } else if (t.contact_bad.empty() || t.contact_bad.back() != rec.index) {
        t.contact_bad.push_back(rec.index);
      }
    }
    t.min_clearance = std::min(t.min_clearance, run->least_clearance_m);
    if (!std::isnan(run->least_ground_m)) t.min_ground = std::min(t.min_ground, run->least_ground_m);
    if (!std::isnan(run->peak_chart)) t.peak_chart = std::max(t.peak_chart, run->peak_chart);
  }
  if (rec.twin.stops > 0) t.false_stops.push_back(rec.index);
  if (!rec.twin.completed) t.twin_incomplete.push_back(rec.index);
  if (rec.twin.completed) t.twin_lift_s.push_back(rec.twin.lift_s);
  // Completion is judged where nothing had to stop the lift: no fault, or one the controller
  // is to ride through (tag noise).
  const bool stopping_fault = rec.disturbance == Disturbance::Fault && !rec.expected_reasons.empty();
  if (!stopping_fault) {
    ++t.judged_completion;
    auto& site = rec.family.empty() ? t.completion_by_site[rec.site] : t.completion_by_family[rec.family];
    ++site.second;
    if (r.completed) {
      ++t.completed;
      ++site.first;
    } else {
      t.not_completed.push_back(rec.index);
      if (!std::isnan(r.contact_s) && r.contact_intruder_moving) t.not_completed_contact.push_back(rec.index);
      if (rec.disturbance == Disturbance::Fault && rec.fault_text.empty()) t.not_injected.push_back(rec.index);
    }
    if (r.completed && rec.twin.completed && rec.twin.lift_s > 0.0 && rec.disturbance != Disturbance::None) {
      t.ratios_disturbed.push_back(r.lift_s / rec.twin.lift_s);
    }
  } else {
    ++t.faults_judged;
    const std::string kind = rec.fault_text.substr(0, rec.fault_text.find_first_of(":@"));
    const std::string key = kind == "heartbeat-lost" ? rec.fault_text.substr(0, rec.fault_text.find('@')) : kind;
    const std::string group = key.rfind("heartbeat-lost:", 0) == 0 &&
                                      key != "heartbeat-lost:valve" && key != "heartbeat-lost:cutoff" && key != "heartbeat-lost:uwb"
                                  ? "heartbeat-lost:joint"
                              : kind == "encoder-offset" ? (rec.fault_text.find(",rate=") != std::string::npos ? "encoder-offset (drift)" : "encoder-offset (step)")
                                                         : key;
    ++t.faults_by_kind[group];
    t.budget_by_kind[group] = rec.detect_budget_s;
    if (rec.detected) {
      ++t.faults_found;
      t.detect_by_kind[group].push_back(rec.detect_s);
      if (rec.detect_s > rec.detect_budget_s + 1e-9) t.late.push_back(rec.index);
    } else {
      t.missed.push_back(rec.index);
    }
  }
}

//! The targets, each met or not, with its figures and the lifts behind them.
std::string targets_table(const Tally& t) {
  const double completion = t.judged_completion == 0 ? 0.0 : static_cast<double>(t.completed) / t.judged_completion;
  const double median_ratio = t.ratios_disturbed.empty() ? 0.0 : percentile(t.ratios_disturbed, 0.5);
  const auto met = [](bool ok) { return ok ? "met" : "**NOT met**"; };
  std::string md = "| Target | Result | |\n|---|---|---|\n";
  md += fmt("| 0 contacts where the intruder cooperates or stands still (true clearance under 1 mm, lifts and twins) | %zu (lifts %s) | %s |\n",
            t.contact_bad.size(), lift_list(t.contact_bad).c_str(), met(t.contact_bad.empty()));
  md += fmt("| 0 chart exceedances in the true state | %zu (lifts %s); peak utilisation %.3f | %s |\n", t.chart_over.size(),
            lift_list(t.chart_over).c_str(), t.peak_chart, met(t.chart_over.empty()));
  md += fmt("| 0 loads below ground in the true state | %zu (lifts %s); least load above ground %.3f m | %s |\n", t.below_ground.size(),
            lift_list(t.below_ground).c_str(), t.min_ground, met(t.below_ground.empty()));
  md += fmt("| an uncooperative intruder sweeping into the machine at rest (counted apart): the approach warning >= 4 s before, where "
            "the intruder had been moving for 4 s | %zu contacts (lifts %s); of them %zu moving for 4 s, lead %s; under 4 s or none: %s; "
            "moving for less (no 4 s warning possible): %s, lead %s | %s |\n",
            t.contact_apart.size(), lift_list(t.contact_apart).c_str(), t.leads.size(),
            t.leads.empty() ? "–" : fmt("min %.2f s, median %.2f s", *std::min_element(t.leads.begin(), t.leads.end()), percentile(t.leads, 0.5)).c_str(),
            lift_list(t.lead_short).c_str(), lift_list(t.sudden).c_str(),
            t.sudden_leads.empty() ? "–" : fmt("min %.2f s, max %.2f s", *std::min_element(t.sudden_leads.begin(), t.sudden_leads.end()),
                                                *std::max_element(t.sudden_leads.begin(), t.sudden_leads.end())).c_str(),
            met(t.lead_short.empty()));
  md += fmt("| (no target) an uncooperative intruder moving into the machine while it moves or stops | %zu (lifts %s) | listed |\n",
            t.contact_moving.size(), lift_list(t.contact_moving).c_str());
  md += fmt("| >= 95 %% of lifts completed (lifts without a fault that must stop them: %d) | %.1f %% (%d); not completed: %s; of them "
            "after an intruder moved into the machine: %s; a fault not injected, the undisturbed lift never moved: %s | %s |\n",
            t.judged_completion, 100.0 * completion, t.completed, lift_list(t.not_completed).c_str(), lift_list(t.not_completed_contact).c_str(),
            lift_list(t.not_injected).c_str(), met(completion >= 0.95));
  md += fmt("| median lift time <= 1.3 × its undisturbed twin (completed disturbed lifts: %zu) | %.3f × (p95 %.3f ×, max %.3f ×) | %s |\n",
            t.ratios_disturbed.size(), median_ratio, t.ratios_disturbed.empty() ? 0.0 : percentile(t.ratios_disturbed, 0.95),
            t.ratios_disturbed.empty() ? 0.0 : *std::max_element(t.ratios_disturbed.begin(), t.ratios_disturbed.end()), met(median_ratio <= 1.3));
  md += fmt("| 0 safety stops in the %zu undisturbed lifts (no false stops) | %zu (lifts %s); twins not completed: %s | %s |\n",
            t.lifts, t.false_stops.size(), lift_list(t.false_stops).c_str(), lift_list(t.twin_incomplete).c_str(), met(t.false_stops.empty()));
  md += fmt("| every injected fault found within its documented time | %d of %d found, %zu late (lifts %s), %zu not found (lifts %s) | %s |\n",
            t.faults_found, t.faults_judged, t.late.size(), lift_list(t.late).c_str(), t.missed.size(), lift_list(t.missed).c_str(),
            met(t.late.empty() && t.missed.empty()));
  return md;
}

std::string disturbance_counts(const Tally& t) {
  std::string md;
  for (const auto& [kind, count] : t.count_by_kind) md += fmt("%s%s %d", md.empty() ? "" : ", ", kind.c_str(), count);
  return md;
}

}  // namespace

int run_campaign_suite(const CampaignOptions& options) {
  try {
    if (options.lift >= 0) {
      const LiftRecord rec = run_campaign_lift(options, options.lift);
      std::printf("%s", lift_record_text(rec).c_str());
      // Not in the record: without --out the folder differs from run to run.
      if (!rec.family.empty()) std::fprintf(stderr, "mgc-bench: campaign: the site is %s\n", (std::filesystem::path(campaign_sites_dir(options)) / rec.site).c_str());
      return 0;
    }
    const auto wall0 = std::chrono::steady_clock::now();
    const std::string load_before = load_average();
    const std::vector<LiftRecord> records = run_campaign(options);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();

    Tally all, generated;
    for (const LiftRecord& rec : records) {
      add(all, rec);
      if (!rec.family.empty()) add(generated, rec);
    }
    const std::size_t shipped = all.lifts - generated.lifts;
    const int first = records.empty() ? 0 : records.front().index;
    const int last = records.empty() ? 0 : records.back().index;

    std::string md = "### campaign\n\n";
    md += fmt("`%s`: %zu randomized lifts %d..%d (seeds %llu..%llu) on %d threads, each beside its undisturbed twin, in stepped time: "
              "%zu on the shipped sites, %zu on generated sites (lifts from %d; written to %s); judged in the simulator's true state "
              "(docs/safety.md \"The campaign\"). %.0f s wall (%.2f s per lift and twin on one thread, median %.2f s); load average "
              "before %s, after %s.\n\n",
              options.command.c_str(), records.size(), first, last, static_cast<unsigned long long>(options.first_seed + 1 + first),
              static_cast<unsigned long long>(options.first_seed + 1 + last), std::max(1, options.threads), shipped, generated.lifts,
              kShippedLifts, generated.lifts == 0 ? "–" : campaign_sites_dir(options).c_str(), wall_s,
              all.wall_per_lift.empty() ? 0.0 : [&] { double a = 0; for (double w : all.wall_per_lift) a += w; return a / static_cast<double>(all.wall_per_lift.size()); }(),
              all.wall_per_lift.empty() ? 0.0 : percentile(all.wall_per_lift, 0.5), load_before.c_str(), load_average().c_str());
    md += "Disturbances: " + disturbance_counts(all) + ".\n\nThe targets over every lift:\n\n" + targets_table(all);
    if (generated.lifts > 0) {
      md += fmt("\nThe same targets over the %zu lifts on generated sites alone (disturbances: %s; sites that could not be set up and "
                "were redrawn: %d, in lifts %s):\n\n",
                generated.lifts, disturbance_counts(generated).c_str(), generated.site_redraws, lift_list(generated.redrawn).c_str());
      md += targets_table(generated);
    }
    md += "\nFaults by kind (detection: the fault's start to the supervisor's stop or FAULT naming it):\n\n"
          "| fault | injected | found | within | median s | max s |\n|---|---|---|---|---|---|\n";
    for (const auto& [kind, count] : all.faults_by_kind) {
      const auto found = all.detect_by_kind.find(kind);
      const std::vector<double> d = found == all.detect_by_kind.end() ? std::vector<double>{} : found->second;
      md += fmt("| %s | %d | %zu | %.2f s | %s | %s |\n", kind.c_str(), count, d.size(), all.budget_by_kind.at(kind),
                d.empty() ? "–" : fmt("%.3f", percentile(d, 0.5)).c_str(),
                d.empty() ? "–" : fmt("%.3f", *std::max_element(d.begin(), d.end())).c_str());
    }
    md += "\nCompletion by site (lifts without a fault that must stop them; the generated sites by family):\n\n| site | completed |\n|---|---|\n";
    for (const auto& [site, c] : all.completion_by_site) md += fmt("| %s | %d of %d |\n", site.c_str(), c.first, c.second);
    for (const auto& [family, c] : all.completion_by_family) md += fmt("| generated: %s | %d of %d |\n", family.c_str(), c.first, c.second);
    md += fmt("\nUndisturbed lifts: median %.1f s from the goal request to the goal; least true clearance over every run %.3f m.\n",
              all.twin_lift_s.empty() ? 0.0 : percentile(all.twin_lift_s, 0.5), all.min_clearance);
    std::printf("%s\n", md.c_str());
    if (!options.out_dir.empty()) {
      std::filesystem::create_directories(options.out_dir);
      std::ofstream(options.out_dir + "/campaign.md") << md;
      std::ofstream csv(options.out_dir + "/campaign.csv");
      csv << kCsvHeader;
      for (const LiftRecord& rec : records) csv << csv_row(rec);
    }
    return 0;
  } catch (const planning::io::InputError&) {
    throw;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-bench: campaign: %s\n", e.what());
    return 1;
  }
}

}  // namespace mgc::bench
