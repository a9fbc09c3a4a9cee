// SPDX-License-Identifier: Apache-2.0
// OMPL on our problem: joint values as OMPL's state (no unit conversion, so start and goal stay
// bit-exact), our step metric as OMPL's distance, our validate() and validate_edge() as its
// validity checks. Range and goal tolerance are therefore in steps, as in our planners.
#include "ompl_adapter.hpp"

#include <ompl/base/PlannerData.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/samplers/informed/RejectionInfSampler.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/config.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>

#include "mgc/planning/collision_world.hpp"

namespace mgc::bench {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using planning::JointSpec;
using planning::JointVector;
using planning::PlanningProblem;

JointVector to_joints(const ob::State* state, int dof) {
  const double* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  JointVector q(dof);
  for (int i = 0; i < dof; ++i) q[i] = values[i];
  return q;
}

void from_joints(const JointVector& q, ob::State* state) {
  double* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  for (int i = 0; i < q.size(); ++i) values[i] = q[i];
}

//! splitmix64: one 32-bit seed per (run seed, stream), so the samplers of one run differ.
std::uint32_t stream_seed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + (stream + 1) * 0xD1B54A32D192ED03ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return static_cast<std::uint32_t>(z ^ (z >> 31));
}

const JointSpec& joint(const PlanningProblem& problem, int i) {
  return problem.model->joints()[static_cast<std::size_t>(i)];
}

//! Keeps a joint value inside the space: continuous joints wrap, the others clamp.
double fold(const JointSpec& j, double value) {
  return j.continuous ? planning::wrap_angle(value) : std::clamp(value, j.position_min, j.position_max);
}

//! Uniform over the joint ranges (OMPL's own), and "near"/Gaussian samples whose radius is in
//! steps per joint, as the step metric measures it.
class StepMetricSampler final : public ob::RealVectorStateSampler {
 public:
  StepMetricSampler(const ob::StateSpace* space, const PlanningProblem& problem, std::uint32_t seed)
      : RealVectorStateSampler(space), problem_(problem) {
    rng_.setLocalSeed(seed);
  }

  void sampleUniformNear(ob::State* state, const ob::State* near, double distance_steps) override {
    const JointVector q = to_joints(near, problem_.model->dof());
    JointVector out(q.size());
    for (int i = 0; i < q.size(); ++i) {
      const double half_width = distance_steps * problem_.step[i];
      out[i] = fold(joint(problem_, i), rng_.uniformReal(q[i] - half_width, q[i] + half_width));
    }
    from_joints(out, state);
  }

  void sampleGaussian(ob::State* state, const ob::State* mean, double std_dev_steps) override {
    const JointVector q = to_joints(mean, problem_.model->dof());
    JointVector out(q.size());
    for (int i = 0; i < q.size(); ++i) out[i] = fold(joint(problem_, i), rng_.gaussian(q[i], std_dev_steps * problem_.step[i]));
    from_joints(out, state);
  }

 private:
  const PlanningProblem& problem_;
};

//! R^n holding joint values, measured by our step metric (continuous joints the short way round,
//! as MachineModel::interpolate moves them).
class StepMetricSpace final : public ob::RealVectorStateSpace {
 public:
  StepMetricSpace(const PlanningProblem& problem, std::uint64_t seed)
      : RealVectorStateSpace(static_cast<unsigned int>(problem.model->dof())), problem_(problem), seed_(seed) {
    setName("mgc-joints");
    ob::RealVectorBounds bounds(getDimension());
    for (int i = 0; i < problem.model->dof(); ++i) {
      const JointSpec& j = joint(problem, i);
      bounds.setLow(static_cast<unsigned int>(i), j.continuous ? -std::numbers::pi : j.position_min);
      bounds.setHigh(static_cast<unsigned int>(i), j.continuous ? std::numbers::pi : j.position_max);
    }
    setBounds(bounds);
  }

  double distance(const ob::State* a, const ob::State* b) const override {
    return planning::step_metric(*problem_.model, problem_.step, to_joints(a, dof()), to_joints(b, dof()));
  }

  void interpolate(const ob::State* from, const ob::State* to, double t, ob::State* state) const override {
    from_joints(problem_.model->interpolate(to_joints(from, dof()), to_joints(to, dof()), t), state);
  }

  void enforceBounds(ob::State* state) const override {
    double* values = state->as<StateType>()->values;
    for (int i = 0; i < dof(); ++i) values[i] = fold(joint(problem_, i), values[i]);
  }

  //! The longest step-metric distance in the space: a continuous joint is at most half a turn away.
  double getMaximumExtent() const override {
    double sum = 0.0;
    for (int i = 0; i < dof(); ++i) {
      const JointSpec& j = joint(problem_, i);
      const double span_steps = (j.continuous ? std::numbers::pi : j.range()) / problem_.step[i];
      sum += span_steps * span_steps;
    }
    return std::sqrt(sum);
  }

