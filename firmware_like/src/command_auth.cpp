// SPDX-License-Identifier: Apache-2.0
#include "mgc/firmware/command_auth.hpp"

#include <mgc/command_status_t.hpp>

#include <sodium.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>

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

const char* command_reason_name(std::int8_t reason) noexcept {
  switch (reason) {
    case Status::REASON_ACCEPTED: return "accepted";
    case Status::REASON_BAD_MAC: return "bad MAC";
    case Status::REASON_STALE_SEQUENCE: return "stale sequence";
    case Status::REASON_UNKNOWN_KIND: return "unknown kind";
    case Status::REASON_MALFORMED: return "malformed";
    case Status::REASON_TOO_MANY_SENDERS: return "too many senders";
    case Status::REASON_QUEUE_FULL: return "queue full";
    case Status::REASON_FUTURE_SEQUENCE: return "sequence ahead of the clock";
    case Status::REASON_OLD_SEQUENCE: return "sequence behind the clock";
    case Status::REASON_STATE_NOT_SAVED: return "state not saved";
    default: return "unknown";
  }
}

CommandKey::~CommandKey() { sodium_memzero(bytes_.data(), bytes_.size()); }

CommandKey load_command_key(const std::string& path) { return load_key_file(path, "command key file"); }

CommandKey load_key_file(const std::string& path, const char* what) {
  struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) {
    throw CommandKeyError(std::string(what) + " " + path + ": cannot open (" + std::strerror(errno) +
                          "); expected 32 raw bytes");
  }
  std::array<std::uint8_t, kCommandKeyBytes + 1> buf{};
  const std::size_t n = std::fread(buf.data(), 1, buf.size(), file.get());
  if (n != kCommandKeyBytes) {
    const std::string got = n > kCommandKeyBytes ? "more than 32" : std::to_string(n);
    sodium_memzero(buf.data(), buf.size());
    throw CommandKeyError(std::string(what) + " " + path + ": " + got + " bytes; expected exactly 32 raw bytes");
  }
  std::array<std::uint8_t, kCommandKeyBytes> key{};
  std::memcpy(key.data(), buf.data(), key.size());
  sodium_memzero(buf.data(), buf.size());
  CommandKey result(key);
  sodium_memzero(key.data(), key.size());
  return result;
}

std::size_t command_canonical_bytes(const operator_command_t& cmd, std::span<std::uint8_t> out) noexcept {
  return encoded_without_mac(cmd, out);
}

void compute_mac(std::span<const std::uint8_t> bytes, const CommandKey& key, std::uint8_t* mac) noexcept {
  crypto_auth(mac, bytes.data(), bytes.size(), key.bytes().data());
}

bool mac_verifies(std::span<const std::uint8_t> bytes, const CommandKey& key, const std::uint8_t* mac) noexcept {
  return crypto_auth_verify(mac, bytes.data(), bytes.size(), key.bytes().data()) == 0;
}

void sign_command(operator_command_t& cmd, const CommandKey& key) noexcept {
  std::array<std::uint8_t, kCommandEncodedMaxBytes> buf{};
  const std::size_t n = command_canonical_bytes(cmd, buf);
  compute_mac(std::span(buf.data(), n), key, cmd.mac);
}

CommandAuthenticator::CommandAuthenticator(const CommandKey& key, std::int64_t sequence_floor, std::int64_t max_skew_us)
    : key_(key), sequence_floor_(sequence_floor), max_skew_us_(max_skew_us) {
  if (max_skew_us <= 0) throw std::invalid_argument("CommandAuthenticator: the tolerated clock skew must be > 0 µs");
  // Idempotent and thread-safe; picks the fastest implementation once, before any check().
  if (sodium_init() < 0) throw std::runtime_error("libsodium: sodium_init failed");
}

void CommandAuthenticator::restore(std::span<const SenderCounter> counters) {
  if (counters.size() > kMaxSenders) {
    throw std::invalid_argument("command replay counters: " + std::to_string(counters.size()) + " senders, at most " +
                                std::to_string(kMaxSenders));
  }
  for (std::size_t i = 0; i < counters.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k) {
      if (counters[k].sender_id == counters[i].sender_id) {
        throw std::invalid_argument("command replay counters: sender " + std::to_string(counters[i].sender_id) +
                                    " listed twice");
      }
    }
  }
  num_senders_ = counters.size();
  for (std::size_t i = 0; i < counters.size(); ++i) {
    senders_[i] = counters[i];
    senders_[i].last_sequence = std::max(counters[i].last_sequence, sequence_floor_);
  }
  ++revision_;
}

std::int64_t CommandAuthenticator::last_sequence(std::int32_t sender_id) const noexcept {
  for (std::size_t i = 0; i < num_senders_; ++i) {
    if (senders_[i].sender_id == sender_id) return senders_[i].last_sequence;
  }
  return sequence_floor_;
}

