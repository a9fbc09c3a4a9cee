// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/controller.hpp"

#include <mgc/alert_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/operator_guidance_t.hpp>
#include <mgc/operator_instruction_t.hpp>
#include <mgc/plan_t.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "mgc/firmware/operator_words.hpp"
#include "mgc/firmware/sensing.hpp"
#include "mgc/planning/mobile_crane.hpp"

namespace mgc::firmware {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
//! A setpoint this close to its waypoint has reached it (the generator ends exactly on target). [rad | m]
constexpr double kReachedTolerance = 1e-6;
//! A joint cannot move faster than this multiple of its rated speed: an estimate beyond it is a
//! timing artefact, not motion. [-]
constexpr double kPlausibleSpeedFactor = 1.5;
//! A site member's own motion leads apart from another machine when it widens their gap by more
//! than this within a scan step. [m]
constexpr double kSiteApartM = 1e-3;
//! Another machine whose body points move slower than this, and whose joints stop within as many
//! seconds, is at rest. [m/s, s]
constexpr double kSiteRestSpeedMS = 0.05;
//! Above a distance bound, so that a gap reported at the bound is strictly beyond what matters. [m]
constexpr double kSiteBoundSlackM = 1e-6;
//! An alert stays raised this long after its condition was last seen. [µs]
constexpr std::int64_t kAlertHoldUs = 1'000'000;

//! Longest time-optimal stop of any joint from its full speed. [s]
double longest_stop_s(const planning::MachineModel& model) {
  double t_s = 0.0;
  for (const planning::JointSpec& j : model.joints()) {
    t_s = std::max(t_s, j.max_velocity / j.max_acceleration + j.max_acceleration / j.max_jerk);
  }
  return t_s;
}

//! The planner's world: every moving body dilated by margin_m more than the scenario says, and every
//! dynamic obstacle grown by dynamic_margin_m (boxes, cylinders and capsules; a mesh keeps its
//! shape and only the dilation).
std::unique_ptr<planning::CollisionWorld> planning_world(planning::Scenario scenario, const planning::MachineModel& model,
                                                        double margin_m, double dynamic_margin_m) {
  const double scenario_dilation_m = scenario.planner.dilation_m;
  scenario.planner.dilation_m += margin_m;
  for (planning::DynamicObstacleSpec& d : scenario.dynamic_obstacles) {
    for (planning::ShapePart& part : d.obstacle.parts) {
      switch (part.kind) {
        case planning::ShapeKind::Box:
          part.size_m += Eigen::Vector3d::Constant(2.0 * dynamic_margin_m);
          break;
        case planning::ShapeKind::Cylinder:
          part.size_m += Eigen::Vector3d(2.0 * dynamic_margin_m, 2.0 * dynamic_margin_m, 2.0 * dynamic_margin_m);
          break;
        case planning::ShapeKind::Capsule:
          part.size_m += Eigen::Vector3d(2.0 * dynamic_margin_m, 2.0 * dynamic_margin_m, 0.0);
          break;
        case planning::ShapeKind::Mesh:
          break;
      }
    }
  }
  auto world = planning::build_world(scenario, model);
  // The margin is for motion: a carrier or undercarriage keeps the scenario's dilation.
  world->set_fixed_body_dilation(scenario_dilation_m);
  return world;
}

guidance::SupervisorConfig supervisor_config(guidance::SupervisorConfig c, const planning::Scenario& s) {
  c.num_joints = static_cast<int>(s.machine.joints.size());
  bool tagged = false;
  for (const auto& d : s.dynamic_obstacles) tagged = tagged || !d.tags.empty();
  c.uwb_required = tagged;
  return c;
}

std::vector<guidance::PlausibilityJoint> plausibility_joints(const planning::MachineModel& model) {
  std::vector<guidance::PlausibilityJoint> joints;
  for (const planning::JointSpec& j : model.joints()) {
    joints.push_back({j.max_velocity, j.max_acceleration, j.position_min, j.position_max, j.continuous,
                      j.type == planning::JointType::Prismatic});
  }
  return joints;
}

//! The scenario's machine tags on the model (the loader accepted their mounts; a model without one
//! is refused by MachineTagCheck).
std::vector<guidance::MachineTag> machine_tag_list(const planning::Scenario& s, const planning::MachineModel& model) {
  std::vector<guidance::MachineTag> tags;
  for (const planning::MachineTagSpec& t : s.machine_tags) {
    tags.push_back({static_cast<std::uint8_t>(t.id), planning::resolve_tag_mount(model, t.body), t.position_m});
  }
  return tags;
}

//! The joint whose link carries the bus plan's inclinometer; -1 when the machine's plan has none
//! (or the machine has no plan).
int bus_plan_inclinometer_joint(const planning::Scenario& s) {
  std::vector<std::string> names;
  for (const planning::JointSpec& j : s.machine.joints) names.push_back(j.name);
  try {
    return hal::bus_plan_for(planning::to_string(s.machine.kind), names).inclinometer_joint;
  } catch (const std::invalid_argument&) {
    return -1;
  }
}

RateLimiter make_limiter(const planning::MachineModel& model) {
  const auto limits = rate_limits_from(model.joints(), JerkLimit::Off);
  return RateLimiter(std::span<const RateLimits>(limits.data(), static_cast<std::size_t>(model.dof())));
}

std::int8_t state_code(guidance::SupervisorState s) noexcept {
  // machine_state_t's SUPERVISOR_* are the supervisor's states in order, from 1.
  return static_cast<std::int8_t>(static_cast<int>(s) + 1);
}

// Alert slots, one per kind of condition.
enum AlertKind : std::size_t {
  kAlertCollision = 0,
  kAlertLoadChart,
  kAlertFault,
  kAlertEstop,
  kAlertPlanner,
  kAlertOperator,
  kAlertTracking,
  kAlertEnvelope,
  kAlertApproach,
  kAlertCutoff,
  kAlertMachineTag,
  kAlertSite,
  kAlertInclinometer,
};

std::unique_ptr<guidance::Envelope> make_envelope(const planning::Scenario& scenario, const planning::MachineModel& model) {
  if (!scenario.envelope) return nullptr;
  return std::make_unique<guidance::Envelope>(model, guidance::envelope_config(*scenario.envelope, model));
}

// The feed's envelope codes are the limiter's limits in order.
static_assert(static_cast<int>(guidance::EnvelopeLimit::HeightCeiling) == mgc::operator_instruction_t::ENVELOPE_HEIGHT_CEILING);
static_assert(static_cast<int>(guidance::EnvelopeLimit::Wall) == mgc::operator_instruction_t::ENVELOPE_WALL);

//! Alert index of an envelope limit (alert_t.index): its feed code, a wall's plus its index.
std::int32_t envelope_alert_index(const guidance::EnvelopeDistance& d) noexcept {
  if (d.limit == guidance::EnvelopeLimit::None) return -1;
  return static_cast<std::int32_t>(d.limit) + (d.limit == guidance::EnvelopeLimit::Wall ? std::max(d.wall, 0) : 0);
}

//! The scenario's guidance margins over the configured ones, checked together: a stop zone inside
//! the warning zone, and plans that keep at least what an escape keeps, which keeps at least the
//! stop margin (or a planned motion would itself be stopped).
ControllerConfig with_site_margins(ControllerConfig c, const planning::Scenario& scenario) {
  std::string where = "controller";
  if (scenario.guidance) {
    const planning::GuidanceSpec& g = *scenario.guidance;
    if (g.stop_margin_m) c.stop_check.stop_margin_m = *g.stop_margin_m;
    if (g.warning_margin_m) c.stop_check.warning_margin_m = *g.warning_margin_m;
    if (g.planning_margin_m) c.planning_margin_m = *g.planning_margin_m;
    if (g.escape_margin_m) c.escape_margin_m = *g.escape_margin_m;
    where = g.ref.file + ":" + std::to_string(g.ref.line) + ": " + g.ref.field;
  }
  const auto number = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", v);
    return std::string(text);
  };
  const double stop = c.stop_check.stop_margin_m;
  const double warning = c.stop_check.warning_margin_m;
  if (!(stop > 0.0 && stop < warning)) {
    throw std::invalid_argument(where + ": stop_margin_m (" + number(stop) + " m) must be above 0 and below warning_margin_m (" +
                                number(warning) + " m); an absent field is mgc's default");
  }
  if (!(stop <= c.escape_margin_m && c.escape_margin_m <= c.planning_margin_m)) {
    throw std::invalid_argument(where + ": expected stop_margin_m (" + number(stop) + " m) <= escape_margin_m (" +
                                number(c.escape_margin_m) + " m) <= planning_margin_m (" + number(c.planning_margin_m) +
                                " m); an absent field is mgc's default");
  }
  return c;
}

std::int8_t fault_source(guidance::TransitionReason r) noexcept {
  return r == guidance::TransitionReason::WatchdogTripped ? mgc::alert_t::SOURCE_WATCHDOG : mgc::alert_t::SOURCE_SENSING;
}

}  // namespace

Controller::Controller(const planning::Scenario& scenario, const ControllerConfig& config) : Controller(scenario, config, nullptr) {}

Controller::Controller(const planning::Scenario& scenario, const ControllerConfig& config, const SiteMemberConfig* site)
    : config_(with_site_margins(config, scenario)),
      scenario_(site != nullptr ? site_member_scenario(scenario, *site) : scenario),
      model_(planning::build_model(scenario_)),
      plan_world_(planning_world(scenario_, *model_, config_.planning_margin_m,
                                 config.obstacle_speed_floor_m_s * longest_stop_s(*model_))),
      safety_world_(planning::build_world(site != nullptr ? site_stop_check_scenario(scenario_, scenario.dynamic_obstacles.size()) : scenario_,
                                          *model_)),
      problem_(planning::planning_problem(scenario_, *model_, *plan_world_)),
      replanner_(planning::make_replanner(config.replanner)),
      spare_problem_(problem_),
      spare_(planning::make_replanner(config.replanner)),
      escape_world_(planning_world(scenario_, *model_, config_.escape_margin_m, 0.0)),
      escape_problem_(planning::planning_problem(scenario_, *model_, *escape_world_)),
      escape_(planning::make_replanner(config.replanner)),
      retreat_(std::make_unique<planning::RetreatSearch>(*safety_world_, *escape_world_, config.retreat)),
      path_(model_->dof(), config.max_path_waypoints),
      envelope_(make_envelope(scenario_, *model_)),
      stop_check_(*safety_world_, envelope_.get(), config_.stop_check),
      supervisor_(supervisor_config(config.supervisor, scenario_)),
      monitor_(plausibility_joints(*model_), config.plausibility),
      tag_check_(*model_, machine_tag_list(scenario_, *model_), config.machine_tags),
      inclinometer_check_(bus_plan_inclinometer_joint(scenario_), config.inclinometer),
      limiter_(make_limiter(*model_)),
      n_(model_->dof()) {
  if (!replanner_) throw std::invalid_argument("controller: unknown re-planner '" + config.replanner + "'");
  for (std::size_t k = 0; k < scenario_.machine_tags.size(); ++k) {
    machine_tag_ids_[k] = static_cast<std::uint8_t>(scenario_.machine_tags[k].id);
    machine_tag_fixes_[k].id = machine_tag_ids_[k];
  }
  if (config.plan_iterations_per_cycle < 1 || config.escape_iterations_per_cycle < 1) {
    throw std::invalid_argument("controller: plan_iterations_per_cycle and escape_iterations_per_cycle must be >= 1");
  }
  if (!(config.approach_step_s > 0.0) || !(config.approach_horizon_s >= config.approach_step_s)) {
    throw std::invalid_argument("controller: approach_step_s must be > 0 and approach_horizon_s at least approach_step_s");
  }
  if (config.retreat_configs_per_cycle < 1) throw std::invalid_argument("controller: retreat_configs_per_cycle must be >= 1");
  if (config.shorten_chunks_per_cycle < 1) throw std::invalid_argument("controller: shorten_chunks_per_cycle must be >= 1");
  if (config.max_path_waypoints < 2) throw std::invalid_argument("controller: max_path_waypoints must be >= 2");
  if (!(config.retreat_floor_tolerance_m >= 0.0)) throw std::invalid_argument("controller: retreat_floor_tolerance_m must be >= 0");
  if (!(config.repair_detour_ratio >= 1.0)) throw std::invalid_argument("controller: repair_detour_ratio must be >= 1");
  if (!(config.acceleration_lead_s >= 0.0 && config.acceleration_lead_s <= 1.0)) {
    throw std::invalid_argument("controller: acceleration_lead_s must be in [0, 1] s");
  }
  if (!(config.follow_speed_fraction > 0.0 && config.follow_speed_fraction <= 1.0)) {
    throw std::invalid_argument("controller: follow_speed_fraction must be in (0, 1]");
  }
  if (n_ > static_cast<int>(guidance::OneJointAtATime::kMaxJoints)) throw std::invalid_argument("controller: too many joints");
  if (!(config.obstacle_speed_floor_m_s >= 0.0) || config.obstacle_speed_window_us <= 0 || !(config.obstacle_sigma_factor >= 0.0)) {
    throw std::invalid_argument(
        "controller: obstacle_speed_floor_m_s and obstacle_sigma_factor must be >= 0 and obstacle_speed_window_us > 0");
  }
  for (std::size_t i = 0; i < scenario_.dynamic_obstacles.size(); ++i) {
    const planning::DynamicObstacleSpec& d = scenario_.dynamic_obstacles[i];
    if (d.tags.empty()) continue;
    trackers_.emplace_back(d, config.tracker);
    PoseHistory h;
    h.obstacle = static_cast<int>(i);
    for (const planning::ShapePart& part : d.obstacle.parts) {
      const double reach = part.kind == planning::ShapeKind::Mesh ? 0.0 : 0.5 * part.size_m.norm();
      h.radius_m = std::max(h.radius_m, part.pose.translation().norm() + reach);
      for (const Eigen::Vector3d& v : part.vertices_m) h.radius_m = std::max(h.radius_m, (part.pose * v).norm());
    }
    histories_.push_back(h);
  }
  if (envelope_) {
    if (!(config.envelope_planning_margin_m >= 0.0 && config.envelope_escape_margin_m >= 0.0)) {
      throw std::invalid_argument("controller: envelope_planning_margin_m and envelope_escape_margin_m must be >= 0");
    }
    plan_rule_ = std::make_unique<guidance::EnvelopeRule>(*model_, envelope_->config(), config.envelope_planning_margin_m);
    escape_rule_ = std::make_unique<guidance::EnvelopeRule>(*model_, envelope_->config(), config.envelope_escape_margin_m);
    plan_world_->set_rule(plan_rule_.get());
    escape_world_->set_rule(escape_rule_.get());
  }
  obstacle_speed_m_s_ = config.stop_check.dynamic_obstacle_speed_m_s;
  replan_settings_.max_iterations = scenario_.planner.replan_max_iterations;
  replan_settings_.goal_bias = scenario_.planner.replan_goal_bias;
  // Sizes every buffer of the re-planner now, so that the goal request in the loop does not.
  (void)replanner_->reset(problem_, replan_settings_);
  (void)spare_->reset(spare_problem_, replan_settings_);
  // An escape is planned from scratch round an obstacle parked next to the machine: a harder query
  // than the first plan, with the machine at rest meanwhile, so it may take longer.
  escape_problem_.max_iterations = std::max(escape_problem_.max_iterations, config.escape_max_iterations);
  escape_settings_ = replan_settings_;
  escape_settings_.max_iterations = std::max(escape_settings_.max_iterations, config.escape_max_iterations);
  (void)escape_->reset(escape_problem_, escape_settings_);
  planner_status_ = planning::PlannerStatus::NotReset;
  active_ = replanner_.get();

  if (model_->kind() == planning::MachineKind::MobileCrane) {
    const auto* crane = dynamic_cast<const planning::MobileCrane*>(model_.get());
    if (crane && scenario_.task) rcl_ = std::make_unique<guidance::RatedCapacityLimiter>(*crane, config.rated_capacity);
  }
  for (int j = 0; j < n_; ++j) {
    const planning::JointSpec& spec = model_->joints()[static_cast<std::size_t>(j)];
    follow_limits_[static_cast<std::size_t>(j)] = {config.follow_speed_fraction * spec.max_velocity,
                                                   config.follow_speed_fraction * spec.max_acceleration, spec.max_jerk};
  }
  q_raw_ = planning::JointVector::Zero(n_);
  q_unwrapped_ = q_raw_;
  q_wrapped_ = q_raw_;
  goal_ = scenario_.goal;
  origin_ = q_raw_;
  retreat_from_ = q_raw_;
  target_unwrapped_ = q_raw_;
  v_command_ = q_raw_;
  v_probe_ = q_raw_;
  snap_.machine_kind = model_->kind();
  snap_.num_joints = n_;
  site_meet_s_.fill(std::numeric_limits<double>::infinity());
  if (site != nullptr) {
    site_ = std::make_unique<SiteMemberConfig>(*site);
    site_roster_ = make_site_roster(site_->site);
    site_peers_ = make_site_peers(*site_, *model_, static_cast<int>(scenario.dynamic_obstacles.size()));
    const int me = site_roster_.index_of(site_->machine_id);
    site_priority_ = site_roster_.machines[static_cast<std::size_t>(me)].priority;
    if (!(site_->scan_step_s > 0.0) || !(site_->slow_down_scale > 0.0 && site_->slow_down_scale <= 1.0)) {
      throw std::invalid_argument("controller: site scan_step_s must be > 0 and slow_down_scale in (0, 1]");
    }
    site_q_ = q_raw_;
    site_q2_ = q_raw_;
    site_peer_q_ = q_raw_;
    site_v_ = q_raw_;
    site_state_.machine_id = site_->machine_id;
    site_state_.priority = site_priority_;
    site_state_.num_joints = static_cast<std::int8_t>(n_);
    site_plan_.machine_id = site_->machine_id;
    site_plan_.num_joints = static_cast<std::int8_t>(n_);
  }
}

