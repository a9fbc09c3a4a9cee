// SPDX-License-Identifier: Apache-2.0
// The command replay state file (load_command_state, firmware_like/src/command_auth.cpp), which
// mgc reads at start: the input is the file's bytes. A bad file must end in CommandStateError
// (the controller then refuses to start), never in another exception or a crash; a good one must
// be accepted by CommandAuthenticator::restore() and survive save_command_state() unchanged.
#include <mgc/firmware/command_auth.hpp>

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "fuzz_support.hpp"

using namespace mgc::firmware;
using mgc::fuzz::require;

namespace {

// A folder of its own in memory, removed when the process ends.
struct Folder {
  std::string path;
  Folder() {
    std::string pattern = "/dev/shm/mgc-fuzz-state-XXXXXX";
    require(::mkdtemp(pattern.data()) != nullptr, "cannot make a temporary folder");
    path = pattern;
  }
  ~Folder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  Folder(const Folder&) = delete;
  Folder& operator=(const Folder&) = delete;
};

void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  require(f != nullptr, "cannot write the temporary file");
  require(std::fwrite(data, 1, size, f) == size, "cannot write the temporary file");
  std::fclose(f);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Folder folder;
  static const std::string path = folder.path + "/state";
  static const std::string copy = folder.path + "/copy";
  write_file(path, data, size);

  std::vector<SenderCounter> counters;
  try {
    counters = load_command_state(path);
  } catch (const CommandStateError& e) {
    const std::string what = e.what();
    require(what.find('\n') == std::string::npos, "a CommandStateError message of more than one line");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "load_command_state threw %s\n", e.what());
    mgc::fuzz::fail("load_command_state threw an exception it does not document");
  }
  require(counters.size() <= CommandAuthenticator::kMaxSenders, "more senders than the authenticator takes");
  CommandAuthenticator auth(CommandKey(mgc::fuzz::command_key_bytes()), 0);
  try {
    auth.restore(counters);
  } catch (const std::exception&) {
    mgc::fuzz::fail("restore() refused counters that load_command_state accepted");
  }
  require(save_command_state(copy, counters) == 0, "save_command_state failed");
  std::vector<SenderCounter> again;
  try {
    again = load_command_state(copy);
  } catch (const std::exception&) {
    mgc::fuzz::fail("a saved state file does not load");
  }
  require(again.size() == counters.size(), "a saved state file loads with another sender count");
  for (std::size_t i = 0; i < again.size(); ++i) {
    require(again[i].sender_id == counters[i].sender_id && again[i].last_sequence == counters[i].last_sequence,
            "a saved state file loads with other counters");
  }
  return 0;
}
