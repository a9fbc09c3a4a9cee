// SPDX-License-Identifier: Apache-2.0
#include "mgc/sim/faults.hpp"

#include <charconv>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace mgc::sim {

namespace {

struct KindInfo {
  FaultKind kind;
  const char* name;
  FaultTarget::Kind target;  //!< what the target must be; None = no target allowed
  const char* target_help;
};

constexpr KindInfo kKinds[] = {
    {FaultKind::EncoderDropout, "encoder-dropout", FaultTarget::Kind::Joint, "JOINT | inclinometer"},
    {FaultKind::EncoderStuck, "encoder-stuck", FaultTarget::Kind::Joint, "JOINT | inclinometer"},
    {FaultKind::TagNoise, "tag-noise", FaultTarget::Kind::Tag, "TAG_ID"},
    {FaultKind::UwbSilent, "uwb-silent", FaultTarget::Kind::None, ""},
    {FaultKind::FrameDelay, "frame-delay", FaultTarget::Kind::None, ""},
    {FaultKind::BusOff, "bus-off", FaultTarget::Kind::None, ""},
    {FaultKind::HeartbeatLost, "heartbeat-lost", FaultTarget::Kind::Joint, "JOINT | uwb | valve | cutoff | inclinometer"},
    {FaultKind::ValveIgnore, "valve-ignore", FaultTarget::Kind::None, ""},
    {FaultKind::EncoderOffset, "encoder-offset", FaultTarget::Kind::Joint, "JOINT | inclinometer"},
    {FaultKind::CutoffFail, "cutoff-fail", FaultTarget::Kind::None, ""},
    {FaultKind::JointCreep, "joint-creep", FaultTarget::Kind::Joint, "JOINT"},
};

[[noreturn]] void fail(std::string_view text, const std::string& what) {
  throw std::invalid_argument("fault \"" + std::string(text) + "\": " + what);
}

double parse_signed(std::string_view text, std::string_view part, const char* what) {
  double value = 0.0;
  const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), value);
  if (ec != std::errc() || end != part.data() + part.size() || !std::isfinite(value) || std::abs(value) > 1e6) {
    fail(text, std::string(what) + ": expected a number within +-1e6, got \"" + std::string(part) + "\"");
  }
  return value;
}

double parse_number(std::string_view text, std::string_view part, const char* what) {
  double value = 0.0;
  const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), value);
  if (ec != std::errc() || end != part.data() + part.size() || !std::isfinite(value) || value < 0.0) {
    fail(text, std::string(what) + ": expected a number >= 0, got \"" + std::string(part) + "\"");
  }
  return value;
}

}  // namespace