void Controller::estimate(const hal::SensorSnapshot& s, double dt_s) noexcept {
  joints_valid_ = s.all_joints_valid() && s.num_joints >= n_;
  if (!joints_valid_) {
    ++stats_.estimate_invalid_cycles;
    return;
  }
  bool rest = true;
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const hal::JointReading& r = s.joints[k];
    const bool continuous = model_->joints()[k].continuous;
    if (!have_reading_) {
      q_raw_[j] = r.position;
      q_unwrapped_[j] = r.position;
      sample_us_[k] = r.t_us;
      continue;
    }
    double delta = r.position - q_raw_[j];
    if (continuous) delta = std::remainder(delta, kTwoPi);
    q_raw_[j] = r.position;
    q_unwrapped_[j] += delta;
    if (r.t_us > sample_us_[k]) {
      // Receive times jitter with the bus and the scheduler: two samples read close together
      // after a late cycle were still taken a SYNC period apart, so never divide by less than half
      // of this cycle's period.
      const double sample_dt_s = std::max(static_cast<double>(r.t_us - sample_us_[k]) * 1e-6, 0.5 * dt_s);
      const double v_limit = kPlausibleSpeedFactor * model_->joints()[k].max_velocity;
      const double v = std::clamp(delta / sample_dt_s, -v_limit, v_limit);
      const double v_new = velocity_[k] + config_.velocity_filter * (v - velocity_[k]);
      acceleration_[k] += config_.velocity_filter * ((v_new - velocity_[k]) / std::max(sample_dt_s, dt_s) - acceleration_[k]);
      velocity_[k] = v_new;
      sample_us_[k] = r.t_us;
    }
    rest = rest && std::abs(velocity_[k]) < config_.rest_speed;
  }
  for (int j = 0; j < n_; ++j) {
    const planning::JointSpec& spec = model_->joints()[static_cast<std::size_t>(j)];
    const double q = q_unwrapped_[j];
    if (spec.continuous) {
      q_wrapped_[j] = std::remainder(q, kTwoPi);
      continue;
    }
    // A joint at its end stop reads a hair past it with encoder noise; the chart (whose last row
    // may be the end stop) and the planner would take that for a pose outside their range. The
    // true joint cannot be past its stop, so a reading within the tolerance counts as at the stop;
    // one farther out is kept as read, for the plausibility checks to judge.
    const double tolerance = spec.type == planning::JointType::Prismatic ? config_.end_stop_tolerance_m : config_.end_stop_tolerance_rad;
    if (q > spec.position_max && q <= spec.position_max + tolerance) {
      q_wrapped_[j] = spec.position_max;
    } else if (q < spec.position_min && q >= spec.position_min - tolerance) {
      q_wrapped_[j] = spec.position_min;
    } else {
      q_wrapped_[j] = q;
    }
  }
  at_rest_ = have_reading_ && rest;
  have_reading_ = true;
}

void Controller::track_obstacles(const hal::SensorSnapshot& s) noexcept {
  for (std::size_t t = 0; t < trackers_.size(); ++t) {
    PoseHistory& h = histories_[t];
    ObstacleTracker& tracker = trackers_[t];
    if (tracker.update(s, now_us_)) {
      const Eigen::Isometry3d pose = tracker.pose();
      plan_world_->set_dynamic_pose(h.obstacle, pose);
      escape_world_->set_dynamic_pose(h.obstacle, pose);
      safety_world_->set_dynamic_pose(h.obstacle, pose);
      const std::int64_t spacing_us = config_.obstacle_speed_window_us / static_cast<std::int64_t>(PoseHistory::kSamples - 1);
      const std::size_t newest = (h.head + PoseHistory::kSamples - 1) % PoseHistory::kSamples;
      if (h.count == 0 || now_us_ - h.t_us[newest] >= spacing_us) {
        h.t_us[h.head] = now_us_;
        h.position_m[h.head] = tracker.position_m();
        h.yaw_rad[h.head] = tracker.yaw_rad();
        h.head = (h.head + 1) % PoseHistory::kSamples;
        h.count = std::min(h.count + 1, PoseHistory::kSamples);
        if (h.count == PoseHistory::kSamples) {
          // Least-squares slopes over the whole window: the tags' noise averages down with every
          // sample, where a difference of two poses would keep it whole.
          double t_mean_s = 0.0;
          for (std::size_t i = 0; i < PoseHistory::kSamples; ++i) t_mean_s += static_cast<double>(h.t_us[i] - h.t_us[h.head]) * 1e-6;
          t_mean_s /= static_cast<double>(PoseHistory::kSamples);
          double stt = 0.0;
          double yaw_rate = 0.0;
          Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
          const double yaw0 = h.yaw_rad[h.head];
          for (std::size_t i = 0; i < PoseHistory::kSamples; ++i) {
            const double dt_s = static_cast<double>(h.t_us[i] - h.t_us[h.head]) * 1e-6 - t_mean_s;
            stt += dt_s * dt_s;
            velocity += dt_s * h.position_m[i];
            yaw_rate += dt_s * std::remainder(h.yaw_rad[i] - yaw0, kTwoPi);
          }
          velocity /= stt;
          yaw_rate /= stt;
          h.speed_m_s = velocity.norm() + std::abs(yaw_rate) * h.radius_m + config_.obstacle_speed_floor_m_s;
          h.velocity_m_s = velocity;
          h.yaw_rate_rad_s = yaw_rate;
          h.window_full = true;
        }
      }
    }
    if (!tracker.valid(now_us_)) {
      h.count = 0;
      h.window_full = false;
    }
  }
  // Until every obstacle's window is full, the configured speed stands (or more, if measured).
  double speed_m_s = 0.0;
  bool all_measured = true;
  for (const PoseHistory& h : histories_) {
    speed_m_s = std::max(speed_m_s, h.window_full ? h.speed_m_s : 0.0);
    all_measured = all_measured && h.window_full;
  }
  if (!all_measured) speed_m_s = std::max(speed_m_s, config_.stop_check.dynamic_obstacle_speed_m_s);
  obstacle_speed_m_s_ = speed_m_s;
  stop_check_.set_dynamic_obstacle_speed(speed_m_s);
  double sigma_m = 0.0;
  for (const ObstacleTracker& t : trackers_) sigma_m = std::max(sigma_m, t.valid(now_us_) && t.still() ? t.position_sigma_m() : 0.0);
  stop_check_.set_dynamic_obstacle_allowance(config_.obstacle_sigma_factor * sigma_m);
}

void Controller::run_safety() noexcept {
  guidance::MachineState state;
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    // The command leads the hydraulics: brake from whichever is faster, the command or the estimate.
    const double v_cmd = limiter_.velocity()[k];
    const bool command_faster = std::abs(v_cmd) > std::abs(velocity_[k]);
    // The rate limiter ramps the command without a jerk limit and brakes it at once when told to
    // stop: its acceleration while catching up with the setpoint is no state the braking must
    // first undo (taken as 0); its braking is, up to the most that the jerk limit can take back to
    // 0 just as the velocity reaches 0. A cut of the command by more (a speed scale that falls in
    // one cycle) would otherwise brake through rest into a reverse swing no actuator makes. The
    // estimated acceleration is a second difference of encoder counts: within the joint's limit it
    // is plausible, beyond it noise. It counts only while braking: an actuator that follows its
    // command with a lag does not speed up once it has caught up with it, and at a steady speed
    // the second difference swings to the limit both ways from cycle to cycle; taken as speeding
    // up it added a second to the predicted stop of a slewing boom beside a tower and stopped it
    // in the stop zone (a runaway from the command is the plausibility monitor's).
    const planning::JointSpec& spec = model_->joints()[k];
    const double a_max = spec.max_acceleration;
    const double a_cmd = limiter_.acceleration()[k];
    const double braking_max = std::min(a_max, std::sqrt(2.0 * spec.max_jerk * std::abs(v_cmd)));
    const double a_est = acceleration_[k];
    const double a = command_faster ? (a_cmd * v_cmd > 0.0 ? 0.0 : std::clamp(a_cmd, -braking_max, braking_max))
                                    : (a_est * velocity_[k] > 0.0 ? 0.0 : std::clamp(a_est, -a_max, a_max));
    state.joints[k] = {q_wrapped_[j], command_faster ? v_cmd : velocity_[k], a};
  }
  // Following an escape, with every obstacle settled: only a motion that comes nearer is stopped,
  // since a stop cannot take the machine away from an obstacle that stands within the margin.
  double floor_m = std::numeric_limits<double>::infinity();
  if (following_ && active_ == escape_.get() && obstacles_settled()) {
    floor_m = std::min(config_.stop_check.stop_margin_m, escape_start_m_ - config_.retreat_floor_tolerance_m);
  }
  stop_check_.set_retreat_floor(floor_m);
  check_ = stop_check_.check(state);
  if (rcl_) {
    rcl_result_ = rcl_->limit_velocity(q_wrapped_, rcl_->task_load_lb(), v_command_);
  }
  if (envelope_) {
    // Where the machine stands; the command path below cuts this cycle's command.
    envelope_result_ = guidance::EnvelopeResult{};
    envelope_result_.joint_scale.fill(1.0);
    envelope_result_.nearest = envelope_->nearest(q_wrapped_);
    envelope_result_.violated = envelope_result_.nearest.limit != guidance::EnvelopeLimit::None && envelope_result_.nearest.distance_m < 0.0;
  }
}

