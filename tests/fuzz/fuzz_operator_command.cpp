// SPDX-License-Identifier: Apache-2.0
// Operator command decode and authentication (firmware_like/src/command_auth.cpp): the input is
// one LCM message as it arrives on MGC_COMMAND, checked against a fixed key, clock and replay
// state as the controller's LCM thread does. A fuzzer cannot forge a MAC, so the decoded command
// is then also signed with the key and checked again, which takes it past the MAC to the checks
// behind it. Properties: a verdict is one of the documented reasons; nothing that can move the
// machine is accepted unless it is well formed, signed and fresh; a signed command is accepted
// once, never twice.
#include <mgc/command_status_t.hpp>
#include <mgc/firmware/command_auth.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "fuzz_support.hpp"

using mgc::command_status_t;
using mgc::operator_command_t;
using namespace mgc::firmware;
using mgc::fuzz::kCommandNowUs;
using mgc::fuzz::require;

namespace {

const CommandKey& key() {
  static const CommandKey k(mgc::fuzz::command_key_bytes());
  return k;
}

void check_verdict(const CommandVerdict& v, const operator_command_t& cmd, std::int64_t now_us, std::int64_t skew_us) {
  require(v.reason > command_status_t::REASON_UNKNOWN && v.reason < command_status_t::NUM_REASONS,
          "a verdict with an undocumented reason");
  require(v.accepted == (v.reason == command_status_t::REASON_ACCEPTED), "accepted differs from the reason");
  if (!v.accepted || cmd.kind == operator_command_t::KIND_STOP) return;
  require(cmd.kind == operator_command_t::KIND_GOAL || cmd.kind == operator_command_t::KIND_ACKNOWLEDGE,
          "accepted a command of unknown kind");
  require(cmd.sequence >= now_us - skew_us && cmd.sequence <= now_us + skew_us, "accepted a sequence outside the window");
  require(cmd.num_joints >= 0 && cmd.num_joints <= operator_command_t::MAX_JOINTS && cmd.alert_id >= 0,
          "accepted a malformed command");
  if (cmd.kind == operator_command_t::KIND_GOAL) {
    require(cmd.num_joints > 0, "accepted a goal without joints");
    for (int j = 0; j < cmd.num_joints; ++j) require(std::isfinite(cmd.goal_position[j]), "accepted a goal that is not finite");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  const std::int64_t skew_us = kDefaultCommandSkew_us;
  const std::int64_t floor_us = kCommandNowUs - 60'000'000;

  // Whether the bytes are one operator_command_t: the LCM decoder's own answer.
  operator_command_t decoded{};
  const int n = static_cast<int>(size);
  const bool decodes = decoded.decode(data, 0, n) == n && n == decoded.getEncodedSize();
  if (decodes) {
    // The encoding has one size, and a decoded command encodes back to the same bytes.
    std::array<std::uint8_t, 512> again{};
    require(decoded.encode(again.data(), 0, static_cast<int>(again.size())) == n, "a decoded command does not encode");
    for (std::size_t i = 0; i < size; ++i) require(again[i] == data[i], "a decoded command encodes to other bytes");
  }

  // As received: the verdict on the bytes themselves.
  CommandAuthenticator auth(key(), floor_us, skew_us);
  operator_command_t cmd{};
  const CommandVerdict v = auth.check_bytes(bytes, cmd, kCommandNowUs);
  check_verdict(v, cmd, kCommandNowUs, skew_us);
  if (!decodes) {
    require(!v.accepted && v.reason == command_status_t::REASON_MALFORMED, "bytes that do not decode were not refused as malformed");
    return 0;
  }

  // Signed with the right key: only the checks behind the MAC can refuse it, and only once.
  if (cmd.kind != operator_command_t::KIND_GOAL && cmd.kind != operator_command_t::KIND_ACKNOWLEDGE) return 0;
  operator_command_t signed_cmd = cmd;
  sign_command(signed_cmd, key());
  CommandAuthenticator fresh(key(), floor_us, skew_us);
  const CommandVerdict first = fresh.check(signed_cmd, kCommandNowUs);
  check_verdict(first, signed_cmd, kCommandNowUs, skew_us);
  require(first.reason != command_status_t::REASON_BAD_MAC, "a command signed with the key has a bad MAC");
  const CommandVerdict replay = fresh.check(signed_cmd, kCommandNowUs);
  check_verdict(replay, signed_cmd, kCommandNowUs, skew_us);
  if (first.accepted) {
    require(!replay.accepted && replay.reason == command_status_t::REASON_STALE_SEQUENCE, "a replayed command was accepted");
    require(fresh.last_sequence(signed_cmd.sender_id) == signed_cmd.sequence, "the sender's counter did not move");
  } else {
    require(replay.reason == first.reason, "a refused command got another verdict the second time");
    require(fresh.last_sequence(signed_cmd.sender_id) == floor_us, "a refused command moved the counter");
  }
  // A tampered signed command (one bit of the payload) never passes.
  operator_command_t tampered = signed_cmd;
  tampered.alert_id ^= 1;
  CommandAuthenticator other(key(), floor_us, skew_us);
  require(other.check(tampered, kCommandNowUs).reason == command_status_t::REASON_BAD_MAC, "a tampered command passed the MAC");
  return 0;
}
