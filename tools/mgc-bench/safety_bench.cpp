// SPDX-License-Identifier: Apache-2.0
// Safety suite: what the per-cycle safety functions cost on the thesis site (TMS870 beside the
// steel frame, 20,000 lb on the hook), one call timed at a time after a warm-up pass.
#include "safety_bench.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <functional>
#include <numbers>
#include <utility>
#include <vector>

#include "mgc/guidance/online.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/guidance/safety.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"

namespace mgc::bench {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kFullSlewDegS = 3.75;

struct Row {
  std::string what;
  double median_us = 0.0, p99_us = 0.0, max_us = 0.0;
  //! The same calls on the thread's CPU clock: compute alone, without the time other processes held
  //! the core (a shared machine preempts about one call in a hundred).
  double cpu_median_us = 0.0, cpu_p99_us = 0.0, cpu_max_us = 0.0;
  std::string detail;
};

double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
}

Row time_calls(const std::string& what, int repeats, const std::function<void()>& call) {
  std::vector<double> times_us;
  std::vector<double> cpu_us;
  for (int pass = 0; pass < 2; ++pass) {  // the first pass warms caches and branch predictors
    times_us.clear();
    cpu_us.clear();
    for (int i = 0; i < repeats; ++i) {
      const double c0 = thread_cpu_us();
      const auto t0 = std::chrono::steady_clock::now();
      call();
      const auto t1 = std::chrono::steady_clock::now();
      const double c1 = thread_cpu_us();
      times_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      cpu_us.push_back(c1 - c0);
    }
  }
  const auto stats = [](std::vector<double>& v, double& median, double& p99, double& max) {
    std::sort(v.begin(), v.end());
    const auto at = [&](double p) {
      return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
    };
    median = at(0.5);
    p99 = at(0.99);
    max = v.back();
  };
  Row row;
  row.what = what;
  stats(times_us, row.median_us, row.p99_us, row.max_us);
  stats(cpu_us, row.cpu_median_us, row.cpu_p99_us, row.cpu_max_us);
  return row;
}

//! Boom at 25 deg, 20 m, cable 2 m (the stop-check tests' pose), slewing at swing_velocity_deg_s.
guidance::MachineState state(double swing_deg, double swing_velocity_deg_s) {
  guidance::MachineState s;
  s.joints[0] = {swing_deg * kDeg, swing_velocity_deg_s * kDeg, 0.0};
  s.joints[1] = {25.0 * kDeg, 0.0, 0.0};
  s.joints[2] = {20.0, 0.0, 0.0};
  s.joints[3] = {2.0, 0.0, 0.0};
  return s;
}

}  // namespace

int run_safety_suite(const SafetyBenchOptions& options) {
  auto loaded = planning::io::load_and_build(options.scenarios_dir + "/thesis-steel-frame.yaml");
  const auto& crane = dynamic_cast<const planning::MobileCrane&>(*loaded.model);
  guidance::StopCheck check(*loaded.world, nullptr, guidance::StopCheckConfig{});
  // The same check sampling every body, the parked carrier too: what measuring the fixed bodies
  // once per check saves, in the same run.
  guidance::StopCheckConfig all_bodies;
  all_bodies.fixed_bodies_once = false;
  guidance::StopCheck check_all(*loaded.world, nullptr, all_bodies);
  // The default check measuring the nearest obstacle in full at every sample, as it did before the
  // bounded queries: what those save, in the same run.
  guidance::StopCheckConfig all_distance;
  all_distance.bounded_queries = false;
  guidance::StopCheck check_full(*loaded.world, nullptr, all_distance);
  std::vector<Row> rows;

  const auto stop_case = [&](guidance::StopCheck& c, const std::string& what, const guidance::MachineState& s) {
    guidance::StopCheckResult r{};
    Row row = time_calls(what, options.repeats, [&] { r = c.check(s); });
    row.detail = std::string(guidance::to_string(r.status)) + ", " + std::to_string(r.samples) + " samples";
    rows.push_back(row);
  };
  const std::pair<const char*, guidance::MachineState> stop_states[] = {
      {"at rest at swing 80 deg", state(80, 0)},
      {"full slew away from the frame (80 deg)", state(80, kFullSlewDegS)},
      {"full slew toward the frame (62 deg)", state(62, -kFullSlewDegS)},
      {"full slew toward the frame (61 deg)", state(61, -kFullSlewDegS)},
      {"half slew toward the frame (61 deg)", state(61, -0.5 * kFullSlewDegS)},
  };
  for (const auto& [what, s] : stop_states) stop_case(check, std::string("stop check, ") + what, s);
  for (const auto& [what, s] : stop_states) stop_case(check_full, std::string("stop check, all-distance sweep, ") + what, s);
  for (const auto& [what, s] : stop_states) stop_case(check_all, std::string("stop check, every body sampled, ") + what, s);

  guidance::RatedCapacityLimiter rcl(crane, guidance::RatedCapacityConfig{});
  planning::JointVector q(4);
  q << 80 * kDeg, 40 * kDeg, 20.0, 14.0;
  planning::JointVector v(4);
  v << 0.01, -0.01, 0.05, -0.1;
  guidance::RatedCapacityResult rated{};
  Row rcl_row = time_calls("rated capacity limiter, 20,000 lb at 40 deg", options.repeats,
                           [&] { rated = rcl.limit_velocity(q, 20'000.0, v); });
  rcl_row.detail = std::string(guidance::to_string(rated.stage));
  rows.push_back(rcl_row);

  guidance::JointTrajectory online;
  const guidance::JointLimits limits{3.75 * kDeg, 3.75 * kDeg, 7.5 * kDeg};
  guidance::JointState current{0.0, 0.0, 0.0};
  guidance::JointState next{};
  rows.push_back(time_calls("online trajectory update, target unchanged (profile reused)", options.repeats * 50, [&] {
    (void)online.update(current, 30 * kDeg, limits, 0.01, next);
    current = next;
    if (current.position > 29 * kDeg) current = {0.0, 0.0, 0.0};
  }));

  std::string table = "### safety\n\nPer-cycle safety functions on `thesis-steel-frame.yaml`, " +
                      std::to_string(options.repeats) +
                      " timed calls per case (the online update: 50x that); wall clock, and the thread's CPU clock (compute "
                      "without preemption) read around the same calls.\n\n| case | median us | p99 us | max us | CPU median us | "
                      "CPU p99 us | CPU max us | result |\n|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    char line[400];
    std::snprintf(line, sizeof line, "| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s |\n", r.what.c_str(), r.median_us,
                  r.p99_us, r.max_us, r.cpu_median_us, r.cpu_p99_us, r.cpu_max_us, r.detail.c_str());
    table += line;
  }
  std::printf("%s\n", table.c_str());
  if (!options.out_dir.empty()) std::ofstream(options.out_dir + "/safety.md") << table;
  return 0;
}

}  // namespace mgc::bench