void Controller::predict_approach() noexcept {
  bool any_moving = false;
  for (const PoseHistory& h : histories_) any_moving = any_moving || obstacle_moving(h);
  if (!joints_valid_ || !any_moving) {
    approach_step_ = 0;
    approach_s_ = std::numeric_limits<double>::infinity();
    approach_obstacle_ = -1;
    return;
  }
  // Scan the horizon one predicted pose a cycle: the moving obstacles carried forward at their
  // tracked velocity and slew rate (a slewing crane turns about its mast, its frame's origin),
  // the machine where it stands or, moving, where it comes to rest if it stops now: an intruder
  // that will cross that place reaches a stopped machine, and the operator needs the warning
  // while the machine still moves. The tracked poses are put back at once for the next stop check.
  const double tau_s = ++approach_step_ * config_.approach_step_s;
  // Between two steps an obstacle moves on: one that comes within the margin at some instant
  // (after the first half step) is within the margin plus half a step's travel at the nearer step.
  double step_travel_m = 0.0;
  for (std::size_t t = 0; t < trackers_.size(); ++t) {
    const PoseHistory& h = histories_[t];
    if (!obstacle_moving(h)) continue;
    step_travel_m = std::max(step_travel_m, h.speed_m_s * config_.approach_step_s);
    Eigen::Isometry3d predicted = Eigen::Isometry3d::Identity();
    predicted.translate(trackers_[t].position_m() + h.velocity_m_s * tau_s);
    predicted.rotate(Eigen::AngleAxisd(trackers_[t].yaw_rad() + h.yaw_rate_rad_s * tau_s, Eigen::Vector3d::UnitZ()));
    safety_world_->set_dynamic_pose(h.obstacle, predicted);
  }
  const double margin_m = config_.stop_check.stop_margin_m + 0.5 * step_travel_m;
  const bool braked = !at_rest_ && check_.status != guidance::StopCheckStatus::ErrorInput && check_.stop_position.size() == n_;
  const planning::Clearance near =
      safety_world_->nearest_below(braked ? check_.stop_position : q_wrapped_, planning::CollisionWorld::Bodies::All, 0.0, margin_m)
          .dynamic_obstacle;
  for (std::size_t t = 0; t < trackers_.size(); ++t) {
    if (obstacle_moving(histories_[t])) safety_world_->set_dynamic_pose(histories_[t].obstacle, trackers_[t].pose());
  }
  const bool within = near.with == planning::Contact::With::Dynamic && near.distance_m < margin_m;
  // The earliest pose within the margin ends the scan; a scan that finds none clears the warning.
  if (!within && tau_s < config_.approach_horizon_s) return;
  if (within && !std::isfinite(approach_s_)) ++stats_.approach_warnings;
  approach_s_ = within ? tau_s : std::numeric_limits<double>::infinity();
  approach_obstacle_ = within ? near.other : -1;
  approach_step_ = 0;
}

void Controller::update_settled() noexcept {
  if (!following_ || target_ < path_size_) {
    settled_ = false;
    setpoint_done_us_ = -1;
    return;
  }
  if (setpoint_done_us_ < 0) setpoint_done_us_ = now_us_;
  bool within = joints_valid_;
  for (int j = 0; j < n_ && within; ++j) {
    const bool revolute = model_->joints()[static_cast<std::size_t>(j)].type == planning::JointType::Revolute;
    within = std::abs(q_unwrapped_[j] - target_unwrapped_[j]) <= (revolute ? config_.goal_tolerance_rad : config_.goal_tolerance_m);
  }
  const bool timed_out = now_us_ - setpoint_done_us_ >= config_.settle_timeout_us;
  if (!settled_ && !within && timed_out) ++stats_.settle_timeouts;
  settled_ = within || timed_out;
}

void Controller::load_path() noexcept {
  following_ = true;
  path_size_ = path_.size();
  target_ = 1;
  origin_ = q_unwrapped_;
  target_unwrapped_ = path_size_ > 1 ? origin_ + model_->difference(waypoint(0), waypoint(1)) : origin_;
  // At rest, so no reach lessens it: where the escape starts.
  escape_start_m_ = check_.min_geometric_m;
  for (int j = 0; j < n_; ++j) setpoint_[static_cast<std::size_t>(j)] = {q_unwrapped_[j], 0.0, 0.0};
  moving_joint_ = -1;
  ++plan_id_;
}

void Controller::handle_plan_request(const guidance::SupervisorOutput& out) noexcept {
  using planning::PlannerStatus;
  if (out.plan_request == guidance::PlanRequest::Plan) {
    following_ = false;
    replan_pending_ = false;
    retreat_searching_ = false;
    retreat_prefix_ = false;
    path_taken_ = false;
    shortening_ = false;
    repairing_ = false;
    planned_afresh_ = false;
    start_blocked_ = false;
    comparing_ = false;
    active_ = replanner_.get();
    problem_.start = q_wrapped_;
    problem_.goal = goal_;
    planner_status_ = active_->reset(problem_, replan_settings_);
    ++stats_.plans;
    // A worker or a parked truck within the margin of the stand: the same escape as after a stop.
    if (planner_status_ == PlannerStatus::InvalidStart && plan_world_->hits_dynamic(q_wrapped_)) plan_escape();
    planner_status_ = goal_refusal(planner_status_);
  } else if (out.plan_request == guidance::PlanRequest::Replan) {
    following_ = false;
    replan_pending_ = true;
    retreat_searching_ = false;
    shortening_ = false;
    repairing_ = true;
    planned_afresh_ = false;
    start_blocked_ = false;
    comparing_ = false;
    planner_status_ = PlannerStatus::Running;
  }
  if (out.state != guidance::SupervisorState::Replanning) {
    replan_pending_ = false;
    retreat_searching_ = false;
  }
  if (out.state != guidance::SupervisorState::Planning && out.state != guidance::SupervisorState::Replanning) shortening_ = false;
  if (replan_pending_ && obstacles_settled()) {
    // The repair starts where the machine stopped, on its way to waypoint target_: the planner is
    // told the first of its own nodes at or after it (a retreat's start and the shortener's
    // corners are not its nodes).
    replan_pending_ = false;
    const std::size_t planner_size = active_->path().size();
    std::size_t planner_target = planner_size > 0 ? planner_size - 1 : 0;
    for (std::size_t i = target_; i < path_size_; ++i) {
      if (path_.source(i) < 0) continue;
      planner_target = static_cast<std::size_t>(path_.source(i));
      break;
    }
    retreat_prefix_ = false;
    path_taken_ = false;
    const int next = static_cast<int>(std::min(planner_target, planner_size > 0 ? planner_size - 1 : 0));
    planner_status_ = active_->replan(q_wrapped_, std::max(next, 1), true);
    ++stats_.replans;
    // An obstacle stopped within the margin the planner keeps from moving obstacles.
    if (planner_status_ == PlannerStatus::InvalidStart) plan_escape();
  }
  const bool planning = out.state == guidance::SupervisorState::Planning || out.state == guidance::SupervisorState::Replanning;
  if (planning && !replan_pending_ && planner_status_ == PlannerStatus::Running) {
    if (retreat_searching_) {
      const planning::RetreatSearch::Status rs = retreat_->step(config_.retreat_configs_per_cycle);
      if (rs == planning::RetreatSearch::Status::Found) {
        // The escape is planned from the retreat's end; the machine follows both in one path.
        retreat_searching_ = false;
        retreat_prefix_ = true;
        ++stats_.retreats;
        escape_problem_.start = retreat_->target();
        path_taken_ = false;
        planner_status_ = goal_refusal(active_->reset(escape_problem_, escape_settings_));
      } else if (rs != planning::RetreatSearch::Status::Running) {
        retreat_searching_ = false;
        ++stats_.retreats_refused;
        planner_status_ = PlannerStatus::InvalidStart;
      }
    } else if (shortening_) {
      if (path_.step(config_.shorten_chunks_per_cycle) == planning::PathShortener::Status::Done) {
        shortening_ = false;
        planner_status_ = PlannerStatus::Solved;
        const int removed = static_cast<int>(active_->path().size() + (retreat_prefix_ ? 1 : 0)) - static_cast<int>(path_.size());
        if (removed != 0) ++stats_.paths_shortened;
        stats_.waypoints_removed += removed;
      }
    } else if (comparing_) {
      if (spare_->step(config_.plan_iterations_per_cycle) != PlannerStatus::Running) planner_status_ = PlannerStatus::Solved;
    } else {
      planner_status_ = active_->step(active_ == escape_.get() ? config_.escape_iterations_per_cycle : config_.plan_iterations_per_cycle);
      if (repairing_ && !planned_afresh_ && !retreat_prefix_ &&
          (planner_status_ == PlannerStatus::IterationLimit || planner_status_ == PlannerStatus::PoolExhausted)) {
        // The repair spent its cap keeping the old path's far end: plan once from the stop
        // instead, the query a new goal request would make, before the supervisor drops the goal.
        planned_afresh_ = true;
        ++stats_.repairs_planned_afresh;
        planning::PlanningProblem& problem = active_ == escape_.get() ? escape_problem_ : problem_;
        problem.start = q_wrapped_;
        problem.goal = goal_;
        planner_status_ = goal_refusal(active_->reset(problem, active_ == escape_.get() ? escape_settings_ : replan_settings_));
      }
    }
    ++stats_.planner_cycles;
  }
  if (planner_status_ == PlannerStatus::Solved && !path_taken_ && detour_checked()) take_path();
}

double Controller::follow_time_s(const std::vector<planning::JointVector>& path) const noexcept {
  double t_s = 0.0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const planning::JointVector d = model_->difference(path[i], path[i + 1]);
    for (int j = 0; j < n_; ++j) t_s += std::abs(d[j]) / follow_limits_[static_cast<std::size_t>(j)].max_velocity;
  }
  return t_s;
}

bool Controller::detour_checked() noexcept {
  using planning::PlannerStatus;
  if (comparing_) {
    // The fresh plan has ended: the quicker path to follow is the one repairs go on from.
    comparing_ = false;
    if (spare_->step(0) == PlannerStatus::Solved && follow_time_s(spare_->path()) < repair_follow_s_) {
      std::swap(replanner_, spare_);
      active_ = replanner_.get();
      ++stats_.detours_replaced;
    }
    return true;
  }
  if (!repairing_ || active_ != replanner_.get() || planned_afresh_ || retreat_prefix_) return true;
  repair_follow_s_ = follow_time_s(active_->path());
  planning::JointVector direct = model_->difference(q_wrapped_, goal_);
  double direct_s = 0.0;
  for (int j = 0; j < n_; ++j) direct_s += std::abs(direct[j]) / follow_limits_[static_cast<std::size_t>(j)].max_velocity;
  if (repair_follow_s_ <= config_.repair_detour_ratio * direct_s) return true;
  spare_problem_.start = q_wrapped_;
  spare_problem_.goal = goal_;
  ++stats_.detours_compared;
  if (spare_->reset(spare_problem_, replan_settings_) != PlannerStatus::Running) {
    planner_status_ = PlannerStatus::Solved;
    comparing_ = true;
    return detour_checked();
  }
  comparing_ = true;
  planner_status_ = PlannerStatus::Running;
  return false;
}

void Controller::plan_escape() noexcept {
  using planning::PlannerStatus;
  // Plan anew in the world that keeps a smaller margin, still beyond the stop check's stop margin.
  start_blocked_ = true;
  active_ = escape_.get();
  escape_problem_.start = q_wrapped_;
  escape_problem_.goal = goal_;
  planner_status_ = goal_refusal(active_->reset(escape_problem_, escape_settings_));
  ++stats_.escapes;
  if (planner_status_ != PlannerStatus::InvalidStart) return;
  // Too near even for the escape world: look for a single-joint move away first.
  retreat_from_ = q_wrapped_;
  if (retreat_->begin(q_wrapped_) == planning::RetreatSearch::Status::Running) {
    retreat_searching_ = true;
    planner_status_ = PlannerStatus::Running;
  } else {
    ++stats_.retreats_in_contact;
  }
}

planning::PlannerStatus Controller::goal_refusal(planning::PlannerStatus status) noexcept {
  if (status != planning::PlannerStatus::InvalidGoal) return status;
  planning::CollisionWorld& world = active_ == escape_.get() ? *escape_world_ : *plan_world_;
  return world.hits_dynamic(goal_) ? planning::PlannerStatus::GoalOccupied : status;
}

void Controller::take_path() noexcept {
  using planning::PlannerStatus;
  path_taken_ = true;
  const bool escape = active_ == escape_.get();
  // The first plan is followed as planned; a repair or an escape is shortened in the world it was
  // planned in, with the obstacles where it saw them.
  const bool shorten = escape || repairing_;
  planning::CollisionWorld& world = escape ? *escape_world_ : *plan_world_;
  const planning::JointVector& step = escape ? escape_problem_.step : problem_.step;
  const std::size_t first = retreat_prefix_ ? 1 : 0;
  const planning::PathShortener::Status st =
      path_.begin(world, retreat_prefix_ ? &retreat_from_ : nullptr, active_->path(), step, first, shorten);
  if (path_.truncated()) {
    planner_status_ = PlannerStatus::PoolExhausted;
  } else if (st == planning::PathShortener::Status::Running) {
    // Reported as still planning until the shortened path is ready.
    shortening_ = true;
    planner_status_ = PlannerStatus::Running;
  }
}

