// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/operator_words.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace mgc::firmware {
namespace {

constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

//! How one joint is said: its name, the word for a positive and a negative move, and its unit.
struct JointWords {
  const char* name;      //!< empty: the direction word is said alone ("hoist up")
  const char* positive;
  const char* negative;
  bool revolute;
};

// Mobile crane: a longer cable lowers the hook, so cable + is "hoist down".
constexpr JointWords kMobileCrane[] = {
    {"swing", "left", "right", true},
    {"boom", "up", "down", true},
    {"telescope", "out", "in", false},
    {"hoist", "down", "up", false},
};
constexpr JointWords kTowerCrane[] = {
    {"slew", "left", "right", true},
    {"trolley", "out", "in", false},
    {"hook", "up", "down", false},
};
// Excavator angles grow upwards, so arm and bucket moving in (curling) are negative.
constexpr JointWords kExcavator[] = {
    {"swing", "left", "right", true},
    {"boom", "up", "down", true},
    {"arm", "out", "in", true},
    {"bucket", "dump", "curl", true},
};

const JointWords* words_for(planning::MachineKind kind, int joint) noexcept {
  if (joint < 0) return nullptr;
  const auto pick = [joint](const auto& table) -> const JointWords* {
    return joint < static_cast<int>(std::size(table)) ? &table[joint] : nullptr;
  };
  switch (kind) {
    case planning::MachineKind::MobileCrane: return pick(kMobileCrane);
    case planning::MachineKind::TowerCrane: return pick(kTowerCrane);
    case planning::MachineKind::Excavator: return pick(kExcavator);
  }
  return nullptr;
}

bool worth_saying(planning::MachineKind kind, int joint, double delta) noexcept {
  const JointWords* w = words_for(kind, joint);
  const bool revolute = w == nullptr || w->revolute;
  return std::isfinite(delta) && std::abs(delta) >= (revolute ? kWordsMinAngleRad : kWordsMinLengthM);
}

//! Appends text at out[len..]; false (and nothing written) when it does not fit with its NUL.
bool append(std::span<char> out, std::size_t& len, const char* text, std::size_t text_len) noexcept {
  if (len + text_len + 1 > out.size()) return false;
  std::memcpy(out.data() + len, text, text_len);
  len += text_len;
  out[len] = '\0';
  return true;
}

//! One segment (every joint that moves on it, joined with "and") into out; its length, 0 if none.
std::size_t segment_in_words(planning::MachineKind kind, int num_joints, const double* from,
                             const double* to, std::span<char> out) noexcept {
  std::size_t len = 0;
  for (int j = 0; j < num_joints; ++j) {
    const double delta = to[j] - from[j];
    if (!worth_saying(kind, j, delta)) continue;
    std::array<char, 48> move{};
    const std::size_t n = joint_move_in_words(kind, j, delta, move);
    if (n == 0) return 0;
    if (len > 0 && !append(out, len, " and ", 5)) return 0;
    if (!append(out, len, move.data(), n)) return 0;
  }
  return len;
}

}  // namespace

std::size_t joint_move_in_words(planning::MachineKind kind, int joint, double delta,
                                std::span<char> out) noexcept {
  if (out.empty()) return 0;
  out[0] = '\0';
  const JointWords* w = words_for(kind, joint);
  const bool revolute = w == nullptr || w->revolute;
  const double amount = revolute ? std::abs(delta) * kDegPerRad : std::abs(delta);
  // Whole degrees and decimetres are what an operator reads off a display; small moves keep a
  // decimal so they do not read as "0".
  const int decimals = revolute ? (amount < 0.95 ? 1 : 0) : (amount < 0.1 ? 2 : (amount < 9.95 ? 1 : 0));
  const char* unit = revolute ? "deg" : "m";
  int n = 0;
  if (w != nullptr) {
    n = std::snprintf(out.data(), out.size(), "%s %s %.*f %s", w->name, delta > 0.0 ? w->positive : w->negative,
                      decimals, amount, unit);
  } else {
    // A joint this machine kind has no words for (e.g. a second crane's): say it by number.
    n = std::snprintf(out.data(), out.size(), "joint %d %s%.*f %s", joint, delta > 0.0 ? "+" : "-", decimals,
                      amount, unit);
  }
  if (n < 0 || static_cast<std::size_t>(n) >= out.size()) {
    out[0] = '\0';
    return 0;
  }
  return static_cast<std::size_t>(n);
}

std::size_t next_moves_in_words(planning::MachineKind kind, int num_joints, std::span<const double> current,
                                std::span<const std::array<double, kMaxJoints>> waypoints, int segment_index,
                                int max_moves, std::span<char> out) noexcept {
  if (out.empty()) return 0;
  out[0] = '\0';
  if (num_joints <= 0 || num_joints > kMaxJoints || static_cast<int>(current.size()) < num_joints ||
      segment_index < 0 || max_moves <= 0) {
    return 0;
  }
  constexpr char kThen[] = ", then ";
  constexpr char kMore[] = ", ...";
  std::size_t len = 0;
  int said = 0;
  const double* from = current.data();
  for (std::size_t w = static_cast<std::size_t>(segment_index) + 1; w < waypoints.size() && said < max_moves;
       ++w) {
    std::array<char, kMaxJoints * 48> segment{};
    const std::size_t n = segment_in_words(kind, num_joints, from, waypoints[w].data(), segment);
    from = waypoints[w].data();
    if (n == 0) continue;  // a waypoint where nothing moves (or the current one, already reached)
    // Keep room for ", ..." so a cut is visible to the operator.
    const std::size_t sep = said > 0 ? sizeof(kThen) - 1 : 0;
    if (len + sep + n + sizeof(kMore) > out.size()) {
      if (said > 0) append(out, len, kMore, sizeof(kMore) - 1);
      break;
    }
    if (said > 0) append(out, len, kThen, sep);
    append(out, len, segment.data(), n);
    ++said;
  }
  return len;
}

}  // namespace mgc::firmware