CommandVerdict CommandAuthenticator::check(const operator_command_t& cmd, std::int64_t now_us) noexcept {
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
  if (n == 0 || !mac_verifies(std::span(buf.data(), n), key_, cmd.mac)) {
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
  // The window before the counter: a sequence far ahead would otherwise become the sender's
  // counter and lock the real sender out. The bounds are computed from now_us, a realistic clock
  // far from the int64 limits, so that no sequence can make them overflow.
  if (cmd.sequence > now_us + max_skew_us_) return {false, Status::REASON_FUTURE_SEQUENCE};
  if (cmd.sequence < now_us - max_skew_us_) return {false, Status::REASON_OLD_SEQUENCE};
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
  ++revision_;
  return {true, Status::REASON_ACCEPTED};
}

CommandVerdict CommandAuthenticator::check_bytes(std::span<const std::uint8_t> bytes, operator_command_t& cmd,
                                                 std::int64_t now_us) noexcept {
  cmd = operator_command_t{};
  const int size = static_cast<int>(bytes.size());
  // The encoding has one size: trailing bytes would be unauthenticated, so they are refused too.
  if (cmd.decode(bytes.data(), 0, size) != size || size != cmd.getEncodedSize()) {
    cmd = operator_command_t{};
    return {false, Status::REASON_MALFORMED};
  }
  return check(cmd, now_us);
}

namespace {

constexpr const char* kStateHeader = "mgc-command-state 1";

[[noreturn]] void state_error(const std::string& path, int line, const std::string& what) {
  throw CommandStateError("command state file " + path + " (line " + std::to_string(line) + "): " + what +
                          "; remove the file to start with the clock window only (docs/operator-feed.md)");
}

bool parse_i64(const std::string& text, std::int64_t& out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (errno != 0 || end != text.c_str() + text.size()) return false;
  out = v;
  return true;
}

}  // namespace

std::vector<SenderCounter> load_command_state(const std::string& path) {
  struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "r"));
  if (!file) {
    if (errno == ENOENT) return {};  // the first start: nothing accepted yet
    throw CommandStateError("command state file " + path + ": cannot open (" + std::strerror(errno) +
                            "); expected a readable file or none");
  }
  std::string content;
  std::array<char, 1024> chunk{};
  std::size_t got = 0;
  while ((got = std::fread(chunk.data(), 1, chunk.size(), file.get())) > 0) content.append(chunk.data(), got);
  if (std::ferror(file.get()) != 0) {
    throw CommandStateError("command state file " + path + ": read error (" + std::strerror(errno) + ")");
  }
  std::istringstream in(content);
  std::vector<SenderCounter> counters;
  std::string line;
  int line_no = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    if (!have_header) {
      if (line != kStateHeader) state_error(path, line_no, "header \"" + line + "\", expected \"" + kStateHeader + "\"");
      have_header = true;
      continue;
    }
    std::istringstream fields(line);
    std::string word;
    std::string id_text;
    std::string seq_text;
    std::string extra;
    fields >> word >> id_text >> seq_text;
    if (word != "sender") state_error(path, line_no, "\"" + word + "\", expected \"sender ID SEQUENCE_US\"");
    std::int64_t id = 0;
    if (!parse_i64(id_text, id) || id < INT32_MIN || id > INT32_MAX) {
      state_error(path, line_no, "sender id \"" + id_text + "\", expected an int32");
    }
    std::int64_t seq = 0;
    if (!parse_i64(seq_text, seq) || seq < 0) {
      state_error(path, line_no, "sequence \"" + seq_text + "\", expected a non-negative integer [µs]");
    }
    if (fields >> extra) state_error(path, line_no, "trailing \"" + extra + "\", expected \"sender ID SEQUENCE_US\"");
    for (const SenderCounter& c : counters) {
      if (c.sender_id == id) state_error(path, line_no, "sender " + id_text + " listed twice, expected once");
    }
    if (counters.size() == CommandAuthenticator::kMaxSenders) {
      state_error(path, line_no, "more than " + std::to_string(CommandAuthenticator::kMaxSenders) + " senders");
    }
    counters.push_back({static_cast<std::int32_t>(id), seq});
  }
  // An empty file is what a crash between create and write leaves behind without the rename
  // protocol; with it, a file without its header is damage, never a normal state.
  if (!have_header) state_error(path, std::max(line_no, 1), "no header, expected \"" + std::string(kStateHeader) + "\"");
  return counters;
}

int save_command_state(const std::string& path, std::span<const SenderCounter> counters) noexcept {
  // Fixed buffers: the saver runs on the I/O thread, which allocates as little as it can.
  std::array<char, 4096> tmp{};
  if (std::snprintf(tmp.data(), tmp.size(), "%s.tmp", path.c_str()) >= static_cast<int>(tmp.size())) return ENAMETOOLONG;
  std::array<char, 64 + 48 * CommandAuthenticator::kMaxSenders> text{};
  int len = std::snprintf(text.data(), text.size(), "%s\n", kStateHeader);
  for (const SenderCounter& c : counters) {
    const int room = static_cast<int>(text.size()) - len;
    const int n = std::snprintf(text.data() + len, static_cast<std::size_t>(room), "sender %" PRId32 " %" PRId64 "\n",
                                c.sender_id, c.last_sequence);
    if (n < 0 || n >= room) return EOVERFLOW;
    len += n;
  }
  const int fd = ::open(tmp.data(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return errno;
  int err = 0;
  for (int done = 0; done < len && err == 0;) {
    const ssize_t w = ::write(fd, text.data() + done, static_cast<std::size_t>(len - done));
    if (w < 0 && errno != EINTR) err = errno;
    if (w > 0) done += static_cast<int>(w);
  }
  if (err == 0 && ::fsync(fd) != 0) err = errno;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err == 0 && std::rename(tmp.data(), path.c_str()) != 0) err = errno;
  if (err != 0) {
    ::unlink(tmp.data());
    return err;
  }
  // The rename is durable only once the directory is.
  std::array<char, 4096> dir{};
  std::snprintf(dir.data(), dir.size(), "%s", path.c_str());
  char* slash = std::strrchr(dir.data(), '/');
  if (slash == nullptr) {
    std::snprintf(dir.data(), dir.size(), ".");
  } else if (slash == dir.data()) {
    slash[1] = '\0';
  } else {
    *slash = '\0';
  }
  const int dfd = ::open(dir.data(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return errno;
  if (::fsync(dfd) != 0) err = errno;
  ::close(dfd);
  return err;
}

}  // namespace mgc::firmware