bool Controller::obstacles_settled() const noexcept {
  for (const PoseHistory& h : histories_) {
    if (!h.window_full || h.speed_m_s > config_.obstacle_speed_floor_m_s + config_.settled_speed_m_s) return false;
  }
  return true;
}

void Controller::follow(double dt_s, double speed_scale) noexcept {
  for (int j = 0; j < n_; ++j) v_target_[static_cast<std::size_t>(j)] = 0.0;
  if (!following_) return;
  if (target_ < path_size_ && speed_scale > 0.0) {
    // The joint farthest from its target moves; the others hold. An edge of several joints is
    // taken joint by joint, largest first.
    int moving = -1;
    double largest = 0.0;
    for (int j = 0; j < n_; ++j) {
      const double remaining = std::abs(target_unwrapped_[j] - setpoint_[static_cast<std::size_t>(j)].position);
      if (remaining > kReachedTolerance && remaining > largest) {
        largest = remaining;
        moving = j;
      }
    }
    if (moving < 0) moving = moving_joint_ >= 0 ? moving_joint_ : 0;
    moving_joint_ = moving;
    double clock_scale = speed_scale;
    if (envelope_) {
      // Near a limit the envelope slows the moving joint; the setpoint slows with it, or the
      // machine would fall behind and the next joint start before this one arrives.
      const auto k = static_cast<std::size_t>(moving);
      v_probe_.setZero();
      v_probe_[moving] = std::copysign(follow_limits_[k].max_velocity, target_unwrapped_[moving] - setpoint_[k].position);
      clock_scale *= envelope_->limit_velocity(q_wrapped_, v_probe_).joint_scale[k];
    }
    const guidance::TrajectoryStatus st =
        generator_.update(setpoint_.data(), follow_limits_.data(), static_cast<std::size_t>(n_), static_cast<std::size_t>(moving),
                          target_unwrapped_[moving], dt_s * clock_scale, next_.data());
    if (st == guidance::TrajectoryStatus::Working || st == guidance::TrajectoryStatus::Finished) {
      setpoint_ = next_;
      bool reached = st == guidance::TrajectoryStatus::Finished;
      for (int j = 0; j < n_ && reached; ++j) {
        reached = std::abs(target_unwrapped_[j] - setpoint_[static_cast<std::size_t>(j)].position) <= kReachedTolerance;
      }
      if (reached) {
        ++target_;
        if (target_ < path_size_) {
          target_unwrapped_ += model_->difference(waypoint(target_ - 1), waypoint(target_));
        }
      }
    } else {
      ++stats_.trajectory_errors;
    }
  }
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double error = setpoint_[k].position - q_unwrapped_[j];
    const double v_max = model_->joints()[k].max_velocity;
    const double lead = setpoint_[k].velocity + config_.acceleration_lead_s * setpoint_[k].acceleration;
    v_target_[k] = std::clamp(speed_scale * (lead + config_.position_gain_per_s * error), -v_max, v_max);
  }
}

ControllerOutput Controller::step(const hal::SensorSnapshot& s, std::int64_t dt_us, const ControllerCommands& commands,
                                  bool watchdog_tripped) noexcept {
  return step_impl(s, dt_us, commands, watchdog_tripped, nullptr);
}

ControllerOutput Controller::step(const hal::SensorSnapshot& s, std::int64_t dt_us, const ControllerCommands& commands,
                                  bool watchdog_tripped, const SiteInputs& site) noexcept {
  return step_impl(s, dt_us, commands, watchdog_tripped, &site);
}

ControllerOutput Controller::step_impl(const hal::SensorSnapshot& s, std::int64_t dt_us, const ControllerCommands& commands,
                                       bool watchdog_tripped, const SiteInputs* site) noexcept {
  now_us_ = s.t_us;
  ++stats_.cycles;
  const double dt_s = static_cast<double>(std::max<std::int64_t>(dt_us, 1)) * 1e-6;

  estimate(s, dt_s);
  track_obstacles(s);
  if (have_reading_) {
    run_safety();
    predict_approach();
  }
  site_worlds_due_ = false;
  if (site_ && site != nullptr && have_reading_) site_cycle(*site, s);

  // The sensors and the valve against the previous cycle's command, which the valve applies now.
  const guidance::PlausibilityResult& plausible = monitor_.update(
      plausibility_inputs(s, std::span<const double>(last_command_.data(), static_cast<std::size_t>(n_)), pilot_enabled_));
  if (plausible.fault != guidance::PlausibilityFault::None && stats_.plausibility_fault == guidance::PlausibilityFault::None) {
    stats_.plausibility_fault = plausible.fault;
    stats_.plausibility_joint = plausible.joint;
    stats_.plausibility_detected_us = plausible.detected_us;
  }
  stats_.plausibility_peak_ratio = std::max(stats_.plausibility_peak_ratio, monitor_.peak_window_ratio());

  // The machine's own tags against forward kinematics of the encoders: a second source.
  const std::size_t num_machine_tags = tag_check_.num_tags();
  for (std::size_t k = 0; k < num_machine_tags; ++k) {
    guidance::MachineTagFix& fix = machine_tag_fixes_[k];
    const hal::TagReading* r = s.find_tag(machine_tag_ids_[k]);
    fix.updated = r != nullptr && r->updated;
    if (!fix.updated) continue;
    fix.position_m = r->position_m;
    fix.quality = r->quality;
    fix.t_us = r->t_us;
  }
  guidance::MachineTagInputs tag_in;
  tag_in.now_us = now_us_;
  tag_in.joints_valid = joints_valid_;
  std::int64_t oldest_us = now_us_;
  for (int j = 0; j < n_; ++j) {
    tag_in.position[static_cast<std::size_t>(j)] = q_unwrapped_[j];
    oldest_us = std::min(oldest_us, s.joints[static_cast<std::size_t>(j)].t_us);
  }
  tag_in.joints_t_us = oldest_us;
  tag_in.fixes = std::span<const guidance::MachineTagFix>(machine_tag_fixes_.data(), num_machine_tags);
  const guidance::MachineTagResult& pose = tag_check_.update(tag_in);
  stats_.machine_tag_peak_ratio = std::max(stats_.machine_tag_peak_ratio, tag_check_.peak_ratio());
  stats_.machine_tag_fixes_judged = tag_check_.judged();
  if (tag_check_.stale_count() > 0) ++stats_.machine_tag_stale_cycles;
  guidance::PlausibilityFault finding = plausible.fault;
  int finding_index = plausible.joint;
  if (finding == guidance::PlausibilityFault::None && pose.disagrees) {
    finding = guidance::PlausibilityFault::PoseDisagrees;
    finding_index = pose.tag_id;
  }
  // The boom inclinometer against the boom's encoder: a second source of the boom's angle.
  guidance::InclinometerInputs angle_in;
  angle_in.now_us = now_us_;
  const int angle_joint = inclinometer_check_.result().joint;
  if (angle_joint >= 0 && s.inclinometer_joint == angle_joint) {
    const hal::JointReading& e = s.joints[static_cast<std::size_t>(angle_joint)];
    angle_in.encoder_valid = e.valid;
    angle_in.encoder_updated = e.updated;
    angle_in.encoder_rad = e.position;
    angle_in.angle_valid = s.inclinometer_angle.valid;
    angle_in.angle_updated = s.inclinometer_angle.updated;
    angle_in.angle_rad = s.inclinometer_angle.position;
  }
  const guidance::InclinometerResult& angle = inclinometer_check_.update(angle_in);
  stats_.inclinometer_judged = inclinometer_check_.judged();
  stats_.inclinometer_peak_ratio = std::max(stats_.inclinometer_peak_ratio, inclinometer_check_.peak_ratio());
  inclinometer_missing_ = angle_joint >= 0 && !(s.inclinometer_joint == angle_joint && s.inclinometer_angle.valid);
  if (inclinometer_missing_) ++stats_.inclinometer_unavailable_cycles;
  else if (angle_joint >= 0) inclinometer_valid_us_ = now_us_;
  if (finding == guidance::PlausibilityFault::None && angle.disagrees) {
    finding = guidance::PlausibilityFault::AngleDisagrees;
    finding_index = angle.joint;
    if (stats_.plausibility_fault == guidance::PlausibilityFault::None) {
      stats_.plausibility_fault = finding;
      stats_.plausibility_joint = angle.joint;
      stats_.plausibility_detected_us = angle.detected_us;
    }
  }
  if (finding == guidance::PlausibilityFault::PoseDisagrees && stats_.plausibility_fault == guidance::PlausibilityFault::None) {
    stats_.plausibility_fault = finding;
    stats_.plausibility_joint = pose.tag_id;
    stats_.plausibility_detected_us = pose.detected_us;
    stats_.pose_joints_seen = pose.joints_seen;
  }

  guidance::SupervisorInputs in;
  in.now_us = now_us_;
  in.sensing = sensing_inputs(s, std::span<const std::uint8_t>(machine_tag_ids_.data(), num_machine_tags));
  in.sensing.plausibility = finding;
  in.sensing.plausibility_joint = finding_index;
  if (have_reading_) {
    in.safety.stop_check = check_.status;
    in.safety.warning_speed_scale = check_.speed_scale;
    if (rcl_) {
      in.safety.rcl_stage = rcl_result_.stage;
      // A machine standing at the chart's rating exactly (where the planner never takes it, but an
      // operator may) may still slew, luff up, telescope in and lower; the stop is for a load over
      // the chart or a path that asks for a motion the limiter holds.
      bool cuts_path = rcl_result_.utilisation > config_.rated_capacity.cutoff_utilisation;
      for (int j = 0; j < n_; ++j) {
        const auto k = static_cast<std::size_t>(j);
        cuts_path = cuts_path || (rcl_result_.cut[k] && std::abs(v_command_[j]) > config_.rest_speed);
      }
      in.safety.rcl_cuts_path = cuts_path;
    }
    if (envelope_) in.safety.envelope_violated = envelope_result_.violated;
    // Stopped for a higher-priority machine: the lower one re-plans round its plan, so the
    // supervisor takes it as a safety stop (a higher one only waits: the speed factor below).
    if (site_replan_) in.safety.stop_check = guidance::StopCheckStatus::Stop;
  }
  in.commands.stop = commands.stop;
  in.commands.goal_request = commands.goal_request;
  in.commands.acknowledge = commands.acknowledge;
  in.planner.status = planner_status_;
  in.planner.start_blocked = start_blocked_;
  in.progress.at_rest = at_rest_;
  in.progress.command_at_rest = limiter_.at_rest();
  update_settled();
  in.progress.path_complete = path_complete();
  in.watchdog_tripped = watchdog_tripped;
  if (commands.goal_request && supervisor_.state() == guidance::SupervisorState::Hold) {
    if (commands.goal_joints == n_) {
      for (int j = 0; j < n_; ++j) goal_[j] = commands.goal[static_cast<std::size_t>(j)];
    } else {
      goal_ = scenario_.goal;
    }
  }

  const guidance::SupervisorOutput out = supervisor_.update(in);
  if (out.goal_outcome != guidance::CommandOutcome::None && out.goal_outcome != guidance::CommandOutcome::Accepted) {
    ++stats_.commands_rejected;
    rejected_until_us_ = now_us_ + 2'000'000;
  }
  if (out.acknowledge_outcome != guidance::CommandOutcome::None && out.acknowledge_outcome != guidance::CommandOutcome::Accepted) {
    ++stats_.commands_rejected;
    rejected_until_us_ = now_us_ + 2'000'000;
  }
  if (out.transitioned) {
    using R = guidance::TransitionReason;
    if (out.state == guidance::SupervisorState::Stopping &&
        (out.reason == R::SafetyStopZone || out.reason == R::SafetyCheckError || out.reason == R::EnvelopeViolated ||
         out.reason == R::RatedCapacityCut)) {
      ++stats_.safety_stops;
    }
    if (out.reason == R::GoalReached) {
      ++stats_.goals_reached;
      following_ = false;
    }
    if (out.state == guidance::SupervisorState::Executing) load_path();
  }
  if (out.motion_permitted && joints_valid_ && check_.min_clearance_m < stats_.min_clearance_m) {
    stats_.min_clearance_m = check_.min_clearance_m;
  }
  if (out.motion_permitted && joints_valid_ && check_.retreat) ++stats_.retreat_cycles;
  if (envelope_ && out.motion_permitted && joints_valid_ && envelope_result_.nearest.limit != guidance::EnvelopeLimit::None) {
    stats_.min_envelope_m = std::min(stats_.min_envelope_m, envelope_result_.nearest.distance_m);
  }

  // A plan or a repair that starts (or a path taken) this cycle reads the planning worlds: the
  // other machines are posed in them now, from this cycle's inputs, unless one was being computed
  // when the cycle began. No other cycle reads them, so no other cycle poses them.
  if (site_ && site != nullptr && site_worlds_due_) {
    const bool planning_after = out.state == guidance::SupervisorState::Planning || out.state == guidance::SupervisorState::Replanning;
    if (out.plan_request != guidance::PlanRequest::None || planning_after ||
        (planner_status_ == planning::PlannerStatus::Solved && !path_taken_)) {
      site_pose_worlds(*site);
    }
  }
  handle_plan_request(out);

  envelope_slowing_ = false;
  if (out.motion_permitted && joints_valid_) {
    follow(dt_s, out.speed_scale * site_speed_scale_);
    for (int j = 0; j < n_; ++j) v_command_[j] = v_target_[static_cast<std::size_t>(j)];
    if (envelope_) {
      // Only the components that approach a limit are slowed, to zero at it; the rest pass.
      envelope_result_ = envelope_->limit_velocity(q_wrapped_, v_command_);
      for (int j = 0; j < n_; ++j) {
        const auto k = static_cast<std::size_t>(j);
        if (envelope_result_.joint_scale[k] >= 1.0) continue;
        // A correction of the position feedback at rest is cut too, but is no motion to report.
        envelope_slowing_ = envelope_slowing_ || std::abs(v_target_[k]) > config_.rest_speed;
        v_target_[k] = envelope_result_.allowed_velocity[j];
      }
      if (envelope_slowing_) ++stats_.envelope_cut_cycles;
    }
    if (rcl_) {
      // Read along the motion of this period, so that a chart boundary crossed within it limits
      // the motion before the crossing.
      const guidance::RatedCapacityResult cut = rcl_->limit_velocity(q_wrapped_, rcl_->task_load_lb(), v_command_, dt_s);
      bool any_cut = false;
      for (int j = 0; j < n_; ++j) {
        if (cut.cut[static_cast<std::size_t>(j)]) {
          v_target_[static_cast<std::size_t>(j)] = 0.0;
          any_cut = true;
        }
      }
      if (any_cut) ++stats_.rcl_cut_cycles;
    }
    (void)limiter_.update(std::span<const double>(v_target_.data(), static_cast<std::size_t>(n_)), dt_s);
  } else if (out.controlled_stop || out.motion_permitted) {
    (void)limiter_.stop(dt_s);
  } else {
    for (int j = 0; j < n_; ++j) v_target_[static_cast<std::size_t>(j)] = 0.0;
    (void)limiter_.update(std::span<const double>(v_target_.data(), static_cast<std::size_t>(n_)), dt_s);
  }

  // An acknowledged fault starts afresh: the machine is at rest and INIT checks every device again.
  if (out.reset_latches) {
    monitor_.reset();
    tag_check_.reset();
    inclinometer_check_.reset();
  }
  const bool pilot = out.state != guidance::SupervisorState::Fault && !monitor_.result().cut_required;
  if (pilot_enabled_ && !pilot) ++stats_.pilot_cuts;
  pilot_enabled_ = pilot;
  const std::span<const double> command = limiter_.velocity();
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    last_command_[k] = k < command.size() ? command[k] : 0.0;
  }

  fill_snapshot(s, out);
  fill_snapshot_obstacles();
  if (site_) {
    // The plan first: the state of the cycle that takes up a new plan names it, so the two can go
    // out together and the others predict this machine by it from their next cycle on.
    site_fill_plan();
    site_fill_state(out);
  }

  ControllerOutput result;
  result.velocity = limiter_.velocity();
  result.start_nodes = out.start_nodes;
  result.reset_watchdog = out.reset_latches;
  result.pilot_enable = pilot_enabled_;
  result.supervisor = out;
  return result;
}

