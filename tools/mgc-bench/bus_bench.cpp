// SPDX-License-Identifier: Apache-2.0
// The `bus` suite of mgc-bench: how many frames per second the loop: and udp: transports carry
// into the Hal's decoder without loss, what one Hal::read costs at a full-bus load, and how long a
// frame the simulator sends takes to reach the controller's decoded snapshot. All times are on the
// steady clock of this machine; compare figures within one run, not across runs.

#include "bus_bench.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "timing_report.hpp"
#include "mgc/hal/bus_plan.hpp"
#include "mgc/hal/can_bus.hpp"
#include "mgc/hal/canopen.hpp"
#include "mgc/hal/clock.hpp"
#include "mgc/hal/device_pdos.hpp"
#include "mgc/hal/hal.hpp"
#include "mgc/hal/udp_can_bus.hpp"
#include "mgc/planning/io/scenario_loader.hpp"
#include "mgc/sim/simulator.hpp"

namespace mgc::bench {

namespace {

using hal::CanFrame;
using hal::Status;

//! A 500 kbit/s bus full of 8-byte standard frames at worst-case stuffing (138 bits with the
//! interframe space): about 3,600 frames/s; the issue rounds it to 4,000 (DOMAIN-FACTS §1.6).
constexpr double kFullBusFramesPerS = 4000.0;
constexpr std::int64_t kControlCycleUs = 10'000;               //!< the controller's SYNC period
constexpr std::size_t kFramesPerCycle = 40;                    //!< a full bus during one control cycle
constexpr std::size_t kBurstFrames = 4 * kFramesPerCycle;      //!< a 30 ms stall caught up in one read
constexpr int kBurstEvery = 10;                                //!< one burst cycle in ten
constexpr std::size_t kTrafficCycles = hal::pdo::kUwbSequenceModulo;  //!< table length: UWB sequences wrap
constexpr std::size_t kUwbTagsPerCycle = 30;
constexpr const char* kLatencyScenario = "thesis-steel-frame.yaml";  //!< mobile crane, 4 joints, 3 UWB tags

enum class Transport { Loop, Udp };

const char* to_string(Transport t) { return t == Transport::Loop ? "loop" : "udp"; }

std::int64_t now_ns() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

//! The bus clock's time (the steady clock in µs), as Hal::read and Simulator::step take it.
std::int64_t bus_now_us() noexcept { return hal::SteadyClock::instance().now_us(); }

void sleep_until_ns(std::int64_t t_ns) {
  std::this_thread::sleep_until(std::chrono::steady_clock::time_point(std::chrono::nanoseconds(t_ns)));
}

//! Raw values for bus.csv: one row per sample or step.
class Csv {
 public:
  void add(const char* measurement, const std::string& transport, const std::string& mode, std::size_t index,
           double value, const char* unit) {
    char row[256];
    std::snprintf(row, sizeof row, "%s,%s,%s,%zu,%.3f,%s\n", measurement, transport.c_str(), mode.c_str(), index, value,
                  unit);
    text_ += row;
  }
  [[nodiscard]] const std::string& text() const { return text_; }

