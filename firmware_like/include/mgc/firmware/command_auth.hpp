// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <mgc/operator_command_t.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

//! Authentication of operator commands (docs/operator-feed.md): a stop is obeyed from anyone;
//! a goal or an acknowledgement, which can cause motion, needs a valid shared-key MAC
//! (libsodium crypto_auth, HMAC-SHA-512-256) and a sequence (the sender's CLOCK_REALTIME in µs)
//! above the sender's last accepted one and within the tolerated skew of the controller's clock.
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

//! Reads a key file: exactly 32 raw bytes (e.g. `head -c 32 /dev/urandom > mgc.key`). A missing,
//! unreadable, short or long file throws CommandKeyError whose message starts with `what` (e.g.
//! "site key file"). The operator-command key and the site key share the format. Start-up only
//! (allocates, may block).
[[nodiscard]] CommandKey load_key_file(const std::string& path, const char* what);

//! load_key_file(path, "command key file").
[[nodiscard]] CommandKey load_command_key(const std::string& path);

//! The bytes a MAC covers for an LCM message whose last field is a kCommandMacBytes mac: its
//! encoding (fingerprint and every field) without the trailing mac. Returns the length written into
//! out (0 if out is too small). RT-safe for fixed-size messages: no alloc, no lock, no throw.
template <class Msg>
std::size_t encoded_without_mac(const Msg& msg, std::span<std::uint8_t> out) noexcept {
  static_assert(sizeof(msg.mac) == kCommandMacBytes, "the message's mac must be a crypto_auth MAC");
  const int size = msg.getEncodedSize();
  if (size <= static_cast<int>(kCommandMacBytes) || static_cast<std::size_t>(size) > out.size()) return 0;
  if (msg.encode(out.data(), 0, size) != size) return 0;
  return static_cast<std::size_t>(size) - kCommandMacBytes;
}

//! crypto_auth of bytes under key into mac. RT-safe.
void compute_mac(std::span<const std::uint8_t> bytes, const CommandKey& key, std::uint8_t* mac) noexcept;
//! Whether mac is crypto_auth of bytes under key (constant time). RT-safe.
[[nodiscard]] bool mac_verifies(std::span<const std::uint8_t> bytes, const CommandKey& key, const std::uint8_t* mac) noexcept;

//! The verdict on one command; reason uses command_status_t::REASON_* values.
struct CommandVerdict {
  bool accepted = false;
  std::int8_t reason = 0;   //!< command_status_t::REASON_* [enum]
};

//! Short English name of a command_status_t::REASON_* code, e.g. "bad MAC". Never null.
[[nodiscard]] const char* command_reason_name(std::int8_t reason) noexcept;

//! The bytes the MAC covers: the LCM encoding of cmd (fingerprint and every field) without the
//! trailing mac field. Returns the length written into out (0 if out is too small).
//! RT-safe: no alloc, no lock, no throw.
std::size_t command_canonical_bytes(const operator_command_t& cmd, std::span<std::uint8_t> out) noexcept;

//! Fills cmd.mac for key over command_canonical_bytes(cmd) (the sender's side; tests and tools).
void sign_command(operator_command_t& cmd, const CommandKey& key) noexcept;

//! The tolerated difference between a command's sequence (the sender's CLOCK_REALTIME) and the
//! controller's CLOCK_REALTIME, either way: clocks kept by NTP agree far better, and a recorded
//! command is useless this long after it was signed. [µs]
inline constexpr std::int64_t kDefaultCommandSkew_us = 5'000'000;

//! One sender's replay counter.
struct SenderCounter {
  std::int32_t sender_id = 0;      //!< [-]
  std::int64_t last_sequence = 0;  //!< last accepted sequence [µs]
};

//! Checks commands against the key, the controller's clock and a per-sender replay table of fixed
//! capacity. A goal or acknowledgement is accepted only when its sequence lies within
//! [now - max_skew, now + max_skew] of the controller's CLOCK_REALTIME (passed in), above
//! sequence_floor and above the sender's last accepted sequence. The window bounds any jump: a
//! signed sequence far in the future is refused and cannot lock the real sender out.
//! The counters survive a restart through restore() and save_command_state() (the caller's job,
//! off the control loop); the controller passes sequence_floor = its start time minus max_skew.
//! Not thread-safe: one thread (the LCM I/O thread) calls check(). RT-safe after construction.
class CommandAuthenticator {
 public:
  static constexpr std::size_t kMaxSenders = 16;  //!< senders tracked; more are refused [-]

  //! max_skew_us must be > 0; throws std::invalid_argument otherwise. Start-up only.
  explicit CommandAuthenticator(const CommandKey& key, std::int64_t sequence_floor = 0,
                                std::int64_t max_skew_us = kDefaultCommandSkew_us);

  //! Takes counters saved before a restart (load_command_state()); a counter below the floor is
  //! raised to it. Start-up only: throws std::invalid_argument for more than kMaxSenders senders or
  //! a sender listed twice.
  void restore(std::span<const SenderCounter> counters);

  //! Verdict on a decoded command at the controller's CLOCK_REALTIME now_us; an accepted goal or
  //! acknowledgement raises the sender's counter. RT-safe: no alloc, no lock, no throw.
  [[nodiscard]] CommandVerdict check(const operator_command_t& cmd, std::int64_t now_us) noexcept;
  //! Verdict on raw bytes from the bus: MALFORMED when they do not decode; then as check().
  [[nodiscard]] CommandVerdict check_bytes(std::span<const std::uint8_t> bytes, operator_command_t& cmd,
                                           std::int64_t now_us) noexcept;

  //! Last accepted sequence of sender, or the floor when none was accepted yet. [µs]
  [[nodiscard]] std::int64_t last_sequence(std::int32_t sender_id) const noexcept;
  //! The replay table, for saving. [-]
  [[nodiscard]] std::span<const SenderCounter> senders() const noexcept { return {senders_.data(), num_senders_}; }
  //! Counts changes of the replay table: a saver compares it with the value it last saved. [-]
  [[nodiscard]] std::uint64_t revision() const noexcept { return revision_; }
  [[nodiscard]] std::int64_t sequence_floor() const noexcept { return sequence_floor_; }
  [[nodiscard]] std::int64_t max_skew_us() const noexcept { return max_skew_us_; }

 private:
  CommandKey key_;
  std::int64_t sequence_floor_;
  std::int64_t max_skew_us_;
  std::array<SenderCounter, kMaxSenders> senders_{};
  std::size_t num_senders_ = 0;
  std::uint64_t revision_ = 0;
};

//! Thrown by load_command_state() with a one-line message naming the file, the line and field,
//! the value and what was expected.
class CommandStateError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

//! Reads the replay counters saved by save_command_state(). A missing file is a first start and
//! gives no counters; an unreadable or malformed file throws CommandStateError (the controller
//! refuses to start: docs/operator-feed.md). Start-up only (allocates, may block).
[[nodiscard]] std::vector<SenderCounter> load_command_state(const std::string& path);

//! Writes the counters to path atomically: a temporary file beside it (path + ".tmp"), fsync,
//! rename over path, fsync of the directory. Returns 0, or the errno of the step that failed
//! (path is then unchanged). No allocation; may block: never on the control loop thread.
int save_command_state(const std::string& path, std::span<const SenderCounter> counters) noexcept;

}  // namespace mgc::firmware