void Controller::raise(std::size_t kind, bool active, std::int8_t severity, std::int8_t source, std::int8_t clear,
                       std::int8_t unit, double value, double limit, std::int32_t index) noexcept {
  if (!active) {
    // Held a while after its condition clears, so that a condition flickering from cycle to cycle
    // (a clearance on its margin) stays one alert rather than a new one every cycle.
    if (alert_active_[kind] && now_us_ - alert_seen_us_[kind] >= kAlertHoldUs) alert_active_[kind] = false;
    return;
  }
  alert_seen_us_[kind] = now_us_;
  SnapshotAlert& a = alerts_[kind];
  // A new id when the condition is raised anew or its severity changes.
  if (!alert_active_[kind] || a.severity != severity) a.alert_id = next_alert_id_++;
  alert_active_[kind] = true;
  a.severity = severity;
  a.source = source;
  a.clear_condition = clear;
  a.value_unit = unit;
  a.value = value;
  a.limit = limit;
  a.index = index;
  a.min_clearance_m = check_.min_clearance_m;
}

void Controller::fill_snapshot_obstacles() noexcept {
  snap_.num_tracked = static_cast<int>(trackers_.size());
  const std::size_t n = std::min<std::size_t>(trackers_.size(), kSnapshotMaxObstacles);
  snap_.num_obstacles = static_cast<int>(n);
  for (std::size_t t = 0; t < n; ++t) {
    const ObstacleTracker& tracker = trackers_[t];
    const PoseHistory& h = histories_[t];
    SnapshotObstacle& o = snap_.obstacles[t];
    o.obstacle_index = h.obstacle;
    o.valid = tracker.valid(now_us_);
    // A tracker that never fitted a pose holds the origin: that is no pose to show.
    const bool ever = o.valid || tracker.last_update_us() > 0;
    o.still = ever && tracker.still();
    const Eigen::Vector3d& p = tracker.position_m();
    o.position_m = ever ? std::array<double, 3>{p.x(), p.y(), p.z()} : std::array<double, 3>{kNaN, kNaN, kNaN};
    o.yaw_rad = ever ? tracker.yaw_rad() : kNaN;
    o.position_sigma_m = ever ? tracker.position_sigma_m() : kNaN;
    o.speed_m_s = o.valid && h.window_full ? h.velocity_m_s.norm() : kNaN;
    o.yaw_rate_rad_s = o.valid && h.window_full ? h.yaw_rate_rad_s : kNaN;
    o.fix_us = ever ? tracker.last_update_us() : 0;
  }
}

void Controller::fill_snapshot(const hal::SensorSnapshot& s, const guidance::SupervisorOutput& out) noexcept {
  using guidance::SupervisorState;
  snap_.utime_us = now_us_;
  snap_.cycle_index = s.cycle;
  std::int64_t oldest = now_us_;
  for (int j = 0; j < n_; ++j) oldest = std::min(oldest, s.joints[static_cast<std::size_t>(j)].t_us);
  snap_.utime_sample_us = oldest;
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    snap_.joint_position[k] = q_wrapped_[j];
    snap_.joint_velocity[k] = velocity_[k];
    snap_.joint_acceleration[k] = acceleration_[k];
    std::int8_t flags = 0;
    if (s.joints[k].health == hal::Health::Stale) flags |= mgc::machine_state_t::JOINT_ENCODER_STALE;
    if (!s.joints[k].valid) flags |= mgc::machine_state_t::JOINT_ENCODER_INVALID;
    if (rcl_ && rcl_result_.cut[k]) flags |= mgc::machine_state_t::JOINT_MOTION_CUT_OFF;
    if (envelope_ && envelope_result_.joint_scale[k] == 0.0) flags |= mgc::machine_state_t::JOINT_MOTION_CUT_OFF;
    snap_.joint_fault_flags[k] = flags;
  }
  if (have_reading_) {
    model_->forward_kinematics(q_wrapped_, kinematics_);
    const int tool = static_cast<int>(model_->key_point_names().size()) - 1;
    const Eigen::Vector3d& p = kinematics_.points[static_cast<std::size_t>(std::max(tool, 0))];
    snap_.tool_position_m = {p.x(), p.y(), p.z()};
  }
  snap_.supervisor_state = state_code(out.state);
  snap_.load_moment_pct = rcl_ ? 100.0 * rcl_result_.utilisation : kNaN;

  // The plan: up to kSnapshotMaxWaypoints, evenly picked, the last always kept.
  SnapshotPlan& plan = snap_.plan;
  if (following_ && plan.plan_id != plan_id_) {
    plan.plan_id = plan_id_;
    plan.status = mgc::plan_t::STATUS_EXACT;
    plan.num_joints = n_;
    const std::size_t count = std::min<std::size_t>(path_size_, kSnapshotMaxWaypoints);
    plan.num_waypoints = static_cast<int>(count);
    planning::JointVector w = origin_;
    std::size_t picked = 0;
    for (std::size_t i = 0; i < path_size_ && picked < count; ++i) {
      if (i > 0) w += model_->difference(waypoint(i - 1), waypoint(i));
      const std::size_t want = count > 1 ? (picked * (path_size_ - 1)) / (count - 1) : 0;
      if (i != want) continue;
      for (int j = 0; j < n_; ++j) plan.positions[picked][static_cast<std::size_t>(j)] = w[j];
      plan.moving_joint[picked] = mgc::plan_t::NO_JOINT;
      ++picked;
    }
  }

  // The instruction and the words.
  snap_.speed_scale = out.speed_scale;
  snap_.segment_index = following_ ? static_cast<std::int32_t>(target_) - 1 : -1;
  snap_.moving_joint = static_cast<std::int8_t>(following_ ? moving_joint_ : -1);
  snap_.target_position = following_ && moving_joint_ >= 0 ? target_unwrapped_[moving_joint_] : kNaN;
  snap_.joint_distance_remaining = following_ && moving_joint_ >= 0
                                       ? std::abs(target_unwrapped_[moving_joint_] - q_unwrapped_[moving_joint_])
                                       : kNaN;
  switch (out.state) {
    case SupervisorState::Executing:
      snap_.instruction = path_complete() ? mgc::operator_guidance_t::INSTRUCTION_DONE : mgc::operator_guidance_t::INSTRUCTION_MOVE_JOINT;
      break;
    case SupervisorState::Planning:
    case SupervisorState::Replanning:
      snap_.instruction = mgc::operator_guidance_t::INSTRUCTION_WAIT_REPLAN;
      break;
    case SupervisorState::Stopping:
    case SupervisorState::Fault:
    case SupervisorState::Estop:
      snap_.instruction = mgc::operator_guidance_t::INSTRUCTION_STOPPED;
      break;
    default:
      snap_.instruction = mgc::operator_guidance_t::INSTRUCTION_HOLD;
  }
  snap_.instruction_text[0] = '\0';
  if (following_ && target_ < path_size_ && out.state == SupervisorState::Executing) {
    // The next two moves: from here to the current target, then the one after.
    std::array<std::array<double, kMaxJoints>, 3> w{};
    planning::JointVector next = target_unwrapped_;
    for (int j = 0; j < n_; ++j) {
      w[0][static_cast<std::size_t>(j)] = q_unwrapped_[j];
      w[1][static_cast<std::size_t>(j)] = target_unwrapped_[j];
    }
    std::size_t count = 2;
    if (target_ + 1 < path_size_) {
      next += model_->difference(waypoint(target_), waypoint(target_ + 1));
      for (int j = 0; j < n_; ++j) w[2][static_cast<std::size_t>(j)] = next[j];
      count = 3;
    }
    // From the unwrapped position: the waypoints are unwrapped, and a wrapped swing past half a
    // turn would read as a whole turn more.
    (void)next_moves_in_words(model_->kind(), n_, std::span<const double>(w[0].data(), static_cast<std::size_t>(n_)),
                              std::span<const std::array<double, kMaxJoints>>(w.data(), count), 0, 2,
                              std::span<char>(snap_.instruction_text.data(), snap_.instruction_text.size()));
  } else if (std::isfinite(approach_s_) && approach_obstacle_ >= 0 &&
             static_cast<std::size_t>(approach_obstacle_) < scenario_.dynamic_obstacles.size()) {
    // At rest nothing moves the machine out of the way: the operator is told what is coming.
    (void)std::snprintf(snap_.instruction_text.data(), snap_.instruction_text.size(), "%s approaching: within the stop margin in %.1f s",
                        scenario_.dynamic_obstacles[static_cast<std::size_t>(approach_obstacle_)].obstacle.name.c_str(), approach_s_);
  }

  // Clearances.
  snap_.obstacle_clearance_m = have_reading_ ? check_.min_clearance_m : kNaN;
  snap_.obstacle_index = check_.nearest.other;
  double margin = 1e300;
  int limit_joint = -1;
  for (int j = 0; j < n_; ++j) {
    const planning::JointSpec& spec = model_->joints()[static_cast<std::size_t>(j)];
    if (spec.continuous) continue;
    const double m = std::min(q_wrapped_[j] - spec.position_min, spec.position_max - q_wrapped_[j]);
    if (m < margin) {
      margin = m;
      limit_joint = j;
    }
  }
  snap_.limit_margin = limit_joint >= 0 ? margin : kNaN;
  snap_.limit_joint = static_cast<std::int8_t>(limit_joint);
  const guidance::EnvelopeDistance& nearest_limit = envelope_result_.nearest;
  const bool envelope_known = envelope_ && have_reading_ && nearest_limit.limit != guidance::EnvelopeLimit::None;
  snap_.envelope_distance_m = envelope_known ? nearest_limit.distance_m : kNaN;
  snap_.envelope_limit = static_cast<std::int8_t>(envelope_known ? nearest_limit.limit : guidance::EnvelopeLimit::None);
  snap_.envelope_wall = static_cast<std::int8_t>(envelope_known ? nearest_limit.wall : -1);

  // Alerts.
  using A = mgc::alert_t;
  const bool moving_state = out.state == SupervisorState::Executing || out.state == SupervisorState::Stopping;
  const bool warn = have_reading_ && moving_state && check_.status == guidance::StopCheckStatus::Warning;
  const bool stop = have_reading_ && moving_state &&
                    (check_.status == guidance::StopCheckStatus::Stop || check_.status == guidance::StopCheckStatus::ErrorInput);
  raise(kAlertCollision, warn || stop, stop ? A::SEVERITY_STOP : A::SEVERITY_SLOW_DOWN, A::SOURCE_COLLISION,
        A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_METRE, check_.min_clearance_m,
        stop ? config_.stop_check.stop_margin_m : config_.stop_check.warning_margin_m, check_.nearest.other);
  const bool rcl_alert = rcl_ && rcl_result_.stage != guidance::RclStage::Normal;
  raise(kAlertLoadChart, rcl_alert, rcl_result_.stage == guidance::RclStage::Warning ? A::SEVERITY_WARN : A::SEVERITY_STOP,
        A::SOURCE_LOAD_CHART, A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_PERCENT, 100.0 * rcl_result_.utilisation,
        rcl_result_.stage == guidance::RclStage::Warning ? 100.0 * config_.rated_capacity.warning_utilisation
                                                         : 100.0 * config_.rated_capacity.cutoff_utilisation,
        -1);
  // The envelope: slowing or cutting a motion toward a limit, or a point already beyond one.
  const bool envelope_acts = envelope_ && have_reading_ && moving_state && (envelope_result_.violated || envelope_slowing_);
  const guidance::EnvelopeDistance& acting = envelope_result_.violated ? envelope_result_.nearest : envelope_result_.acting;
  raise(kAlertEnvelope, envelope_acts, envelope_result_.violated ? A::SEVERITY_STOP : A::SEVERITY_SLOW_DOWN, A::SOURCE_ENVELOPE,
        A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_METRE, acting.distance_m,
        envelope_result_.violated || !envelope_ ? 0.0 : envelope_->config().slowdown_band_m, envelope_alert_index(acting));
  const bool fault = out.state == SupervisorState::Fault;
  raise(kAlertFault, fault, A::SEVERITY_FAULT, fault_source(supervisor_.reason()), A::CLEAR_ON_OPERATOR_ACK, A::UNIT_NONE,
        static_cast<double>(static_cast<int>(supervisor_.reason())), kNaN, supervisor_.reason_value());
  // The second channel asked to cut and pilot pressure stays (or the node faults): only the
  // machine's own emergency stop is left, and the operator must know at once, in any state.
  const bool cutoff_failed = cutoff_health(s) == guidance::CutoffHealth::Failed;
  raise(kAlertCutoff, cutoff_failed, A::SEVERITY_FAULT, A::SOURCE_SENSING, A::CLEAR_ON_OPERATOR_ACK, A::UNIT_NONE,
        static_cast<double>(static_cast<int>(guidance::TransitionReason::CutoffFailed)), kNaN, -1);
  raise(kAlertEstop, out.state == SupervisorState::Estop, A::SEVERITY_STOP, A::SOURCE_OPERATOR, A::CLEAR_ON_OPERATOR_ACK,
        A::UNIT_NONE, kNaN, kNaN, -1);
  const bool planner_alert = out.state == SupervisorState::Replanning || supervisor_.retry_pending();
  raise(kAlertPlanner, planner_alert, A::SEVERITY_INFO, A::SOURCE_PLANNER, A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_NONE,
        kNaN, kNaN, -1);
  raise(kAlertOperator, now_us_ < rejected_until_us_, A::SEVERITY_INFO, A::SOURCE_OPERATOR, A::CLEAR_WHEN_CONDITION_CLEARS,
        A::UNIT_NONE, kNaN, kNaN, -1);
  raise(kAlertApproach, std::isfinite(approach_s_), A::SEVERITY_WARN, A::SOURCE_COLLISION, A::CLEAR_WHEN_CONDITION_CLEARS,
        A::UNIT_SECOND, approach_s_, config_.approach_horizon_s, approach_obstacle_);
  bool tracks_lost = false;
  for (const ObstacleTracker& t : trackers_) tracks_lost = tracks_lost || !t.valid(now_us_);
  raise(kAlertTracking, tracks_lost && supervisor_.state() != SupervisorState::Init, A::SEVERITY_WARN, A::SOURCE_SENSING,
        A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_NONE, kNaN, kNaN, -1);
  // A machine tag without a fix for the stale time: its check is off until fixes return, which
  // the operator must know (value: how many are stale; index: the first one's id).
  raise(kAlertMachineTag, tag_check_.stale_count() > 0 && supervisor_.state() != SupervisorState::Init, A::SEVERITY_WARN,
        A::SOURCE_SENSING, A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_NONE, static_cast<double>(tag_check_.stale_count()), kNaN,
        tag_check_.stale_tag());
  // The bus plan's boom inclinometer silent, stale or faulted: the boom encoder has no second
  // source until it returns, which the operator must know (value: the age of its last valid
  // sample, NaN if none yet; index: the joint it measures).
  const double angle_age_s = inclinometer_valid_us_ >= 0 ? static_cast<double>(now_us_ - inclinometer_valid_us_) * 1e-6 : kNaN;
  raise(kAlertInclinometer, inclinometer_missing_ && supervisor_.state() != SupervisorState::Init, A::SEVERITY_WARN,
        A::SOURCE_SENSING, A::CLEAR_WHEN_CONDITION_CLEARS, A::UNIT_SECOND, angle_age_s, kNaN, inclinometer_check_.result().joint);
  // The site: a stop or slow-down the rules ask for, or a machine stale or never heard (index: its id).
  const bool site_alert = site_ && have_reading_ && (site_motion_ != SiteMotion::Proceed || site_stale_);
  const int site_for = site_ ? site_roster_.index_of(site_decision_.motion_for_id) : -1;
  // A stale machine's alert says what poses it: its value is the SitePrediction (UWB tags, frozen
  // pose, whole reach), unit none.
  const int stale_for = site_ && site_stale_ ? site_roster_.index_of(site_alert_id_) : -1;
  const double site_value = stale_for >= 0 ? static_cast<double>(site_decision_.peers[static_cast<std::size_t>(stale_for)].prediction)
                                           : (site_for >= 0 ? site_meet_s_[static_cast<std::size_t>(site_for)] : kNaN);
  raise(kAlertSite, site_alert,
        site_motion_ == SiteMotion::Stop ? A::SEVERITY_STOP : (site_motion_ == SiteMotion::SlowDown ? A::SEVERITY_SLOW_DOWN : A::SEVERITY_WARN),
        site_stale_ ? A::SOURCE_SENSING : A::SOURCE_COLLISION, A::CLEAR_WHEN_CONDITION_CLEARS, stale_for >= 0 ? A::UNIT_NONE : A::UNIT_SECOND,
        site_value, site_ ? site_->rules.horizon_s : kNaN, site_alert_id_);
  snap_.num_alerts = 0;
  for (std::size_t k = 0; k < kAlertKinds && snap_.num_alerts < kSnapshotMaxAlerts; ++k) {
    if (alert_active_[k]) snap_.alerts[static_cast<std::size_t>(snap_.num_alerts++)] = alerts_[k];
  }
}

