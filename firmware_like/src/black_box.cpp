// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/black_box.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace mgc::firmware::black_box {

namespace {

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) != 0 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

//! CRC-32 (IEEE 802.3, as zlib's crc32).
std::uint32_t crc32(const std::uint8_t* data, std::size_t n) noexcept {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) c = kCrcTable[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

//! Little-endian encoder into a fixed buffer; the caller sizes the buffer for the largest record.
class Writer {
 public:
  explicit Writer(std::uint8_t* out) noexcept : out_(out) {}
  void u8(std::uint8_t v) noexcept { out_[n_++] = v; }
  void u16(std::uint16_t v) noexcept { put(v, 2); }
  void u32(std::uint32_t v) noexcept { put(v, 4); }
  void u64(std::uint64_t v) noexcept { put(v, 8); }
  void i64(std::int64_t v) noexcept { put(static_cast<std::uint64_t>(v), 8); }
  void f64(double v) noexcept {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    put(bits, 8);
  }
  void bytes(const std::uint8_t* p, std::size_t n) noexcept {
    std::memcpy(out_ + n_, p, n);
    n_ += n;
  }
  void str(const std::string& s) {
    const std::size_t n = std::min<std::size_t>(s.size(), 255);
    u8(static_cast<std::uint8_t>(n));
    bytes(reinterpret_cast<const std::uint8_t*>(s.data()), n);
  }
  [[nodiscard]] std::size_t size() const noexcept { return n_; }

 private:
  void put(std::uint64_t v, int bytes) noexcept {
    for (int i = 0; i < bytes; ++i) out_[n_++] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  std::uint8_t* out_;
  std::size_t n_ = 0;
};

//! Little-endian decoder; ok() turns false when a read runs past the end.
class Reader {
 public:
  Reader(const std::uint8_t* p, std::size_t n) noexcept : p_(p), n_(n) {}
  std::uint8_t u8() noexcept { return static_cast<std::uint8_t>(get(1)); }
  std::uint16_t u16() noexcept { return static_cast<std::uint16_t>(get(2)); }
  std::uint32_t u32() noexcept { return static_cast<std::uint32_t>(get(4)); }
  std::uint64_t u64() noexcept { return get(8); }
  std::int64_t i64() noexcept { return static_cast<std::int64_t>(get(8)); }
  double f64() noexcept {
    const std::uint64_t bits = get(8);
    double v = 0.0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  void bytes(std::uint8_t* out, std::size_t n) noexcept {
    if (i_ + n > n_) {
      ok_ = false;
      return;
    }
    std::memcpy(out, p_ + i_, n);
    i_ += n;
  }
  std::string str() {
    const std::size_t n = u8();
    if (i_ + n > n_) {
      ok_ = false;
      return {};
    }
    std::string s(reinterpret_cast<const char*>(p_ + i_), n);
    i_ += n;
    return s;
  }
  [[nodiscard]] bool ok() const noexcept { return ok_; }
  [[nodiscard]] std::size_t pos() const noexcept { return i_; }

 private:
  std::uint64_t get(int bytes) noexcept {
    if (i_ + static_cast<std::size_t>(bytes) > n_) {
      ok_ = false;
      return 0;
    }
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(p_[i_ + static_cast<std::size_t>(i)]) << (8 * i);
    i_ += static_cast<std::size_t>(bytes);
    return v;
  }
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t i_ = 0;
  bool ok_ = true;
};

//! The largest payload: a site plan (kind, roster index, receive time and its 4,683-byte LCM
//! encoding); a cycle with every joint and every alert is some 500. [bytes]
constexpr std::size_t kMaxPayloadBytes = 8192;
//! Kind, roster index, receive time: what a site record holds before the message. [bytes]
constexpr std::size_t kSiteHeadBytes = 10;

void encode_counters(Writer& w, const hal::BusCounters& c) noexcept {
  w.u64(c.tx_frames);
  w.u64(c.tx_failed);
  w.u64(c.rx_frames);
  w.u64(c.rx_lost);
  w.u64(c.rx_malformed);
  w.u64(c.error_frames);
  w.u64(c.bus_off_events);
  w.u64(c.restarts);
}

hal::BusCounters decode_counters(Reader& r) noexcept {
  hal::BusCounters c;
  c.tx_frames = r.u64();
  c.tx_failed = r.u64();
  c.rx_frames = r.u64();
  c.rx_lost = r.u64();
  c.rx_malformed = r.u64();
  c.error_frames = r.u64();
  c.bus_off_events = r.u64();
  c.restarts = r.u64();
  return c;
}

//! The payload of e in format version; its length. plan: the content of a site plan entry.
std::size_t encode_payload(const Entry& e, const site_plan_t* plan, std::uint8_t* out, std::uint32_t version) noexcept {
  Writer w(out);
  switch (e.type) {
    case RecordType::Frame:
      w.i64(e.frame.frame.t_us);
      w.u32(e.frame.frame.frame.can_id);
      w.u8(e.frame.frame.frame.dlc);
      w.bytes(e.frame.frame.frame.data.data(), 8);
      break;
    case RecordType::TxFailure:
      w.u64(e.tx.send_index);
      w.u16(static_cast<std::uint16_t>(e.tx.status));
      break;
    case RecordType::Command: {
      const CommandEntry& c = e.command;
      w.u8(static_cast<std::uint8_t>(c.kind));
      w.u32(static_cast<std::uint32_t>(c.sender_id));
      w.i64(c.sequence);
      w.u32(static_cast<std::uint32_t>(c.num_joints));
      for (double g : c.goal_position) w.f64(g);
      w.u32(static_cast<std::uint32_t>(c.alert_id));
      w.i64(c.received_us);
      break;
    }
    case RecordType::Cycle: {
      const CycleEntry& c = e.cycle;
      w.u64(c.cycle);
      w.i64(c.read_us);
      w.i64(c.dt_us);
      w.u8(static_cast<std::uint8_t>((c.watchdog_tripped ? 1u : 0u) | (c.rx_lost ? 2u : 0u)));
      w.u8(static_cast<std::uint8_t>(c.bus_state));
      encode_counters(w, c.bus);
      w.u8(static_cast<std::uint8_t>((c.commands.stop ? 1u : 0u) | (c.commands.goal_request ? 2u : 0u) |
                                     (c.commands.acknowledge ? 4u : 0u)));
      w.u32(static_cast<std::uint32_t>(c.commands.goal_joints));
      for (double g : c.commands.goal) w.f64(g);
      w.u64(c.refusals_total);
      if (version >= 2) {
        w.u64(c.records_dropped);
        w.u64(c.site_taken);
      }
      w.u8(c.num_joints);
      for (std::size_t j = 0; j < c.num_joints; ++j) w.f64(c.velocity[j]);
      w.u8(static_cast<std::uint8_t>((c.start_nodes ? 1u : 0u) | (c.reset_watchdog ? 2u : 0u) | (c.pilot_enable ? 4u : 0u) |
                                     (c.transitioned ? 8u : 0u)));
      w.u8(static_cast<std::uint8_t>(c.state));
      w.u8(static_cast<std::uint8_t>(c.reason));
      w.u32(c.plan_id);
      w.u8(c.num_alerts);
      for (std::size_t i = 0; i < c.num_alerts; ++i) {
        const AlertDigest& a = c.alerts[i];
        w.u32(static_cast<std::uint32_t>(a.alert_id));
        w.u8(static_cast<std::uint8_t>(a.severity));
        w.u8(static_cast<std::uint8_t>(a.source));
        w.f64(a.value);
        w.f64(a.limit);
      }
      break;
    }
    case RecordType::Site: {
      const SiteEntry& site = e.site;
      w.u8(static_cast<std::uint8_t>(site.kind));
      w.u8(static_cast<std::uint8_t>(site.roster_index));
      w.i64(site.received_us);
      const int room = static_cast<int>(kMaxPayloadBytes - kSiteHeadBytes);
      const int n = site.kind == SiteKind::Plan ? (plan != nullptr ? plan->encode(out + w.size(), 0, room) : -1)
                                                : site.state.encode(out + w.size(), 0, room);
      // Cannot happen (both fit the buffer); an empty payload then fails to decode rather than lie.
      if (n <= 0) return 0;
      return w.size() + static_cast<std::size_t>(n);
    }
    case RecordType::End:
      break;
  }
  return w.size();
}

//! Decodes a payload of type in format version; false when it is shorter than its type needs or a
//! count is out of range. A site plan's content goes to the end of plans.
bool decode_payload(RecordType type, const std::uint8_t* p, std::size_t n, Entry& e, std::uint32_t version,
                    std::vector<site_plan_t>& plans) {
  Reader r(p, n);
  e.type = type;
  switch (type) {
    case RecordType::Frame:
      e.frame = {};
      e.frame.frame.t_us = r.i64();
      e.frame.frame.frame.can_id = r.u32();
      e.frame.frame.frame.dlc = r.u8();
      r.bytes(e.frame.frame.frame.data.data(), 8);
      break;
    case RecordType::TxFailure:
      e.tx = {};
      e.tx.send_index = r.u64();
      e.tx.status = static_cast<hal::Status>(static_cast<std::int16_t>(r.u16()));
      break;
    case RecordType::Command: {
      e.command = {};
      CommandEntry& c = e.command;
      c.kind = static_cast<std::int8_t>(r.u8());
      c.sender_id = static_cast<std::int32_t>(r.u32());
      c.sequence = r.i64();
      c.num_joints = static_cast<std::int32_t>(r.u32());
      for (double& g : c.goal_position) g = r.f64();
      c.alert_id = static_cast<std::int32_t>(r.u32());
      c.received_us = r.i64();
      break;
    }
    case RecordType::Cycle: {
      e.cycle = {};
      CycleEntry& c = e.cycle;
      c.cycle = r.u64();
      c.read_us = r.i64();
      c.dt_us = r.i64();
      const std::uint8_t in_flags = r.u8();
      c.watchdog_tripped = (in_flags & 1u) != 0;
      c.rx_lost = (in_flags & 2u) != 0;
      c.bus_state = static_cast<hal::BusState>(r.u8());
      c.bus = decode_counters(r);
      const std::uint8_t cmd_flags = r.u8();
      c.commands.stop = (cmd_flags & 1u) != 0;
      c.commands.goal_request = (cmd_flags & 2u) != 0;
      c.commands.acknowledge = (cmd_flags & 4u) != 0;
      c.commands.goal_joints = static_cast<int>(r.u32());
      for (double& g : c.commands.goal) g = r.f64();
      c.refusals_total = r.u64();
      if (version >= 2) {
        c.records_dropped = r.u64();
        c.site_taken = r.u64();
      }
      c.num_joints = r.u8();
      if (c.num_joints > kMaxJoints) return false;
      for (std::size_t j = 0; j < c.num_joints; ++j) c.velocity[j] = r.f64();
      const std::uint8_t out_flags = r.u8();
      c.start_nodes = (out_flags & 1u) != 0;
      c.reset_watchdog = (out_flags & 2u) != 0;
      c.pilot_enable = (out_flags & 4u) != 0;
      c.transitioned = (out_flags & 8u) != 0;
      c.state = static_cast<guidance::SupervisorState>(r.u8());
      c.reason = static_cast<guidance::TransitionReason>(r.u8());
      c.plan_id = r.u32();
      c.num_alerts = r.u8();
      if (c.num_alerts > c.alerts.size()) return false;
      for (std::size_t i = 0; i < c.num_alerts; ++i) {
        AlertDigest& a = c.alerts[i];
        a.alert_id = static_cast<std::int32_t>(r.u32());
        a.severity = static_cast<std::int8_t>(r.u8());
        a.source = static_cast<std::int8_t>(r.u8());
        a.value = r.f64();
        a.limit = r.f64();
      }
      break;
    }
    case RecordType::Site: {
      if (version < 2 || n < kSiteHeadBytes) return false;
      e.site = {};
      SiteEntry& site = e.site;
      site.kind = static_cast<SiteKind>(r.u8());
      site.roster_index = static_cast<std::int8_t>(r.u8());
      site.received_us = r.i64();
      const int rest = static_cast<int>(n - kSiteHeadBytes);
      if (site.kind == SiteKind::State) {
        return site.state.decode(p + kSiteHeadBytes, 0, rest) == rest;
      }
      if (site.kind != SiteKind::Plan) return false;
      site_plan_t plan{};
      if (plan.decode(p + kSiteHeadBytes, 0, rest) != rest) return false;
      site.plan_index = static_cast<std::uint32_t>(plans.size());
      plans.push_back(plan);
      return true;
    }
    case RecordType::End:
      e.frame = {};
      break;
    default:
      return false;
  }
  return r.ok() && r.pos() == n;
}

//! Record header + payload into out; its length.
std::size_t encode_record(const Entry& e, const site_plan_t* plan, std::uint8_t* out, std::uint32_t version) noexcept {
  const std::size_t n = encode_payload(e, plan, out + kRecordHeaderBytes, version);
  Writer h(out + 4);
  h.u16(static_cast<std::uint16_t>(e.type));
  h.u16(static_cast<std::uint16_t>(n));
  const std::uint32_t crc = crc32(out + 4, 4 + n);
  Writer c(out);
  c.u32(crc);
  return kRecordHeaderBytes + n;
}

void encode_block_header(std::uint8_t* block, std::uint64_t seq, std::size_t used) noexcept {
  std::memset(block, 0, kBlockHeaderBytes);
  Writer w(block);
  w.u32(kBlockMagic);
  w.u32(0);
  w.u64(seq);
  w.u32(static_cast<std::uint32_t>(used));
  Writer c(block + 4);
  c.u32(crc32(block + 8, kBlockHeaderBytes - 8));
}

std::vector<std::uint8_t> encode_file_header(const Identity& id, std::size_t num_blocks) {
  std::vector<std::uint8_t> h(kFileHeaderBytes, 0);
  Writer w(h.data());
  w.u32(kFileMagic);
  w.u32(id.format_version);
  w.u32(static_cast<std::uint32_t>(kFileHeaderBytes));
  w.u32(static_cast<std::uint32_t>(kBlockBytes));
  w.u32(static_cast<std::uint32_t>(num_blocks));
  w.str(id.scenario_file);
  w.str(id.scenario_name);
  w.str(id.machine_name);
  w.u64(id.scenario_hash);
  w.u64(id.machine_hash);
  w.str(id.replanner);
  w.i64(id.period_us);
  w.f64(id.valve_deadband);
  w.u8(id.num_joints);
  for (std::size_t j = 0; j < kMaxJoints; ++j) {
    w.f64(id.plausible_min[j]);
    w.f64(id.plausible_max[j]);
  }
  w.i64(id.started_unix_s);
  if (id.format_version >= 2) {
    w.u32(static_cast<std::uint32_t>(id.site_machine_id));
    w.u64(id.site_machines_hash);
  }
  Writer c(h.data() + kFileHeaderBytes - 4);
  c.u32(crc32(h.data(), kFileHeaderBytes - 4));
  return h;
}

std::string offset_text(const std::string& path, std::size_t offset) {
  return path + " (offset " + std::to_string(offset) + ")";
}

std::int64_t steady_us() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

CycleEntry make_cycle_entry(std::uint64_t cycle, std::int64_t read_us, std::int64_t dt_us, bool watchdog_tripped,
                            const hal::SensorSnapshot& snapshot, const ControllerCommands& commands, const ControllerOutput& out,
                            const GuidanceSnapshot& guidance, std::uint64_t refusals_total) noexcept {
  CycleEntry c;
  c.cycle = cycle;
  c.read_us = read_us;
  c.dt_us = dt_us;
  c.watchdog_tripped = watchdog_tripped;
  c.rx_lost = snapshot.rx_lost;
  c.bus_state = snapshot.bus_state;
  c.bus = snapshot.bus;
  c.commands = commands;
  c.refusals_total = refusals_total;
  c.num_joints = static_cast<std::uint8_t>(std::min<std::size_t>(out.velocity.size(), kMaxJoints));
  for (std::size_t j = 0; j < c.num_joints; ++j) c.velocity[j] = out.velocity[j];
  c.start_nodes = out.start_nodes;
  c.reset_watchdog = out.reset_watchdog;
  c.pilot_enable = out.pilot_enable;
  c.state = out.supervisor.state;
  c.reason = out.supervisor.reason;
  c.transitioned = out.supervisor.transitioned;
  c.plan_id = guidance.plan.plan_id;
  c.num_alerts = static_cast<std::uint8_t>(std::clamp(guidance.num_alerts, 0, kSnapshotMaxAlerts));
  for (std::size_t i = 0; i < c.num_alerts; ++i) {
    const SnapshotAlert& a = guidance.alerts[i];
    c.alerts[i] = {a.alert_id, a.severity, a.source, a.value, a.limit};
  }
  return c;
}

std::uint64_t hash_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot be read for the black box's identity hash");
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::istreambuf_iterator<char> it(in), end; it != end; ++it) {
    h ^= static_cast<std::uint8_t>(*it);
    h *= 0x100000001b3ull;
  }
  return h;
}

Identity identity_for(const planning::Scenario& scenario, const std::string& replanner, std::int64_t period_us, double valve_deadband) {
  Identity id;
  // Absolute, so that mgc-replay finds it from any folder.
  id.scenario_file = scenario.file.empty() ? std::string() : std::filesystem::absolute(scenario.file).lexically_normal().string();
  id.scenario_name = scenario.name;
  id.machine_name = scenario.machine.name;
  id.scenario_hash = scenario.file.empty() ? 0 : hash_file(scenario.file);
  id.machine_hash = scenario.machine.file.empty() ? 0 : hash_file(scenario.machine.file);
  id.replanner = replanner;
  id.period_us = period_us;
  id.valve_deadband = valve_deadband;
  id.num_joints = static_cast<std::uint8_t>(std::min<std::size_t>(scenario.machine.joints.size(), kMaxJoints));
  id.plausible_min.fill(-std::numeric_limits<double>::infinity());
  id.plausible_max.fill(std::numeric_limits<double>::infinity());
  id.started_unix_s = static_cast<std::int64_t>(std::time(nullptr));
  return id;
}

void set_plausible_ranges(Identity& identity, const planning::Scenario& scenario) {
  for (std::size_t j = 0; j < identity.num_joints; ++j) {
    const planning::JointSpec& spec = scenario.machine.joints[j];
    if (spec.continuous) continue;
    identity.plausible_min[j] = spec.position_min - 0.1 * spec.range();
    identity.plausible_max[j] = spec.position_max + 0.1 * spec.range();
  }
}

void set_site_member(Identity& identity, const planning::Site& site, std::int32_t machine_id) {
  identity.site_machine_id = machine_id;
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const planning::SiteMachine& m : site.machines) {
    const std::uint64_t file_hash = m.machine.file.empty() ? 0 : hash_file(m.machine.file);
    for (int i = 0; i < 8; ++i) {
      h ^= static_cast<std::uint8_t>(file_hash >> (8 * i));
      h *= 0x100000001b3ull;
    }
  }
  identity.site_machines_hash = h;
}

