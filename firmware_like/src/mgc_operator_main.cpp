// SPDX-License-Identifier: Apache-2.0
// mgc-operator: an operator station on the LCM feed (docs/operator-feed.md). Sends signed goal and
// acknowledge commands and unsigned stops, and prints the guidance and alerts as they change.
#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <string>

#include <mgc/alert_t.hpp>
#include <mgc/command_status_t.hpp>
#include <mgc/machine_state_t.hpp>
#include <mgc/operator_command_t.hpp>
#include <mgc/operator_instruction_t.hpp>

#include "mgc/firmware/command_auth.hpp"
#include "mgc/firmware/lcm_feed.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/planning/io/site_loader.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

const char* severity_name(std::int8_t s) {
  static const char* names[] = {"unknown", "info", "warn", "slow-down", "stop", "fault"};
  return s >= 0 && s <= 5 ? names[s] : "unknown";
}
const char* source_name(std::int8_t s) {
  static const char* names[] = {"unknown", "collision", "envelope", "load chart", "sensing", "watchdog", "planner", "operator"};
  return s >= 0 && s <= 7 ? names[s] : "unknown";
}
//! The unit after a value (alert_t.UNIT_*); nothing for none or unknown.
const char* unit_suffix(std::int8_t u) {
  static const char* names[] = {"", "", " m", " rad", " %", " s", " m/s", " rad/s"};
  return u >= 0 && u <= 7 ? names[u] : "";
}
const char* state_name(std::int8_t s) {
  static const char* names[] = {"UNKNOWN", "INIT", "HOLD", "PLANNING", "EXECUTING", "STOPPING", "REPLANNING", "FAULT", "ESTOP"};
  return s >= 0 && s <= 8 ? names[s] : "UNKNOWN";
}

std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

//! Prints what changes on the feed.
class Watcher {
 public:
  explicit Watcher(std::int64_t start_us) : start_us_(start_us) {}

  void on_state(const lcm::ReceiveBuffer*, const std::string&, const mgc::machine_state_t* m) {
    if (m->supervisor_state != state_) {
      print_time();
      std::printf("state %s\n", state_name(m->supervisor_state));
      if (state_ == mgc::machine_state_t::SUPERVISOR_EXECUTING && m->supervisor_state == mgc::machine_state_t::SUPERVISOR_HOLD) {
        ++lifts_ended_;
      }
      state_ = m->supervisor_state;
    }
    last_state_us_ = now();
  }
  void on_instruction(const lcm::ReceiveBuffer*, const std::string&, const mgc::operator_instruction_t* i) {
    // The amounts shrink every cycle of a move: say the words again when the moves themselves
    // change, and otherwise every 10 s.
    std::string moves;
    for (char c : i->text) {
      if ((c < '0' || c > '9') && c != '.') moves += c;
    }
    const bool due = now() - last_text_us_ >= 10'000'000;
    if (!i->text.empty() && i->text != text_ && (moves != moves_ || due)) {
      last_text_us_ = now();
      moves_ = moves;
      print_time();
      std::printf("guidance: %s (nearest obstacle %.1f m", i->text.c_str(), i->obstacle_clearance);
      if (std::isfinite(i->envelope_distance)) std::printf(", envelope %.1f m", i->envelope_distance);
      if (std::isfinite(i->load_moment_pct)) std::printf(", load moment %.0f %%", i->load_moment_pct);
      std::printf(")\n");
    }
    text_ = i->text;
  }
  void on_alert(const lcm::ReceiveBuffer*, const std::string&, const mgc::alert_t* a) {
    // Active alerts repeat at 1 Hz: say each raise and each clear once.
    if (a->active == (announced_.count(a->alert_id) > 0)) return;
    if (a->active) {
      announced_.insert(a->alert_id);
    } else {
      announced_.erase(a->alert_id);
    }
    print_time();
    std::printf("alert %d %s: %s %s", a->alert_id, a->active ? "raised" : "cleared", severity_name(a->severity),
                source_name(a->source));
    if (a->active && a->source == mgc::alert_t::SOURCE_OPERATOR && a->alert_id >= mgc::firmware::kCommandAlertIdBase) {
      // One alert per second at most for refused commands; mgc counts them all (MGC_HEALTH).
      std::printf(", a command from sender %d refused: %s", a->index,
                  mgc::firmware::command_reason_name(static_cast<std::int8_t>(a->value)));
    } else if (a->active && a->source == mgc::alert_t::SOURCE_COLLISION && a->value_unit == mgc::alert_t::UNIT_SECOND) {
      std::printf(", obstacle %d predicted within the stop margin in %.1f s", a->index, a->value);
    } else if (a->active && std::isfinite(a->value)) {
      std::printf(", value %.2f%s (limit %.2f%s)", a->value, unit_suffix(a->value_unit), a->limit, unit_suffix(a->value_unit));
    }
    std::printf("\n");
  }
  void on_status(const lcm::ReceiveBuffer*, const std::string&, const mgc::command_status_t* s) {
    print_time();
    std::printf("command %lld from %d %s (%s)\n", static_cast<long long>(s->sequence), s->sender_id,
                s->accepted ? "accepted" : "REFUSED", mgc::firmware::command_reason_name(s->reason));
  }

