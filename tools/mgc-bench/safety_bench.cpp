// SPDX-License-Identifier: Apache-2.0
// Safety suite: what the per-cycle safety functions cost on the thesis site (TMS870 beside the
// steel frame, 20,000 lb on the hook), one call timed at a time after a warm-up pass; and the
// working-envelope limiter on thesis-steel-frame-road.yaml far from, near and beyond its limits.
#include "safety_bench.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "mgc/guidance/envelope.hpp"
#include "mgc/guidance/online.hpp"
#include "mgc/guidance/rated_capacity.hpp"
#include "mgc/guidance/safety.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/mobile_crane.hpp"
#include "timing_report.hpp"

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

// --- The working-envelope limiter far from, near and beyond its limits -------------------------

//! The site with a road 8 m west (a wall) and a 40 m ceiling: the envelope the loop suite runs.
constexpr const char* kEnvelopeScenario = "thesis-steel-frame-road.yaml";
//! The controller cycle's compute budget: p99 under this. [µs]
constexpr double kCycleBudgetUs = 200.0;
//! Timed rounds over each class's configurations, after one warm-up round.
constexpr int kEnvelopeRounds = 5;
//! Where the timed calls' results go, so that none can be left out.
volatile double g_envelope_sink = 0.0;

//! A configuration by its nearest limit (Envelope::nearest): every monitored point beyond the
//! slowdown band (limit_velocity returns after the distances), some point inside it (the gradients
//! are computed), some point beyond a limit (violated; the gradients too).
enum EnvelopeClass : std::size_t { kFar = 0, kInBand = 1, kBeyond = 2, kEnvelopeClasses = 3 };

constexpr const char* kEnvelopeClassNames[kEnvelopeClasses] = {"(a) far: beyond the band", "(b) near: inside the band",
                                                               "(c) beyond a limit"};

//! One timed configuration: the joints, a random command and the controller's probe of one moving
//! joint at its full speed (Controller::follow).
struct EnvelopeCase {
  planning::JointVector q, v, probe;
};

struct EnvelopeTiming {
  LatencyStats wall, cpu;
};

//! Each call timed on its own, the steady clock inside the thread's CPU clock: one warm-up round over
//! the cases, then kEnvelopeRounds timed rounds.
template <typename Call>
EnvelopeTiming time_cases(const std::vector<EnvelopeCase>& cases, Call&& call) {
  std::vector<double> wall_us;
  std::vector<double> cpu_us;
  for (int round = 0; round <= kEnvelopeRounds; ++round) {
    if (round == 1) {
      wall_us.clear();
      cpu_us.clear();
    }
    for (const EnvelopeCase& c : cases) {
      const double c0 = thread_cpu_us();
      const auto t0 = std::chrono::steady_clock::now();
      call(c);
      const auto t1 = std::chrono::steady_clock::now();
      const double c1 = thread_cpu_us();
      wall_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      cpu_us.push_back(c1 - c0);
    }
  }
  return {latency_stats(wall_us), latency_stats(cpu_us)};
}

