// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/planners/cart_rrt.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mgc/planning/excavator.hpp"

namespace mgc::planning {
namespace {

// Task space and tracking.
constexpr double kCartStepsPerDiagonal = 200.0;  // target spacing = workspace diagonal / this
constexpr double kMaxLengthPerDiagonal = 20.0;   // longest extension = diagonal / this ([GAP] maxLength)
constexpr double kPitchLengthM = 1.0;            // a ground-angle error of 1 rad counts as 1 m
constexpr double kTrackTolM = 1e-3;              // Newton converged: tool point within 1 mm ...
constexpr double kTrackTolRad = 1e-4;            // ... and the ground angle within 0.1 mrad
constexpr int kMaxNewtonSteps = 8;               // [GAP] edgeCountMax, per target
constexpr double kJacobianDeltaQ = 1e-6;         // central-difference step [rad | m]
constexpr double kDamping = 1e-3;                // lambda relative to the Jacobian's scale
constexpr double kSingularRatio = 1e-8;          // [GAP] det(J) ~ 0: smallest / largest eigenvalue of J W J^T
constexpr double kMaxStepsPerTarget = 3.0;       // a jump of more joint steps between targets is not tracking
constexpr double kNullGain = 0.2;                // null-space pull: this share of the gap per target
// Workspace box: tool points of this many joint samples that satisfy the engineering constraints.
constexpr int kBoxSamples = 2048;
constexpr std::uint64_t kBoxSeed = 0x5eed0002;
// Default pool: tree nodes per iteration (an extension stores up to kCartStepsPerDiagonal /
// kMaxLengthPerDiagonal of them, many store none).
constexpr int kDefaultNodesPerIteration = 8;
// Path buffers: the tree's path and its shortcuts (a longer tree path reports PoolExhausted),
// and the spline's samples (a spline needing more counts as failed and the next round is
// denser, down to stopping at the waypoints).
constexpr std::size_t kMaxWaypoints = 4096;
constexpr std::size_t kMaxSplineSamples = 8192;
constexpr std::size_t kChordsPerIteration = 16;
// Tracking holds joints this far inside their end stops: a spline through vias that ride an end
// stop would overshoot it between them.
constexpr double kStopMarginSteps = 1.0;
constexpr double kStopMarginRange = 0.1;  // ... but never more than this share of the range

bool converged(const Eigen::Vector4d& e) noexcept {
  return e.head<3>().norm() <= kTrackTolM && std::abs(e[3]) <= kTrackTolRad;
}

}  // namespace

Eigen::Vector4d CartRrtPlanner::task_point(const JointVector& q) const noexcept {
  problem_->model->forward_kinematics(q, kinematics_);
  Eigen::Vector4d p;
  p.head<3>() = kinematics_.points[static_cast<std::size_t>(tool_)];
  p[3] = pitch_task_ ? bucket_ground_angle_rad(q) : 0.0;
  return p;
}

void CartRrtPlanner::jacobian(const JointVector& q, Eigen::Matrix<double, 4, kMaxJoints>& out) const noexcept {
  out.setZero();
  JointVector probe = q;
  for (int j = 0; j < q.size(); ++j) {
    probe[j] = q[j] + kJacobianDeltaQ;
    const Eigen::Vector4d plus = task_point(probe);
    probe[j] = q[j] - kJacobianDeltaQ;
    const Eigen::Vector4d minus = task_point(probe);
    probe[j] = q[j];
    out.col(j) = (plus - minus) / (2.0 * kJacobianDeltaQ);
  }
}

double CartRrtPlanner::task_distance_m(const Eigen::Vector4d& a, const Eigen::Vector4d& b) const noexcept {
  const Eigen::Vector4d d = a - b;
  return std::sqrt(d.head<3>().squaredNorm() + kPitchLengthM * kPitchLengthM * d[3] * d[3]);
}

PlannerStatus CartRrtPlanner::reset(const PlanningProblem& problem) {
  problem_ = &problem;
  const MachineModel& model = *problem.model;
  random_.reseed(problem.seed);
  iterations_ = 0;
  grow_iterations_ = 0;
  checks_at_reset_ = problem.world->collision_checks();
  greedy_node_ = -1;
  shortcut_attempts_ = 0;
  spline_vias_ = kInitialVias;
  chord_ = 0;
  report_ = Report{};
  path_.clear();
  waypoints_.clear();
  phase_ = Phase::Done;

  tool_ = model.key_point_index(model.kind() == MachineKind::Excavator ? "bucket_tip" : "hook");
  pitch_task_ = model.kind() == MachineKind::Excavator;

  const int dof = model.dof();
  weights_ = JointVector::Zero(dof);
  for (int j = 0; j < dof; ++j) {
    const JointSpec& spec = model.joints()[static_cast<std::size_t>(j)];
    weights_[j] = spec.max_velocity * spec.max_velocity;
    const double margin = std::min(kStopMarginSteps * problem.step[j], kStopMarginRange * spec.range());
    stop_lo_[static_cast<std::size_t>(j)] = spec.position_min + margin;
    stop_hi_[static_cast<std::size_t>(j)] = spec.position_max - margin;
  }

  const auto capacity = static_cast<std::size_t>(
      problem.node_capacity > 0 ? problem.node_capacity : kDefaultNodesPerIteration * (problem.max_iterations + 1));
  tree_.reset(capacity);
  points_.clear();
  points_.reserve(capacity);
  // The tree's path has at most every node plus the goal.
  const std::size_t waypoint_capacity = std::min(capacity + 2, kMaxWaypoints);
  for (auto* v : {&waypoints_, &scratch_, &vias_}) v->reserve(waypoint_capacity);
  waypoint_points_.reserve(waypoint_capacity);
  scratch_points_.reserve(waypoint_capacity);
  arc_.reserve(waypoint_capacity);
  trajectory_.reserve(waypoint_capacity);
  path_.reserve(std::max(kMaxSplineSamples, waypoint_capacity));
  const auto chain_capacity = static_cast<std::size_t>(kCartStepsPerDiagonal) + 8;
  chain_.reserve(chain_capacity);
  chain_points_.reserve(chain_capacity);

  if (tool_ < 0 || !problem.world->validate(problem.start).valid()) return status_ = PlannerStatus::InvalidStart;
  if (!problem.world->validate(problem.goal).valid()) return status_ = PlannerStatus::InvalidGoal;

  // Sampling box: where the tool point goes over configurations that satisfy the machine's
  // constraints (the cranes' load above ground, the load chart), with start and goal. A fixed
  // seed keeps the box, and so the edge resolution, the same for every query seed.
  const Eigen::Vector4d start_point = task_point(problem.start);
  goal_point_ = task_point(problem.goal);
  box_lo_m_ = start_point.head<3>().cwiseMin(goal_point_.head<3>());
  box_hi_m_ = start_point.head<3>().cwiseMax(goal_point_.head<3>());
  Random box_random(kBoxSeed);
  for (int i = 0; i < kBoxSamples; ++i) {
    const JointVector q = uniform_sample(model, box_random);
    if (!model.check_constraints(q).ok()) continue;
    const Eigen::Vector3d p = task_point(q).head<3>();
    box_lo_m_ = box_lo_m_.cwiseMin(p);
    box_hi_m_ = box_hi_m_.cwiseMax(p);
  }
  const double diagonal_m = std::max((box_hi_m_ - box_lo_m_).norm(), kTrackTolM * kCartStepsPerDiagonal);
  cart_step_m_ = diagonal_m / kCartStepsPerDiagonal;
  max_length_m_ = diagonal_m / kMaxLengthPerDiagonal;
  pitch_lo_rad_ = std::min(start_point[3], goal_point_[3]);
  pitch_hi_rad_ = std::max(start_point[3], goal_point_[3]);

  if (!tree_.add(problem.start, -1)) return status_ = PlannerStatus::PoolExhausted;
  points_.push_back(start_point);
  phase_ = Phase::Grow;
  return status_ = PlannerStatus::Running;
}

PlannerStats CartRrtPlanner::stats() const noexcept {
  PlannerStats s;
  s.iterations = iterations_;
  s.tree_nodes = static_cast<int>(tree_.size());
  if (problem_) s.collision_checks = problem_->world->collision_checks() - checks_at_reset_;
  return s;
}

void CartRrtPlanner::tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const {
  nodes = tree_.nodes();
  parents = tree_.parents();
}

Eigen::Vector4d CartRrtPlanner::random_task_point() noexcept {
  Eigen::Vector4d p;
  for (int i = 0; i < 3; ++i) p[i] = random_.uniform(box_lo_m_[i], box_hi_m_[i]);
  p[3] = pitch_task_ ? random_.uniform(pitch_lo_rad_, pitch_hi_rad_) : 0.0;
  return p;
}

Eigen::Vector4d CartRrtPlanner::goal_region_point() noexcept {
  // The goal region is a cube round the goal's tool point ([GAP] cart_g), its corners within
  // max_length_m() of the centre, so every point of it qualifies for connect_goal().
  Eigen::Vector4d p = goal_point_;
  for (int i = 0; i < 3; ++i) p[i] += random_.uniform(-0.5, 0.5) * max_length_m_;
  return p;
}

int CartRrtPlanner::nearest(const Eigen::Vector4d& p) const noexcept {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const double d = task_distance_m(points_[i], p);
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(i);
    }
  }
  return best;
}