double Controller::site_apart_m(const SitePeerModel& p, const planning::Kinematics& me, double grow_m, double bound_m) const noexcept {
  // A body's box in its own axes: half extents (a capsule's along z with its caps), as the
  // collision worlds shape it: mine undilated, the other's grown.
  const auto body_half = [](const planning::BodyState& b, bool box, double floor_m, double by_m) {
    const Eigen::Vector3d size = b.size_m.cwiseMax(Eigen::Vector3d::Constant(floor_m));
    return box ? Eigen::Vector3d(0.5 * size + Eigen::Vector3d::Constant(by_m))
               : Eigen::Vector3d(0.5 * size.x() + by_m, 0.5 * size.x() + by_m, 0.5 * size.z() + 0.5 * size.x() + by_m);
  };
  double least_m = std::numeric_limits<double>::infinity();
  const std::size_t mine = model_->bodies().size();
  for (const int pb : p.moving_bodies) {
    const auto b = static_cast<std::size_t>(pb);
    const planning::BodyState& other = p.kinematics.bodies[b];
    const Eigen::Matrix3d& other_r = other.world_from_body.linear();
    const Eigen::Vector3d other_half = body_half(other, p.model->bodies()[b].shape == planning::BodyShape::Box, 0.01, grow_m);
    const Eigen::Vector3d other_world_half = other_r.cwiseAbs() * other_half;
    for (std::size_t k = 0; k < mine; ++k) {
      const planning::BodyState& body = me.bodies[k];
      const Eigen::Matrix3d& r = body.world_from_body.linear();
      const Eigen::Vector3d half = body_half(body, model_->bodies()[k].shape == planning::BodyShape::Box, 0.0, 0.0);
      const Eigen::Vector3d d = other.world_from_body.translation() - body.world_from_body.translation();
      // The world boxes round the two: the distance between them.
      double gap_m = (d.cwiseAbs() - r.cwiseAbs() * half - other_world_half).cwiseMax(0.0).norm();
      if (gap_m < bound_m) {
        // The two boxes' projections on each one's face normals: each a gap no point pair beats,
        // and a slanted boom's own box is far tighter than its world box.
        const Eigen::Matrix3d m = (r.transpose() * other_r).cwiseAbs();
        const Eigen::Vector3d in_mine = (r.transpose() * d).cwiseAbs() - half - m * other_half;
        const Eigen::Vector3d in_other = (other_r.transpose() * d).cwiseAbs() - other_half - m.transpose() * half;
        gap_m = std::max({gap_m, in_mine.maxCoeff(), in_other.maxCoeff()});
        if (gap_m < bound_m) return gap_m;
      }
      least_m = std::min(least_m, gap_m);
    }
  }
  return least_m;
}

double Controller::site_gap_m(SitePeerModel& p, const planning::JointVector& peer_q, double grow_m,
                              const planning::JointVector& my_q, double bound_m, const planning::Kinematics* me) noexcept {
  p.model->forward_kinematics(peer_q, p.kinematics);
  if (me != nullptr && std::isfinite(bound_m)) {
    const double apart_m = site_apart_m(p, *me, grow_m, bound_m);
    if (apart_m >= bound_m) {
      // What the query would have found: nothing below the bound.
      p.nearest = planning::CollisionWorld::NearestBelow{};
      p.nearest.dynamic_obstacle.distance_m = bound_m;
      return apart_m;
    }
  }
  site_pose_meet(p, grow_m);
  p.nearest = p.meet_world->nearest_below(my_q, planning::CollisionWorld::Bodies::All, 0.0, bound_m, &p.nearest);
  return p.nearest.dynamic_obstacle.distance_m;
}

void Controller::site_pose_meet(SitePeerModel& p, double grow_m) noexcept {
  for (std::size_t k = 0; k < p.moving_bodies.size(); ++k) {
    const auto b = static_cast<std::size_t>(p.moving_bodies[k]);
    const planning::BodyState& body = p.kinematics.bodies[b];
    const bool box = p.model->bodies()[b].shape == planning::BodyShape::Box;
    const Eigen::Vector3d grown = body.size_m.cwiseMax(Eigen::Vector3d::Constant(0.01)) +
                                  Eigen::Vector3d(2.0 * grow_m, 2.0 * grow_m, box ? 2.0 * grow_m : 0.0);
    p.meet_world->set_dynamic_part_size(static_cast<int>(k), 0, grown);
    p.meet_world->set_dynamic_pose(static_cast<int>(k), body.world_from_body);
  }
}

bool Controller::site_leads_apart(SitePeerModel& p, const planning::JointVector& peer_q, double grow_m,
                                  const planning::JointVector& moving_q, double moving_known_m, const planning::JointVector& still_q,
                                  double still_known_m) noexcept {
  // Standing still where the way starts: one gap both ways, which no motion widens.
  if (moving_q.size() == still_q.size() && moving_q == still_q) return false;
  // Posed as the scan's sample posed it (setting the same pose and sizes again changes nothing).
  p.model->forward_kinematics(peer_q, p.kinematics);
  site_pose_meet(p, grow_m);
  // clearance()'s gap: 0 in contact with the other machine or with myself (is_free()), else the
  // distance, which nearest_below() gives below its bound and otherwise reports as the bound.
  const auto touches = [&p](const planning::JointVector& q) noexcept { return !p.meet_world->is_free(q); };
  // The scan's hint is read, not replaced: the samples' queries start from the pair they found.
  const auto gap_below = [&](const planning::JointVector& q, double bound_m) noexcept {
    if (touches(q)) return 0.0;
    return p.meet_world->nearest_below(q, planning::CollisionWorld::Bodies::All, 0.0, bound_m, &p.nearest).dynamic_obstacle.distance_m;
  };
  // Each gap measured only up to what decides moving > still + kSiteApartM: a gap reported at its
  // bound (kSiteBoundSlackM beyond the threshold) compares as the gap itself would.
  if (!std::isnan(moving_known_m)) {
    const double moving_m = touches(moving_q) ? 0.0 : moving_known_m;
    // No stand is nearer than touching.
    if (moving_m <= kSiteApartM) return false;
    const double still_m = gap_below(still_q, moving_m - kSiteApartM + kSiteBoundSlackM);
    return moving_m > still_m + kSiteApartM;
  }
  double still_m = 0.0;
  if (std::isnan(still_known_m)) {
    still_m = gap_below(still_q, std::numeric_limits<double>::infinity());
  } else {
    still_m = touches(still_q) ? 0.0 : still_known_m;
  }
  const double moving_m = gap_below(moving_q, still_m + kSiteApartM + kSiteBoundSlackM);
  return moving_m > still_m + kSiteApartM;
}

void Controller::site_pose_copy(SitePeerModel& p, int copy, const planning::JointVector& q, double grow_m) noexcept {
  if (copy < 0 || copy >= p.copies) return;
  p.model->forward_kinematics(q, p.kinematics);
  const int moving = static_cast<int>(p.moving_bodies.size());
  for (int k = 0; k < moving; ++k) {
    const auto b = static_cast<std::size_t>(p.moving_bodies[static_cast<std::size_t>(k)]);
    const planning::BodyState& body = p.kinematics.bodies[b];
    const bool box = p.model->bodies()[b].shape == planning::BodyShape::Box;
    const Eigen::Vector3d grown = body.size_m.cwiseMax(Eigen::Vector3d::Constant(0.01)) +
                                  Eigen::Vector3d(2.0 * grow_m, 2.0 * grow_m, box ? 2.0 * grow_m : 0.0);
    const int index = p.world_first + copy * moving + k;
    plan_world_->set_dynamic_part_size(index, 0, grown);
    plan_world_->set_dynamic_pose(index, body.world_from_body);
    escape_world_->set_dynamic_part_size(index, 0, grown);
    escape_world_->set_dynamic_pose(index, body.world_from_body);
  }
  p.parked_from = std::max(p.parked_from, copy + 1);
  if (copy >= 1) p.plan_posed = false;
}

