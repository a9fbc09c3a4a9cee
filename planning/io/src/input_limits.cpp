// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/io/input_limits.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <system_error>

namespace mgc::planning::io {
namespace {

const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "another kind of file";
}

std::string stat_problem(const struct stat& st) {
  if (!S_ISREG(st.st_mode)) return std::string("expected a regular file, got ") + file_kind(st.st_mode);
  if (static_cast<std::uintmax_t>(st.st_size) > kMaxFileBytes) {
    return "the file has " + std::to_string(st.st_size) + " bytes, above the limit of " + std::to_string(kMaxFileBytes) +
           " (16 MiB)";
  }
  return {};
}

std::string errno_problem(const char* what, int error) {
  // The bare words for the common case: programs and their tests have long printed exactly these.
  if (error == ENOENT) return what;
  if (error == ENAMETOOLONG) {
    return std::string(what) + ": the path name is too long (at most " + std::to_string(NAME_MAX) +
           " bytes per name and " + std::to_string(PATH_MAX) + " in all)";
  }
  return std::string(what) + ": " + std::system_category().message(error);
}

}  // namespace

std::string echo(std::string_view text, std::size_t max_chars) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(std::min(text.size(), max_chars) + 8);
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      out += "\\x";
      out += kHex[u >> 4];
      out += kHex[u & 0xf];
    } else {
      out += c;
    }
    // Stop early: a megabyte value needs only its first few characters.
    if (out.size() > max_chars) break;
  }
  if (out.size() <= max_chars) return out;
  std::string marker = "... (";
  marker.append(std::to_string(text.size())).append(" characters)");
  std::size_t keep = max_chars > marker.size() ? max_chars - marker.size() : 0;
  // Never split a UTF-8 sequence: back up over continuation bytes to the start of a character.
  while (keep > 0 && (static_cast<unsigned char>(out[keep]) & 0xc0) == 0x80) --keep;
  out.resize(keep);
  out.append(marker);
  return out;
}

std::string input_file_problem(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return errno_problem("cannot open the file", errno);
  return stat_problem(st);
}

std::string read_input_file(const std::filesystem::path& path, std::string& text) {
  text.clear();
  // Look before opening: opening a FIFO without a writer would block.
  if (std::string problem = input_file_problem(path); !problem.empty()) return problem;
  // O_NONBLOCK: should the path have turned into a FIFO since, opening still returns at once.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return errno_problem("cannot open the file", errno);
  std::string problem;
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    problem = errno_problem("cannot open the file", errno);
  } else {
    problem = stat_problem(st);
  }
  // Read one byte past the limit: files under /proc report size 0 but may hold more.
  char buffer[65536];
  while (problem.empty()) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      problem = errno_problem("cannot read the file", errno);
    } else if (n == 0) {
      break;
    } else {
      text.append(buffer, static_cast<std::size_t>(n));
      if (text.size() > kMaxFileBytes) problem = "the file has more than " + std::to_string(kMaxFileBytes) + " bytes (16 MiB), the limit";
    }
  }
  ::close(fd);
  if (!problem.empty()) text.clear();
  return problem;
}

}  // namespace mgc::planning::io