bool CartRrtPlanner::ik_step(const JointVector& q, const Eigen::Vector4d& error, const JointVector* attractor,
                             JointVector& dq) noexcept {
  const MachineModel& model = *problem_->model;
  const int dof = model.dof();
  const int rows = pitch_task_ ? 4 : 3;
  Eigen::Matrix<double, 4, kMaxJoints> jac;
  jacobian(q, jac);

  JointVector w = weights_;
  const auto weighted_gram = [&]() {
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    for (int j = 0; j < dof; ++j) a.noalias() += w[j] * jac.col(j) * jac.col(j).transpose();
    return a;
  };
  Eigen::Matrix4d gram = weighted_gram();
  // A singular Jacobian (the paper's det(J) ~ 0 test, made scale-free) ends the edge.
  double smallest = 0.0;
  double largest = 0.0;
  if (rows == 4) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(gram, Eigen::EigenvaluesOnly);
    smallest = eig.eigenvalues()[0];
    largest = eig.eigenvalues()[3];
  } else {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(gram.topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly);
    smallest = eig.eigenvalues()[0];
    largest = eig.eigenvalues()[2];
  }
  if (!(largest > 0.0) || smallest < kSingularRatio * largest) return false;
  const double damping = kDamping * kDamping * largest;

  // Redundant joints drift toward the attractor's in the null space, a bounded share per target.
  JointVector pull = JointVector::Zero(dof);
  if (attractor) {
    const JointVector gap = model.difference(q, *attractor);
    for (int j = 0; j < dof; ++j) {
      pull[j] = std::clamp(kNullGain * gap[j], -problem_->step[j], problem_->step[j]);
    }
  }

  // Weighted damped least squares, dq = W J^T (J W J^T + l^2 I)^-1 e + (I - W J^T (..)^-1 J) z.
  // A joint that would pass an end stop is held there and the rest re-solved for what it
  // leaves undone (the note's joint-limit handling; the paper has none).
  JointVector held = JointVector::Zero(dof);
  Eigen::Vector4d remaining = error;
  for (int pass = 0; pass <= dof; ++pass) {
    Eigen::Matrix4d a = weighted_gram();
    a.diagonal().array() += damping;
    if (rows == 3) a(3, 3) = 1.0;  // the unused pitch row
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(a);
    const Eigen::Vector4d x = ldlt.solve(remaining);
    JointVector z = JointVector::Zero(dof);
    for (int j = 0; j < dof; ++j) z[j] = w[j] > 0.0 ? pull[j] : 0.0;
    const Eigen::Vector4d jz = jac.leftCols(dof) * z;
    const Eigen::Vector4d y = ldlt.solve(jz);
    JointVector free_step(dof);
    for (int j = 0; j < dof; ++j) free_step[j] = w[j] * jac.col(j).dot(x) + z[j] - w[j] * jac.col(j).dot(y);

    bool newly_held = false;
    for (int j = 0; j < dof; ++j) {
      const auto k = static_cast<std::size_t>(j);
      if (model.joints()[k].continuous || w[j] == 0.0) continue;
      const double to = q[j] + free_step[j];
      if (to >= stop_lo_[k] && to <= stop_hi_[k]) continue;
      held[j] = std::clamp(to, stop_lo_[k], stop_hi_[k]) - q[j];
      remaining -= jac.col(j) * held[j];
      w[j] = 0.0;
      newly_held = true;
    }
    if (!newly_held) {
      for (int j = 0; j < dof; ++j) dq[j] = w[j] > 0.0 ? free_step[j] : held[j];
      return true;
    }
  }
  dq = held;
  return true;
}

