// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/command_auth.hpp"

#include <mgc/command_status_t.hpp>

#include <sodium.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

namespace mgc::firmware {
namespace {

static_assert(kCommandKeyBytes == crypto_auth_KEYBYTES);
static_assert(kCommandMacBytes == crypto_auth_BYTES);
static_assert(sizeof(operator_command_t::mac) == kCommandMacBytes);
static_assert(operator_command_t::MAC_BYTES == static_cast<int>(kCommandMacBytes));

// operator_command_t has only fixed-size fields, so its encoding has one size.
constexpr std::size_t kCommandEncodedMaxBytes = 256;

using Status = command_status_t;

}  // namespace

CommandKey::~CommandKey() { sodium_memzero(bytes_.data(), bytes_.size()); }

CommandKey load_command_key(const std::string& path) {
  struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) {
    throw CommandKeyError("command key file " + path + ": cannot open (" + std::strerror(errno) +
                          "); expected 32 raw bytes");
  }
  std::array<std::uint8_t, kCommandKeyBytes + 1> buf{};
  const std::size_t n = std::fread(buf.data(), 1, buf.size(), file.get());
  if (n != kCommandKeyBytes) {
    const std::string got = n > kCommandKeyBytes ? "more than 32" : std::to_string(n);
    sodium_memzero(buf.data(), buf.size());
    throw CommandKeyError("command key file " + path + ": " + got + " bytes; expected exactly 32 raw bytes");
  }
  std::array<std::uint8_t, kCommandKeyBytes> key{};
  std::memcpy(key.data(), buf.data(), key.size());
  sodium_memzero(buf.data(), buf.size());
  CommandKey result(key);
  sodium_memzero(key.data(), key.size());
  return result;
}

std::size_t command_canonical_bytes(const operator_command_t& cmd, std::span<std::uint8_t> out) noexcept {
  const int size = cmd.getEncodedSize();
  if (size <= static_cast<int>(kCommandMacBytes) || static_cast<std::size_t>(size) > out.size()) return 0;
  if (cmd.encode(out.data(), 0, size) != size) return 0;
  // mac is the last field, so the encoding without its final 32 bytes is everything else.
  return static_cast<std::size_t>(size) - kCommandMacBytes;
}

void sign_command(operator_command_t& cmd, const CommandKey& key) noexcept {
  std::array<std::uint8_t, kCommandEncodedMaxBytes> buf{};
  const std::size_t n = command_canonical_bytes(cmd, buf);
  crypto_auth(cmd.mac, buf.data(), n, key.bytes().data());
}

CommandAuthenticator::CommandAuthenticator(const CommandKey& key, std::int64_t sequence_floor)
    : key_(key), sequence_floor_(sequence_floor) {
  // Idempotent and thread-safe; picks the fastest implementation once, before any check().
  if (sodium_init() < 0) throw std::runtime_error("libsodium: sodium_init failed");
}

std::int64_t CommandAuthenticator::last_sequence(std::int32_t sender_id) const noexcept {
  for (std::size_t i = 0; i < num_senders_; ++i) {
    if (senders_[i].sender_id == sender_id) return senders_[i].last_sequence;
  }
  return sequence_floor_;
}

CommandVerdict CommandAuthenticator::check(const operator_command_t& cmd) noexcept {
  if (cmd.kind == operator_command_t::KIND_STOP) {
    // A stop can only make the machine safer, so it is never refused, and it never touches the
    // replay counters: an unauthenticated sender must not be able to move them.
    return {true, Status::REASON_ACCEPTED};
  }
  if (cmd.kind != operator_command_t::KIND_GOAL && cmd.kind != operator_command_t::KIND_ACKNOWLEDGE) {
    return {false, Status::REASON_UNKNOWN_KIND};
  }
  // The MAC first: nothing else about an unauthenticated command is worth reporting to its sender.
  std::array<std::uint8_t, kCommandEncodedMaxBytes> buf{};
  const std::size_t n = command_canonical_bytes(cmd, buf);
  if (n == 0 || crypto_auth_verify(cmd.mac, buf.data(), n, key_.bytes().data()) != 0) {
    return {false, Status::REASON_BAD_MAC};
  }
  if (cmd.num_joints < 0 || cmd.num_joints > operator_command_t::MAX_JOINTS || cmd.alert_id < 0) {
    return {false, Status::REASON_MALFORMED};
  }
  if (cmd.kind == operator_command_t::KIND_GOAL) {
    if (cmd.num_joints == 0) return {false, Status::REASON_MALFORMED};
    for (int j = 0; j < cmd.num_joints; ++j) {
      if (!std::isfinite(cmd.goal_position[j])) return {false, Status::REASON_MALFORMED};
    }
  }
  SenderCounter* counter = nullptr;
  for (std::size_t i = 0; i < num_senders_; ++i) {
    if (senders_[i].sender_id == cmd.sender_id) counter = &senders_[i];
  }
  const std::int64_t last = counter != nullptr ? counter->last_sequence : sequence_floor_;
  if (cmd.sequence <= last) return {false, Status::REASON_STALE_SEQUENCE};
  if (counter == nullptr) {
    if (num_senders_ == senders_.size()) return {false, Status::REASON_TOO_MANY_SENDERS};
    counter = &senders_[num_senders_++];
    counter->sender_id = cmd.sender_id;
  }
  counter->last_sequence = cmd.sequence;
  return {true, Status::REASON_ACCEPTED};
}

CommandVerdict CommandAuthenticator::check_bytes(std::span<const std::uint8_t> bytes,
                                                 operator_command_t& cmd) noexcept {
  cmd = operator_command_t{};
  const int size = static_cast<int>(bytes.size());
  // The encoding has one size: trailing bytes would be unauthenticated, so they are refused too.
  if (cmd.decode(bytes.data(), 0, size) != size || size != cmd.getEncodedSize()) {
    cmd = operator_command_t{};
    return {false, Status::REASON_MALFORMED};
  }
  return check(cmd);
}

}  // namespace mgc::firmware