 private:
  std::string text_ = "measurement,transport,mode,index,value,unit\n";
};

//! The controller's endpoint and the devices' endpoint of one bus, opened fresh for each case so
//! that queues and counters start empty.
struct BusPair {
  std::unique_ptr<hal::CanBus> controller;
  std::unique_ptr<hal::CanBus> device;
};

BusPair open_pair(Transport transport) {
  static int serial = 0;
  BusPair pair;
  if (transport == Transport::Loop) {
    const std::string url = "loop:bench-" + std::to_string(serial++);
    auto a = hal::open_can_bus(url);
    auto b = hal::open_can_bus(url);
    if (!a || !b) throw std::runtime_error("cannot open " + url + ": " + a.error + b.error);
    pair.controller = std::move(a.bus);
    pair.device = std::move(b.bus);
    return pair;
  }
  // Two endpoints on 127.0.0.1 with OS-chosen ports, each the other's only peer.
  auto a = hal::open_can_bus("udp:127.0.0.1:0");
  auto b = hal::open_can_bus("udp:127.0.0.1:0");
  if (!a || !b) throw std::runtime_error("cannot open udp:127.0.0.1:0: " + a.error + b.error);
  auto& ua = dynamic_cast<hal::UdpCanBus&>(*a.bus);
  auto& ub = dynamic_cast<hal::UdpCanBus&>(*b.bus);
  if (ua.add_peer("127.0.0.1:" + std::to_string(ub.local_port())) != Status::Ok ||
      ub.add_peer("127.0.0.1:" + std::to_string(ua.local_port())) != Status::Ok) {
    throw std::runtime_error("cannot pair the udp endpoints");
  }
  pair.controller = std::move(a.bus);
  pair.device = std::move(b.bus);
  return pair;
}

//! Device traffic of a full bus, 40 frames per control cycle, every one a frame the Hal decodes:
//! the four encoder PDOs, valve status and applied, 30 UWB tag fixes and four heartbeats. UWB
//! sequence numbers advance by one per cycle so the Hal sees no missed fixes.
class FullBusTraffic {
 public:
  explicit FullBusTraffic(const hal::BusPlan& plan) {
    frames_.reserve(kTrafficCycles * kFramesPerCycle);
    for (std::size_t c = 0; c < kTrafficCycles; ++c) {
      const auto cycle = static_cast<std::uint8_t>(c);
      for (std::size_t j = 0; j < plan.num_joints; ++j) {
        add(hal::pdo::encode_encoder_position({plan.encoders[j].node_id, 1000 * cycle + static_cast<std::int32_t>(j), 0}));
      }
      add(hal::pdo::encode_valve_status(
          {plan.valve_node_id, hal::pdo::ValveState::Active, hal::pdo::ValveReason::None, 0, cycle}));
      add(hal::pdo::encode_valve_applied({plan.valve_node_id, 0, {cycle, 0, 0, 0}}));
      for (std::size_t t = 0; t < kUwbTagsPerCycle; ++t) {
        const auto x_cm = static_cast<std::int16_t>(100 * t + c);
        add(hal::pdo::encode_uwb_tag_position(
            {plan.uwb_gateway_node_id, static_cast<std::uint8_t>(t), {x_cm, 200, 300}, cycle, 2}));
      }
      for (std::size_t j = 0; j < plan.num_joints; ++j) {
        add(hal::canopen::encode_heartbeat({plan.encoders[j].node_id, hal::canopen::NmtState::Operational}));
      }
      if (frames_.size() != (c + 1) * kFramesPerCycle) throw std::logic_error("full-bus traffic: not 40 frames a cycle");
    }
  }
  [[nodiscard]] const CanFrame& frame(std::uint64_t index) const { return frames_[index % frames_.size()]; }

