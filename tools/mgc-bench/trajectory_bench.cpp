// SPDX-License-Identifier: Apache-2.0
// Trajectory suite: the cost of calculate_time_optimal (1-DoF, closed form) and of
// calculate_synchronized (4 joints) on random moving start states, timed one calculation at a time
// (steady_clock around each call, so the figures include the clock's own ~20 ns) after a warm-up
// pass over the same problems, each problem with the current generator and with a frozen copy of
// the one before the exact braking (trajectory_baseline.cpp), alternately; and the durations of the
// two compared.
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
#include "trajectory_baseline.hpp"

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

struct Stats {
  double median_us = 0.0, p95_us = 0.0, p99_us = 0.0, max_us = 0.0;
};

double percentile(std::vector<double>& v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

Stats stats(std::vector<double> times_us) {
  Stats st;
  st.max_us = *std::max_element(times_us.begin(), times_us.end());
  st.median_us = percentile(times_us, 0.5);
  st.p95_us = percentile(times_us, 0.95);
  st.p99_us = percentile(times_us, 0.99);
  return st;
}

struct Row {
  const char* what;
  Stats current, baseline;
  int failures = 0, baseline_failures = 0;
};

//! Times `current(i)` and `baseline(i)` on the same problems in groups of `dofs`, alternating which
//! runs first, twice; the first pass warms caches and branch predictors.
template <class Current, class Baseline>
Row measure(const char* what, std::size_t problem_count, std::size_t dofs, const Current& current,
            const Baseline& baseline) {
  std::vector<double> ours_us, base_us;
  Row row{what, {}, {}, 0, 0};
  for (int pass = 0; pass < 2; ++pass) {
    ours_us.clear();
    base_us.clear();
    for (std::size_t i = 0; i + dofs <= problem_count; i += dofs) {
      for (int k = 0; k < 2; ++k) {
        const bool ours_now = (k == 0) == ((i / dofs) % 2 == 0);
        const auto t0 = std::chrono::steady_clock::now();
        const bool ok = ours_now ? current(i) : baseline(i);
        const auto t1 = std::chrono::steady_clock::now();
        (ours_now ? ours_us : base_us).push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
        if (pass == 1 && !ok) ++(ours_now ? row.failures : row.baseline_failures);
      }
    }
  }
  row.current = stats(ours_us);
  row.baseline = stats(base_us);
  return row;
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
  const auto single_baseline = [&](std::size_t i) {
    const Problem& p = problems[i];
    return baseline::calculate_time_optimal(p.start, p.target, p.limits, profile).ok();
  };
  const auto independent = [&](std::size_t i) {
    bool ok = true;
    for (std::size_t k = 0; k < 4; ++k) {
      const Problem& p = problems[i + k];
      ok = guidance::calculate_time_optimal(p.start, p.target, p.limits, profiles[k]).ok() && ok;
    }
    return ok;
  };
  const auto independent_baseline = [&](std::size_t i) {
    bool ok = true;
    for (std::size_t k = 0; k < 4; ++k) {
      const Problem& p = problems[i + k];
      ok = baseline::calculate_time_optimal(p.start, p.target, p.limits, profiles[k]).ok() && ok;
    }
    return ok;
  };
  const auto fill = [&](std::size_t i) {
    for (std::size_t k = 0; k < 4; ++k) {
      starts[k] = problems[i + k].start;
      targets[k] = problems[i + k].target;
      limits[k] = problems[i + k].limits;
    }
  };
  const auto synchronized = [&](std::size_t i) {
    fill(i);
    return guidance::calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, profiles.data()).ok();
  };
  const auto synchronized_baseline = [&](std::size_t i) {
    fill(i);
    return baseline::calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, profiles.data()).ok();
  };
  const auto n = static_cast<std::size_t>(options.cases);
  const Row rows[] = {
      measure("1-DoF time-optimal, moving start (closed form)", n, 1, single, single_baseline),
      measure("synchronized 4-DoF, moving starts (calculate_synchronized)", 4 * n, 4, synchronized,
              synchronized_baseline),
      measure("4 x 1-DoF time-optimal, not synchronized (for comparison)", 4 * n, 4, independent,
              independent_baseline),
  };

  // Durations against the baseline: unchanged where the start need not brake; where it must, the
  // earliest return within the limit (docs/trajectory.md) against the former fixed braking rule.
  std::size_t braking = 0, braking_shorter = 0, unchanged_shorter = 0;
  double unchanged_worst = 0.0, unchanged_best = 0.0, braking_min = 1e300, braking_max = 0.0;
  std::vector<double> braking_ratios;
  for (std::size_t i = 0; i < n; ++i) {
    const Problem& p = problems[i];
    guidance::Profile ours, base;
    if (!guidance::calculate_time_optimal(p.start, p.target, p.limits, ours).ok() ||
        !baseline::calculate_time_optimal(p.start, p.target, p.limits, base).ok()) {
      continue;
    }
    if (ours.brake_phase_count == 0 && base.brake_phase_count == 0) {
      const double change = (ours.duration() - base.duration()) / std::max(base.duration(), 1e-300);
      unchanged_worst = std::max(unchanged_worst, change);
      unchanged_best = std::min(unchanged_best, change);
      if (change < -1e-9) ++unchanged_shorter;
    } else if (base.duration() > 0.0) {
      ++braking;
      const double ratio = ours.duration() / base.duration();
      braking_ratios.push_back(ratio);
      braking_min = std::min(braking_min, ratio);
      braking_max = std::max(braking_max, ratio);
      if (ratio < 1.0) ++braking_shorter;
    }
  }
  // Synchronized common durations against the baseline.
  std::size_t sync_shorter = 0, sync_longer = 0;
  double sync_min = 1e300;
  for (std::size_t i = 0; i + 4 <= 4 * n; i += 4) {
    fill(i);
    const auto ours = guidance::calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, profiles.data());
    const auto base = baseline::calculate_synchronized(starts.data(), targets.data(), limits.data(), 4, profiles.data());
    if (!ours.ok() || !base.ok() || !(base.duration_s > 0.0)) continue;
    const double ratio = ours.duration_s / base.duration_s;
    sync_min = std::min(sync_min, ratio);
    if (ratio < 1.0 - 1e-9) ++sync_shorter;
    if (ratio > 1.0 + 1e-9) ++sync_longer;
  }

  std::string table = "### trajectory\n\nRandom moving start states inside the limits, " +
                      std::to_string(options.cases) + " calculations per row, seed " + std::to_string(options.seed) +
                      "; each problem timed with the current generator and the baseline (the generator before the "
                      "exact braking, tools/mgc-bench/trajectory_baseline.cpp), alternately.\n\n"
                      "| case | median us | p95 us | p99 us | max us | baseline median us | baseline p95 us | "
                      "baseline p99 us | baseline/current median | baseline/current p95 | baseline/current p99 | "
                      "failures (baseline) |\n"
                      "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    char line[512];
    std::snprintf(line, sizeof line, "| %s | %.3f | %.3f | %.3f | %.1f | %.3f | %.3f | %.3f | %.2fx | %.2fx | %.2fx | %d (%d) |\n",
                  r.what, r.current.median_us, r.current.p95_us, r.current.p99_us, r.current.max_us,
                  r.baseline.median_us, r.baseline.p95_us, r.baseline.p99_us, r.baseline.median_us / r.current.median_us,
                  r.baseline.p95_us / r.current.p95_us, r.baseline.p99_us / r.current.p99_us, r.failures,
                  r.baseline_failures);
    table += line;
  }
  {
    const double median_ratio = braking_ratios.empty() ? 1.0 : percentile(braking_ratios, 0.5);
    char line[1024];
    std::snprintf(line, sizeof line,
                  "\nDurations against the baseline, 1-DoF: starts that need not brake %zu, relative change from "
                  "%.2e to %.2e (shorter by more than 1e-9 in %zu: the plateau types' roots refined); starts that "
                  "must brake %zu (%.1f%%), current/baseline median %.4f, from %.4f to %.4f, shorter in %zu. "
                  "Synchronized 4-DoF: common duration shorter in %zu sets, longer in %zu, least current/baseline "
                  "%.4f.\n",
                  n - braking, unchanged_best, unchanged_worst, unchanged_shorter, braking,
                  100.0 * static_cast<double>(braking) / static_cast<double>(n),
                  median_ratio, braking_ratios.empty() ? 1.0 : braking_min, braking_ratios.empty() ? 1.0 : braking_max,
                  braking_shorter, sync_shorter, sync_longer, sync_min > 1e299 ? 1.0 : sync_min);
    table += line;
  }
  std::printf("%s\n", table.c_str());
  if (!options.out_dir.empty()) std::ofstream(options.out_dir + "/trajectory.md") << table;
  int failures = 0;
  for (const Row& r : rows) failures += r.failures;
  return failures == 0 ? 0 : 1;
}

}  // namespace mgc::bench
