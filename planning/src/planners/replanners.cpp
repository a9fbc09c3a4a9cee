// SPDX-License-Identifier: Apache-2.0
// The re-planners: the thesis's modified Dynamic RRT on RRTBiasedLimCon (seed 001 §1.11, App. F)
// and seed 000's DRRT-Con-Con-Mod local repair (Fig. 8), whose bridges also come from the default
// one-joint-at-a-time planner (drrt-axis-connect). docs/replanning.md.
#include <algorithm>
#include <utility>

#include "mgc/planning/planners/axis_connect.hpp"
#include "mgc/planning/planners/bidirectional.hpp"
#include "mgc/planning/planners/replanner.hpp"
#include "mgc/planning/planners/single_axis_tree.hpp"

namespace mgc::planning {
namespace {

//! A re-planner's own counters with those of the query now running or last finished.
ReplanStats with_query(ReplanStats s, const PlannerStats& query, const PlanningProblem* problem,
                       std::uint64_t checks_at_reset) noexcept {
  s.iterations = query.iterations;
  s.tree_nodes = query.tree_nodes;
  s.collision_checks = problem ? problem->world->collision_checks() - checks_at_reset : 0;
  return s;
}

//! A single-axis tree rooted at the real goal and grown toward the machine, which DRRT trims and
//! re-targets in place.
class GoalRootedTree final : public SingleAxisTreePlanner {
 public:
  explicit GoalRootedTree(bool limited_connect) : limited_(limited_connect) {}
  [[nodiscard]] std::string_view name() const noexcept override { return limited_ ? "drrt" : "drrt-rrt"; }
  [[nodiscard]] NodeTree& nodes() noexcept { return tree_; }
  [[nodiscard]] int solved() const noexcept { return solved_node(); }
  [[nodiscard]] PlannerStatus restart() noexcept { return resume(); }

 protected:
  [[nodiscard]] bool iterate() noexcept override { return limited_ ? limited_connect() : single_step(); }

 private:
  bool limited_;
};

//! The thesis's DRRT (App. F): the tree grows from the goal to the machine, so the root never
//! moves while the machine walks parent pointers. A repair flags the nodes that now lie inside a
//! dynamic obstacle and the node the machine was heading for, trims their subtrees, and regrows
//! the rest toward the machine's stop with the re-plan cap and bias. Unlike App. F, the edges of
//! the regrown path that come from the old tree are re-checked against the new obstacle poses
//! (Ferguson's "if the solution path contains an invalid node, regrow"): a node check alone
//! misses an obstacle lying across an edge between two free nodes.
class DrrtReplanner final : public Replanner {
 public:
  explicit DrrtReplanner(bool limited_connect) : tree_(limited_connect) {}

  [[nodiscard]] std::string_view name() const noexcept override { return tree_.name(); }

  PlannerStatus reset(const PlanningProblem& problem, const ReplanSettings& settings) override {
    problem_ = &problem;
    settings_ = settings;
    stats_ = {};
    repairing_ = false;
    reversed_ = problem;
    std::swap(reversed_.start, reversed_.goal);
    // Trimming frees room, but a run of repairs can still add their caps on top of the first tree.
    reversed_.node_capacity = problem.node_capacity > 0 ? problem.node_capacity
                                                        : problem.max_iterations + 1 + 4 * settings.max_iterations;
    const auto capacity = static_cast<std::size_t>(reversed_.node_capacity) + static_cast<std::size_t>(problem.model->dof()) + 1;
    path_.clear();
    candidate_.clear();
    path_.reserve(capacity);
    candidate_.reserve(capacity);
    path_node_.reserve(capacity);
    candidate_node_.reserve(capacity);
    invalid_.reserve(capacity);
    new_index_.reserve(capacity);
    checks_at_reset_ = problem.world->collision_checks();

    PlannerStatus s = tree_.reset(reversed_);
    if (s == PlannerStatus::InvalidStart) return status_ = PlannerStatus::InvalidGoal;
    if (s == PlannerStatus::InvalidGoal) return status_ = PlannerStatus::InvalidStart;
    return status_ = accept(s);
  }

  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override {
    if (status_ != PlannerStatus::Running) return status_;
    PlannerStatus s = tree_.step(iteration_budget);
    if (s == PlannerStatus::IterationLimit && !repairing_ && settings_.dual_phase && !stats_.dual_phase_used) {
      // Dual phase: the first tree becomes a repair problem with the re-plan cap and bias.
      stats_.dual_phase_used = true;
      reversed_.max_iterations = settings_.max_iterations;
      reversed_.goal_bias = settings_.goal_bias;
      s = tree_.restart();
    }
    return status_ = accept(s);
  }

  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }

  // DRRT checks every node at a repair and re-checks the old edges of its regrown path, whether
  // the obstacles move or not.
  [[nodiscard]] PlannerStatus replan(const JointVector& q_machine, int next,
                                     [[maybe_unused]] bool obstacles_still) noexcept override {
    if (path_.empty()) return status_;
    ++stats_.repairs;
    repairing_ = true;
    stats_.invalidated_nodes = 0;
    stats_.checked_nodes = 0;
    CollisionWorld& world = *problem_->world;
    if (!world.validate(q_machine).valid()) return status_ = PlannerStatus::InvalidStart;
    NodeTree& tree = tree_.nodes();
    // The root is the goal: trimming it would empty the tree. Leave the tree whole and let the
    // caller wait for the obstacle to move on.
    if (world.hits_dynamic(tree.node(0))) return status_ = PlannerStatus::GoalOccupied;

    const std::size_t before = tree.size();
    invalid_.assign(before, 0);
    for (std::size_t i = 1; i < before; ++i) invalid_[i] = world.hits_dynamic(tree.node(static_cast<int>(i))) ? 1 : 0;
    // App. F: the edge being executed collides, so the node it leads to is invalid.
    for (std::size_t k = static_cast<std::size_t>(std::max(next, 0)); k < path_node_.size(); ++k) {
      if (path_node_[k] < 0) continue;
      if (path_node_[k] > 0) invalid_[static_cast<std::size_t>(path_node_[k])] = 1;
      break;
    }
    trim();
    stats_.invalidated_nodes = static_cast<int>(before - tree.size());

    reversed_.goal = q_machine;
    reversed_.max_iterations = settings_.max_iterations;
    reversed_.goal_bias = settings_.goal_bias;
    first_new_node_ = static_cast<int>(tree.size());
    return status_ = accept(tree_.restart());
  }

  [[nodiscard]] ReplanStats stats() const noexcept override {
    ReplanStats s = with_query(stats_, tree_.stats(), problem_, checks_at_reset_);
    if (repairing_) s.repair_iterations = s.iterations;
    return s;
  }

 private:
  //! Drops the flagged nodes and their subtrees; the path's node indices follow the renumbering.
  void trim() noexcept {
    tree_.nodes().trim(invalid_, new_index_);
    for (int& n : path_node_) n = n < 0 ? -1 : new_index_[static_cast<std::size_t>(n)];
  }

  //! On Solved, turns the tree's root-first path round into a machine-first path and, during a
  //! repair, re-checks the edges that came from the old tree; an invalid one costs its machine-side
  //! node and the repair goes on. path_ changes only once a whole path is valid.
  [[nodiscard]] PlannerStatus accept(PlannerStatus s) noexcept {
    while (s == PlannerStatus::Solved) {
      const std::vector<JointVector>& p = tree_.path();
      const NodeTree& tree = tree_.nodes();
      int depth = 0;
      for (int n = tree_.solved(); tree.parent(n) >= 0; n = tree.parent(n)) ++depth;
      candidate_.clear();
      candidate_node_.clear();
      int n = -1;
      for (std::size_t k = p.size(); k-- > 0;) {
        candidate_.push_back(p[k]);
        if (static_cast<int>(k) == depth) n = tree_.solved();
        candidate_node_.push_back(static_cast<int>(k) <= depth ? n : -1);
        if (static_cast<int>(k) <= depth) n = tree.parent(n);
      }
      const int bad = repairing_ ? first_invalid_old_edge() : -1;
      if (bad < 0) {
        path_.swap(candidate_);
        path_node_.swap(candidate_node_);
        stats_.checked_nodes = static_cast<int>(path_.size());
        return PlannerStatus::Solved;
      }
      invalid_.assign(tree.size(), 0);
      invalid_[static_cast<std::size_t>(candidate_node_[static_cast<std::size_t>(bad)])] = 1;
      const std::size_t before = tree.size();
      trim();
      stats_.invalidated_nodes += static_cast<int>(before - tree.size());
      first_new_node_ = std::min(first_new_node_, static_cast<int>(tree_.nodes().size()));
      s = tree_.restart();
    }
    return s;
  }