bool CartRrtPlanner::solve_ik(JointVector& q, const Eigen::Vector4d& target, const JointVector* attractor) noexcept {
  const MachineModel& model = *problem_->model;
  JointVector dq(model.dof());
  for (int it = 0; it < kMaxNewtonSteps; ++it) {
    const Eigen::Vector4d error = target - task_point(q);
    if (converged(error)) return true;
    if (!ik_step(q, error, it == 0 ? attractor : nullptr, dq)) return false;
    q += dq;
    for (int j = 0; j < model.dof(); ++j) {
      if (model.joints()[static_cast<std::size_t>(j)].continuous) q[j] = wrap_angle(q[j]);
    }
  }
  return converged(target - task_point(q));
}

CartRrtPlanner::Track CartRrtPlanner::track_line(const JointVector& q0, const Eigen::Vector4d& from,
                                                 const Eigen::Vector4d& to, const JointVector& attractor) noexcept {
  const PlanningProblem& p = *problem_;
  const MachineModel& model = *p.model;
  const double length_m = task_distance_m(from, to);
  const int targets = std::max(1, static_cast<int>(std::ceil(length_m / cart_step_m_ - 1e-9)));
  if (chain_.size() + static_cast<std::size_t>(targets) > chain_.capacity()) return Track::Failed;
  const JointVector* pull = model.dof() > (pitch_task_ ? 4 : 3) ? &attractor : nullptr;
  JointVector q = q0;
  for (int k = 1; k <= targets; ++k) {
    const JointVector previous = q;
    const Eigen::Vector4d target = k == targets ? to : Eigen::Vector4d(from + (static_cast<double>(k) / targets) * (to - from));
    if (!solve_ik(q, target, pull)) return Track::Failed;
    // Newton may converge to a distant configuration (another branch, a joint unwinding): that
    // would not follow the line, so the edge fails as the paper's does on non-convergence.
    const JointVector jump = model.difference(previous, q);
    for (int j = 0; j < model.dof(); ++j) {
      if (std::abs(jump[j]) > kMaxStepsPerTarget * p.step[j]) return Track::Failed;
    }
    if (!p.world->validate_edge(previous, q, p.step).valid()) return Track::Failed;
    chain_.push_back(q);
    chain_points_.push_back(task_point(q));
  }
  return Track::Reached;
}