const char* to_string(FaultKind kind) noexcept {
  for (const KindInfo& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "unknown";
}

std::string fault_syntax() {
  std::string out = "KIND[:TARGET][@START_S[+DURATION_S]][,sigma_m=M][,delay_ms=MS][,offset=X][,rate=X] with KIND:TARGET one of:";
  for (const KindInfo& k : kKinds) {
    out += std::string(" ") + k.name + (k.target == FaultTarget::Kind::None ? "" : std::string(":") + k.target_help) + ";";
  }
  out.pop_back();
  return out;
}

namespace {

Fault parse_fault_impl(std::string_view text, std::span<const std::string> joint_names, std::span<const planning::JointSpec> joints) {
  Fault fault;
  std::string_view head = text;
  std::string_view options;
  if (const auto comma = text.find(','); comma != std::string_view::npos) {
    head = text.substr(0, comma);
    options = text.substr(comma + 1);
  }
  std::string_view timing;
  if (const auto at = head.find('@'); at != std::string_view::npos) {
    timing = head.substr(at + 1);
    head = head.substr(0, at);
  }
  std::string_view target;
  if (const auto colon = head.find(':'); colon != std::string_view::npos) {
    target = head.substr(colon + 1);
    head = head.substr(0, colon);
  }

  const KindInfo* info = nullptr;
  for (const KindInfo& k : kKinds) {
    if (head == k.name) info = &k;
  }
  if (info == nullptr) fail(text, "unknown kind \"" + std::string(head) + "\"; expected " + fault_syntax());
  fault.kind = info->kind;

  if (info->target == FaultTarget::Kind::None) {
    if (!target.empty()) fail(text, std::string(info->name) + " takes no target, got \"" + std::string(target) + "\"");
  } else {
    if (target.empty()) fail(text, std::string(info->name) + " needs a target " + info->target_help);
    if (info->target == FaultTarget::Kind::Tag) {
      const double id = parse_number(text, target, "tag id");
      if (id != std::floor(id) || id > 255) fail(text, "tag id: expected an integer 0..255, got \"" + std::string(target) + "\"");
      fault.target = {FaultTarget::Kind::Tag, static_cast<int>(id)};
    } else if (fault.kind == FaultKind::HeartbeatLost && target == "uwb") {
      fault.target = {FaultTarget::Kind::UwbGateway, -1};
    } else if (fault.kind == FaultKind::HeartbeatLost && target == "valve") {
      fault.target = {FaultTarget::Kind::Valve, -1};
    } else if (fault.kind == FaultKind::HeartbeatLost && target == "cutoff") {
      fault.target = {FaultTarget::Kind::Cutoff, -1};
    } else if (target == "inclinometer" && (fault.kind == FaultKind::EncoderStuck || fault.kind == FaultKind::EncoderOffset ||
                                            fault.kind == FaultKind::EncoderDropout || fault.kind == FaultKind::HeartbeatLost)) {
      fault.target = {FaultTarget::Kind::Inclinometer, -1};
    } else {
      for (std::size_t j = 0; j < joint_names.size(); ++j) {
        if (target == joint_names[j]) fault.target = {FaultTarget::Kind::Joint, static_cast<int>(j)};
      }
      if (fault.target.kind == FaultTarget::Kind::None) {
        std::string names;
        for (const auto& n : joint_names) names += (names.empty() ? "" : ", ") + n;
        fail(text, "unknown target \"" + std::string(target) + "\"; expected one of " + names +
                       (fault.kind == FaultKind::HeartbeatLost ? ", uwb, valve, cutoff, inclinometer"
                        : fault.kind == FaultKind::EncoderStuck || fault.kind == FaultKind::EncoderOffset || fault.kind == FaultKind::EncoderDropout
                            ? ", inclinometer"
                            : ""));
      }
    }
  }

  if (!timing.empty()) {
    std::string_view start = timing;
    if (const auto plus = timing.find('+'); plus != std::string_view::npos) {
      start = timing.substr(0, plus);
      fault.duration_s = parse_number(text, timing.substr(plus + 1), "duration");
    }
    fault.start_s = parse_number(text, start, "start time");
  }

  while (!options.empty()) {
    std::string_view option = options;
    options = {};
    if (const auto comma = option.find(','); comma != std::string_view::npos) {
      options = option.substr(comma + 1);
      option = option.substr(0, comma);
    }
    const auto eq = option.find('=');
    const std::string_view key = option.substr(0, eq);
    const std::string_view value = eq == std::string_view::npos ? std::string_view{} : option.substr(eq + 1);
    if (key == "sigma_m" && fault.kind == FaultKind::TagNoise) {
      fault.sigma_m = parse_number(text, value, "sigma_m");
    } else if (key == "delay_ms" && fault.kind == FaultKind::FrameDelay) {
      fault.delay_ms = parse_number(text, value, "delay_ms");
      if (fault.delay_ms > 10'000.0) fail(text, "delay_ms: expected at most 10000, got \"" + std::string(value) + "\"");
    } else if (((key == "offset" || key == "rate") && fault.kind == FaultKind::EncoderOffset) ||
               (key == "rate" && fault.kind == FaultKind::JointCreep)) {
      // The inclinometer reads degrees.
      const bool inclinometer = fault.target.kind == FaultTarget::Kind::Inclinometer;
      const std::size_t j = static_cast<std::size_t>(fault.target.index);
      if (!inclinometer && j >= joints.size()) fail(text, std::string(info->name) + " needs the machine's joints to know the unit of its values");
      const bool revolute = inclinometer || joints[j].type == planning::JointType::Revolute;
      const double si = parse_signed(text, value, key == "offset" ? "offset" : "rate") * (revolute ? std::numbers::pi / 180.0 : 1.0);
      (key == "offset" ? fault.offset : fault.offset_rate) = si;
    } else {
      fail(text, "unknown option \"" + std::string(option) + "\" for " + info->name +
                     (fault.kind == FaultKind::TagNoise       ? " (sigma_m=M)"
                      : fault.kind == FaultKind::FrameDelay   ? " (delay_ms=MS)"
                      : fault.kind == FaultKind::EncoderOffset ? " (offset=X, rate=X per s; deg or m)"
                      : fault.kind == FaultKind::JointCreep    ? " (rate=X per s; deg or m)"
                                                               : " (none)"));
    }
  }
  if (fault.kind == FaultKind::EncoderOffset && fault.offset == 0.0 && fault.offset_rate == 0.0) {
    fail(text, "encoder-offset needs offset=X or rate=X (deg or m, not both zero)");
  }
  if (fault.kind == FaultKind::JointCreep && fault.offset_rate == 0.0) fail(text, "joint-creep needs rate=X (deg or m per s, not zero)");
  return fault;
}

}  // namespace

Fault parse_fault(std::string_view text, std::span<const std::string> joint_names) {
  return parse_fault_impl(text, joint_names, {});
}

Fault parse_machine_fault(std::string_view text, std::span<const planning::JointSpec> joints) {
  std::vector<std::string> names;
  for (const planning::JointSpec& j : joints) names.push_back(j.name);
  return parse_fault_impl(text, names, joints);
}

}  // namespace mgc::sim
