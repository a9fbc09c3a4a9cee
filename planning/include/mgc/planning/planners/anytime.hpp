// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

#include "mgc/planning/planners/bidirectional.hpp"

namespace mgc::planning {

//! Seed 000's anytime loop (§4.6, reconstructed in the note): for seeds s, s + 1, ..., an
//! RRT-Con-Con run, then RRT-Con-Con-Mod with gamma = 1.7, 1.6, ..., 1.1, lowering gamma while
//! the roughness does not rise; the least rough path so far is kept (Eq. 4's cost is reported
//! beside it). The problem's max_iterations caps each inner run (the paper's m); `seeds` caps the
//! loop. Solved once every seed is done and a path was found; path() holds the best path so far
//! at any time, and history() every improvement.
class AnytimePlanner final : public Planner {
 public:
  //! One improvement of the best path.
  struct Improvement {
    int iterations = 0;        //!< total iterations spent when it was found
    int seed_index = 0;        //!< seeds done before it (0: the first seed)
    double gamma = 0.0;        //!< 0 for the RRT-Con-Con run
    double roughness = 0.0;    //!< seed 000 Eq. 3 [-]
    double cost = 0.0;         //!< seed 000 Eq. 4 as used there: 0.5 t [min] + 0.5 roughness
  };

  explicit AnytimePlanner(int seeds = 51);

  [[nodiscard]] std::string_view name() const noexcept override { return "anytime"; }
  PlannerStatus reset(const PlanningProblem& problem) override;
  [[nodiscard]] PlannerStatus step(int iteration_budget) noexcept override;
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return best_; }
  [[nodiscard]] PlannerStats stats() const noexcept override;
  void tree(std::vector<JointVector>& nodes, std::vector<int>& parents) const override;
  [[nodiscard]] const std::vector<Improvement>& history() const noexcept { return history_; }
  //! The least rough path found so far exists.
  [[nodiscard]] bool has_path() const noexcept { return !best_.empty(); }

 private:
  static constexpr int kGammaSteps = 7;  //!< 1.7 down to 1.1
  [[nodiscard]] double gamma_at(int index) const noexcept { return 1.7 - 0.1 * index; }
  //! Starts the run for (seed_index_, gamma_index_); -1 is the RRT-Con-Con run.
  void start_run() noexcept;
  //! Records the finished run and moves on; false when every seed is done.
  [[nodiscard]] bool finish_run(PlannerStatus run_status) noexcept;

  int seeds_;
  const PlanningProblem* problem_ = nullptr;
  PlanningProblem run_problem_;
  BidirectionalPlanner connect_{BidirectionalPlanner::Variant::ConCon};
  BidirectionalPlanner modified_{BidirectionalPlanner::Variant::ConConMod};
  Planner* current_ = nullptr;
  int seed_index_ = 0;
  int gamma_index_ = -1;
  double previous_roughness_ = 0.0;
  int iterations_ = 0;
  int tree_nodes_ = 0;
  std::uint64_t checks_at_reset_ = 0;
  double best_roughness_ = 0.0;
  std::vector<JointVector> best_;
  std::vector<Improvement> history_;
  PlannerStatus status_ = PlannerStatus::NotReset;
};

}  // namespace mgc::planning