int CartRrtPlanner::add_chain(int parent) noexcept {
  for (std::size_t i = 0; i < chain_.size(); ++i) {
    if (!tree_.add(chain_[i], parent)) return -1;
    points_.push_back(chain_points_[i]);
    parent = static_cast<int>(tree_.size()) - 1;
  }
  return parent;
}

CartRrtPlanner::Track CartRrtPlanner::extend(int from, const Eigen::Vector4d& target, bool& reached, int& added) noexcept {
  const Eigen::Vector4d& origin = points_[static_cast<std::size_t>(from)];
  const double d = task_distance_m(origin, target);
  reached = d <= max_length_m_;
  // Already there: no edge to add, and nothing learned.
  if (d < kTrackTolM) return Track::Failed;
  const Eigen::Vector4d end = reached ? target : Eigen::Vector4d(origin + (max_length_m_ / d) * (target - origin));
  chain_.clear();
  chain_points_.clear();
  const Track t = track_line(tree_.node(from), origin, end, problem_->goal);
  if (t != Track::Reached) return t;
  added = add_chain(from);
  return added < 0 ? Track::Full : Track::Reached;
}

CartRrtPlanner::Track CartRrtPlanner::connect_goal(int from, bool& joined) noexcept {
  joined = false;
  const PlanningProblem& p = *problem_;
  chain_.clear();
  chain_points_.clear();
  const Track t = track_line(tree_.node(from), points_[static_cast<std::size_t>(from)], goal_point_, p.goal);
  if (t != Track::Reached) return t;
  // The line's last configuration has the goal's task point; end on the exact goal instead, by
  // a joint-space edge from the one before (for the mobile crane this also closes the gap in
  // the redundant joints).
  chain_.pop_back();
  chain_points_.pop_back();
  const JointVector& last = chain_.empty() ? tree_.node(from) : chain_.back();
  if (!p.world->validate_edge(last, p.goal, p.step).valid()) return Track::Failed;
  chain_.push_back(p.goal);
  chain_points_.push_back(goal_point_);
  const int goal_node = add_chain(from);
  if (goal_node < 0) return Track::Full;

  // The tree's path, root to goal, with its task points.
  std::size_t depth = 0;
  for (int n = goal_node; n >= 0; n = tree_.parent(n)) ++depth;
  if (depth > waypoints_.capacity()) return Track::Full;
  waypoints_.clear();
  waypoint_points_.clear();
  for (int n = goal_node; n >= 0; n = tree_.parent(n)) {
    waypoints_.push_back(tree_.node(n));
    waypoint_points_.push_back(points_[static_cast<std::size_t>(n)]);
  }
  std::reverse(waypoints_.begin(), waypoints_.end());
  std::reverse(waypoint_points_.begin(), waypoint_points_.end());
  report_.raw_nodes = static_cast<int>(waypoints_.size());
  for (std::size_t i = 0; i + 1 < waypoint_points_.size(); ++i) {
    report_.raw_tool_length_m += (waypoint_points_[i + 1] - waypoint_points_[i]).head<3>().norm();
  }
  joined = true;
  return Track::Reached;
}

