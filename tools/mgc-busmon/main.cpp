// SPDX-License-Identifier: Apache-2.0
// mgc-busmon: the controller's view of a machine's bus, without the controller. Runs the Hal's
// cycle (SYNC, heartbeat, zero valve commands) against a real or simulated machine and prints the
// snapshot: joints, tags, valve and per-device health. For bring-up and for tests of mgc-sim.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/sim/simulator.hpp"
#include "mgc/tools/cli_checks.hpp"

namespace {

void print(const mgc::hal::SensorSnapshot& s, const mgc::planning::Scenario& scenario, double t_s) {
  std::printf("t=%.2f s bus=%s frames=%u malformed=%" PRIu64 " unknown=%" PRIu64 "\n", t_s, to_string(s.bus_state),
              s.frames, s.codec.malformed(), s.codec.unknown_id);
  for (std::size_t j = 0; j < s.num_joints; ++j) {
    const auto& spec = scenario.machine.joints[j];
    const bool revolute = spec.type == mgc::planning::JointType::Revolute;
    const double value = s.joints[j].position * (revolute ? 180.0 / std::numbers::pi : 1.0);
    std::printf("  joint %-16s %12.4f %-3s %-8s node %s\n", spec.name.c_str(), value, revolute ? "deg" : "m",
                to_string(s.joints[j].health), to_string(s.encoders[j].health));
  }
  std::printf("  valve %s state %d reason %d; uwb gateway %s\n", to_string(s.valve.health),
              static_cast<int>(s.valve_status.state), static_cast<int>(s.valve_status.reason),
              to_string(s.uwb_gateway.health));
  for (std::size_t i = 0; i < s.num_tags; ++i) {
    const auto& t = s.tags[i];
    std::printf("  tag %3u %8.2f %8.2f %8.2f m %s fixes %u missed %u\n", t.tag_id, t.position_m[0], t.position_m[1],
                t.position_m[2], t.valid ? "valid" : "invalid", t.fixes, t.missed);
  }
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mgc-busmon: read a machine's bus through the Hal and print what the controller would see"};
  std::string scenario_file;
  std::string bus_url = "udp:127.0.0.1:47011,peer=127.0.0.1:47010";
  double duration_s = 5.0;
  double print_every_s = 1.0;
  bool start = false;
  bool require_valid = false;
  app.add_option("--scenario", scenario_file, "scenario whose machine is on the bus")->required();
  app.add_option("--bus", bus_url, "CAN bus URL (docs/protocol.md)")->capture_default_str();
  app.add_option("--duration", duration_s, "run this long [s]")->capture_default_str()->check(mgc::tools::positive_number());
  app.add_option("--print-every", print_every_s, "print the snapshot this often [s]")->capture_default_str()->check(mgc::tools::positive_number());
  app.add_flag("--start", start, "send NMT Start to all nodes once every device has been heard");
  app.add_flag("--require-valid", require_valid, "exit 1 unless every joint is valid at the end");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "mgc-busmon: %s (see --help)\n", e.what());
    return 2;
  }
  mgc::planning::Scenario scenario;
  mgc::hal::BusPlan plan;
  try {
    scenario = mgc::planning::io::load_scenario(scenario_file);
    plan = mgc::sim::bus_plan_for(scenario);
  } catch (const mgc::planning::io::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "mgc-busmon: %s\n", e.what());
    return 2;
  }
  const mgc::hal::SteadyClock& clock = mgc::hal::SteadyClock::instance();
  auto opened = mgc::hal::open_can_bus(bus_url, &clock);
  if (!opened) {
    std::fprintf(stderr, "mgc-busmon: --bus: %s\n", opened.error.c_str());
    return 2;
  }
  std::vector<double> vmax;
  for (const auto& j : scenario.machine.joints) vmax.push_back(j.max_velocity);
  mgc::hal::Hal hal(*opened.bus, plan, vmax);
  const std::vector<double> zero(vmax.size(), 0.0);

  const std::int64_t t0 = clock.now_us();
  const auto period_us = plan.timing.sync_period_us;
  std::int64_t next = t0;
  std::int64_t next_print = t0 + static_cast<std::int64_t>(print_every_s * 1e6);
  bool started = false;
  bool printed_last = false;
  const mgc::hal::SensorSnapshot* s = nullptr;
  while (clock.now_us() - t0 < static_cast<std::int64_t>(duration_s * 1e6)) {
    std::this_thread::sleep_for(std::chrono::microseconds(std::max<std::int64_t>(0, next - clock.now_us())));
    const std::int64_t now = clock.now_us();
    s = &hal.read(now);
    (void)hal.write(zero, now);
    if (start && !started) {
      bool all_heard = s->valve.heard && s->uwb_gateway.heard;
      for (std::size_t j = 0; j < s->num_joints; ++j) all_heard = all_heard && s->encoders[j].heard;
      if (all_heard) started = hal.send_nmt(mgc::hal::canopen::NmtCommand::Start, 0) == mgc::hal::Status::Ok;
    }
    printed_last = now >= next_print;
    if (printed_last) {
      print(*s, scenario, static_cast<double>(now - t0) / 1e6);
      next_print += static_cast<std::int64_t>(print_every_s * 1e6);
    }
    next += period_us;
  }
  if (s != nullptr && !printed_last) print(*s, scenario, static_cast<double>(clock.now_us() - t0) / 1e6);
  if (require_valid && (s == nullptr || !s->all_joints_valid())) {
    std::fprintf(stderr, "mgc-busmon: not every joint is valid at the end\n");
    return 1;
  }
  return 0;
}
