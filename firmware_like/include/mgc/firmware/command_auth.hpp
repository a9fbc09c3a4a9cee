// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/operator_command_t.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

//! Authentication of operator commands (docs/operator-feed.md): a stop is obeyed from anyone;
//! a goal or an acknowledgement, which can cause motion, needs a valid shared-key MAC
//! (libsodium crypto_auth, HMAC-SHA-512-256) and a sequence above the sender's last accepted one.
namespace mgc::firmware {

inline constexpr std::size_t kCommandKeyBytes = 32;  //!< crypto_auth_KEYBYTES [bytes]
inline constexpr std::size_t kCommandMacBytes = 32;  //!< crypto_auth_BYTES [bytes]

//! The shared key. Not printable, and wiped (sodium_memzero) when destroyed.
class CommandKey {
 public:
  explicit CommandKey(const std::array<std::uint8_t, kCommandKeyBytes>& bytes) noexcept : bytes_(bytes) {}
  CommandKey(const CommandKey&) = default;
  CommandKey& operator=(const CommandKey&) = default;
  ~CommandKey();
  [[nodiscard]] const std::array<std::uint8_t, kCommandKeyBytes>& bytes() const noexcept { return bytes_; }

 private:
  std::array<std::uint8_t, kCommandKeyBytes> bytes_;
};

//! Thrown by load_command_key() with a one-line message naming the file and what was expected.
class CommandKeyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

//! Reads the key file: exactly 32 raw bytes (e.g. `head -c 32 /dev/urandom > mgc.key`). A missing,
//! unreadable, short or long file throws CommandKeyError. Start-up only (allocates, may block).
[[nodiscard]] CommandKey load_command_key(const std::string& path);

//! The verdict on one command; reason uses command_status_t::REASON_* values.
struct CommandVerdict {
  bool accepted = false;
  std::int8_t reason = 0;   //!< command_status_t::REASON_* [enum]
};

//! The bytes the MAC covers: the LCM encoding of cmd (fingerprint and every field) without the
//! trailing mac field. Returns the length written into out (0 if out is too small).
//! RT-safe: no alloc, no lock, no throw.
std::size_t command_canonical_bytes(const operator_command_t& cmd, std::span<std::uint8_t> out) noexcept;

//! Fills cmd.mac for key over command_canonical_bytes(cmd) (the sender's side; tests and tools).
void sign_command(operator_command_t& cmd, const CommandKey& key) noexcept;

//! Checks commands against the key and a per-sender replay table of fixed capacity.
//! Replay counters live in memory and start at sequence_floor for every sender at construction:
//! with the default floor 0 a controller restart forgets them, so senders should use a sequence
//! that never repeats over the key's life (their CLOCK_REALTIME in µs) and the controller should
//! pass a floor of its own start time minus the tolerated clock skew (docs/operator-feed.md).
//! Not thread-safe: one thread (the LCM I/O thread) calls check(). RT-safe after construction.
class CommandAuthenticator {
 public:
  static constexpr std::size_t kMaxSenders = 16;  //!< senders tracked; more are refused [-]

  explicit CommandAuthenticator(const CommandKey& key, std::int64_t sequence_floor = 0);

  //! Verdict on a decoded command; an accepted goal or acknowledgement raises the sender's counter.
  [[nodiscard]] CommandVerdict check(const operator_command_t& cmd) noexcept;
  //! Verdict on raw bytes from the bus: MALFORMED when they do not decode; then as check().
  [[nodiscard]] CommandVerdict check_bytes(std::span<const std::uint8_t> bytes, operator_command_t& cmd) noexcept;

  //! Last accepted sequence of sender, or the floor when none was accepted yet. [-]
  [[nodiscard]] std::int64_t last_sequence(std::int32_t sender_id) const noexcept;

 private:
  struct SenderCounter {
    std::int32_t sender_id = 0;
    std::int64_t last_sequence = 0;
  };
  CommandKey key_;
  std::int64_t sequence_floor_;
  std::array<SenderCounter, kMaxSenders> senders_{};
  std::size_t num_senders_ = 0;
};

}  // namespace mgc::firmware