void CartRrtPlanner::grow_iteration() noexcept {
  ++grow_iterations_;
  int from = 0;
  Eigen::Vector4d target;
  bool greedy = true;
  if (greedy_node_ >= 0) {
    // The greedy extension (Alg. 3) goes on toward its target, one extension per iteration.
    from = greedy_node_;
    target = greedy_target_;
  } else if (random_.uniform() < problem_->goal_bias) {
    greedy_target_ = goal_region_point();
    target = greedy_target_;
    from = nearest(target);
  } else {
    greedy = false;
    target = random_task_point();
    from = nearest(target);
  }
  greedy_node_ = -1;
  // The root may already lie in the goal region.
  int added = from;
  bool reached = false;
  if (!(grow_iterations_ == 1 && task_distance_m(points_[0], goal_point_) <= max_length_m_)) {
    const Track t = extend(from, target, reached, added);
    if (t == Track::Full) {
      status_ = PlannerStatus::PoolExhausted;
      return;
    }
    if (t == Track::Failed) return;
    if (greedy && !reached) greedy_node_ = added;
  }
  if (task_distance_m(points_[static_cast<std::size_t>(added)], goal_point_) > max_length_m_) return;
  bool joined = false;
  const Track g = connect_goal(added, joined);
  if (g == Track::Full) {
    status_ = PlannerStatus::PoolExhausted;
    return;
  }
  if (joined) {
    greedy_node_ = -1;
    phase_ = Phase::Shortcut;
  }
}