  //! The first candidate edge between two old tree nodes that collides now, by its machine-side
  //! index; -1 if none. Edges with a node grown in this repair were checked as they grew.
  [[nodiscard]] int first_invalid_old_edge() noexcept {
    for (std::size_t e = 0; e + 1 < candidate_.size(); ++e) {
      const int child = candidate_node_[e];
      const int parent = candidate_node_[e + 1];
      if (child < 0 || parent < 0 || child >= first_new_node_) continue;
      if (!problem_->world->validate_edge(candidate_[e], candidate_[e + 1], problem_->step).valid()) {
        return static_cast<int>(e);
      }
    }
    return -1;
  }

  GoalRootedTree tree_;
  const PlanningProblem* problem_ = nullptr;
  PlanningProblem reversed_;  //!< goal and start swapped; its goal becomes the machine's stop
  ReplanSettings settings_;
  PlannerStatus status_ = PlannerStatus::NotReset;
  bool repairing_ = false;
  int first_new_node_ = 0;
  std::vector<JointVector> path_;
  std::vector<int> path_node_;  //!< tree node of each path entry; -1 for the closing moves
  std::vector<JointVector> candidate_;
  std::vector<int> candidate_node_;
  std::vector<unsigned char> invalid_;
  std::vector<int> new_index_;
  ReplanStats stats_;
  std::uint64_t checks_at_reset_ = 0;
};

//! Seed 000's DRRT-Con-Con-Mod (Fig. 8): keep the rest of the path and bridge from the machine's
//! stop to the first remaining node that is still free, with RRT-Con-Con-Mod; when the bridge
//! fails, drop that node and bridge to the next. The paper drops only the leading invalid nodes
//! and leaves later edges unchecked (far obstacles may have moved by the time the machine gets
//! there, L127, L283). When the caller's prediction has the obstacles standing still, the bridge
//! also goes past the last old edge that is blocked now: an obstacle parked across the old route
//! would otherwise stop the machine at each of its edges in turn, each repair bridging only to
//! the far end of one.
//! When every remaining node collides the goal itself is covered -- the paper leaves this case
//! open; here it is GoalOccupied, the path is kept, and the caller holds and asks again.
//! The bridges come from `planner`: RRT-Con-Con-Mod as in the paper (drrt-con-con-mod), or
//! axis-connect (drrt-axis-connect), whose bridges, like its first path, move one joint per edge.
class BridgingReplanner final : public Replanner {
 public:
  BridgingReplanner(std::string_view name, std::unique_ptr<Planner> planner) : name_(name), planner_(std::move(planner)) {}

  [[nodiscard]] std::string_view name() const noexcept override { return name_; }

  PlannerStatus reset(const PlanningProblem& problem, const ReplanSettings& settings) override {
    problem_ = &problem;
    settings_ = settings;
    stats_ = {};
    repairing_ = false;
    bridge_ = problem;
    checks_at_reset_ = problem.world->collision_checks();
    status_ = planner_->reset(bridge_);
    // Every bridge reuses the planner with the same caps, so its buffers never grow again; a
    // merged path is a bridge plus what is left of the old path.
    const std::size_t capacity = 2 * planner_->path().capacity();
    path_.clear();
    candidate_.clear();
    path_.reserve(capacity);
    candidate_.reserve(capacity);
    return status_;
  }

  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override {
    if (status_ != PlannerStatus::Running) return status_;
    const PlannerStatus s = planner_->step(iteration_budget);
    if (s == PlannerStatus::Running) return status_;
    if (!repairing_) {
      if (s == PlannerStatus::Solved) path_.assign(planner_->path().begin(), planner_->path().end());
      return status_ = s;
    }
    budget_left_ -= planner_->stats().iterations;
    stats_.repair_iterations += planner_->stats().iterations;
    if (s == PlannerStatus::Solved) return status_ = merge();
    // Fig. 8 lines 16-23: the bridge failed; the goal was the last hope.
    if (goal_index_ + 1 >= path_.size()) return status_ = s;
    // The repair's cap is spent across its bridges: without it, dropping one node per failed
    // bridge would let a repair run for as many caps as the path has nodes.
    if (budget_left_ <= 0) return status_ = PlannerStatus::IterationLimit;
    ++goal_index_;
    return status_ = bridge();
  }

  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return path_; }