  //! Volume in steps^n, so that radius-based connection rules see the same units as distance().
  double getMeasure() const override {
    double volume = 1.0;
    for (int i = 0; i < dof(); ++i) {
      const JointSpec& j = joint(problem_, i);
      volume *= (j.continuous ? 2.0 * std::numbers::pi : j.range()) / problem_.step[i];
    }
    return volume;
  }

  ob::StateSamplerPtr allocDefaultStateSampler() const override {
    return std::make_shared<StepMetricSampler>(this, problem_, stream_seed(seed_, samplers_allocated_++));
  }

 private:
  [[nodiscard]] int dof() const { return problem_.model->dof(); }

  const PlanningProblem& problem_;
  std::uint64_t seed_;
  mutable std::uint64_t samplers_allocated_ = 0;
};

class OurStateValidity final : public ob::StateValidityChecker {
 public:
  OurStateValidity(const ob::SpaceInformationPtr& si, const PlanningProblem& problem)
      : StateValidityChecker(si), problem_(problem) {}
  bool isValid(const ob::State* state) const override {
    return problem_.world->validate(to_joints(state, problem_.model->dof())).valid();
  }

 private:
  const PlanningProblem& problem_;
};

//! Every edge through CollisionWorld::validate_edge at the problem's step, as our planners check
//! theirs.
class OurEdgeValidity final : public ob::MotionValidator {
 public:
  OurEdgeValidity(const ob::SpaceInformationPtr& si, const PlanningProblem& problem)
      : MotionValidator(si), problem_(problem) {}

  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const int dof = problem_.model->dof();
    const bool ok = problem_.world->validate_edge(to_joints(s1, dof), to_joints(s2, dof), problem_.step).valid();
    ++(ok ? valid_ : invalid_);
    return ok;
  }

  //! On failure, the last valid state is the step-resolution sample just before the first invalid
  //! configuration when the edge up to it checks valid, else s1 itself.
  bool checkMotion(const ob::State* s1, const ob::State* s2, std::pair<ob::State*, double>& last_valid) const override {
    const int dof = problem_.model->dof();
    const JointVector from = to_joints(s1, dof);
    const JointVector to = to_joints(s2, dof);
    JointVector at;
    if (problem_.world->validate_edge(from, to, problem_.step, &at).valid()) {
      ++valid_;
      return true;
    }
    ++invalid_;
    const planning::MachineModel& model = *problem_.model;
    const double length_steps = planning::step_metric(model, problem_.step, from, to);
    const double samples = std::max(1.0, std::ceil(length_steps));
    const double t_invalid = planning::step_metric(model, problem_.step, from, at) / std::max(length_steps, 1e-300);
    double t = std::max(0.0, (std::floor(t_invalid * samples) - 1.0) / samples);
    if (t > 0.0 && !problem_.world->validate_edge(from, model.interpolate(from, to, t), problem_.step).valid()) t = 0.0;
    if (last_valid.first != nullptr) si_->getStateSpace()->interpolate(s1, s2, t, last_valid.first);
    last_valid.second = t;
    return false;
  }

 private:
  const PlanningProblem& problem_;
};

//! Path length under the step metric. The direct ellipsoid sampler OMPL would pick assumes plain
//! Euclidean coordinates; ours scale each joint and wrap the swing, so informed samples come from
//! rejection sampling against the same heuristic instead.
class StepLengthObjective final : public ob::PathLengthOptimizationObjective {
 public:
  using PathLengthOptimizationObjective::PathLengthOptimizationObjective;
  ob::InformedSamplerPtr allocInformedStateSampler(const ob::ProblemDefinitionPtr& problem,
                                                   unsigned int max_calls) const override {
    return std::make_shared<ob::RejectionInfSampler>(problem, max_calls);
  }
};

// OMPL's own RNG members are protected: seeding them per run needs a subclass.
class SeededRrt final : public og::RRT {
 public:
  SeededRrt(const ob::SpaceInformationPtr& si, std::uint32_t seed) : RRT(si) { rng_.setLocalSeed(seed); }
};

class SeededRrtConnect final : public og::RRTConnect {
 public:
  SeededRrtConnect(const ob::SpaceInformationPtr& si, std::uint32_t seed) : RRTConnect(si) { rng_.setLocalSeed(seed); }
};

class SeededSimplifier final : public og::PathSimplifier {
 public:
  SeededSimplifier(const ob::SpaceInformationPtr& si, std::uint32_t seed) : PathSimplifier(si) { rng_.setLocalSeed(seed); }
};

std::vector<JointVector> to_path(const og::PathGeometric& path, int dof) {
  std::vector<JointVector> out;
  out.reserve(path.getStateCount());
  for (std::size_t i = 0; i < path.getStateCount(); ++i) out.push_back(to_joints(path.getState(i), dof));
  return out;
}

//! Vertices that belong to a tree: roots and every vertex with an edge.
int tree_vertices(const ob::PlannerData& data) {
  int count = 0;
  std::vector<unsigned int> edges;
  for (unsigned int v = 0; v < data.numVertices(); ++v) {
    if (data.isStartVertex(v) || data.isGoalVertex(v) || data.getEdges(v, edges) > 0 || data.getIncomingEdges(v, edges) > 0) {
      ++count;
    }
  }
  return count;
}