void CartRrtPlanner::shortcut_iteration() noexcept {
  const PlanningProblem& p = *problem_;
  const std::size_t n = waypoints_.size();
  if (shortcut_attempts_ >= kShortcutAttempts || n < 3) {
    // Shortcutting done: set up the via spacing (cumulative chord time, as the spline's knots).
    const MachineModel& model = *p.model;
    arc_.clear();
    arc_.push_back(0.0);
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const JointVector d = model.difference(waypoints_[i], waypoints_[i + 1]);
      double chord_s = 0.0;
      for (int j = 0; j < model.dof(); ++j) chord_s = std::max(chord_s, std::abs(d[j]) / model.joints()[static_cast<std::size_t>(j)].max_velocity);
      arc_.push_back(arc_.back() + chord_s);
    }
    report_.waypoints = static_cast<int>(n);
    for (std::size_t i = 0; i + 1 < n; ++i) report_.tool_length_m += (waypoint_points_[i + 1] - waypoint_points_[i]).head<3>().norm();
    phase_ = Phase::Spline;
    return;
  }
  ++shortcut_attempts_;
  // Seed 002's random shortcut (after [10]): two configurations a < b of the path, any of them.
  const auto i = std::min(n - 3, static_cast<std::size_t>(random_.uniform() * static_cast<double>(n - 2)));
  const auto k = std::min(n - 1, i + 2 + static_cast<std::size_t>(random_.uniform() * static_cast<double>(n - i - 2)));
  double stretch_m = 0.0;
  for (std::size_t e = i; e < k; ++e) stretch_m += task_distance_m(waypoint_points_[e], waypoint_points_[e + 1]);
  if (task_distance_m(waypoint_points_[i], waypoint_points_[k]) >= stretch_m - kTrackTolM) return;

  chain_.clear();
  chain_points_.clear();
  if (track_line(waypoints_[i], waypoint_points_[i], waypoint_points_[k], waypoints_[k]) != Track::Reached) return;
  chain_.pop_back();  // as in connect_goal: end on the path's own configuration
  chain_points_.pop_back();
  const JointVector& last = chain_.empty() ? waypoints_[i] : chain_.back();
  // The closing edge must be as short as a tracked one, or the path would kink in joint space
  // (the mobile crane's redundant joints arriving elsewhere) and no spline could follow it.
  const JointVector gap = p.model->difference(last, waypoints_[k]);
  for (int j = 0; j < p.model->dof(); ++j) {
    if (std::abs(gap[j]) > kMaxStepsPerTarget * p.step[j]) return;
  }
  if (!p.world->validate_edge(last, waypoints_[k], p.step).valid()) return;
  if (i + 1 + chain_.size() + (n - k) > scratch_.capacity()) return;

  scratch_.clear();
  scratch_points_.clear();
  scratch_.insert(scratch_.end(), waypoints_.begin(), waypoints_.begin() + static_cast<std::ptrdiff_t>(i + 1));
  scratch_points_.insert(scratch_points_.end(), waypoint_points_.begin(), waypoint_points_.begin() + static_cast<std::ptrdiff_t>(i + 1));
  scratch_.insert(scratch_.end(), chain_.begin(), chain_.end());
  scratch_points_.insert(scratch_points_.end(), chain_points_.begin(), chain_points_.end());
  scratch_.insert(scratch_.end(), waypoints_.begin() + static_cast<std::ptrdiff_t>(k), waypoints_.end());
  scratch_points_.insert(scratch_points_.end(), waypoint_points_.begin() + static_cast<std::ptrdiff_t>(k), waypoint_points_.end());
  waypoints_.swap(scratch_);
  waypoint_points_.swap(scratch_points_);
  ++report_.shortcuts;
}