  [[nodiscard]] PlannerStatus replan(const JointVector& q_machine, int next, bool obstacles_still) noexcept override {
    if (path_.empty()) return status_;
    ++stats_.repairs;
    repairing_ = true;
    checked_old_path_ = obstacles_still;
    stats_.bridge_attempts = 0;
    stats_.invalidated_nodes = 0;
    stats_.checked_nodes = 0;
    budget_left_ = settings_.max_iterations;
    stats_.repair_iterations = 0;
    if (!problem_->world->validate(q_machine).valid()) return status_ = PlannerStatus::InvalidStart;
    bridge_.start = q_machine;
    goal_index_ = static_cast<std::size_t>(std::clamp(next, 1, static_cast<int>(path_.size()) - 1));
    if (obstacles_still) {
      // The last blocked old edge: the bridge ends at its far node or later.
      for (std::size_t e = path_.size() - 1; e-- > goal_index_;) {
        if (!problem_->world->validate_edge(path_[e], path_[e + 1], problem_->step).valid()) {
          stats_.invalidated_nodes += static_cast<int>(e + 1 - goal_index_);
          goal_index_ = e + 1;
          break;
        }
      }
    }
    return status_ = bridge();
  }

  [[nodiscard]] ReplanStats stats() const noexcept override {
    return with_query(stats_, planner_->stats(), problem_, checks_at_reset_);
  }

 private:
  //! Validate-Nodes from goal_index_ on, then a bridge to the first free node.
  [[nodiscard]] PlannerStatus bridge() noexcept {
    while (goal_index_ < path_.size() && !problem_->world->validate(path_[goal_index_]).valid()) {
      ++goal_index_;
      ++stats_.invalidated_nodes;
    }
    if (goal_index_ >= path_.size()) return PlannerStatus::GoalOccupied;
    bridge_.goal = path_[goal_index_];
    // A seed of its own per bridge: repeatable, and unlike the first plan's.
    bridge_.seed = problem_->seed + 0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(stats_.repairs * 64 + stats_.bridge_attempts + 1);
    ++stats_.bridge_attempts;
    // At most the first plan's caps: the trees' and path's reserved capacity suffices, so this
    // reset does not allocate.
    bridge_.max_iterations = std::min(problem_->max_iterations, budget_left_);
    const PlannerStatus s = planner_->reset(bridge_);
    return s == PlannerStatus::InvalidGoal ? PlannerStatus::IterationLimit : s;
  }

  //! Fig. 8 line 24: the bridge, then the old path after the node it reached.
  [[nodiscard]] PlannerStatus merge() noexcept {
    const std::vector<JointVector>& b = planner_->path();
    if (b.size() + (path_.size() - goal_index_ - 1) > candidate_.capacity()) return PlannerStatus::PoolExhausted;
    candidate_.assign(b.begin(), b.end());
    candidate_.insert(candidate_.end(), path_.begin() + static_cast<std::ptrdiff_t>(goal_index_ + 1), path_.end());
    path_.swap(candidate_);
    stats_.checked_nodes = static_cast<int>(checked_old_path_ ? path_.size() : b.size());
    return PlannerStatus::Solved;
  }

  std::string_view name_;
  std::unique_ptr<Planner> planner_;
  const PlanningProblem* problem_ = nullptr;
  PlanningProblem bridge_;
  ReplanSettings settings_;
  PlannerStatus status_ = PlannerStatus::NotReset;
  bool repairing_ = false;
  bool checked_old_path_ = false;  //!< the current repair checked the old path's edges too
  std::size_t goal_index_ = 0;
  int budget_left_ = 0;  //!< iterations the current repair may still spend on bridges
  std::vector<JointVector> path_;
  std::vector<JointVector> candidate_;
  ReplanStats stats_;
  std::uint64_t checks_at_reset_ = 0;
};

}  // namespace

std::unique_ptr<Replanner> make_replanner(std::string_view name) {
  if (name == "drrt") return std::make_unique<DrrtReplanner>(true);
  if (name == "drrt-rrt") return std::make_unique<DrrtReplanner>(false);
  if (name == "drrt-con-con-mod") {
    return std::make_unique<BridgingReplanner>("drrt-con-con-mod", std::make_unique<BidirectionalPlanner>(BidirectionalPlanner::Variant::ConConMod));
  }
  if (name == "drrt-axis-connect") return std::make_unique<BridgingReplanner>("drrt-axis-connect", std::make_unique<AxisConnectPlanner>());
  return nullptr;
}

std::vector<std::string_view> replanner_names() { return {"drrt-axis-connect", "drrt", "drrt-rrt", "drrt-con-con-mod"}; }

}  // namespace mgc::planning