  [[nodiscard]] int lifts_ended() const { return lifts_ended_; }
  [[nodiscard]] std::int8_t state() const { return state_; }
  [[nodiscard]] std::int64_t last_state_us() const { return last_state_us_; }
  [[nodiscard]] std::int64_t now() const {
    return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }

 private:
  void print_time() const { std::printf("mgc-operator: %7.2f s  ", static_cast<double>(now() - start_us_) * 1e-6); }

  std::int64_t start_us_;
  std::int8_t state_ = 0;
  std::int64_t last_state_us_ = 0;
  std::string text_;
  std::string moves_;
  std::int64_t last_text_us_ = 0;
  int lifts_ended_ = 0;
  std::set<std::int32_t> announced_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-operator: send operator commands to mgc over LCM and watch its guidance (docs/operator-feed.md)"};
  std::string lcm_url = mgc::firmware::kDefaultLcmUrl;
  std::string key_file;
  std::string scenario_file;
  std::string site_file;
  int machine_id = 0;
  bool goal = false;
  bool stop = false;
  bool acknowledge = false;
  double watch_s = 0.0;
  bool until_done = false;
  int sender_id = 1;
  app.add_option("--lcm-url", lcm_url, "LCM provider")->capture_default_str();
  app.add_option("--key", key_file, "shared command key (32 raw bytes), needed for --goal and --ack");
  auto* scenario_opt = app.add_option("--scenario", scenario_file, "scenario whose goal --goal requests");
  app.add_option("--site", site_file, "instead of --scenario: site file whose machine's first lift's goal --goal requests")
      ->excludes(scenario_opt);
  app.add_option("--machine-id", machine_id, "with --site: the machine's id in the site file");
  app.add_flag("--goal", goal, "request the scenario's goal (signed)");
  app.add_flag("--stop", stop, "stop (unsigned: obeyed from anyone)");
  app.add_flag("--ack", acknowledge, "acknowledge every alert waiting for it (signed)");
  app.add_option("--watch", watch_s, "print the guidance and alerts for this many seconds")->check(mgc::tools::nonnegative_number());
  app.add_flag("--until-done", until_done, "with --watch: end when a lift ends (EXECUTING to HOLD) or in FAULT or ESTOP");
  app.add_option("--sender-id", sender_id, "this station's id")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-operator: %s (see --help)\n", e.what());
    return 2;
  }
  if ((goal || acknowledge) && key_file.empty()) {
    std::fprintf(stderr, "mgc-operator: --goal and --ack are signed: expected --key FILE\n");
    return 2;
  }
  if (goal && scenario_file.empty() && site_file.empty()) {
    std::fprintf(stderr, "mgc-operator: --goal: expected --scenario FILE (or --site FILE --machine-id N) for the goal\n");
    return 2;
  }
  if (site_file.empty() != (app.count("--machine-id") == 0)) {
    std::fprintf(stderr, "mgc-operator: --machine-id goes with --site, and --site needs it (see --help)\n");
    return 2;
  }

  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "mgc-operator: --lcm-url: cannot open '%s'\n", lcm_url.c_str());
    return 2;
  }
  Watcher watcher(std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
  lcm.subscribe(mgc::firmware::channel::kMachineState, &Watcher::on_state, &watcher);
  lcm.subscribe(mgc::firmware::channel::kOperatorInstruction, &Watcher::on_instruction, &watcher);
  lcm.subscribe(mgc::firmware::channel::kAlert, &Watcher::on_alert, &watcher);
  lcm.subscribe(mgc::firmware::channel::kCommandStatus, &Watcher::on_status, &watcher);

  try {
    std::optional<mgc::firmware::CommandKey> key;
    std::int64_t last_sequence = 0;
    if (!key_file.empty()) key.emplace(mgc::firmware::load_command_key(key_file));
    const auto send = [&](std::int8_t kind, const mgc::planning::Scenario* s) {
      mgc::operator_command_t cmd{};
      cmd.utime = watcher.now();
      cmd.kind = kind;
      cmd.sender_id = sender_id;
      // The wall clock in µs, which mgc checks against its own within the tolerated skew; bumped
      // when the clock has not moved, so that it never repeats (docs/operator-feed.md).
      cmd.sequence = std::max(wall_us(), last_sequence + 1);
      last_sequence = cmd.sequence;
      if (s) {
        cmd.num_joints = static_cast<std::int8_t>(s->goal.size());
        for (int j = 0; j < s->goal.size(); ++j) cmd.goal_position[j] = s->goal[j];
      }
      if (key) mgc::firmware::sign_command(cmd, *key);
      lcm.publish(mgc::firmware::channel::kCommand, &cmd);
    };
    if (stop) send(mgc::operator_command_t::KIND_STOP, nullptr);
    if (acknowledge) send(mgc::operator_command_t::KIND_ACKNOWLEDGE, nullptr);
    if (goal) {
      mgc::planning::Scenario s;
      if (site_file.empty()) {
        s = mgc::planning::io::load_scenario(scenario_file);
      } else {
        // The lift mgc --site runs: the machine's first.
        const mgc::planning::Site site = mgc::planning::io::load_site(site_file);
        s = mgc::planning::lift_scenario(site, mgc::planning::io::site_machine_index(site, machine_id), 0);
      }
      // The controller takes a goal only in HOLD: wait for it (up to 10 s) before sending.
      const std::int64_t give_up = watcher.now() + 10'000'000;
      while (watcher.state() != mgc::machine_state_t::SUPERVISOR_HOLD && watcher.now() < give_up) lcm.handleTimeout(100);
      if (watcher.state() != mgc::machine_state_t::SUPERVISOR_HOLD) {
        std::fprintf(stderr, "mgc-operator: no controller in HOLD on %s within 10 s\n", lcm_url.c_str());
        return 1;
      }
      send(mgc::operator_command_t::KIND_GOAL, &s);
    }
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const mgc::firmware::CommandKeyError& e) {
    std::fprintf(stderr, "mgc-operator: --key: %s\n", e.what());
    return 2;
  }

  const std::int64_t end = watcher.now() + static_cast<std::int64_t>(watch_s * 1e6);
  while (watcher.now() < end) {
    lcm.handleTimeout(100);
    if (until_done && (watcher.lifts_ended() > 0 || watcher.state() == mgc::machine_state_t::SUPERVISOR_FAULT ||
                       watcher.state() == mgc::machine_state_t::SUPERVISOR_ESTOP)) {
      break;
    }
  }
  std::fflush(stdout);
  return 0;
}
