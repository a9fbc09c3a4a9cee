// SPDX-License-Identifier: Apache-2.0
// mgc-replay: reads a black box recording (mgc --black-box), feeds its frames, operator commands
// and (a site member's) site messages to a fresh Hal and Controller in stepped time and compares
// every cycle's decisions with the recorded ones (docs/black-box.md). Exit 0: identical; 1: a
// decision differs, the recording lacks a cycle's inputs, or the ring no longer holds the run's
// start; 2: not a recording, a corrupt record, or the scenario or site does not match.
#include <CLI/CLI.hpp>

#include <cinttypes>
#include <cstdio>
#include <memory>
#include <string>

#include "mgc/firmware/black_box.hpp"
#include "mgc/guidance/supervisor.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/io/site_loader.hpp"

int main(int argc, char** argv) {
  using namespace mgc;
  namespace bb = firmware::black_box;
  CLI::App app{"mgc-replay: replay a black box recording against a fresh controller (docs/black-box.md)"};
  std::string file;
  std::string scenario_file;
  app.add_option("FILE", file, "the recording (mgc --black-box FILE)")->required();
  auto* scenario_opt = app.add_option("--scenario", scenario_file, "the scenario file (default: the path recorded in the header)");
  std::string site_file;
  app.add_option("--site", site_file, "a site member's recording: the site file (default: the path recorded in the header)")
      ->excludes(scenario_opt);
  bool summary_only = false;
  app.add_flag("--summary", summary_only, "print what the recording holds and stop (no scenario needed, no replay)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-replay: %s (see --help)\n", e.what());
    return 2;
  }

  bb::Recording rec;
  try {
    rec = bb::read_recording(file);
  } catch (const bb::BadRecording& e) {
    std::fprintf(stderr, "mgc-replay: %s\n", e.what());
    return 2;
  }
  const bb::Identity& id = rec.identity;
  std::uint64_t cycles = 0, frames = 0, commands = 0, tx_failures = 0, site_states = 0, site_plans = 0, dropped = 0;
  std::int64_t first_us = -1, last_us = -1;
  for (const bb::Entry& e : rec.entries) {
    if (e.type == bb::RecordType::Cycle) {
      ++cycles;
      if (first_us < 0) first_us = e.cycle.read_us;
      last_us = e.cycle.read_us;
    }
    frames += e.type == bb::RecordType::Frame ? 1u : 0u;
    commands += e.type == bb::RecordType::Command ? 1u : 0u;
    tx_failures += e.type == bb::RecordType::TxFailure ? 1u : 0u;
    if (e.type == bb::RecordType::Site) ++(e.site.kind == bb::SiteKind::Plan ? site_plans : site_states);
    if (e.type == bb::RecordType::Cycle) dropped = e.cycle.records_dropped;
  }
  std::printf("mgc-replay: %s: format %u, %s on %s, period %" PRId64 " us, re-planner %s; %zu of %zu blocks used%s\n", file.c_str(),
              id.format_version, id.machine_name.c_str(), id.scenario_name.c_str(), id.period_us, id.replanner.c_str(), rec.blocks_used,
              rec.num_blocks, rec.wrapped ? " (wrapped)" : "");
  if (id.site_machine_id != 0) {
    std::printf("mgc-replay: site member: machine %d of %s, %" PRIu64 " site states and %" PRIu64 " site plans taken by the loop\n",
                id.site_machine_id, id.scenario_file.c_str(), site_states, site_plans);
  }
  if (dropped > 0) std::printf("mgc-replay: the recorder dropped %" PRIu64 " records (its queue was full): the recording is incomplete\n", dropped);
  std::printf("mgc-replay: %" PRIu64 " cycles over %.2f s, %" PRIu64 " frames, %" PRIu64 " operator commands, %" PRIu64
              " refused sends; recorded cycle times %" PRId64 " .. %" PRId64 " us\n",
              cycles, first_us >= 0 ? static_cast<double>(last_us - first_us) * 1e-6 : 0.0, frames, commands, tx_failures, first_us,
              last_us);
  if (rec.ended) {
    std::printf("mgc-replay: the recording ends cleanly (the recorder was closed)\n");
  } else {
    std::printf("mgc-replay: the recording ends without its end record: the recorder still runs, or was killed or lost power and "
                "what it had not yet written (under a second) is lost%s\n",
                rec.torn_tail_bytes > 0 ? "; a torn tail was dropped" : "");
  }
  if (rec.torn_tail_bytes > 0) std::printf("mgc-replay: truncated tail: %zu bytes not a whole record, dropped\n", rec.torn_tail_bytes);

  // The transitions as recorded, readable without a replay (a wrapped ring's too): printed with
  // the summary, and where the recording cannot be replayed.
  const auto print_recorded_transitions = [&] {
    for (const bb::RecordedTransition& t : bb::recorded_transitions(rec)) {
      std::printf("mgc-replay: recorded %8.2f s  %-10s -> %-10s %s (cycle %" PRIu64 ")\n", static_cast<double>(t.t_us - first_us) * 1e-6,
                  t.from_known ? guidance::to_string(t.from) : "?", guidance::to_string(t.to), guidance::to_string(t.reason), t.cycle);
    }
  };
  if (summary_only) {
    print_recorded_transitions();
    return 0;
  }

  const bool member = id.site_machine_id != 0;
  if (member && !scenario_file.empty()) {
    std::fprintf(stderr, "mgc-replay: %s: a site member's recording (machine %d): expected --site, not --scenario\n", file.c_str(),
                 id.site_machine_id);
    return 2;
  }
  if (!member && !site_file.empty()) {
    std::fprintf(stderr, "mgc-replay: %s: one machine's recording, not a site member's: expected --scenario, not --site\n", file.c_str());
    return 2;
  }
  if (scenario_file.empty()) scenario_file = member ? (site_file.empty() ? id.scenario_file : site_file) : id.scenario_file;
  planning::Scenario scenario;
  std::unique_ptr<firmware::SiteMemberConfig> site;
  try {
    if (member) {
      // As mgc --site builds its controller: the machine's first lift, the default site rules.
      site = std::make_unique<firmware::SiteMemberConfig>();
      site->site = planning::io::load_site(scenario_file);
      site->machine_id = id.site_machine_id;
      scenario = planning::lift_scenario(site->site, planning::io::site_machine_index(site->site, id.site_machine_id), 0);
    } else {
      scenario = planning::io::load_scenario(scenario_file);
    }
    bb::Identity now = bb::identity_for(scenario, id.replanner, id.period_us, id.valve_deadband);
    if (member) bb::set_site_member(now, site->site, id.site_machine_id);
    if (now.scenario_hash != id.scenario_hash || now.machine_hash != id.machine_hash) {
      std::fprintf(stderr,
                   "mgc-replay: %s: %s %s (hash %016" PRIx64 ", machine %016" PRIx64 "), expected the recorded %016" PRIx64
                   " and %016" PRIx64 ": the files changed since the recording\n",
                   file.c_str(), member ? "site" : "scenario", scenario_file.c_str(), now.scenario_hash, now.machine_hash,
                   id.scenario_hash, id.machine_hash);
      return 2;
    }
    if (now.site_machines_hash != id.site_machines_hash) {
      std::fprintf(stderr,
                   "mgc-replay: %s: site %s: its machine files hash %016" PRIx64 ", expected the recorded %016" PRIx64
                   ": a machine file changed since the recording\n",
                   file.c_str(), scenario_file.c_str(), now.site_machines_hash, id.site_machines_hash);
      return 2;
    }
  } catch (const planning::io::InputError& e) {
    std::fprintf(stderr, "mgc-replay: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-replay: %s: %s\n", scenario_file.c_str(), e.what());
    return 2;
  }

  bb::ReplayResult r;
  try {
    r = bb::replay(rec, scenario, site.get());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-replay: %s: %s\n", file.c_str(), e.what());
    return 2;
  }
  if (!r.replayable) {
    print_recorded_transitions();
    std::printf("mgc-replay: cannot replay: %s\n", r.why_not.c_str());
    return 1;
  }
  // What the run did and why, as mgc printed it: the replayed supervisor's transitions, up to
  // where the replay stopped.
  for (const guidance::TransitionRecord& t : r.transition_log) {
    std::printf("mgc-replay: %8.2f s  %-10s -> %-10s %s%s%s\n", static_cast<double>(t.t_us - r.first_cycle_read_us) * 1e-6,
                guidance::to_string(t.from), guidance::to_string(t.to), guidance::to_string(t.reason),
                t.detail[0] != '\0' ? ": " : "", t.detail.data());
  }
  if (r.incomplete) {
    std::printf("mgc-replay: incomplete at cycle %" PRIu64 " (t %" PRId64 " us, after %" PRIu64 " identical cycles): %s; not replayed further\n",
                r.incomplete_cycle, r.first_read_us, r.cycles, r.why_incomplete.c_str());
    return 1;
  }
  if (r.identical) {
    char site_text[64] = "";
    if (member) std::snprintf(site_text, sizeof site_text, ", %" PRIu64 " site messages", r.site_messages);
    std::printf("mgc-replay: identical for %" PRIu64 " cycles (%" PRIu64 " frames%s, %" PRIu64 " supervisor transitions)\n", r.cycles,
                r.frames, site_text, r.transitions);
    return 0;
  }
  std::printf("mgc-replay: differs at cycle %" PRIu64 " (t %" PRId64 " us, after %" PRIu64 " identical cycles): %s recorded %s, replayed %s\n",
              r.first_cycle, r.first_read_us, r.cycles, r.field.c_str(), r.recorded.c_str(), r.replayed.c_str());
  return 1;
}
