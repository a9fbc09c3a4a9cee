// SPDX-License-Identifier: Apache-2.0
// The re-planners run inside the control loop: after reset(), replan() and step() must
// never touch the heap, through every repair a lift needs. tests/support/allocation_counter.cpp
// counts allocations program-wide; a wrapper counts those made inside the repair calls only.
#include <catch2/catch.hpp>

#include "allocation_counter.hpp"
#include "mgc/planning/execution.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "test_support.hpp"

using namespace mgc::planning;

namespace {

//! Forwards to a re-planner and counts the allocations made inside replan() and inside step()
//! once the first plan is done.
class CountingReplanner final : public Replanner {
 public:
  explicit CountingReplanner(std::unique_ptr<Replanner> inner) : inner_(std::move(inner)) {}
  [[nodiscard]] std::string_view name() const noexcept override { return inner_->name(); }
  PlannerStatus reset(const PlanningProblem& problem, const ReplanSettings& settings) override {
    repairing_ = false;
    return inner_->reset(problem, settings);
  }
  [[nodiscard]] PlannerStatus step(int budget) noexcept override {
    const long before = mgc::test::allocation_count();
    const PlannerStatus s = inner_->step(budget);
    if (repairing_) allocations += mgc::test::allocation_count() - before;
    return s;
  }
  [[nodiscard]] const std::vector<JointVector>& path() const noexcept override { return inner_->path(); }
  [[nodiscard]] PlannerStatus replan(const JointVector& q, int next, bool obstacles_still) noexcept override {
    repairing_ = true;
    ++repairs;
    const long before = mgc::test::allocation_count();
    const PlannerStatus s = inner_->replan(q, next, obstacles_still);
    allocations += mgc::test::allocation_count() - before;
    return s;
  }
  [[nodiscard]] ReplanStats stats() const noexcept override { return inner_->stats(); }

  long allocations = 0;
  int repairs = 0;

 private:
  std::unique_ptr<Replanner> inner_;
  bool repairing_ = false;
};

}  // namespace

TEST_CASE("repairs do not allocate: replan() and step() after the first plan", "[unit]") {
  for (std::string_view name : replanner_names()) {
    int repairs = 0;
    int solved = 0;
    for (const char* file : {"excavator-truck.yaml", "thesis-steel-frame.yaml"}) {
      CAPTURE(file, name);
      auto loaded = io::load_and_build(mgc::test::source_path(std::string("scenarios/") + file));
      loaded.world = build_world(loaded.scenario, *loaded.model, 0.0, 3);
      ReplanSettings replan;
      replan.max_iterations = loaded.scenario.planner.replan_max_iterations;
      replan.goal_bias = loaded.scenario.planner.replan_goal_bias;
      ExecutionSettings execution;
      execution.prediction_horizon_s = 3.0;
      execution.record_trajectory = false;
      CountingReplanner counting(make_replanner(name));
      for (std::uint64_t seed = 0; seed < 10; ++seed) {
        PlanningProblem problem = planning_problem(loaded.scenario, *loaded.model, *loaded.world);
        problem.seed = seed;
        const ExecutionResult r = execute_with_replanning(loaded.scenario, problem, counting, replan, execution);
        for (const RepairEvent& e : r.repairs) solved += e.status == PlannerStatus::Solved ? 1 : 0;
      }
      CHECK(counting.allocations == 0);
      repairs += counting.repairs;
    }
    CAPTURE(name);
    CHECK(repairs >= 3);
    CHECK(solved >= 1);
  }
}