bool CartRrtPlanner::start_spline_round() noexcept {
  const MachineModel& model = *problem_->model;
  const std::size_t n = waypoints_.size();
  const std::size_t count = std::min(n, static_cast<std::size_t>(std::max(2, spline_vias_)));
  // Vias evenly spaced in chord time along the path ([GAP]: "evenly spaced configurations"),
  // each snapped to a path configuration, which is valid.
  vias_.clear();
  vias_.push_back(waypoints_.front());
  std::size_t previous = 0;
  for (std::size_t m = 1; m < count; ++m) {
    std::size_t index = n - 1;
    if (m + 1 < count) {
      const double mark = arc_.back() * static_cast<double>(m) / static_cast<double>(count - 1);
      index = static_cast<std::size_t>(std::lower_bound(arc_.begin(), arc_.end(), mark) - arc_.begin());
      if (index > 0 && mark - arc_[index - 1] < arc_[index] - mark) --index;
      index = std::clamp(index, previous + 1, n - 1 - (count - 1 - m));
    }
    if (model.difference(vias_.back(), waypoints_[index]).cwiseAbs().maxCoeff() > 0.0) vias_.push_back(waypoints_[index]);
    previous = index;
  }
  if (vias_.size() < 2 || !trajectory_.fit(model, vias_, SplineTrajectory::Shape::Spline)) return false;
  ++report_.spline_rounds;

  // Samples on the spline as dense as validate_edge's own: no joint moves more than a step and
  // no body point more than the dilation between two of them, by the segment's largest joint
  // rates. Each chord's check then looks at its end, a point of the spline, so the spline keeps
  // the half dilation a valid edge keeps. Knots take the via configurations themselves.
  const double dilation_m = problem_->world->dilation_m();
  path_.clear();
  path_.push_back(vias_.front());
  for (std::size_t s = 0; s + 1 < trajectory_.knots(); ++s) {
    const double t0 = trajectory_.knot_tau(s);
    const double h = trajectory_.knot_tau(s + 1) - t0;
    const JointVector rate = trajectory_.max_rate(s);
    double need = 1.0;
    double travel_m = 0.0;
    for (int j = 0; j < model.dof(); ++j) {
      need = std::max(need, rate[j] * h / problem_->step[j]);
      travel_m += model.displacement_bound(j) * rate[j] * h;
    }
    if (dilation_m > 0.0) need = std::max(need, travel_m / dilation_m);
    if (path_.size() + static_cast<std::size_t>(need) + 1 > path_.capacity()) return false;
    const int chords = static_cast<int>(std::ceil(need - 1e-12));
    for (int c = 1; c < chords; ++c) path_.push_back(trajectory_.position_at_tau(t0 + h * c / chords));
    path_.push_back(vias_[s + 1]);
  }
  chord_ = 0;
  return true;
}

void CartRrtPlanner::spline_iteration() noexcept {
  const PlanningProblem& p = *problem_;
  const bool every_waypoint = static_cast<std::size_t>(spline_vias_) >= waypoints_.size();
  const auto next_round = [&]() {
    if (every_waypoint) {
      // No spline through the waypoints is valid: stop at each of them. That trajectory runs
      // along the waypoints' own edges, which are valid.
      path_ = waypoints_;
      report_.stops_at_vias = true;
      report_.vias = static_cast<int>(waypoints_.size());
      if (!trajectory_.fit(*p.model, waypoints_, SplineTrajectory::Shape::StopAtVias)) report_.vias = 0;
      report_.duration_s = trajectory_.duration_s();
      phase_ = Phase::Done;
      status_ = PlannerStatus::Solved;
      return;
    }
    spline_vias_ = 2 * spline_vias_ - 1;
    path_.clear();
  };
  if (path_.empty()) {
    // Setting up a round is this iteration's work; its chords are checked kChordsPerIteration
    // per iteration (each about one collision query).
    if (!start_spline_round()) next_round();
    return;
  }
  const std::size_t last = std::min(path_.size() - 1, chord_ + kChordsPerIteration);
  for (; chord_ < last; ++chord_) {
    if (!p.world->validate_edge(path_[chord_], path_[chord_ + 1], p.step).valid()) {
      next_round();
      return;
    }
  }
  if (chord_ + 1 < path_.size()) return;
  report_.vias = static_cast<int>(vias_.size());
  report_.duration_s = trajectory_.duration_s();
  phase_ = Phase::Done;
  status_ = PlannerStatus::Solved;
}

PlannerStatus CartRrtPlanner::step(int iteration_budget) noexcept {
  if (status_ != PlannerStatus::Running) return status_;
  for (int k = 0; k < iteration_budget && status_ == PlannerStatus::Running; ++k) {
    switch (phase_) {
      case Phase::Grow:
        if (grow_iterations_ >= problem_->max_iterations) return status_ = PlannerStatus::IterationLimit;
        grow_iteration();
        break;
      case Phase::Shortcut:
        ++report_.post_iterations;
        shortcut_iteration();
        break;
      case Phase::Spline:
        ++report_.post_iterations;
        spline_iteration();
        break;
      case Phase::Done: break;
    }
    ++iterations_;
  }
  return status_;
}

}  // namespace mgc::planning