//! OMPL's simplify() without its final B-spline pass: the spline adds vertices, each of them a
//! joint-space corner an operator would have to steer, so it would only lengthen OMPL's paths by
//! our metrics. Repeats while a pass still changes the path.
void simplify(og::PathSimplifier& simplifier, og::PathGeometric& path) {
  constexpr int kMaxRounds = 20;
  bool changed = true;
  for (int round = 0; changed && round < kMaxRounds; ++round) {
    changed = simplifier.reduceVertices(path);
    changed = simplifier.collapseCloseVertices(path) || changed;
    changed = simplifier.shortcutPath(path) || changed;
  }
}

double elapsed_ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

const char* ompl_version() noexcept {
#define MGC_BENCH_STR2(x) #x
#define MGC_BENCH_STR(x) MGC_BENCH_STR2(x)
  return MGC_BENCH_STR(OMPL_MAJOR_VERSION) "." MGC_BENCH_STR(OMPL_MINOR_VERSION) "." MGC_BENCH_STR(OMPL_PATCH_VERSION);
#undef MGC_BENCH_STR
#undef MGC_BENCH_STR2
}

bool seed_ompl_globally(std::uint32_t seed) {
  // OMPL rejects 0 and, once any RNG exists, ignores the call; 1 + seed keeps every seed usable.
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  ompl::RNG::setSeed(seed + 1u);
  return ompl::RNG::getSeed() == seed + 1u;
}

OmplResult solve_with_ompl(const PlanningProblem& problem, OmplPlanner which, const OmplOptions& options,
                           std::uint64_t seed) {
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  const int dof = problem.model->dof();
  auto space = std::make_shared<StepMetricSpace>(problem, seed);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<OurStateValidity>(si, problem));
  si->setMotionValidator(std::make_shared<OurEdgeValidity>(si, problem));
  si->setup();

  ob::ScopedState<> start(space);
  ob::ScopedState<> goal(space);
  from_joints(problem.start, start.get());
  from_joints(problem.goal, goal.get());
  auto definition = std::make_shared<ob::ProblemDefinition>(si);
  // OMPL's default goal threshold (machine epsilon, in steps): only the goal itself satisfies it,
  // so every solution ends at the exact goal, as ours do.
  definition->setStartAndGoalStates(start, goal);
  definition->setOptimizationObjective(std::make_shared<StepLengthObjective>(si));

  const double range_steps = options.range_steps > 0.0 ? options.range_steps : problem.extend_steps;
  ob::PlannerPtr planner;
  switch (which) {
    case OmplPlanner::RrtConnect: {
      auto p = std::make_shared<SeededRrtConnect>(si, stream_seed(seed, 1000));
      p->setRange(range_steps);
      planner = p;
      break;
    }
    case OmplPlanner::Rrt: {
      auto p = std::make_shared<SeededRrt>(si, stream_seed(seed, 1000));
      p->setRange(range_steps);
      p->setGoalBias(problem.goal_bias);
      planner = p;
      break;
    }
    case OmplPlanner::BitStar: {
      // BIT* in its default k-nearest form, which OMPL insists on naming kBITstar.
      auto p = std::make_shared<og::BITstar>(si, "kBITstar");
      // Its first solution is what a planning-time comparison asks for; BIT* would otherwise
      // refine until the time limit.
      p->setStopOnSolnImprovement(true);
      planner = p;
      break;
    }
  }
  planner->setProblemDefinition(definition);

  OmplResult result;
  const auto t0 = std::chrono::steady_clock::now();
  planner->setup();
  const ob::PlannerStatus status = planner->solve(ob::timedPlannerTerminationCondition(options.time_limit_s));
  result.time_ms = elapsed_ms(t0);
  result.solve_collision_checks = problem.world->collision_checks();
  result.solve_body_checks = problem.world->body_checks();

  ob::PlannerData data(si);
  planner->getPlannerData(data);
  result.planner_data_vertices = static_cast<int>(data.numVertices());
  result.tree_nodes = tree_vertices(data);
  result.solved = status == ob::PlannerStatus::EXACT_SOLUTION && definition->hasExactSolution();
  if (!result.solved) return result;

  auto* solution = definition->getSolutionPath()->as<og::PathGeometric>();
  result.path = to_path(*solution, dof);
  if (result.path.size() < 2 || result.path.front() != problem.start || result.path.back() != problem.goal) {
    result.error = "path does not run from the exact start to the exact goal";
    result.solved = false;
    return result;
  }

  if (!options.simplify) return result;
  og::PathGeometric simplified(*solution);
  SeededSimplifier simplifier(si, stream_seed(seed, 2000));
  const auto t1 = std::chrono::steady_clock::now();
  simplify(simplifier, simplified);
  result.simplify_ms = elapsed_ms(t1);
  result.simplified = to_path(simplified, dof);
  if (result.simplified.front() != problem.start || result.simplified.back() != problem.goal) {
    result.error = "simplified path does not run from the exact start to the exact goal";
  }
  return result;
}

}  // namespace mgc::bench