void configure_hal(hal::Hal& hal, const Identity& identity) {
  hal.set_valve_deadband(identity.valve_deadband);
  for (std::size_t j = 0; j < identity.num_joints; ++j) {
    if (std::isfinite(identity.plausible_min[j]) || std::isfinite(identity.plausible_max[j])) {
      hal.set_joint_plausible_range(j, identity.plausible_min[j], identity.plausible_max[j]);
    }
  }
}

std::size_t ring_bytes_for_minutes(double minutes, std::size_t site_peers) noexcept {
  const double rate = static_cast<double>(kMeasuredBytesPerSecond + site_peers * kSitePeerBytesPerSecond);
  const double bytes = std::max(0.0, minutes) * 60.0 * rate;
  const auto blocks = std::max<std::size_t>(2, static_cast<std::size_t>(std::ceil(bytes / static_cast<double>(kBlockBytes))));
  return kFileHeaderBytes + blocks * kBlockBytes;
}

// ---- The recorder ------------------------------------------------------------------------------

BlackBox::BlackBox(const std::string& path, const Identity& identity, std::size_t file_bytes)
    : queue_(std::make_unique<Queue>()),
      plans_(std::make_unique<PlanQueue>()),
      version_(identity.format_version),
      record_(kRecordHeaderBytes + kMaxPayloadBytes, 0),
      path_(path),
      block_(kBlockBytes, 0) {
  if (version_ < 1 || version_ > kFormatVersion) {
    throw std::runtime_error(path + ": black box format version " + std::to_string(version_) + ", expected 1 to " +
                             std::to_string(kFormatVersion));
  }
  num_blocks_ = std::max<std::size_t>(2, (file_bytes > kFileHeaderBytes ? file_bytes - kFileHeaderBytes : 0) / kBlockBytes);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(path + ": cannot create the black box: " + std::strerror(errno));
  const auto fail = [&](const char* what) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error(path + ": " + what + ": " + std::strerror(err));
  };
  // The whole ring up front, zero-filled: a block never written reads as unused.
  if (::ftruncate(fd_, static_cast<off_t>(kFileHeaderBytes + num_blocks_ * kBlockBytes)) != 0) fail("cannot size the ring");
  const std::vector<std::uint8_t> header = encode_file_header(identity, num_blocks_);
  if (::pwrite(fd_, header.data(), header.size(), 0) != static_cast<ssize_t>(header.size())) fail("cannot write the header");
  if (::fdatasync(fd_) != 0) fail("cannot sync the header");
  block_seq_ = 1;
  stats_.blocks_started = 1;
}