void Controller::site_park(SitePeerModel& p, int from_copy) noexcept {
  // A parked copy stays where it was parked until it is posed: a lower-priority machine's copies
  // are set once, not every cycle.
  const int until = std::min(p.parked_from, p.copies);
  if (from_copy >= until) return;
  p.parked_from = from_copy;
  p.plan_posed = false;
  for (int c = from_copy; c < until; ++c) site_park_copy(p, c);
}

void Controller::site_park_copy(SitePeerModel& p, int copy) noexcept {
  const int moving = static_cast<int>(p.moving_bodies.size());
  for (int k = 0; k < moving; ++k) {
    const Eigen::Isometry3d parked = site_parked_pose(p.roster_index, copy, k);
    plan_world_->set_dynamic_pose(p.world_first + copy * moving + k, parked);
    escape_world_->set_dynamic_pose(p.world_first + copy * moving + k, parked);
  }
}

void Controller::site_cycle(const SiteInputs& in, const hal::SensorSnapshot& s) noexcept {
  const SiteRulesConfig& rules = site_->rules;
  const double margin_m = config_.stop_check.stop_margin_m;
  const double skew_s = static_cast<double>(rules.max_skew_us) * 1e-6;
  const double step_s = site_->scan_step_s;
  // Far enough to see the lower-priority machine's slow-down lead: L + H with L = 2H.
  const double horizon_s = 3.0 * rules.horizon_s;
  // My motion carried forward: per joint the fastest of the command, the estimate and, on a path,
  // the follower's speed toward its target, so that a machine the site holds still sees its way.
  double my_speed_m_s = 0.0;
  double my_reach_m = 0.0;
  double my_bound_m_s = 0.0;
  // The joint the follower moves next: before it first moved (held from the start), the farthest
  // from its target, as follow() picks it.
  int next_joint = moving_joint_;
  if (following_ && target_ < path_size_ && next_joint < 0) {
    double largest = kReachedTolerance;
    for (int j = 0; j < n_; ++j) {
      const double remaining = std::abs(target_unwrapped_[j] - q_unwrapped_[j]);
      if (remaining > largest) {
        largest = remaining;
        next_joint = j;
      }
    }
  }
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const planning::JointSpec& spec = model_->joints()[k];
    double v = std::abs(limiter_.velocity()[k]) > std::abs(velocity_[k]) ? limiter_.velocity()[k] : velocity_[k];
    if (following_ && target_ < path_size_ && j == next_joint) {
      const double toward = target_unwrapped_[j] - q_unwrapped_[j];
      const double intended = std::copysign(follow_limits_[k].max_velocity, toward);
      if (std::abs(toward) > kReachedTolerance && std::abs(intended) > std::abs(v)) v = intended;
    }
    site_v_[j] = v;
    const double bound = model_->displacement_bound(j);
    my_speed_m_s += bound * std::abs(v);
    my_reach_m += bound * v * v / (2.0 * spec.max_acceleration);
    my_bound_m_s += bound * spec.max_velocity;
  }
  // My way is taken up from the speed I have now under my joints' accelerations, not at full
  // speed from the first instant: held at rest by the site, a machine carried at full speed would
  // see itself braking from full speed where its way passes near the other, and wait for it while
  // the other, stopped for it, waits too (a standoff).
  const auto speed_now = [&](int j) noexcept {
    const auto k = static_cast<std::size_t>(j);
    const double v = std::abs(limiter_.velocity()[k]) > std::abs(velocity_[k]) ? limiter_.velocity()[k] : velocity_[k];
    // Only a speed the way's direction: a joint still braking the other way starts from rest.
    return v * site_v_[j] > 0.0 ? std::min(std::abs(v), std::abs(site_v_[j])) : 0.0;
  };
  const auto carried = [&](int j, double tau_s) noexcept {
    const double v = std::abs(site_v_[j]);
    const double v0 = speed_now(j);
    const double a = model_->joints()[static_cast<std::size_t>(j)].max_acceleration;
    const double ramp_s = (v - v0) / a;
    const double d = tau_s <= ramp_s ? v0 * tau_s + 0.5 * a * tau_s * tau_s : v0 * ramp_s + 0.5 * a * ramp_s * ramp_s + v * (tau_s - ramp_s);
    return std::copysign(d, site_v_[j]);
  };
  // My stop travel's reach at tau_s along that way, at the speed reached by then. [m]
  const auto my_reach_at = [&](double tau_s) noexcept {
    double reach_m = 0.0;
    for (int j = 0; j < n_; ++j) {
      const double a = model_->joints()[static_cast<std::size_t>(j)].max_acceleration;
      const double v = std::min(std::abs(site_v_[j]), speed_now(j) + a * tau_s);
      reach_m += model_->displacement_bound(j) * v * v / (2.0 * a);
    }
    return reach_m;
  };
  const bool planning_now = supervisor_.state() == guidance::SupervisorState::Planning ||
                            supervisor_.state() == guidance::SupervisorState::Replanning;
  model_->forward_kinematics(q_wrapped_, site_kin_);
  bool stale_stop = false;
  site_stale_ = false;
  site_alert_id_ = 0;
  for (SitePeerModel& p : site_peers_) {
    const auto r = static_cast<std::size_t>(p.roster_index);
    const SitePeerMessages& m = in.peers[r];
    SitePeerInput& pin = site_in_[r];
    pin.state = m.has_state ? &m.state : nullptr;
    pin.state_received_us = m.state_received_us;
    pin.plan = m.has_plan ? &m.plan : nullptr;
    pin.meet_in_s = std::numeric_limits<double>::infinity();
    pin.tags_posed = false;
    site_meet_s_[r] = pin.meet_in_s;
    const bool live = m.has_state && now_us_ - m.state_received_us <= rules.stale_after_us();
    if (m.has_state) {
      for (int j = 0; j < std::min<int>(m.state.num_joints, p.model->dof()); ++j) p.q[j] = m.state.joint_position[static_cast<std::size_t>(j)];
    }
    // The site's RTLS follows a tagged machine all along, so that its velocity is known the
    // moment its messages stop.
    const bool tags = p.num_tags > 0 &&
                      site_fit_tags(p, s, p.q, m.has_state ? m.state_received_us - rules.max_skew_us : std::numeric_limits<std::int64_t>::min(),
                                    now_us_, *site_)
                          .valid;
    if (!live) {
      site_stale_ = true;
      if (site_alert_id_ == 0) site_alert_id_ = p.machine_id;
    }
    if (!live && tags) {
      // Stale, seen by its tags: posed where they put it, carried at their velocity, and judged by
      // the mutual-stop rule as a machine that may not hear me (decide_site()).
      pin.tags_posed = true;
      ++stats_.site_tag_cycles;
      site_state_t& t = p.tag_state;
      t.num_joints = static_cast<std::int8_t>(p.model->dof());
      t.plan_id = 0;
      double rest_s = 0.0;
      for (int j = 0; j < p.model->dof(); ++j) {
        const auto k = static_cast<std::size_t>(j);
        const double a = p.model->joints()[k].max_acceleration;
        const double v = p.tag_pose.v[j];
        t.joint_position[k] = p.tag_pose.q[j];
        t.joint_velocity[k] = v;
        t.stop_travel[k] = v * std::abs(v) / (2.0 * a);
        rest_s = std::max(rest_s, std::abs(v) / a);
      }
      t.time_to_rest_s = rest_s;
    }
    const site_state_t& st = live ? m.state : p.tag_state;
    const std::int64_t age_us = now_us_ - (live ? m.state_received_us : p.tag_pose.t_us);
    const int nq = std::min<int>(st.num_joints, p.model->dof());
    double peer_speed_m_s = 0.0;
    double peer_reach_m = 0.0;
    if (live || tags || m.has_state) {
      const site_state_t& from = live || tags ? st : m.state;
      for (int j = 0; j < std::min<int>(from.num_joints, p.model->dof()); ++j) {
        const auto k = static_cast<std::size_t>(j);
        p.q[j] = from.joint_position[k];
        peer_speed_m_s += p.model->displacement_bound(j) * std::abs(from.joint_velocity[k]);
        peer_reach_m += p.model->displacement_bound(j) * std::abs(from.stop_travel[k]);
      }
    }
    if (!live && !tags) {
      // Not seen by tags (none, or none fresh and plausible): its frozen pose grown by its speed
      // bound over the time unheard, or, never heard, anywhere it can reach.
      ++stats_.site_frozen_cycles;
      if (!m.has_state) {
        stale_stop = true;
        site_park(p, 0);
        continue;
      }
      const double unheard_s = static_cast<double>(now_us_ - m.state_received_us) * 1e-6;
      const double grow_m = peer_reach_m + p.max_point_speed_m_s * (unheard_s + skew_s);
      const double gap_m = site_gap_m(p, p.q, grow_m, q_wrapped_, margin_m + my_reach_m + kSiteBoundSlackM, &site_kin_) - my_reach_m;
      stale_stop = stale_stop || gap_m <= margin_m;
      continue;
    }
    const double t0_s = static_cast<double>(age_us) * 1e-6;
    const bool uses_plan = live && m.state.plan_id != 0 && m.has_plan && m.plan.plan_id == m.state.plan_id;
    // Live: what the state cannot say, its speed over the skew. From tags: the fit's own bound.
    const double grow_m = peer_reach_m + (live ? peer_speed_m_s * skew_s : p.tag_pose.grow_m);
    // A machine at rest (one that waits, for me perhaps) does not take up its plan at full speed
    // at once: it stays where it is, grown by how far its joints' accelerations carry it.
    const bool at_rest = peer_speed_m_s < kSiteRestSpeedMS && st.time_to_rest_s < kSiteRestSpeedMS;
    const auto start_reach_m = [&](double tau_s) noexcept {
      double reach_m = 0.0;
      for (int j = 0; j < nq; ++j) {
        const planning::JointSpec& spec = p.model->joints()[static_cast<std::size_t>(j)];
        reach_m += p.model->displacement_bound(j) * std::min(0.5 * spec.max_acceleration * tau_s * tau_s, spec.max_velocity * tau_s);
      }
      return reach_m;
    };
    // Carried forward from the state, which is t0_s old: along its plan, or at its velocity.
    const auto predict = [&](double tau_s, planning::JointVector& q) noexcept {
      if (at_rest) {
        for (int j = 0; j < nq; ++j) q[j] = st.joint_position[static_cast<std::size_t>(j)];
        return;
      }
      if (uses_plan) {
        site_plan_at(m.plan, st.plan_time_s + t0_s + tau_s, q);
        return;
      }
      for (int j = 0; j < nq; ++j) q[j] = st.joint_position[static_cast<std::size_t>(j)] + st.joint_velocity[static_cast<std::size_t>(j)] * (t0_s + tau_s);
    };
    double meet_s = std::numeric_limits<double>::infinity();
    // The other machine's configurations have its own joint count, which need not be mine.
    site_peer_q_ = p.q;
    site_q2_ = p.q;
    for (double tau_s = 0.0; tau_s <= horizon_s + 1e-9; tau_s += step_s) {
      // Between two samples either machine moves at most half a step's travel from the nearer
      // one: mine at its carried velocity, the other's along its prediction.
      predict(std::max(tau_s - step_s, 0.0), site_peer_q_);
      predict(tau_s, site_q2_);
      double between_m = my_speed_m_s * step_s;
      for (int j = 0; j < nq; ++j) between_m += p.model->displacement_bound(j) * std::abs(site_q2_[j] - site_peer_q_[j]);
      if (tau_s == 0.0) between_m += peer_speed_m_s * step_s;
      for (int j = 0; j < n_; ++j) site_q_[j] = q_wrapped_[j] + carried(j, tau_s);
      // From tags: how far its joints' accelerations carry it off the velocity since that was
      // measured, and the fits' noise on the velocity.
      const double start_m = !live ? start_reach_m(p.tag_pose.velocity_lag_s + t0_s + tau_s) + p.tag_pose.speed_error_m_s * (t0_s + tau_s)
                                   : (at_rest ? start_reach_m(t0_s + tau_s + skew_s) : 0.0);
      // Only a distance that can matter is measured: within the stop margin of my stop travel's
      // reach, and at the first sample within what both machines' speed bounds can close over the
      // horizon. Beyond it the bounding boxes alone show the machine clear: no narrow phase.
      const double reach_m = my_reach_at(tau_s);
      const double matters_m = tau_s == 0.0 ? margin_m + horizon_s * (my_bound_m_s + p.max_point_speed_m_s) + my_reach_at(horizon_s)
                                            : margin_m + reach_m;
      // The world boxes of my bodies, where I stand at the first sample and along my way after it,
      // are compared first: most samples find the other machine beyond the bound by them alone.
      const double sample_grow_m = grow_m + start_m + 0.5 * between_m;
      const double sample_bound_m = matters_m + kSiteBoundSlackM;
      if (tau_s > 0.0) model_->forward_kinematics(site_q_, site_way_kin_);
      const double sample_m = tau_s == 0.0 ? site_gap_m(p, site_q2_, sample_grow_m, q_wrapped_, sample_bound_m, &site_kin_)
                                           : site_gap_m(p, site_q2_, sample_grow_m, site_q_, sample_bound_m, &site_way_kin_);
      const double gap_m = sample_m - reach_m;
      if (tau_s == 0.0) {
        stats_.site_min_gap_m = std::min(stats_.site_min_gap_m, gap_m);
        // Nothing either can do within the horizon closes a gap this wide.
        if (gap_m - horizon_s * (my_bound_m_s + p.max_point_speed_m_s) - (my_reach_at(horizon_s) - my_reach_at(0.0)) > margin_m) break;
      }
      if (gap_m <= margin_m) {
        // Only my motion toward it is stopped: where my way leads apart (as against standing
        // still, a step on), stopping would keep me in its way. The sample measured one of the
        // two gaps already, below its bound: at the first, standing; after it, my way a step on
        // and more, which is the sample's own configuration.
        const double known_m = sample_m < sample_bound_m ? sample_m : kNaN;
        if (tau_s == 0.0) {
          for (int j = 0; j < n_; ++j) site_q_[j] = q_wrapped_[j] + carried(j, step_s);
          if (site_leads_apart(p, site_q2_, sample_grow_m, site_q_, kNaN, q_wrapped_, known_m)) continue;
        } else if (site_leads_apart(p, site_q2_, sample_grow_m, site_q_, known_m, q_wrapped_, kNaN)) {
          continue;
        }
        meet_s = tau_s;
        break;
      }
    }
    pin.meet_in_s = meet_s;
    site_meet_s_[r] = meet_s;
  }
  // The planning worlds are posed from these inputs when a plan or a repair starts this cycle
  // (site_pose_worlds()), never while one is being computed.
  site_worlds_due_ = !planning_now;
  site_decision_ = decide_site(site_roster_, site_->machine_id,
                               std::span<const SitePeerInput>(site_in_.data(), site_roster_.count), now_us_, rules);
  SiteMotion motion = site_decision_.motion;
  if (stale_stop) motion = SiteMotion::Stop;
  if (motion == SiteMotion::Stop) {
    ++stats_.site_stop_cycles;
    if (site_motion_ != SiteMotion::Stop) ++stats_.site_stops;
  } else if (motion == SiteMotion::SlowDown) {
    ++stats_.site_slow_cycles;
  }
  if (site_stale_ && !site_was_stale_) ++stats_.site_stale_alerts;
  site_was_stale_ = site_stale_;
  site_motion_ = motion;
  if (site_decision_.motion_for_id != 0 && !site_stale_) site_alert_id_ = site_decision_.motion_for_id;
  site_speed_scale_ = motion == SiteMotion::Stop ? 0.0 : (motion == SiteMotion::SlowDown ? site_->slow_down_scale : 1.0);
  // The lower-priority machine re-plans round each new plan of a higher one, before they would
  // meet (a path already planned round that plan is kept, and the machine waits where the rule
  // stops it), and when stopped for a higher one that has no plan.
  // Kept stopped by a higher-priority machine for wait_replan_us on such a path, it re-plans again,
  // round where that machine now stands and what is left of its plan: it may be waiting for me.
  bool replan = false;
  bool waiting = false;
  for (std::size_t i = 0; i < site_decision_.count; ++i) {
    const SitePeerDecision& d = site_decision_.peers[i];
    const SitePeerMessages& m = in.peers[i];
    if (planning_now) site_planned_round_[i] = m.has_state ? m.state.plan_id : 0;
    const bool planned_round = m.has_state && site_planned_round_[i] == m.state.plan_id;
    const bool stop_for = d.role == SiteRole::PlanAround && d.motion == SiteMotion::Stop;
    const bool new_plan = d.role == SiteRole::PlanAround && d.prediction == SitePrediction::Plan && !planned_round;
    waiting = waiting || stop_for;
    replan = replan || (stop_for && !planned_round) || new_plan;
  }
  if (!waiting || planning_now) site_wait_since_us_ = now_us_;
  if (waiting && now_us_ - site_wait_since_us_ >= site_->wait_replan_us) {
    replan = true;
    site_wait_since_us_ = now_us_;
  }
  site_replan_ = replan && following_ && supervisor_.state() == guidance::SupervisorState::Executing;
  if (site_replan_) ++stats_.site_replans;
}