 private:
  void add(const hal::Result<CanFrame>& encoded) {
    if (!encoded.ok()) throw std::logic_error("full-bus traffic: a frame does not encode");
    frames_.push_back(encoded.value);
  }
  std::vector<CanFrame> frames_;
};

const std::vector<double>& unit_velocities() {
  static const std::vector<double> v(4, 1.0);
  return v;
}

// --- Throughput -------------------------------------------------------------------------------

struct Throughput {
  Transport transport = Transport::Loop;
  const char* threads = "";
  double offered_hz = 0.0;   //!< 0: as fast as one thread can send and read
  double duration_s = 0.0;
  std::uint64_t sent = 0;
  std::uint64_t send_failed = 0;
  std::uint64_t decoded = 0;
  std::uint64_t rx_lost = 0;     //!< the transport's own loss count
  double sent_hz = 0.0;
  double decoded_hz = 0.0;
  [[nodiscard]] std::uint64_t lost() const { return sent > decoded ? sent - decoded : 0; }
  //! Every frame sent was decoded and every send succeeded.
  [[nodiscard]] bool clean() const { return send_failed == 0 && rx_lost == 0 && lost() == 0; }
  //! The device thread sent at least 95 % of the offered rate (else the sender, not the receiver, limits).
  [[nodiscard]] bool kept_up() const { return offered_hz == 0.0 || sent_hz >= 0.95 * offered_hz; }
};

//! Reads until nothing has arrived for quiet_us, so that frames still in flight are counted.
void drain(hal::Hal& hal, std::int64_t quiet_us) {
  std::int64_t last_us = bus_now_us();
  while (bus_now_us() - last_us < quiet_us) {
    if (hal.bus().wait_readable(quiet_us) == Status::Ok && hal.read(bus_now_us()).frames > 0) last_us = bus_now_us();
  }
}

//! One thread sends a cycle's 40 frames, then Hal::read drains and decodes them; repeated for
//! duration_s. The cost of sending, moving and decoding a frame, with no waiting anywhere.
Throughput same_thread_throughput(Transport transport, const FullBusTraffic& traffic, double duration_s) {
  BusPair bus = open_pair(transport);
  (void)bus.device->set_filters({});  // send-only: the device side keeps nothing queued
  hal::Hal hal(*bus.controller, hal::mobile_crane_bus_plan(), unit_velocities());
  hal.enable_sync(false);
  Throughput r{transport, "1 (send, then read)", 0.0, duration_s};
  const std::int64_t start_ns = now_ns();
  const std::int64_t end_ns = start_ns + static_cast<std::int64_t>(duration_s * 1e9);
  std::int64_t stop_ns = start_ns;
  while ((stop_ns = now_ns()) < end_ns) {
    for (std::size_t k = 0; k < kFramesPerCycle; ++k) {
      if (bus.device->send(traffic.frame(r.sent + r.send_failed)) == Status::Ok) ++r.sent; else ++r.send_failed;
    }
    (void)hal.read(bus_now_us());
  }
  drain(hal, 20'000);
  const double elapsed_s = static_cast<double>(stop_ns - start_ns) * 1e-9;
  r.decoded = hal.snapshot().codec.decoded;
  r.rx_lost = hal.snapshot().bus.rx_lost;
  r.sent_hz = static_cast<double>(r.sent) / elapsed_s;
  r.decoded_hz = static_cast<double>(r.decoded) / elapsed_s;
  return r;
}

//! A device thread sends offered_hz frames per second in 1 ms ticks; the controller thread blocks
//! in wait_readable and decodes with Hal::read, as the loop harness would.
Throughput paced_throughput(Transport transport, const FullBusTraffic& traffic, double offered_hz, double duration_s) {
  BusPair bus = open_pair(transport);
  (void)bus.device->set_filters({});
  hal::Hal hal(*bus.controller, hal::mobile_crane_bus_plan(), unit_velocities());
  hal.enable_sync(false);
  Throughput r{transport, "2 (device thread, Hal thread)", offered_hz, duration_s};

  constexpr std::int64_t kTickNs = 1'000'000;
  const auto per_tick = static_cast<std::uint64_t>(std::llround(offered_hz * 1e-3));
  std::atomic<bool> done{false};
  std::int64_t start_ns = 0, stop_ns = 0;
  std::thread device([&] {
    start_ns = now_ns();
    const std::int64_t end_ns = start_ns + static_cast<std::int64_t>(duration_s * 1e9);
    std::int64_t tick_ns = start_ns;
    while (tick_ns < end_ns) {
      sleep_until_ns(tick_ns);
      for (std::uint64_t k = 0; k < per_tick; ++k) {
        if (bus.device->send(traffic.frame(r.sent + r.send_failed)) == Status::Ok) ++r.sent; else ++r.send_failed;
      }
      tick_ns += kTickNs;
      // After a stall longer than a tick, the missed ticks are skipped, not sent as one burst:
      // a device's rate does not rise to make up for this machine's scheduling. The shortfall
      // shows as a sent rate below the offered one.
      if (now_ns() - tick_ns > kTickNs) tick_ns = now_ns();
    }
    stop_ns = now_ns();
    done.store(true, std::memory_order_release);
  });
  while (!done.load(std::memory_order_acquire)) {
    if (bus.controller->wait_readable(2'000) == Status::Ok) (void)hal.read(bus_now_us());
  }
  device.join();
  drain(hal, 20'000);
  const double elapsed_s = static_cast<double>(stop_ns - start_ns) * 1e-9;
  r.decoded = hal.snapshot().codec.decoded;
  r.rx_lost = hal.snapshot().bus.rx_lost;
  r.sent_hz = static_cast<double>(r.sent) / elapsed_s;
  r.decoded_hz = static_cast<double>(r.decoded) / elapsed_s;
  return r;
}

// --- Hal::read cost ---------------------------------------------------------------------------

struct ReadCost {
  Transport transport = Transport::Loop;
  std::size_t frames_per_read = 0;
  std::vector<double> read_us;
  std::uint64_t short_reads = 0;  //!< reads that decoded fewer frames than were queued
  std::uint64_t rx_lost = 0;
};

//! Queues one cycle's frames (every tenth cycle a four-cycle burst), then times Hal::read with
//! SYNC on: the SYNC send, draining, decoding and the health update.
std::vector<ReadCost> read_cost(Transport transport, const FullBusTraffic& traffic, int cycles) {
  BusPair bus = open_pair(transport);
  hal::Hal hal(*bus.controller, hal::mobile_crane_bus_plan(), unit_velocities());
  ReadCost normal{transport, kFramesPerCycle, {}};
  ReadCost burst{transport, kBurstFrames, {}};
  std::array<hal::TimedFrame, 64> device_rx{};
  std::uint64_t index = 0;
  constexpr int kWarmupCycles = 50;
  for (int c = -kWarmupCycles; c < cycles; ++c) {
    const bool is_burst = (c + kWarmupCycles) % kBurstEvery == kBurstEvery - 1;
    ReadCost& into = is_burst ? burst : normal;
    const std::size_t n = into.frames_per_read;
    for (std::size_t k = 0; k < n; ++k) (void)bus.device->send(traffic.frame(index++));
    const std::int64_t t0_ns = now_ns();
    const hal::SensorSnapshot& snap = hal.read(bus_now_us());
    const std::int64_t t1_ns = now_ns();
    // The SYNC this read sent is the device side's only traffic; dropped outside the timing.
    while (bus.device->receive(device_rx).count == device_rx.size()) {}
    if (c < 0) continue;
    into.read_us.push_back(static_cast<double>(t1_ns - t0_ns) * 1e-3);
    if (snap.frames < n) ++into.short_reads;
    if (snap.rx_lost) ++into.rx_lost;
  }
  return {normal, burst};
}

// --- Latency ----------------------------------------------------------------------------------

//! The simulator's endpoint, seen through a wrapper that notes when joint 0's encoder PDO leaves
//! and which SYNC it answers, so that the controller thread can pair the sample it decodes with
//! the moment it was sent.
class StampingBus final : public hal::CanBus {
 public:
  StampingBus(hal::CanBus& inner, std::uint32_t watched_can_id) : inner_(inner), watched_(watched_can_id) {}

  Status send(const CanFrame& frame) noexcept override {
    if (frame.can_id == watched_) {
      sent_ns_.store(now_ns(), std::memory_order_relaxed);
      sent_for_sync_.store(last_sync_, std::memory_order_release);  // after the time: a reader that sees it sees that
    }
    return inner_.send(frame);
  }
  hal::ReceiveResult receive(std::span<hal::TimedFrame> out) noexcept override {
    const hal::ReceiveResult r = inner_.receive(out);
    for (std::size_t k = 0; k < r.count; ++k) {
      const CanFrame& f = out[k].frame;
      if (f.can_id == hal::canopen::kSyncCobId && f.dlc == 1) last_sync_ = f.data[0];
    }
    return r;
  }
  Status wait_readable(std::int64_t timeout_us) noexcept override { return inner_.wait_readable(timeout_us); }
  Status set_filters(std::span<const hal::CanFilter> filters) noexcept override { return inner_.set_filters(filters); }
  Status set_error_mask(std::uint32_t class_mask) noexcept override { return inner_.set_error_mask(class_mask); }
  hal::BusState state() const noexcept override { return inner_.state(); }
  hal::BusCounters counters() const noexcept override { return inner_.counters(); }
  std::string url() const override { return inner_.url(); }

  //! The SYNC counter the last watched frame answered (0: none yet).
  [[nodiscard]] std::uint8_t sent_for_sync() const noexcept { return sent_for_sync_.load(std::memory_order_acquire); }
  [[nodiscard]] std::int64_t sent_ns() const noexcept { return sent_ns_.load(std::memory_order_relaxed); }

 private:
  hal::CanBus& inner_;
  std::uint32_t watched_;
  std::uint8_t last_sync_ = 0;  // simulator thread only
  std::atomic<std::int64_t> sent_ns_{0};
  std::atomic<std::uint8_t> sent_for_sync_{0};
};

enum class Receiver { Blocking, Polling };

const char* to_string(Receiver r) { return r == Receiver::Blocking ? "blocking wait_readable" : "polling read()"; }

struct Latency {
  Transport transport = Transport::Loop;
  Receiver receiver = Receiver::Blocking;
  std::vector<double> send_to_snapshot_us;
  std::vector<double> sync_to_snapshot_us;
  std::uint64_t missed = 0;  //!< rounds with no answer within kAnswerTimeoutNs
};

constexpr std::int64_t kLatencyPeriodNs = 2'000'000;  //!< one SYNC round every 2 ms
constexpr std::int64_t kAnswerTimeoutNs = 20'000'000;  //!< two control cycles: later is a missed round

//! mgc-sim's loop (step, then block until a frame or the next event) on its own thread, and the
//! controller's Hal on this one: each round sends a SYNC, writes the valve command, then waits
//! for joint 0's answer, blocking in wait_readable or spinning on read().
Latency latency(Transport transport, Receiver receiver, const planning::Scenario& scenario, int samples) {
  BusPair bus = open_pair(transport);
  sim::SimConfig config;
  const hal::BusPlan plan = sim::bus_plan_for(scenario);
  StampingBus sim_bus(*bus.device, 0x180U + plan.encoders[0].node_id);
  sim::Simulator sim(scenario, sim_bus, config);
  std::vector<double> max_velocity;
  for (const auto& j : scenario.machine.joints) max_velocity.push_back(j.max_velocity);
  hal::Hal hal(*bus.controller, plan, max_velocity);
  const std::vector<double> still(max_velocity.size(), 0.0);

  std::atomic<bool> stop{false};
  std::thread machine([&] {
    while (!stop.load(std::memory_order_relaxed)) {
      sim.step(bus_now_us());
      const std::int64_t wait_us = std::min<std::int64_t>(sim.next_event_us() - bus_now_us(), 5'000);
      if (wait_us > 0) (void)sim_bus.wait_readable(wait_us);
    }
  });

  Latency r{transport, receiver, {}, {}};
  std::int64_t cycle_ns = now_ns();
  // Start: boot-up heartbeats, NMT start, then cycles until every joint reports.
  (void)hal.send_nmt(hal::canopen::NmtCommand::Start, 0);
  for (int c = 0; c < 200 && !hal.snapshot().all_joints_valid(); ++c) {
    cycle_ns += kLatencyPeriodNs;
    sleep_until_ns(cycle_ns);
    (void)hal.read(bus_now_us());
    (void)hal.write(still, bus_now_us());
  }
  const bool started = hal.snapshot().all_joints_valid();
  for (int i = 0; started && i < samples; ++i) {
    cycle_ns += kLatencyPeriodNs;
    if (now_ns() > cycle_ns) cycle_ns = now_ns();  // after a stall: no back-to-back rounds
    sleep_until_ns(cycle_ns);
    hal.enable_sync(true);
    const std::int64_t sync_ns = now_ns();
    const hal::SensorSnapshot& first = hal.read(bus_now_us());
    const std::int64_t first_ns = now_ns();
    const std::uint8_t sync = first.sync_counter;
    hal.enable_sync(false);  // the waiting reads below only drain
    // read() drains after sending the SYNC, so a quick answer may already be in this snapshot.
    bool answered = first.joints[0].updated && sim_bus.sent_for_sync() == sync;
    if (answered) {
      r.send_to_snapshot_us.push_back(static_cast<double>(first_ns - sim_bus.sent_ns()) * 1e-3);
      r.sync_to_snapshot_us.push_back(static_cast<double>(first_ns - sync_ns) * 1e-3);
    }
    (void)hal.write(still, bus_now_us());
    while (!answered) {
      const std::int64_t left_ns = sync_ns + kAnswerTimeoutNs - now_ns();
      if (left_ns <= 0 || sync == 0) {
        ++r.missed;
        break;
      }
      if (receiver == Receiver::Blocking) (void)bus.controller->wait_readable(left_ns / 1000 + 1);
      const bool updated = hal.read(bus_now_us()).joints[0].updated;
      const std::int64_t decoded_ns = now_ns();
      // An update whose stamp names an earlier SYNC is a late answer; keep waiting for ours.
      if (updated && sim_bus.sent_for_sync() == sync) {
        r.send_to_snapshot_us.push_back(static_cast<double>(decoded_ns - sim_bus.sent_ns()) * 1e-3);
        r.sync_to_snapshot_us.push_back(static_cast<double>(decoded_ns - sync_ns) * 1e-3);
        break;
      }
    }
    hal.enable_sync(true);
  }
  stop.store(true);
  machine.join();
  if (!started) throw std::runtime_error(std::string("latency on ") + to_string(transport) + ": the simulator's joints never reported");
  return r;
}

// --- Report -----------------------------------------------------------------------------------

}  // namespace

int run_bus_suite(const BusBenchOptions& options) {
  try {
    const hal::BusPlan plan = hal::mobile_crane_bus_plan();
    const FullBusTraffic traffic(plan);
    const planning::Scenario scenario =
        planning::io::load_scenario(std::filesystem::path(options.scenarios_dir) / kLatencyScenario);
    Csv csv;
    const auto wall_start_ns = now_ns();
    const std::string load_before = load_average();
    std::string md = "### bus\n\nFieldbus transports into the Hal on this machine, 4-joint mobile-crane bus plan. `--bus-samples " +
                     std::to_string(options.latency_samples) + "`.\n\n";

    // 1. Throughput.
    std::fprintf(stderr, "[bus] throughput\n");
    md += "#### Throughput: device endpoint → Hal::read decode, no loss\n\n"
          "| transport | threads | offered frames/s | sent frames/s | decoded frames/s | lost | × full bus (4,000/s) | no loss | sender kept up |\n"
          "|---|---|---|---|---|---|---|---|---|\n";
    const auto throughput_row = [&](const Throughput& t) {
      const std::string offered = t.offered_hz > 0.0 ? fmt("%.0f", t.offered_hz) : "max";
      md += fmt("| %s | %s | %s | %.0f | %.0f | %llu | %.1f | %s | %s |\n", to_string(t.transport), t.threads, offered.c_str(),
                t.sent_hz, t.decoded_hz, static_cast<unsigned long long>(t.lost() + t.send_failed), t.decoded_hz / kFullBusFramesPerS,
                t.clean() ? "yes" : "no", t.kept_up() ? "yes" : "no");
      csv.add("throughput_decoded", to_string(t.transport), fmt("%s offered %.0f", t.threads, t.offered_hz), 0, t.decoded_hz,
              "frames/s");
    };
    std::vector<std::string> max_clean;
    for (const Transport transport : {Transport::Loop, Transport::Udp}) {
      throughput_row(same_thread_throughput(transport, traffic, 1.0));
      // Offered rates double until the first with loss, or until the device thread's rate stops
      // growing (then the sender, not the receiver, limits and a higher offer measures nothing new).
      double best_hz = 0.0;
      double previous_sent_hz = 0.0;
      for (double offered_hz = kFullBusFramesPerS; offered_hz <= 512'000.0; offered_hz *= 2.0) {
        const Throughput t = paced_throughput(transport, traffic, offered_hz, 0.5);
        throughput_row(t);
        if (!t.clean()) break;
        best_hz = std::max(best_hz, t.decoded_hz);
        if (!t.kept_up() && t.sent_hz < 1.25 * previous_sent_hz) break;
        previous_sent_hz = t.sent_hz;
      }
      max_clean.push_back(fmt("%s, two threads: %.0f frames/s = %.0f× a full bus", to_string(transport), best_hz,
                              best_hz / kFullBusFramesPerS));
    }
    md += "\nMax sustained rate (highest decoded rate of a step with no loss): ";
    for (std::size_t i = 0; i < max_clean.size(); ++i) md += (i ? "; " : "") + max_clean[i];
    md += ".\n\n";

    // 2. Hal::read at full-bus load.
    std::fprintf(stderr, "[bus] Hal::read cost\n");
    md += "#### Hal::read draining one cycle at full-bus load (SYNC on, same thread)\n\n"
          "| transport | frames per read | reads | median µs | p95 µs | p99 µs | max µs | median µs/frame | p99 share of 10 ms | short reads | reads with loss |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Transport transport : {Transport::Loop, Transport::Udp}) {
      for (const ReadCost& c : read_cost(transport, traffic, 2000)) {
        const LatencyStats s = latency_stats(c.read_us);
        md += fmt("| %s | %zu | %zu | %.1f | %.1f | %.1f | %.1f | %.3f | %.2f %% | %llu | %llu |\n", to_string(transport),
                  c.frames_per_read, s.n, s.median, s.p95, s.p99, s.max, s.median / static_cast<double>(c.frames_per_read),
                  100.0 * s.p99 / static_cast<double>(kControlCycleUs), static_cast<unsigned long long>(c.short_reads),
                  static_cast<unsigned long long>(c.rx_lost));
        for (std::size_t i = 0; i < c.read_us.size(); ++i) {
          csv.add("hal_read", to_string(transport), fmt("%zu frames", c.frames_per_read), i, c.read_us[i], "us");
        }
      }
    }

    // 3. Latency.
    md += "\n#### One-way latency: simulator send → Hal::read returns the decoded sample (two threads)\n\n"
          "A SYNC round every 2 ms; a round with no answer within 20 ms is missed.\n\n"
          "| transport | receiver | samples | missed | median µs | p95 µs | p99 µs | p99.9 µs | max µs | SYNC → snapshot median µs | SYNC → snapshot p99 µs |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Transport transport : {Transport::Loop, Transport::Udp}) {
      for (const Receiver receiver : {Receiver::Blocking, Receiver::Polling}) {
        std::fprintf(stderr, "[bus] latency %s, %s\n", to_string(transport), to_string(receiver));
        const Latency l = latency(transport, receiver, scenario, options.latency_samples);
        const LatencyStats s = latency_stats(l.send_to_snapshot_us);
        const LatencyStats rt = latency_stats(l.sync_to_snapshot_us);
        md += fmt("| %s | %s | %zu | %llu | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", to_string(transport),
                  to_string(receiver), s.n, static_cast<unsigned long long>(l.missed), s.median, s.p95, s.p99, s.p999,
                  s.max, rt.median, rt.p99);
        for (std::size_t i = 0; i < l.send_to_snapshot_us.size(); ++i) {
          csv.add("latency_send_to_snapshot", to_string(transport), to_string(receiver), i, l.send_to_snapshot_us[i], "us");
          csv.add("latency_sync_to_snapshot", to_string(transport), to_string(receiver), i, l.sync_to_snapshot_us[i], "us");
        }
      }
    }
    md += fmt("\nWhole suite: %.1f s; load average (1, 5, 15 min) before %s, after %s.\n",
              static_cast<double>(now_ns() - wall_start_ns) * 1e-9, load_before.c_str(), load_average().c_str());

    std::printf("%s\n", md.c_str());
    if (!options.out_dir.empty()) {
      std::filesystem::create_directories(options.out_dir);
      std::ofstream(options.out_dir + "/bus.md") << md;
      std::ofstream(options.out_dir + "/bus.csv") << csv.text();
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mgc-bench: bus: %s\n", e.what());
    return 2;
  }
}

}  // namespace mgc::bench