BlackBox::~BlackBox() {
  close();
  if (fd_ >= 0) ::close(fd_);
}

void BlackBox::start() {
  if (started_ || closed_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

void BlackBox::close() {
  if (closed_) return;
  closed_ = true;
  if (started_) {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    return;
  }
  finish();
}

void BlackBox::write_pending() noexcept {
  if (started_ || closed_) return;
  drain();
  write_block(true);
}

void BlackBox::finish() noexcept {
  drain();
  Entry end;
  end.type = RecordType::End;
  append(end);
  write_block(true);
}

void BlackBox::push_frame(const hal::TimedFrame& frame) noexcept {
  Entry e;
  e.type = RecordType::Frame;
  e.frame.frame = frame;
  (void)queue_->try_push(e);
}

void BlackBox::push_tx_failure(std::uint64_t send_index, hal::Status status) noexcept {
  Entry e;
  e.type = RecordType::TxFailure;
  e.tx = {send_index, status};
  (void)queue_->try_push(e);
}

void BlackBox::push_command(const CommandEntry& command) noexcept {
  Entry e;
  e.type = RecordType::Command;
  e.command = command;
  (void)queue_->try_push(e);
}

void BlackBox::push_cycle(const CycleEntry& cycle) noexcept {
  Entry e;
  e.type = RecordType::Cycle;
  e.cycle = cycle;
  e.cycle.records_dropped = dropped();
  e.cycle.site_taken = site_taken_;
  (void)queue_->try_push(e);
}

void BlackBox::push_recorded_cycle(const CycleEntry& cycle) noexcept {
  Entry e;
  e.type = RecordType::Cycle;
  e.cycle = cycle;
  (void)queue_->try_push(e);
}

void BlackBox::push_site_state(int roster_index, const site_state_t& state, std::int64_t received_us) noexcept {
  ++site_taken_;
  Entry e;
  e.type = RecordType::Site;
  e.site.kind = SiteKind::State;
  e.site.roster_index = static_cast<std::int8_t>(roster_index);
  e.site.received_us = received_us;
  e.site.state = state;
  (void)queue_->try_push(e);
}

void BlackBox::push_site_plan(int roster_index, const site_plan_t& plan) noexcept {
  ++site_taken_;
  // The entry that marks the plan's place must find room after the plan went in: the loop alone
  // pushes, and the writer only makes room, so room seen now is room then.
  if (queue_->size() >= kQueueCapacity || !plans_->try_push(plan)) {
    plans_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Entry e;
  e.type = RecordType::Site;
  e.site.kind = SiteKind::Plan;
  e.site.roster_index = static_cast<std::int8_t>(roster_index);
  (void)queue_->try_push(e);
}

void BlackBox::run() noexcept {
  std::int64_t last_flush_us = steady_us();
  while (!stop_.load()) {
    drain();
    const std::int64_t now = steady_us();
    if (now - last_flush_us >= kFlushPeriodUs) {
      write_block(true);
      last_flush_us = now;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  finish();
}

void BlackBox::drain() noexcept {
  Entry e;
  while (queue_->try_pop(e)) append(e);
}

void BlackBox::append(const Entry& e) noexcept {
  const site_plan_t* plan = nullptr;
  if (e.type == RecordType::Site && e.site.kind == SiteKind::Plan) {
    // Pushed before the entry that marks it, so it is there.
    if (!plans_->try_pop(plan_)) return;
    plan = &plan_;
  }
  if (e.type == RecordType::Site && version_ < 2) return;  // version 1 has no site records
  const std::size_t n = encode_record(e, plan, record_.data(), version_);
  if (used_ + n > kBlockBytes) {
    write_block(false);
    ++block_seq_;
    ++stats_.blocks_started;
    std::fill(block_.begin(), block_.end(), std::uint8_t{0});
    used_ = kBlockHeaderBytes;
  }
  std::memcpy(block_.data() + used_, record_.data(), n);
  used_ += n;
  ++stats_.entries_written;
  stats_.bytes_written += n;
}

void BlackBox::write_block(bool sync) noexcept {
  encode_block_header(block_.data(), block_seq_, used_);
  const std::size_t index = static_cast<std::size_t>((block_seq_ - 1) % num_blocks_);
  const std::int64_t t0 = steady_us();
  // The whole block in one write: what a kill leaves is a block as it was at a write, never half of one.
  if (::pwrite(fd_, block_.data(), kBlockBytes, static_cast<off_t>(kFileHeaderBytes + index * kBlockBytes)) !=
      static_cast<ssize_t>(kBlockBytes)) {
    io_errno_.store(errno != 0 ? errno : EIO);
  }
  if (sync) {
    if (::fdatasync(fd_) != 0) io_errno_.store(errno);
    const std::int64_t took = steady_us() - t0;
    ++stats_.flushes;
    stats_.flush_total_us += took;
    stats_.flush_max_us = std::max(stats_.flush_max_us, took);
  }
}

// ---- The recording bus -------------------------------------------------------------------------

hal::Status RecordingBus::send(const hal::CanFrame& frame) noexcept {
  const hal::Status s = bus_.send(frame);
  if (s != hal::Status::Ok) box_.push_tx_failure(sends_, s);
  ++sends_;
  return s;
}

hal::ReceiveResult RecordingBus::receive(std::span<hal::TimedFrame> out) noexcept {
  const hal::ReceiveResult r = bus_.receive(out);
  for (std::size_t i = 0; i < r.count; ++i) box_.push_frame(out[i]);
  return r;
}

// ---- Reading -----------------------------------------------------------------------------------

Recording read_recording(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw BadRecording(path + ": cannot be read");
  in.seekg(0, std::ios::end);
  const auto file_size = static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg()));
  // Only the header, the block headers and the blocks in use are read: a ring is mostly unused
  // (a sparse file) until it wraps.
  const auto data = std::make_unique_for_overwrite<std::uint8_t[]>(std::max<std::size_t>(file_size, 1));
  const auto read_at = [&](std::size_t offset, std::size_t n) {
    in.seekg(static_cast<std::streamoff>(offset), std::ios::beg);
    if (!in.read(reinterpret_cast<char*>(data.get() + offset), static_cast<std::streamsize>(n))) {
      throw BadRecording(offset_text(path, offset) + ": cannot be read");
    }
  };
  read_at(0, std::min(file_size, kFileHeaderBytes));
  if (file_size >= 4) {
    Reader m(data.get(), 4);
    const std::uint32_t magic = m.u32();
    if (magic != kFileMagic) {
      throw BadRecording(offset_text(path, 0) + ": magic " + std::to_string(magic) + ", expected MGBX: not a black box recording");
    }
  }
  if (file_size < kFileHeaderBytes) {
    throw BadRecording(offset_text(path, 0) + ": " + std::to_string(file_size) + " bytes, expected a black box of at least " +
                       std::to_string(kFileHeaderBytes));
  }
  Reader h(data.get(), kFileHeaderBytes - 4);
  (void)h.u32();  // the magic, checked above
  const std::uint32_t version = h.u32();
  if (version < 1 || version > kFormatVersion) {
    throw BadRecording(offset_text(path, 4) + ": format version " + std::to_string(version) + ", expected 1 to " +
                       std::to_string(kFormatVersion));
  }
  Reader crc_at(data.get() + kFileHeaderBytes - 4, 4);
  if (crc_at.u32() != crc32(data.get(), kFileHeaderBytes - 4)) throw BadRecording(offset_text(path, kFileHeaderBytes - 4) + ": header CRC mismatch");
  const std::uint32_t header_bytes = h.u32();
  const std::uint32_t block_bytes = h.u32();
  const std::uint32_t num_blocks = h.u32();
  if (header_bytes != kFileHeaderBytes || block_bytes != kBlockBytes) {
    throw BadRecording(offset_text(path, 8) + ": header " + std::to_string(header_bytes) + " and block " + std::to_string(block_bytes) +
                       " bytes, expected " + std::to_string(kFileHeaderBytes) + " and " + std::to_string(kBlockBytes));
  }
  Recording rec;
  rec.num_blocks = num_blocks;
  Identity& id = rec.identity;
  id.scenario_file = h.str();
  id.scenario_name = h.str();
  id.machine_name = h.str();
  id.scenario_hash = h.u64();
  id.machine_hash = h.u64();
  id.replanner = h.str();
  id.period_us = h.i64();
  id.valve_deadband = h.f64();
  id.num_joints = h.u8();
  for (std::size_t j = 0; j < kMaxJoints; ++j) {
    id.plausible_min[j] = h.f64();
    id.plausible_max[j] = h.f64();
  }
  id.started_unix_s = h.i64();
  id.format_version = version;
  if (version >= 2) {
    id.site_machine_id = static_cast<std::int32_t>(h.u32());
    id.site_machines_hash = h.u64();
  }
  if (!h.ok() || id.num_joints > kMaxJoints) throw BadRecording(offset_text(path, 20) + ": the identity does not fit the header");

  struct Block {
    std::uint64_t seq;
    std::size_t offset;
    std::size_t used;
  };
  std::vector<Block> blocks;
  for (std::size_t b = 0; b < num_blocks; ++b) {
    const std::size_t offset = kFileHeaderBytes + b * kBlockBytes;
    if (offset + kBlockBytes > file_size) {
      // A ring is sized up front: a shorter file was cut, and the blocks past the cut are lost.
      if (offset < file_size) rec.torn_tail_bytes += file_size - offset;
      break;
    }
    read_at(offset, kBlockHeaderBytes);
    Reader bh(data.get() + offset, kBlockHeaderBytes);
    const std::uint32_t bmagic = bh.u32();
    const std::uint32_t bcrc = bh.u32();
    const std::uint64_t seq = bh.u64();
    const std::uint32_t used = bh.u32();
    if (bmagic == 0 && bcrc == 0 && seq == 0) continue;  // never written
    if (bmagic != kBlockMagic || bcrc != crc32(data.get() + offset + 8, kBlockHeaderBytes - 8) || used < kBlockHeaderBytes ||
        used > kBlockBytes) {
      throw BadRecording(offset_text(path, offset) + ": block " + std::to_string(b) + " header corrupt (magic, CRC or length)");
    }
    read_at(offset + kBlockHeaderBytes, used - kBlockHeaderBytes);
    blocks.push_back({seq, offset, used});
  }
  std::sort(blocks.begin(), blocks.end(), [](const Block& a, const Block& b) { return a.seq < b.seq; });
  for (std::size_t i = 1; i < blocks.size(); ++i) {
    if (blocks[i].seq != blocks[i - 1].seq + 1) {
      throw BadRecording(offset_text(path, blocks[i].offset) + ": block sequence " + std::to_string(blocks[i].seq) + ", expected " +
                         std::to_string(blocks[i - 1].seq + 1));
    }
  }
  rec.blocks_used = blocks.size();
  rec.wrapped = !blocks.empty() && blocks.front().seq > 1;
  for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
    const Block& b = blocks[bi];
    const bool newest = bi + 1 == blocks.size();
    std::size_t pos = kBlockHeaderBytes;
    while (pos < b.used) {
      const std::size_t at = b.offset + pos;
      bool good = pos + kRecordHeaderBytes <= b.used;
      std::size_t len = 0;
      RecordType type = RecordType::Frame;
      if (good) {
        Reader rh(data.get() + at, kRecordHeaderBytes);
        const std::uint32_t crc = rh.u32();
        type = static_cast<RecordType>(rh.u16());
        len = rh.u16();
        good = pos + kRecordHeaderBytes + len <= b.used && crc == crc32(data.get() + at + 4, 4 + len);
      }
      Entry e;
      if (good && !decode_payload(type, data.get() + at + kRecordHeaderBytes, len, e, version, rec.plans)) {
        throw BadRecording(offset_text(path, at) + ": record type " + std::to_string(static_cast<int>(type)) + " of " +
                           std::to_string(len) + " bytes does not decode");
      }
      if (!good) {
        if (newest) {
          rec.torn_tail_bytes += b.used - pos;
          break;
        }
        throw BadRecording(offset_text(path, at) + ": record CRC mismatch in the middle of the recording (block " +
                           std::to_string((b.offset - kFileHeaderBytes) / kBlockBytes) + ")");
      }
      if (e.type == RecordType::End) rec.ended = true;
      rec.entries.push_back(e);
      pos += kRecordHeaderBytes + len;
    }
  }
  return rec;
}

void write_recording(const std::string& path, const Recording& recording, std::size_t file_bytes) {
  BlackBox box(path, recording.identity, file_bytes);
  std::size_t pending = 0;
  std::size_t plans_pending = 0;
  for (const Entry& e : recording.entries) {
    switch (e.type) {
      case RecordType::Frame: box.push_frame(e.frame.frame); break;
      case RecordType::TxFailure: box.push_tx_failure(e.tx.send_index, e.tx.status); break;
      case RecordType::Command: box.push_command(e.command); break;
      case RecordType::Cycle: box.push_recorded_cycle(e.cycle); break;
      case RecordType::Site:
        if (e.site.kind == SiteKind::Plan) {
          box.push_site_plan(e.site.roster_index, recording.plans.at(e.site.plan_index));
          ++plans_pending;
        } else {
          box.push_site_state(e.site.roster_index, e.site.state, e.site.received_us);
        }
        break;
      default: continue;  // End: close() writes it
    }
    // The queues are bounded: write out before they fill.
    if (++pending == kQueueCapacity / 2 || plans_pending == kPlanQueueCapacity / 2) {
      box.write_pending();
      pending = 0;
      plans_pending = 0;
    }
  }
  box.close();
}

// ---- Replay ------------------------------------------------------------------------------------

namespace {

//! Plays recorded frames back to a Hal, cycle by cycle; sends succeed except those recorded as refused.
class ReplayBus final : public hal::CanBus {
 public:
  explicit ReplayBus(std::vector<TxFailureEntry> failures) : failures_(std::move(failures)) {}

  void load(std::span<const hal::TimedFrame> frames, const CycleEntry& c) noexcept {
    frames_ = frames;
    next_ = 0;
    rx_lost_ = c.rx_lost;
    state_ = c.bus_state;
    counters_ = c.bus;
  }
  hal::Status send(const hal::CanFrame& /*frame*/) noexcept override {
    hal::Status s = hal::Status::Ok;
    for (const TxFailureEntry& f : failures_) {
      if (f.send_index == sends_) s = f.status;
    }
    ++sends_;
    return s;
  }
  hal::ReceiveResult receive(std::span<hal::TimedFrame> out) noexcept override {
    hal::ReceiveResult r;
    if (rx_lost_) {
      r.status = hal::Status::RxOverflow;
      rx_lost_ = false;
    }
    while (r.count < out.size() && next_ < frames_.size()) out[r.count++] = frames_[next_++];
    return r;
  }
  hal::Status wait_readable(std::int64_t /*timeout_us*/) noexcept override { return hal::Status::Timeout; }
  hal::Status set_filters(std::span<const hal::CanFilter> /*filters*/) noexcept override { return hal::Status::Ok; }
  hal::Status set_error_mask(std::uint32_t /*class_mask*/) noexcept override { return hal::Status::Ok; }
  hal::BusState state() const noexcept override { return state_; }
  hal::BusCounters counters() const noexcept override { return counters_; }
  std::string url() const override { return "replay:"; }

 private:
  std::vector<TxFailureEntry> failures_;
  std::span<const hal::TimedFrame> frames_;
  std::size_t next_ = 0;
  bool rx_lost_ = false;
  hal::BusState state_ = hal::BusState::ErrorActive;
  hal::BusCounters counters_{};
  std::uint64_t sends_ = 0;
};

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

bool same_bits(double a, double b) noexcept { return std::memcmp(&a, &b, sizeof a) == 0; }

//! The first decision that differs: field name, recorded and replayed text; empty when none.
struct Difference {
  std::string field, recorded, replayed;
};

Difference compare(const CycleEntry& rec, const CycleEntry& rep) {
  const auto flag = [](bool b) { return std::string(b ? "true" : "false"); };
  if (rec.num_joints != rep.num_joints) return {"num_joints", std::to_string(rec.num_joints), std::to_string(rep.num_joints)};
  for (std::size_t j = 0; j < rec.num_joints; ++j) {
    if (!same_bits(rec.velocity[j], rep.velocity[j])) {
      return {"velocity[" + std::to_string(j) + "]", number(rec.velocity[j]), number(rep.velocity[j])};
    }
  }
  if (rec.start_nodes != rep.start_nodes) return {"start_nodes", flag(rec.start_nodes), flag(rep.start_nodes)};
  if (rec.reset_watchdog != rep.reset_watchdog) return {"reset_watchdog", flag(rec.reset_watchdog), flag(rep.reset_watchdog)};
  if (rec.pilot_enable != rep.pilot_enable) return {"pilot_enable", flag(rec.pilot_enable), flag(rep.pilot_enable)};
  if (rec.state != rep.state) return {"supervisor.state", guidance::to_string(rec.state), guidance::to_string(rep.state)};
  if (rec.reason != rep.reason) return {"supervisor.reason", guidance::to_string(rec.reason), guidance::to_string(rep.reason)};
  if (rec.transitioned != rep.transitioned) return {"supervisor.transitioned", flag(rec.transitioned), flag(rep.transitioned)};
  if (rec.plan_id != rep.plan_id) return {"plan_id", std::to_string(rec.plan_id), std::to_string(rep.plan_id)};
  if (rec.num_alerts != rep.num_alerts) return {"num_alerts", std::to_string(rec.num_alerts), std::to_string(rep.num_alerts)};
  for (std::size_t i = 0; i < rec.num_alerts; ++i) {
    const AlertDigest& a = rec.alerts[i];
    const AlertDigest& b = rep.alerts[i];
    const std::string at = "alerts[" + std::to_string(i) + "].";
    if (a.alert_id != b.alert_id) return {at + "alert_id", std::to_string(a.alert_id), std::to_string(b.alert_id)};
    if (a.severity != b.severity) return {at + "severity", std::to_string(a.severity), std::to_string(b.severity)};
    if (a.source != b.source) return {at + "source", std::to_string(a.source), std::to_string(b.source)};
    if (!same_bits(a.value, b.value)) return {at + "value", number(a.value), number(b.value)};
    if (!same_bits(a.limit, b.limit)) return {at + "limit", number(a.limit), number(b.limit)};
  }
  return {};
}

}  // namespace

std::vector<RecordedTransition> recorded_transitions(const Recording& recording) {
  std::vector<RecordedTransition> out;
  const CycleEntry* previous = nullptr;
  for (const Entry& e : recording.entries) {
    if (e.type != RecordType::Cycle) continue;
    const CycleEntry& c = e.cycle;
    if (c.transitioned) {
      RecordedTransition t;
      t.cycle = c.cycle;
      t.t_us = c.read_us;
      t.from_known = previous != nullptr && previous->cycle + 1 == c.cycle;
      if (t.from_known) t.from = previous->state;
      t.to = c.state;
      t.reason = c.reason;
      out.push_back(t);
    }
    previous = &c;
  }
  return out;
}

ReplayResult replay(const Recording& recording, const planning::Scenario& scenario, const SiteMemberConfig* site) {
  ReplayResult result;
  const Identity& id = recording.identity;
  std::vector<TxFailureEntry> failures;
  const CycleEntry* first = nullptr;
  bool has_site = false;
  for (const Entry& e : recording.entries) {
    if (e.type == RecordType::TxFailure) failures.push_back(e.tx);
    if (e.type == RecordType::Site) has_site = true;
    if (e.type == RecordType::Cycle && first == nullptr) first = &e.cycle;
    if (e.type == RecordType::Cycle) result.last_read_us = e.cycle.read_us;
  }
  if (first == nullptr) {
    result.replayable = false;
    result.why_not = "the recording holds no cycle";
    return result;
  }
  if (recording.wrapped || first->cycle != 0) {
    result.replayable = false;
    result.why_not = "the ring has wrapped: its oldest cycle is " + std::to_string(first->cycle) +
                     ", and a fresh controller must start from cycle 0";
    return result;
  }
  if (site == nullptr && (has_site || id.site_machine_id != 0)) {
    result.replayable = false;
    result.why_not = "a site member's recording (machine " + std::to_string(id.site_machine_id) + "): it replays with its site";
    return result;
  }

  ControllerConfig config;
  config.replanner = id.replanner;
  Controller controller(scenario, config, site);
  // Large (every machine's latest plan): not on the stack.
  const auto site_inputs = std::make_unique<SiteInputs>();
  std::vector<double> vmax;
  std::vector<std::string> joint_names;
  for (const auto& j : scenario.machine.joints) {
    vmax.push_back(j.max_velocity);
    joint_names.push_back(j.name);
  }
  ReplayBus bus(std::move(failures));
  hal::Hal hal(bus, hal::bus_plan_for(planning::to_string(scenario.machine.kind), joint_names), vmax);
  configure_hal(hal, id);
  std::array<guidance::TransitionRecord, guidance::TransitionLog::kCapacity> drained{};

  std::vector<hal::TimedFrame> frames;
  frames.reserve(hal::kMaxFramesPerRead * 2);
  for (const Entry& e : recording.entries) {
    if (e.type == RecordType::Frame) {
      frames.push_back(e.frame.frame);
      continue;
    }
    if (e.type == RecordType::Site) {
      if (e.site.kind == SiteKind::Plan) {
        take_site_plan(*site_inputs, e.site.roster_index, recording.plans.at(e.site.plan_index), nullptr);
      } else {
        take_site_state(*site_inputs, e.site.roster_index, e.site.state, e.site.received_us, nullptr);
      }
      ++result.site_messages;
      continue;
    }
    if (e.type != RecordType::Cycle) continue;
    const CycleEntry& c = e.cycle;
    // A cycle whose inputs are not all in the recording would differ, or worse not differ, for a
    // reason that is not the controller's: say so and stop.
    std::string missing;
    if (c.cycle != result.cycles) {
      missing = "its cycle number is " + std::to_string(c.cycle) + ", expected " + std::to_string(result.cycles) + ": cycles are missing";
    } else if (c.records_dropped > 0) {
      missing = std::to_string(c.records_dropped) + " records dropped by the recorder's full queue before it";
    } else if (c.site_taken != result.site_messages) {
      missing = "the loop took " + std::to_string(c.site_taken) + " site messages before it, the recording holds " +
                std::to_string(result.site_messages);
    }
    if (!missing.empty()) {
      result.incomplete = true;
      result.incomplete_cycle = c.cycle;
      result.first_read_us = c.read_us;
      result.why_incomplete = missing;
      return result;
    }
    bus.load(frames, c);
    result.frames += frames.size();
    const hal::SensorSnapshot& s = hal.read(c.read_us);
    frames.clear();
    const ControllerOutput out = site != nullptr ? controller.step(s, c.dt_us, c.commands, c.watchdog_tripped, *site_inputs)
                                                 : controller.step(s, c.dt_us, c.commands, c.watchdog_tripped);
    if (out.start_nodes) (void)hal.send_nmt(hal::canopen::NmtCommand::Start, 0);
    hal.set_pilot_enabled(out.pilot_enable);
    (void)hal.write(out.velocity, c.read_us);
    const std::size_t n_drained = controller.supervisor().log().drain(drained);
    result.transition_log.insert(result.transition_log.end(), drained.begin(),
                                 drained.begin() + static_cast<std::ptrdiff_t>(n_drained));
    if (result.cycles == 0) result.first_cycle_read_us = c.read_us;
    if (c.transitioned) ++result.transitions;
    const CycleEntry mine = make_cycle_entry(c.cycle, c.read_us, c.dt_us, c.watchdog_tripped, s, c.commands, out,
                                             controller.snapshot(), c.refusals_total);
    const Difference d = compare(c, mine);
    if (!d.field.empty()) {
      result.identical = false;
      result.first_cycle = c.cycle;
      result.first_read_us = c.read_us;
      result.field = d.field;
      result.recorded = d.recorded;
      result.replayed = d.replayed;
      return result;
    }
    ++result.cycles;
  }
  return result;
}

}  // namespace mgc::firmware::black_box
