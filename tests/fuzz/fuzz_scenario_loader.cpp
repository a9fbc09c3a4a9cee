// SPDX-License-Identifier: Apache-2.0
// The scenario and machine loader (planning/io): load_and_build(), as mgc-plan calls it. The input
// is a scenario file; when it holds a line "#@machine", the bytes after that line are a machine
// file m.yaml beside it, which the scenario may name ("machine: m.yaml"). The shipped machines
// are there too (machines/), so the shipped scenarios are seeds as they are. Every bad input must
// end in InputError with a one-line message of at most kMaxMessageChars; any other exception, a
// crash or a hang fails the run.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <typeinfo>

#include "fuzz_support.hpp"
#include "mgc/planning/io/input_error.hpp"
#include "mgc/planning/io/input_limits.hpp"
#include "mgc/planning/io/scenario_loader.hpp"

using mgc::fuzz::require;
namespace io = mgc::planning::io;

namespace {

constexpr std::string_view kMachineMarker = "\n#@machine\n";

struct Folder {
  std::filesystem::path path;
  Folder() {
    std::string pattern = "/dev/shm/mgc-fuzz-loader-XXXXXX";
    require(::mkdtemp(pattern.data()) != nullptr, "cannot make a temporary folder");
    path = pattern;
    std::filesystem::create_directory_symlink(std::filesystem::path(MGC_SOURCE_DIR) / "scenarios" / "machines",
                                              path / "machines");
  }
  ~Folder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  Folder(const Folder&) = delete;
  Folder& operator=(const Folder&) = delete;
};

void write_file(const std::filesystem::path& file, std::string_view bytes) {
  std::FILE* f = std::fopen(file.c_str(), "wb");
  require(f != nullptr, "cannot write a temporary file");
  require(std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size(), "cannot write a temporary file");
  std::fclose(f);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Folder folder;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t marker = input.find(kMachineMarker);
  const std::filesystem::path scenario = folder.path / "s.yaml";
  const std::filesystem::path machine = folder.path / "m.yaml";
  write_file(scenario, input.substr(0, marker));
  if (marker == std::string_view::npos) {
    std::filesystem::remove(machine);
  } else {
    write_file(machine, input.substr(marker + kMachineMarker.size()));
  }

  try {
    const io::LoadedScenario loaded = io::load_and_build(scenario);
    require(loaded.model != nullptr && loaded.world != nullptr, "load_and_build() gave no model or world");
  } catch (const io::InputError& e) {
    const std::string_view what = e.what();
    require(what.find('\n') == std::string_view::npos, "an InputError message of more than one line");
    require(what.size() <= io::kMaxMessageChars, "an InputError message longer than kMaxMessageChars");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "load_and_build threw %s: %s\n", typeid(e).name(), e.what());
    mgc::fuzz::fail("the loader threw an exception it does not document");
  } catch (...) {
    mgc::fuzz::fail("the loader threw something that is not a std::exception");
  }
  return 0;
}
