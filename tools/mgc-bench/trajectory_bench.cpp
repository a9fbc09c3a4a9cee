// SPDX-License-Identifier: Apache-2.0
// Trajectory suite: the cost of calculate_time_optimal (1-DoF, closed form) and of
// calculate_synchronized (4 joints) on random moving start states, timed one calculation at a time
// (steady_clock around each call, so the figures include the clock's own ~20 ns) after a warm-up
// pass over the same problems.
#include "trajectory_bench.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <vector>

#include "mgc/guidance/trajectory.hpp"

namespace mgc::bench {
namespace {

using guidance::JointLimits;
using guidance::JointState;

struct Problem {
  JointState start;
  double target = 0.0;
  JointLimits limits;
};

//! Moving start states inside the limits, as in the control cycle (a target changed mid-motion).
Problem random_problem(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, unit(rng)); };
  Problem p;
  p.limits = {log_uniform(0.1, 2.0), log_uniform(0.2, 5.0), log_uniform(0.5, 20.0)};
  p.start = {(2.0 * unit(rng) - 1.0) * 3.0, (2.0 * unit(rng) - 1.0) * p.limits.max_velocity,
             (2.0 * unit(rng) - 1.0) * p.limits.max_acceleration};
  p.target = (2.0 * unit(rng) - 1.0) * 3.0;
  return p;
}

struct Row {
  const char* what;
  double median_us, p95_us, p99_us, max_us;
  int failures;
  const char* ruckig;
};

double percentile(std::vector<double>& v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

//! Times `calculate(first_problem_index)` over the problems in groups of `dofs`, twice; the first
//! pass warms caches and branch predictors.
template <class Calculate>
Row measure(const char* what, const char* ruckig, std::size_t problem_count, std::size_t dofs, const Calculate& calculate) {
  std::vector<double> times_us;
  int failures = 0;
  for (int pass = 0; pass < 2; ++pass) {
    times_us.clear();
    for (std::size_t i = 0; i + dofs <= problem_count; i += dofs) {
      const auto t0 = std::chrono::steady_clock::now();
      const bool ok = calculate(i);
      const auto t1 = std::chrono::steady_clock::now();
      times_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      if (pass == 1 && !ok) ++failures;
    }
  }
  const double max_us = *std::max_element(times_us.begin(), times_us.end());
  const double median_us = percentile(times_us, 0.5), p95_us = percentile(times_us, 0.95);
  return {what, median_us, p95_us, percentile(times_us, 0.99), max_us, failures, ruckig};
}

}  // namespace

int run_trajectory_suite(const TrajectoryBenchOptions& options) {
  std::mt19937_64 rng(options.seed);
  std::vector<Problem> problems;
  for (int i = 0; i < 4 * options.cases; ++i) problems.push_back(random_problem(rng));
  guidance::Profile profile;
  std::array<guidance::Profile, 4> profiles{};
  std::array<JointState, 4> starts{};
  std::array<double, 4> targets{};
  std::array<JointLimits, 4> limits{};
  const auto single = [&](std::size_t i) {
    const Problem& p = problems[i];
    return guidance::calculate_time_optimal(p.start, p.target, p.limits, profile).ok();
  };
  const auto independent = [&](std::size_t i) {
    bool ok = true;
    for (std::size_t k = 0; k < 4; ++k) {
      const Problem& p = problems[i + k];
      ok = guidance::calculate_time_optimal(p.start, p.target, p.limits, profiles[k]).ok() && ok;
    }
    return ok;
  };
  const auto synchronized = [&](std::size_t i) {
    for (std::size_t k = 0; k < 4; ++k) {
      starts[k] = problems[i + k].start;
      targets[k] = problems[i + k].target;
      limits[k] = problems[i + k].limits;
    }
    return guidance::calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, profiles.data()).ok();
  };
  const auto n = static_cast<std::size_t>(options.cases);
  const Row rows[] = {
      measure("1-DoF time-optimal, moving start (closed form)", "~0.2 us", n, 1, single),
      measure("synchronized 4-DoF, moving starts (calculate_synchronized)", "~2 us", 4 * n, 4, synchronized),
      measure("4 x 1-DoF time-optimal, not synchronized (for comparison)", "", 4 * n, 4, independent),
  };
  std::string table = "### trajectory\n\nRandom moving start states inside the limits, " +
                      std::to_string(options.cases) + " calculations per row, seed " + std::to_string(options.seed) +
                      ".\n\n| case | median us | p95 us | p99 us | max us | failures | Ruckig (issue) |\n"
                      "|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %.3f | %.3f | %.3f | %.1f | %d | %s |\n", r.what, r.median_us, r.p95_us,
                  r.p99_us, r.max_us, r.failures, r.ruckig);
    table += line;
  }
  std::printf("%s\n", table.c_str());
  if (!options.out_dir.empty()) std::ofstream(options.out_dir + "/trajectory.md") << table;
  int failures = 0;
  for (const Row& r : rows) failures += r.failures;
  return failures == 0 ? 0 : 1;
}

}  // namespace mgc::bench