const SiteTagPose* Controller::site_tag_pose(std::int32_t machine_id) const noexcept {
  for (const SitePeerModel& p : site_peers_) {
    if (p.machine_id == machine_id && p.num_tags > 0) return &p.tag_pose;
  }
  return nullptr;
}

void Controller::site_pose_worlds(const SiteInputs& in) noexcept {
  const SiteRulesConfig& rules = site_->rules;
  const double skew_s = static_cast<double>(rules.max_skew_us) * 1e-6;
  for (SitePeerModel& p : site_peers_) {
    const SitePeerMessages& m = in.peers[static_cast<std::size_t>(p.roster_index)];
    // Its configurations at its own joint count.
    site_q2_ = p.q;
    if (site_in_[static_cast<std::size_t>(p.roster_index)].tags_posed && now_us_ - m.state_received_us > rules.stale_after_us()) {
      // Stale, posed from its tags as site_cycle() measured it: where they put it, and where its
      // velocity's stop travel takes it.
      const site_state_t& t = p.tag_state;
      const int nt = std::min<int>(t.num_joints, p.model->dof());
      double speed_m_s = 0.0;
      double reach_m = 0.0;
      for (int j = 0; j < nt; ++j) {
        const auto k = static_cast<std::size_t>(j);
        p.q[j] = t.joint_position[k];
        site_q2_[j] = t.joint_position[k] + t.stop_travel[k];
        speed_m_s += p.model->displacement_bound(j) * std::abs(t.joint_velocity[k]);
        reach_m += p.model->displacement_bound(j) * std::abs(t.stop_travel[k]);
      }
      const double age_s = static_cast<double>(now_us_ - p.tag_pose.t_us) * 1e-6;
      site_pose_copy(p, 0, p.q, reach_m + p.tag_pose.grow_m + speed_m_s * age_s);
      site_pose_copy(p, 1, site_q2_, p.tag_pose.grow_m + speed_m_s * age_s);
      site_park(p, p.copies > 1 ? 2 : 1);
      continue;
    }
    // A machine never heard is parked by site_cycle(), every cycle.
    if (!m.has_state) continue;
    const std::int64_t age_us = now_us_ - m.state_received_us;
    const int nq = std::min<int>(m.state.num_joints, p.model->dof());
    double peer_speed_m_s = 0.0;
    double peer_reach_m = 0.0;
    for (int j = 0; j < nq; ++j) {
      const auto k = static_cast<std::size_t>(j);
      p.q[j] = m.state.joint_position[k];
      peer_speed_m_s += p.model->displacement_bound(j) * std::abs(m.state.joint_velocity[k]);
      peer_reach_m += p.model->displacement_bound(j) * std::abs(m.state.stop_travel[k]);
    }
    if (age_us > rules.stale_after_us()) {
      // Stale: its frozen pose, grown as site_cycle() measures it.
      site_pose_copy(p, 0, p.q, peer_reach_m + p.max_point_speed_m_s * (static_cast<double>(age_us) * 1e-6 + skew_s));
      site_park(p, 1);
      continue;
    }
    const double t0_s = static_cast<double>(age_us) * 1e-6;
    const bool uses_plan = m.state.plan_id != 0 && m.has_plan && m.plan.plan_id == m.state.plan_id;
    // A higher-priority machine is planned around: its pose and its plan's remaining sweep. A
    // lower-priority one is not.
    if (p.higher) {
      site_pose_copy(p, 0, p.q, peer_reach_m + peer_speed_m_s * (t0_s + skew_s));
      if (uses_plan) {
        const int w = std::clamp<int>(m.plan.num_waypoints, 2, site_plan_t::MAX_WAYPOINTS);
        const double from_s = m.state.plan_time_s;
        const int copies = site_->plan_copies - 1;
        // At their own size: grown to cover the sweep between them they would lie on my carrier,
        // which that machine planned round, and leave me no start. What passes between two copies
        // is the meet scan's to stop. They stand at fixed times of the plan, evenly over the whole
        // of it, so that they depend on the plan alone: a new plan poses them, and as the machine
        // goes on along it each copy it has passed is parked once.
        // A plan time gone back (the same motion started again) poses the parked copies again.
        const bool went_back = p.plan_passed > 0 && site_plan_copy_time_s(m.plan, w, p.plan_passed, copies) >= from_s;
        if (!(p.plan_posed && !went_back && site_same_motion(p.plan_posed_from, m.plan))) {
          p.plan_posed_from = m.plan;
          p.plan_passed = 0;
          for (int c = 1; c <= copies; ++c) {
            site_plan_at(m.plan, site_plan_copy_time_s(m.plan, w, c, copies), site_q2_);
            site_pose_copy(p, c, site_q2_, 0.0);
          }
          p.plan_posed = true;
        }
        while (p.plan_passed < copies && site_plan_copy_time_s(m.plan, w, p.plan_passed + 1, copies) < from_s) {
          ++p.plan_passed;
          site_park_copy(p, p.plan_passed);
        }
      } else {
        for (int j = 0; j < nq; ++j) site_q2_[j] = p.q[j] + m.state.stop_travel[static_cast<std::size_t>(j)];
        site_pose_copy(p, 1, site_q2_, peer_speed_m_s * (t0_s + skew_s));
        site_park(p, 2);
      }
    } else {
      site_park(p, 0);
    }
  }
}

void Controller::site_fill_state(const guidance::SupervisorOutput& out) noexcept {
  site_state_.supervisor_state = state_code(out.state);
  site_state_.num_joints = static_cast<std::int8_t>(n_);
  double rest_s = 0.0;
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double v = velocity_[k];
    const double a = model_->joints()[k].max_acceleration;
    site_state_.joint_position[k] = q_wrapped_[j];
    site_state_.joint_velocity[k] = v;
    site_state_.stop_travel[k] = v * std::abs(v) / (2.0 * a);
    rest_s = std::max(rest_s, std::abs(v) / a);
  }
  site_state_.time_to_rest_s = rest_s;
  const bool executing = following_ && out.state == guidance::SupervisorState::Executing && site_plan_version_ > 0 &&
                         site_plan_source_ == plan_id_;
  site_state_.plan_id = executing ? site_plan_.plan_id : 0;
  double t_s = 0.0;
  if (executing && target_ >= 1) {
    // Along the segment being followed by the share of its moving joint's way done.
    const std::size_t seg = std::min(target_, path_size_) - 1;
    const std::size_t i = seg >= site_plan_first_ ? seg - site_plan_first_ : 0;
    const int w = site_plan_.num_waypoints;
    if (static_cast<int>(i) + 1 < w) {
      const double t_a = site_plan_.waypoint_time_s[i];
      const double t_b = site_plan_.waypoint_time_s[i + 1];
      double done = 1.0;
      double largest = 0.0;
      for (int j = 0; j < n_; ++j) {
        const double span = std::abs(site_plan_.positions[i + 1][static_cast<std::size_t>(j)] - site_plan_.positions[i][static_cast<std::size_t>(j)]);
        if (span > largest) {
          largest = span;
          done = std::clamp(1.0 - std::abs(target_unwrapped_[j] - q_unwrapped_[j]) / span, 0.0, 1.0);
        }
      }
      t_s = t_a + done * (t_b - t_a);
    } else {
      t_s = site_plan_.waypoint_time_s[std::max(w - 1, 0)];
    }
  }
  site_state_.plan_time_s = t_s;
}

void Controller::site_fill_plan() noexcept {
  if (!following_ || path_size_ < 2) return;
  const std::size_t window = static_cast<std::size_t>(site_plan_t::MAX_WAYPOINTS);
  // The window starts at the active segment; a plan that fits is sent whole.
  const std::size_t first = path_size_ <= window ? 0 : std::min(target_ >= 1 ? target_ - 1 : 0, path_size_ - 2);
  if (site_plan_version_ > 0 && site_plan_source_ == plan_id_ && first == site_plan_first_) return;
  site_plan_source_ = plan_id_;
  site_plan_first_ = first;
  site_plan_.plan_id = static_cast<std::int32_t>(plan_id_);
  const std::size_t count = std::min(window, path_size_ - first);
  site_plan_.num_waypoints = static_cast<std::int8_t>(count);
  site_plan_.ends_at_goal = first + count == path_size_;
  planning::JointVector w = origin_;
  for (std::size_t i = 1; i <= first; ++i) w += model_->difference(waypoint(i - 1), waypoint(i));
  double t_s = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    if (i > 0) {
      const planning::JointVector d = model_->difference(waypoint(first + i - 1), waypoint(first + i));
      // One joint at a time, each at the follower's speed with its acceleration ramps.
      double seg_s = 0.0;
      for (int j = 0; j < n_; ++j) {
        const guidance::JointLimits& l = follow_limits_[static_cast<std::size_t>(j)];
        if (std::abs(d[j]) > kReachedTolerance) seg_s += std::abs(d[j]) / l.max_velocity + l.max_velocity / l.max_acceleration;
      }
      t_s += std::max(seg_s, 1e-3);
      w += d;
    }
    site_plan_.waypoint_time_s[i] = t_s;
    for (int j = 0; j < n_; ++j) site_plan_.positions[i][static_cast<std::size_t>(j)] = w[j];
  }
  for (std::size_t i = count; i < window; ++i) {
    site_plan_.waypoint_time_s[i] = 0.0;
    for (auto& x : site_plan_.positions[i]) x = 0.0;
  }
  ++site_plan_version_;
  ++stats_.site_plans_published;
}

}  // namespace mgc::firmware
