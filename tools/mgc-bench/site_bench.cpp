// SPDX-License-Identifier: Apache-2.0
// The `site` suite of mgc-bench: the crossing sweep of docs/site.md in stepped time on the site rig.
#include "site_bench.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_rig.hpp"
#include "timing_report.hpp"

namespace mgc::bench {
namespace {

constexpr std::int32_t kLower = 1;   // the TMS870, priority 2
constexpr std::int32_t kHigher = 2;  // the tower crane, priority 1
//! The rig checks for the lifts' ends this often: the lift times are this exact. [s]
constexpr double kCheckPeriodS = 0.1;

struct MemberResult {
  bool done = false;
  double lift_s = std::numeric_limits<double>::quiet_NaN();  //!< goal request to goal reached [s]
  int replans = 0;       //!< the controller's repairs
  int site_replans = 0;  //!< of them, asked for by the site rules
  int site_stops = 0;
};

struct SiteRun {
  double offset_s = 0.0;
  MemberResult lower;
  MemberResult higher;
  double least_m = std::numeric_limits<double>::infinity();
  double least_at_s = 0.0;
  std::uint64_t contact_samples = 0;
  double end_s = 0.0;
  double wall_s = 0.0;
};

//! One run: lift_start per machine in site order (negative: never requested).
SiteRun run_one(const planning::Site& site, double lower_start_s, double higher_start_s, double limit_s, const std::string& name) {
  sim::SiteRigConfig config;
  config.lift_start_s.resize(site.machines.size(), -1.0);
  for (std::size_t i = 0; i < site.machines.size(); ++i) {
    if (site.machines[i].id == kLower) config.lift_start_s[i] = lower_start_s;
    if (site.machines[i].id == kHigher) config.lift_start_s[i] = higher_start_s;
  }
  const auto t0 = std::chrono::steady_clock::now();
  sim::SiteRig rig(site, config, "bench-site-" + name);
  SiteRun r;
  r.offset_s = higher_start_s - lower_start_s;
  const auto record = [&](sim::SiteRigMember& m, MemberResult& out) {
    if (out.done || !rig.lift_done(m)) return;
    out.done = true;
    out.lift_s = rig.sim_s() - m.lift_start_s;
  };
  while (rig.sim_s() < limit_s) {
    rig.run_until(rig.sim_s() + kCheckPeriodS, true);
    record(rig.member(kLower), r.lower);
    record(rig.member(kHigher), r.higher);
    bool all = true;
    for (sim::SiteRigMember& m : rig.members()) all = all && (m.lift_start_s < 0.0 || rig.lift_done(m));
    if (all) break;
  }
  const auto fill = [&](std::int32_t id, MemberResult& out) {
    const firmware::ControllerStats& st = rig.member(id).controller->stats();
    out.replans = st.replans;
    out.site_replans = st.site_replans;
    out.site_stops = st.site_stops;
  };
  fill(kLower, r.lower);
  fill(kHigher, r.higher);
  for (const sim::SitePairTruth& p : rig.pairs()) {
    if (p.least_m < r.least_m) {
      r.least_m = p.least_m;
      r.least_at_s = p.least_t_s;
    }
    r.contact_samples += p.samples_in_contact;
  }
  r.end_s = rig.sim_s();
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string done_text(const MemberResult& m) { return m.done ? fmt("%.1f", m.lift_s) : std::string("not done"); }

}  // namespace

int run_site_suite(const SiteBenchOptions& options) {
  const std::string file = options.scenarios_dir + "/sites/crossing-cranes.yaml";
  const planning::Site site = planning::io::load_site(file);
  const std::string load_before = load_average();
  const auto t0 = std::chrono::steady_clock::now();

  std::fprintf(stderr, "site: each machine alone\n");
  const SiteRun lower_alone = run_one(site, 0.0, -1.0, options.limit_s, "lower-alone");
  const SiteRun higher_alone = run_one(site, -1.0, 0.0, options.limit_s, "higher-alone");
  std::vector<SiteRun> runs;
  for (int offset = options.first_offset_s; offset <= options.last_offset_s; ++offset) {
    std::fprintf(stderr, "site: offset %d s\n", offset);
    runs.push_back(run_one(site, 0.0, static_cast<double>(offset), options.limit_s, std::to_string(offset)));
  }

  std::vector<double> least, lower_lift, higher_lift, lower_replans, lower_site_stops, higher_site_stops;
  int both_done = 0;
  std::uint64_t contact = 0;
  for (const SiteRun& r : runs) {
    least.push_back(r.least_m);
    if (r.lower.done) lower_lift.push_back(r.lower.lift_s);
    if (r.higher.done) higher_lift.push_back(r.higher.lift_s);
    lower_replans.push_back(r.lower.replans);
    lower_site_stops.push_back(r.lower.site_stops);
    higher_site_stops.push_back(r.higher.site_stops);
    if (r.lower.done && r.higher.done) ++both_done;
    contact += r.contact_samples;
  }
  const auto ratio = [](double a, double b) { return std::isfinite(a) && std::isfinite(b) && b > 0.0 ? a / b : std::nan(""); };

  std::string md = "### site\n\n";
  md += fmt("`%s`: crossing-cranes.yaml on the site rig (stepped time, every message signed and verified), the TMS870 "
            "(machine 1, priority 2) lifting from 0 s and the tower crane (machine 2, priority 1) from the offset; a run ends "
            "when both lifts are done or at %.0f s. Lift times from the goal request to the goal, to %.1f s; alone: the "
            "machine with the other on site, at rest, heard.\n\n",
            options.command.c_str(), options.limit_s, kCheckPeriodS);
  md += fmt("Alone: TMS870 %s s (%d re-plans), tower crane %s s (%d re-plans).\n\n", done_text(lower_alone.lower).c_str(),
            lower_alone.lower.replans, done_text(higher_alone.higher).c_str(), higher_alone.higher.replans);
  md += "| Offset [s] | TMS870 lift [s] | Tower crane lift [s] | TMS870 re-plans (for the site) | Tower crane re-plans | Site stops TMS870 / tower | Least between [m] (at s) | End [s] |\n";
  md += "|---|---|---|---|---|---|---|---|\n";
  for (const SiteRun& r : runs) {
    md += fmt("| %.0f | %s | %s | %d (%d) | %d | %d / %d | %.2f (%.1f) | %.1f |\n", r.offset_s, done_text(r.lower).c_str(),
              done_text(r.higher).c_str(), r.lower.replans, r.lower.site_replans, r.higher.replans, r.lower.site_stops,
              r.higher.site_stops, r.least_m, r.least_at_s, r.end_s);
  }
  const double lower_med = percentile(lower_lift, 0.5);
  const double higher_med = percentile(higher_lift, 0.5);
  md += fmt("\nBoth lifts done at %d of %zu offsets; %llu referee samples in contact. Least true clearance between the "
            "machines: least %.2f m, median %.2f m. TMS870 lift median %.1f s, p95 %.1f s (%.2f and %.2f times alone); tower "
            "crane median %.1f s, p95 %.1f s (%.2f and %.2f times alone). TMS870 re-plans median %.0f, p95 %.0f; site stops "
            "median %.0f / %.0f.\n",
            both_done, runs.size(), static_cast<unsigned long long>(contact), percentile(least, 0.0), percentile(least, 0.5),
            lower_med, percentile(lower_lift, 0.95), ratio(lower_med, lower_alone.lower.lift_s),
            ratio(percentile(lower_lift, 0.95), lower_alone.lower.lift_s), higher_med, percentile(higher_lift, 0.95),
            ratio(higher_med, higher_alone.higher.lift_s), ratio(percentile(higher_lift, 0.95), higher_alone.higher.lift_s),
            percentile(lower_replans, 0.5), percentile(lower_replans, 0.95), percentile(lower_site_stops, 0.5),
            percentile(higher_site_stops, 0.5));
  md += fmt("\nWhole suite: %.1f s; load average (1, 5, 15 min) before %s, after %s.\n",
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), load_before.c_str(), load_average().c_str());
  std::printf("%s", md.c_str());