//! The envelope section of the safety report (markdown).
std::string envelope_near_limits(const SafetyBenchOptions& options) {
  auto loaded = planning::io::load_and_build(options.scenarios_dir + "/" + kEnvelopeScenario);
  const planning::MachineModel& model = *loaded.model;
  // As the controller builds it (Controller::Controller, make_envelope).
  guidance::Envelope envelope(model, guidance::envelope_config(*loaded.scenario.envelope, model));
  const double band_m = envelope.config().slowdown_band_m;
  const int n = model.dof();
  const auto joints = model.joints();
  const auto classify = [&](const guidance::EnvelopeDistance& d) {
    if (d.limit == guidance::EnvelopeLimit::None || d.distance_m >= band_m) return kFar;
    return d.distance_m >= 0.0 ? kInBand : kBeyond;
  };

  // Uniform over the joint ranges, a command uniform within each joint's speed, and a probe of one
  // joint at full speed, either way.
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> pick_joint(0, n - 1);
  const auto command_for = [&](EnvelopeCase& c) {
    c.v = planning::JointVector(n);
    c.probe = planning::JointVector::Zero(n);
    for (int j = 0; j < n; ++j) c.v[j] = (2.0 * unit(rng) - 1.0) * joints[static_cast<std::size_t>(j)].max_velocity;
    const int moving = pick_joint(rng);
    c.probe[moving] = (unit(rng) < 0.5 ? -1.0 : 1.0) * joints[static_cast<std::size_t>(moving)].max_velocity;
  };
  const auto per_class = static_cast<std::size_t>(options.repeats);
  std::array<std::vector<EnvelopeCase>, kEnvelopeClasses> cases;
  std::array<std::size_t, kEnvelopeClasses> drawn{};
  std::size_t draws = 0;
  const std::size_t max_draws = 100 * per_class;
  const auto full = [&] {
    return std::all_of(cases.begin(), cases.end(), [&](const auto& c) { return c.size() >= per_class; });
  };
  while (!full() && draws < max_draws) {
    EnvelopeCase c;
    c.q = planning::JointVector(n);
    for (int j = 0; j < n; ++j) {
      const planning::JointSpec& js = joints[static_cast<std::size_t>(j)];
      c.q[j] = js.position_min + unit(rng) * js.range();
    }
    command_for(c);
    const EnvelopeClass k = classify(envelope.nearest(c.q));
    ++draws;
    ++drawn[k];
    if (cases[k].size() < per_class) cases[k].push_back(std::move(c));
  }
  // A rare band: configurations bisected between a far one and a beyond one until the nearest limit
  // lies inside the band (it is continuous in q, so the crossing exists).
  const std::size_t band_sampled = cases[kInBand].size();
  for (std::size_t i = 0; cases[kInBand].size() < per_class && !cases[kFar].empty() && !cases[kBeyond].empty() && i < 4 * per_class; ++i) {
    const planning::JointVector& from = cases[kFar][i % cases[kFar].size()].q;
    const planning::JointVector& to = cases[kBeyond][(i * 7 + 3) % cases[kBeyond].size()].q;
    double lo = 0.0;
    double hi = 1.0;
    for (int step = 0; step < 60; ++step) {
      const double t = 0.5 * (lo + hi);
      EnvelopeCase c;
      c.q = model.interpolate(from, to, t);
      const EnvelopeClass k = classify(envelope.nearest(c.q));
      if (k == kInBand) {
        command_for(c);
        cases[kInBand].push_back(std::move(c));
        break;
      }
      (k == kFar ? lo : hi) = t;
    }
  }

  // What the calls give, so that they cannot be left out, and what they decided.
  double sink = 0.0;
  std::array<std::size_t, kEnvelopeClasses> cut_calls{};
  std::array<std::size_t, kEnvelopeClasses> cut_total{};
  struct Cell {
    EnvelopeTiming nearest, limit, cycle;
  };
  std::array<Cell, kEnvelopeClasses> cells;
  for (std::size_t k = 0; k < kEnvelopeClasses; ++k) {
    if (cases[k].empty()) continue;
    cells[k].nearest = time_cases(cases[k], [&](const EnvelopeCase& c) { sink += envelope.nearest(c.q).distance_m; });
    cells[k].limit = time_cases(cases[k], [&](const EnvelopeCase& c) {
      const guidance::EnvelopeResult r = envelope.limit_velocity(c.q, c.v);
      sink += r.allowed_velocity[0];
      ++cut_total[k];
      if (r.acting.limit != guidance::EnvelopeLimit::None) ++cut_calls[k];
    });
    // The controller's cycle near a limit: follow()'s probe of the moving joint, the command's cut,
    // run_safety()'s distances.
    cells[k].cycle = time_cases(cases[k], [&](const EnvelopeCase& c) {
      sink += envelope.limit_velocity(c.q, c.probe).joint_scale[0];
      sink += envelope.limit_velocity(c.q, c.v).allowed_velocity[0];
      sink += envelope.nearest(c.q).distance_m;
    });
  }

  const auto share = [&](std::size_t k) { return draws > 0 ? 100.0 * static_cast<double>(drawn[k]) / static_cast<double>(draws) : 0.0; };
  std::string md = "### The envelope limiter near its limits\n\n";
  md += fmt("`%s`'s envelope (%d monitored points, %d wall(s), height ceiling %s, slowdown band %.1f m), built as the controller "
            "builds it (guidance::envelope_config on the scenario's model). Seed %llu: %zu configurations drawn uniformly over the "
            "joint ranges and classed by nearest(): far %.1f %%, in the band %.1f %%, beyond a limit %.1f %%. Up to %zu per class "
            "(in the band: %zu drawn, %zu bisected between a far and a beyond one), each with a command uniform within the joint "
            "speeds and a probe of one joint at full speed; each call timed on its own, %d rounds after a warm-up round; wall "
            "(steady clock) and the thread's CPU clock around the same calls (reading it costs about a microsecond, which the CPU "
            "columns include). Cycle: one probe limit_velocity (only the moving joint non-zero) + one limit_velocity of the "
            "command + one nearest(), as Controller::step calls them near a limit.\n\n",
            kEnvelopeScenario, envelope.config().point_count, envelope.config().wall_count,
            envelope.config().height_ceiling_enabled ? fmt("%.0f m", envelope.config().height_ceiling_m).c_str() : "off", band_m,
            static_cast<unsigned long long>(options.seed), draws, share(kFar), share(kInBand), share(kBeyond), per_class,
            band_sampled, cases[kInBand].size() - band_sampled, kEnvelopeRounds);
  md += "| class | call | n | median us | p95 us | p99 us | max us | CPU median us | CPU p99 us | result |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  const auto row = [&](std::size_t k, const char* call, const EnvelopeTiming& t, const std::string& result) {
    md += fmt("| %s | %s | %zu | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s |\n", kEnvelopeClassNames[k], call, t.wall.n, t.wall.median,
              t.wall.p95, t.wall.p99, t.wall.max, t.cpu.median, t.cpu.p99, result.c_str());
  };
  for (std::size_t k = 0; k < kEnvelopeClasses; ++k) {
    if (cases[k].empty()) {
      md += fmt("| %s | (none drawn) | 0 | | | | | | | |\n", kEnvelopeClassNames[k]);
      continue;
    }
    row(k, "nearest", cells[k].nearest, "");
    row(k, "limit_velocity", cells[k].limit,
        fmt("%.0f %% of calls cut", 100.0 * static_cast<double>(cut_calls[k]) / static_cast<double>(std::max<std::size_t>(cut_total[k], 1))));
    row(k, "cycle: probe + command + nearest", cells[k].cycle, "");
  }
  if (!cases[kFar].empty() && !cases[kInBand].empty()) {
    const Cell& far = cells[kFar];
    const Cell& near = cells[kInBand];
    const auto ratio = [](double a, double b) { return a / std::max(b, 1e-9); };
    md += fmt("\nNear / far, medians in this run (wall): nearest %.2f×, limit_velocity %.2f×, cycle %.2f× (CPU clock: %.2f×, %.2f×, "
              "%.2f×). Against the cycle's compute budget (compute p99 < %.0f µs): the near-limit cycle's envelope calls take p99 %.2f µs "
              "wall = %.1f %% (median %.2f µs = %.1f %%); far from the limits p99 %.2f µs = %.1f %%.\n",
              ratio(near.nearest.wall.median, far.nearest.wall.median), ratio(near.limit.wall.median, far.limit.wall.median),
              ratio(near.cycle.wall.median, far.cycle.wall.median), ratio(near.nearest.cpu.median, far.nearest.cpu.median),
              ratio(near.limit.cpu.median, far.limit.cpu.median), ratio(near.cycle.cpu.median, far.cycle.cpu.median), kCycleBudgetUs,
              near.cycle.wall.p99, 100.0 * near.cycle.wall.p99 / kCycleBudgetUs, near.cycle.wall.median,
              100.0 * near.cycle.wall.median / kCycleBudgetUs, far.cycle.wall.p99, 100.0 * far.cycle.wall.p99 / kCycleBudgetUs);
  }
  g_envelope_sink = sink;
  return md;
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
  // Appended piece by piece: GCC 12 at -O3 misreads "\n" + a temporary's insert at the front as an
  // overlapping copy (-Wrestrict).
  table += '\n';
  table += envelope_near_limits(options);
  std::printf("%s\n", table.c_str());
  if (!options.out_dir.empty()) std::ofstream(options.out_dir + "/safety.md") << table;
  return 0;
}

}  // namespace mgc::bench
