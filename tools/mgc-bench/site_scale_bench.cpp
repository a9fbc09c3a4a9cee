// SPDX-License-Identifier: Apache-2.0
// The `site-scale` suite of mgc-bench: the coordinated site at 2, 4, 8 and 16 machines on the site
// rig, measured (docs/site.md, "Scale").
#include "site_scale_bench.hpp"

#include <unistd.h>

#include <mgc/site_plan_t.hpp>
#include <mgc/site_state_t.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "mgc/firmware/site_rules.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/sim/site_rig.hpp"
#include "site_scale.hpp"
#include "timing_report.hpp"

namespace mgc::bench {
namespace {

std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

//! The UDP payload of one LCM message: LCM's small-message header (magic and sequence, 8 bytes),
//! the channel name with its terminating zero, and the encoded message. docs/site.md measured
//! 309 and 4,705 bytes for the two site types this way. [bytes]
std::size_t datagram_bytes(const char* channel, std::size_t encoded) { return 8 + std::char_traits<char>::length(channel) + 1 + encoded; }

struct Triple {
  double p50 = std::numeric_limits<double>::quiet_NaN();
  double p95 = std::numeric_limits<double>::quiet_NaN();
  double p99 = std::numeric_limits<double>::quiet_NaN();
};

Triple triple(const std::vector<double>& v) {
  Triple t;
  if (v.empty()) return t;
  t.p50 = percentile(v, 0.5);
  t.p95 = percentile(v, 0.95);
  t.p99 = percentile(v, 0.99);
  return t;
}

struct SizeRun {
  int machines = 0;
  int tower_cranes = 0;
  int redraws = 0;
  std::string file;
  double sim_s = 0.0;
  double wall_s = 0.0;
  std::vector<double> step_us;         //!< every member, every cycle
  std::vector<double> step_mobile_us;  //!< the TMS870 members'
  std::vector<double> verify_us;       //!< per message delivered
  std::vector<double> rules_us;        //!< decide_site(), every member, every cycle
  std::uint64_t states_sent = 0;
  std::uint64_t plans_sent = 0;
  std::uint64_t messages_delivered = 0;
  int plans_new = 0;                  //!< new plan ids published
  std::uint64_t uses = 0;             //!< (receiver, new plan id) pairs taken up
  std::vector<double> after_plan_cycles;   //!< receiver cycles from the plan's delivery to its use
  std::vector<double> after_state_cycles;  //!< from the first state naming it to its use
  std::vector<double> from_publish_ms;     //!< from its publication to its use [ms]
  int lifts_done = 0;
  double least_m = std::numeric_limits<double>::infinity();
  std::string least_pair;
  std::uint64_t contact_samples = 0;
  int site_stops = 0;
  int site_replans = 0;
  int stale_alerts = 0;
};

//! What one receiver has seen of one sender's plans.
struct Link {
  std::int32_t delivered_id = 0;
  long delivered_cycle = 0;
  std::int32_t named_id = 0;
  long named_cycle = 0;
  std::int32_t used_id = 0;
};

SizeRun run_size(const std::filesystem::path& file, const ScaleSite& generated, double sim_s) {
  const planning::Site site = planning::io::load_site(file);
  const std::size_t n = site.machines.size();
  SizeRun r;
  r.machines = static_cast<int>(n);
  r.tower_cranes = generated.tower_cranes;
  r.redraws = generated.redraws;
  r.file = file.string();
  sim::SiteRigConfig config;
  config.lift_start_s.assign(n, 0.0);
  config.clock_ns = wall_ns;
  const auto t0 = std::chrono::steady_clock::now();
  sim::SiteRig rig(site, config, "bench-scale-" + std::to_string(n) + "-" + std::to_string(::getpid()));
  std::vector<sim::SiteRigMember>& members = rig.members();
  const firmware::SiteRoster& roster = members.front().verifier->roster();
  std::vector<bool> mobile(n);
  for (std::size_t i = 0; i < n; ++i) mobile[i] = site.machines[i].machine.kind == planning::MachineKind::MobileCrane;
  std::vector<int> index(n);
  for (std::size_t i = 0; i < n; ++i) index[i] = roster.index_of(site.machines[i].id);

  std::vector<std::uint64_t> plans_seen(n, 0);
  std::vector<std::int32_t> published_id(n, 0);
  std::vector<std::map<std::int32_t, long>> published_cycle(n);
  std::vector<Link> links(n * n);
  std::array<firmware::SitePeerInput, firmware::kMaxSiteMachines> rule_in{};
  const std::size_t cycles = static_cast<std::size_t>(std::llround(sim_s / 0.01));
  r.step_us.reserve(cycles * n);
  r.rules_us.reserve(cycles * n);
  long cycle = 0;
  double next_progress_s = 10.0;
  while (rig.sim_s() < sim_s - 1e-9) {
    // One period: every member's cycle at the same clock time (sim_s() moves by 10 ms).
    rig.run_until(rig.sim_s() + 0.005);
    ++cycle;
    for (std::size_t i = 0; i < n; ++i) {
      sim::SiteRigMember& m = members[i];
      const double step_us = static_cast<double>(m.last_step_ns) * 1e-3;
      r.step_us.push_back(step_us);
      if (mobile[i]) r.step_mobile_us.push_back(step_us);
      if (m.last_received > 0) {
        r.messages_delivered += static_cast<std::uint64_t>(m.last_received);
        r.verify_us.push_back(static_cast<double>(m.last_receive_ns) * 1e-3 / m.last_received);
      }
      // The rules again on the inputs the cycle had, with the cycle's meet_in_s: the pure function
      // alone, which the controller runs inside its step.
      for (std::size_t k = 0; k < roster.count; ++k) {
        const firmware::SitePeerMessages& p = m.inputs.peers[k];
        rule_in[k].state = p.has_state ? &p.state : nullptr;
        rule_in[k].state_received_us = p.state_received_us;
        rule_in[k].plan = p.has_plan ? &p.plan : nullptr;
        rule_in[k].meet_in_s = m.controller->site_meet_in_s(k);
      }
      const std::int64_t rules_from_ns = wall_ns();
      const firmware::SiteDecision d = firmware::decide_site(roster, m.machine_id, std::span<const firmware::SitePeerInput>(rule_in.data(), roster.count),
                                                             m.rig->t_us, firmware::SiteRulesConfig{});
      r.rules_us.push_back(static_cast<double>(wall_ns() - rules_from_ns) * 1e-3);
      (void)d;
      if (m.plans_sent != plans_seen[i]) {
        plans_seen[i] = m.plans_sent;
        const std::int32_t id = m.controller->site_plan().plan_id;
        if (id != published_id[i]) {
          published_id[i] = id;
          published_cycle[i][id] = cycle;
          ++r.plans_new;
        }
      }
    }
    // Delivered in this cycle means handed to the receiver's loop before its step of this cycle:
    // a plan taken up in the same cycle counts 0 cycles.
    for (std::size_t rx = 0; rx < n; ++rx) {
      const firmware::SiteDecision& decision = members[rx].controller->site_decision();
      for (std::size_t s = 0; s < n; ++s) {
        if (s == rx) continue;
        const auto k = static_cast<std::size_t>(index[s]);
        const firmware::SitePeerMessages& peer = members[rx].inputs.peers[k];
        Link& l = links[rx * n + s];
        if (peer.has_plan && peer.plan.plan_id != l.delivered_id) {
          l.delivered_id = peer.plan.plan_id;
          l.delivered_cycle = cycle;
        }
        if (peer.has_state && peer.state.plan_id != 0 && peer.state.plan_id != l.named_id) {
          l.named_id = peer.state.plan_id;
          l.named_cycle = cycle;
        }
        if (decision.peers[k].prediction != firmware::SitePrediction::Plan || peer.state.plan_id == l.used_id) continue;
        l.used_id = peer.state.plan_id;
        if (l.used_id != l.delivered_id || l.used_id != l.named_id) continue;
        ++r.uses;
        r.after_plan_cycles.push_back(static_cast<double>(cycle - l.delivered_cycle));
        r.after_state_cycles.push_back(static_cast<double>(cycle - l.named_cycle));
        const auto published = published_cycle[s].find(l.used_id);
        if (published != published_cycle[s].end()) r.from_publish_ms.push_back(static_cast<double>(cycle - published->second) * 10.0);
      }
    }
    if (rig.sim_s() >= next_progress_s - 1e-9) {
      std::fprintf(stderr, "site-scale: %zu machines, %.0f of %.0f s simulated, %.1f s wall\n", n, rig.sim_s(), sim_s,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      next_progress_s += 10.0;
    }
  }
  r.sim_s = rig.sim_s();
  for (const sim::SiteRigMember& m : members) {
    r.states_sent += m.states_sent;
    r.plans_sent += m.plans_sent;
    r.lifts_done += rig.lift_done(m) ? 1 : 0;
    const firmware::ControllerStats& st = m.controller->stats();
    r.site_stops += st.site_stops;
    r.site_replans += st.site_replans;
    r.stale_alerts += st.site_stale_alerts;
  }
  for (const sim::SitePairTruth& p : rig.pairs()) {
    if (p.least_m < r.least_m) {
      r.least_m = p.least_m;
      r.least_pair = std::to_string(p.machine_a) + "-" + std::to_string(p.machine_b);
    }
    r.contact_samples += p.samples_in_contact;
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string t3(const Triple& t) { return fmt("%.0f / %.0f / %.0f", t.p50, t.p95, t.p99); }

}  // namespace

int run_site_scale_suite(const SiteScaleOptions& options) {
  const std::string load_before = load_average();
  const auto t0 = std::chrono::steady_clock::now();
  const std::filesystem::path machines_dir = std::filesystem::path(options.scenarios_dir) / "machines";
  const std::filesystem::path sites_dir = options.out_dir.empty()
                                              ? std::filesystem::temp_directory_path() / ("mgc-site-scale-" + std::to_string(::getpid()))
                                              : std::filesystem::path(options.out_dir) / "sites";
  std::filesystem::create_directories(sites_dir);
  std::fprintf(stderr, "site-scale: the generated sites in %s\n", sites_dir.string().c_str());

  std::vector<int> sizes = {1};
  for (const int n : options.machines) sizes.push_back(n);
  std::vector<SizeRun> runs;
  for (const int n : sizes) {
    const ScaleSite generated = generate_scale_site(n, options.seed, machines_dir, sites_dir);
    std::fprintf(stderr, "site-scale: %d machine(s), %s\n", n, generated.file.string().c_str());
    runs.push_back(run_size(generated.file, generated, options.sim_s));
  }
  const SizeRun& alone = runs.front();
  const Triple alone_t = triple(alone.step_mobile_us);
  // Ratios within the run: the machine is shared, its absolute times move from run to run.
  const SizeRun* two = nullptr;
  for (const SizeRun& r : runs) {
    if (r.machines == 2) two = &r;
  }
  const Triple two_t = two == nullptr ? Triple{} : triple(two->step_mobile_us);

  const site_state_t state{};
  const site_plan_t plan{};
  const auto state_bytes = static_cast<std::size_t>(state.getEncodedSize());
  const auto plan_bytes = static_cast<std::size_t>(plan.getEncodedSize());
  const std::size_t state_udp = datagram_bytes("MGC_SITE_STATE", state_bytes);
  const std::size_t plan_udp = datagram_bytes("MGC_SITE_PLAN", plan_bytes);

  std::string md = "### site-scale\n\n";
  md += fmt("`%s`: generated sites of %d to %d machines (tools/mgc-bench/site_scale.cpp, seed %llu; TMS870s and tower cranes "
            "%.0f m apart, one lift each, all requested at 0 s) on the site rig in stepped time for %.0f s simulated, every "
            "message signed, checked and delivered; the baseline a lone TMS870 site member. Wall clock of each member's "
            "Controller::step (the site cycle inside it), every cycle of every member; the checks of the delivered "
            "messages (SiteVerifier, the I/O thread's work in mgc, outside the step) and the site rules (decide_site() "
            "again on the cycle's inputs; also inside the step) timed apart.\n\n",
            options.command.c_str(), sizes.size() > 1 ? sizes[1] : 1, sizes.back(), static_cast<unsigned long long>(options.seed),
            kScaleSpacing_m, options.sim_s);
  md += "| Machines (tower cranes) | Step p50 / p95 / p99, all members [µs] | TMS870 members [µs] | TMS870 p50, p99 / 2-machine site's | Added per other "
        "machine p50 / p95 / p99 [µs] | Rules p50 / p99 [µs] | Check per message p50 / p99 [µs] |\n";
  md += "|---|---|---|---|---|---|---|\n";
  for (const SizeRun& r : runs) {
    const Triple all = triple(r.step_us);
    const Triple mob = triple(r.step_mobile_us);
    const Triple rules = triple(r.rules_us);
    const Triple verify = triple(r.verify_us);
    std::string added = "-";
    if (r.machines > 1) {
      const double others = r.machines - 1;
      added = fmt("%.1f / %.1f / %.1f", (mob.p50 - alone_t.p50) / others, (mob.p95 - alone_t.p95) / others, (mob.p99 - alone_t.p99) / others);
    }
    const std::string ratio = two == nullptr ? std::string("-") : fmt("%.2f, %.2f", mob.p50 / two_t.p50, mob.p99 / two_t.p99);
    md += fmt("| %d (%d) | %s | %s | %s | %s | %.2f / %.2f | %s |\n", r.machines, r.tower_cranes, t3(all).c_str(), t3(mob).c_str(),
              ratio.c_str(), added.c_str(), rules.p50, rules.p99, r.verify_us.empty() ? "-" : fmt("%.1f / %.1f", verify.p50, verify.p99).c_str());
  }
  // A least-squares line through every size, the lone machine included: the TMS870 members'
  // percentile against the number of other machines, less sensitive to one size's tail.
  const auto slope = [&runs](double Triple::*field) {
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    double count = 0.0;
    for (const SizeRun& r : runs) {
      const double x = r.machines - 1;
      const double y = triple(r.step_mobile_us).*field;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
      count += 1.0;
    }
    const double d = count * sxx - sx * sx;
    return d > 0.0 ? (count * sxy - sx * sy) / d : std::nan("");
  };
  md += fmt("\nA least-squares line through the sizes (TMS870 members against the other machines): p50 %.1f, p95 %.1f, p99 %.1f µs "
            "per other machine.\n",
            slope(&Triple::p50), slope(&Triple::p95), slope(&Triple::p99));
  md += fmt("\nTraffic: states %zu bytes encoded (%zu bytes of UDP payload), plans %zu (%zu), as sent over the run.\n\n", state_bytes,
            state_udp, plan_bytes, plan_udp);
  md += "| Machines | States / s, plans / s per machine | UDP payload per machine: states, plans, both [kB/s] | Site: states / s, "
        "plans / s | Site UDP payload: states, plans, both [kB/s] | Received and checked per machine [msgs/s] |\n";
  md += "|---|---|---|---|---|---|\n";
  for (const SizeRun& r : runs) {
    const double m = r.machines;
    const double states_s = static_cast<double>(r.states_sent) / r.sim_s;
    const double plans_s = static_cast<double>(r.plans_sent) / r.sim_s;
    const double state_kb_s = states_s * static_cast<double>(state_udp) * 1e-3;
    const double plan_kb_s = plans_s * static_cast<double>(plan_udp) * 1e-3;
    md += fmt("| %d | %.2f, %.2f | %.2f, %.2f, %.2f | %.1f, %.1f | %.1f, %.1f, %.1f | %.1f |\n", r.machines, states_s / m, plans_s / m,
              state_kb_s / m, plan_kb_s / m, (state_kb_s + plan_kb_s) / m, states_s, plans_s, state_kb_s, plan_kb_s,
              state_kb_s + plan_kb_s, static_cast<double>(r.messages_delivered) / r.sim_s / m);
  }
  md += "\nPlan changes: a new plan id published, and each other member's prediction of that machine taking it up (its "
        "decision's prediction `Plan` with that id), in the receiver's cycles after the cycle it was delivered in (0: taken "
        "up by the step of that cycle).\n\n";
  md += "| Machines | New plans | Taken up (receiver, plan) | After the plan's delivery median / max [cycles] | After the first "
        "state naming it median / max [cycles] | From publication median / max [ms] | Lifts done | Least true clearance "
        "between machines [m] (pair) | Samples in contact | Site stops / re-plans | Wall [s] |\n";
  md += "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SizeRun& r : runs) {
    const auto med_max = [](const std::vector<double>& v) {
      return v.empty() ? std::string("-") : fmt("%.0f / %.0f", percentile(v, 0.5), percentile(v, 1.0));
    };
    md += fmt("| %d | %d | %llu | %s | %s | %s | %d of %d | %s | %llu | %d / %d | %.1f |\n", r.machines, r.plans_new,
              static_cast<unsigned long long>(r.uses), med_max(r.after_plan_cycles).c_str(), med_max(r.after_state_cycles).c_str(),
              med_max(r.from_publish_ms).c_str(), r.lifts_done, r.machines,
              r.machines > 1 ? fmt("%.2f (%s)", r.least_m, r.least_pair.c_str()).c_str() : "-",
              static_cast<unsigned long long>(r.contact_samples), r.site_stops, r.site_replans, r.wall_s);
  }
  md += fmt("\nWhole suite: %.1f s; load average (1, 5, 15 min) before %s, after %s.\n",
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), load_before.c_str(), load_average().c_str());
  std::printf("%s", md.c_str());

  if (!options.out_dir.empty()) {
    std::ofstream mdf(options.out_dir + "/site-scale.md");
    mdf << md;
    std::ofstream csv(options.out_dir + "/site-scale.csv");
    csv << "machines,tower_cranes,sim_s,step_p50_us,step_p95_us,step_p99_us,mobile_p50_us,mobile_p95_us,mobile_p99_us,rules_p99_us,"
           "check_p50_us,check_p99_us,states_sent,plans_sent,messages_delivered,plans_new,uses,after_plan_median,after_plan_max,"
           "lifts_done,least_m,contact_samples,site_stops,site_replans,wall_s,file\n";
    std::string json = "{\"suite\": \"site-scale\", \"command\": \"" + options.command + "\", \"runs\": [";
    for (std::size_t i = 0; i < runs.size(); ++i) {
      const SizeRun& r = runs[i];
      const Triple all = triple(r.step_us), mob = triple(r.step_mobile_us), rules = triple(r.rules_us), verify = triple(r.verify_us);
      const double after_med = r.after_plan_cycles.empty() ? std::nan("") : percentile(r.after_plan_cycles, 0.5);
      const double after_max = r.after_plan_cycles.empty() ? std::nan("") : percentile(r.after_plan_cycles, 1.0);
      csv << fmt("%d,%d,%.2f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.2f,%.2f,%.2f,%llu,%llu,%llu,%d,%llu,%.0f,%.0f,%d,%.3f,%llu,%d,%d,%.1f,%s\n",
                 r.machines, r.tower_cranes, r.sim_s, all.p50, all.p95, all.p99, mob.p50, mob.p95, mob.p99, rules.p99, verify.p50,
                 verify.p99, static_cast<unsigned long long>(r.states_sent), static_cast<unsigned long long>(r.plans_sent),
                 static_cast<unsigned long long>(r.messages_delivered), r.plans_new, static_cast<unsigned long long>(r.uses), after_med,
                 after_max, r.lifts_done, r.least_m, static_cast<unsigned long long>(r.contact_samples), r.site_stops, r.site_replans,
                 r.wall_s, r.file.c_str());
      json += fmt("%s{\"machines\": %d, \"step_p99_us\": %.1f, \"mobile_p99_us\": %.1f, \"lifts_done\": %d, \"contact_samples\": %llu}",
                  i == 0 ? "" : ", ", r.machines, all.p99, mob.p99, r.lifts_done, static_cast<unsigned long long>(r.contact_samples));
    }
    json += "]}\n";
    std::ofstream jf(options.out_dir + "/site-scale.json");
    jf << json;
    if (!mdf || !csv || !jf) throw std::runtime_error("cannot write the site-scale suite's files under " + options.out_dir);
  }
  return 0;
}

}  // namespace mgc::bench