  if (!options.out_dir.empty()) {
    std::ofstream mdf(options.out_dir + "/site.md");
    mdf << md;
    std::ofstream csv(options.out_dir + "/site.csv");
    csv << "offset_s,lower_done,lower_lift_s,lower_replans,lower_site_replans,lower_site_stops,higher_done,higher_lift_s,"
           "higher_replans,higher_site_stops,least_m,least_at_s,contact_samples,end_s,wall_s\n";
    std::string json = "{\"suite\": \"site\", \"command\": \"" + options.command + "\", \"runs\": [";
    for (std::size_t i = 0; i < runs.size(); ++i) {
      const SiteRun& r = runs[i];
      csv << fmt("%.0f,%d,%.1f,%d,%d,%d,%d,%.1f,%d,%d,%.3f,%.2f,%llu,%.1f,%.2f\n", r.offset_s, r.lower.done ? 1 : 0,
                 r.lower.lift_s, r.lower.replans, r.lower.site_replans, r.lower.site_stops, r.higher.done ? 1 : 0, r.higher.lift_s,
                 r.higher.replans, r.higher.site_stops, r.least_m, r.least_at_s, static_cast<unsigned long long>(r.contact_samples),
                 r.end_s, r.wall_s);
      json += fmt("%s{\"offset_s\": %.0f, \"lower_done\": %s, \"higher_done\": %s, \"least_m\": %.3f, \"end_s\": %.1f}",
                  i == 0 ? "" : ", ", r.offset_s, r.lower.done ? "true" : "false", r.higher.done ? "true" : "false", r.least_m,
                  r.end_s);
    }
    json += "]}\n";
    std::ofstream jf(options.out_dir + "/site.json");
    jf << json;
    if (!mdf || !csv || !jf) throw std::runtime_error("cannot write the site suite's files under " + options.out_dir);
  }
  // A benchmark reports: the table says which lifts were not done, as the campaign's targets do.
  return 0;
}

}  // namespace mgc::bench
