// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

// Files for the site generators' tests: the shipped machine files, a fresh folder, a file's bytes.
namespace mgc::bench::test {

inline const std::filesystem::path kMachines = std::filesystem::path(MGC_SOURCE_DIR) / "scenarios" / "machines";

//! An empty folder of the system's temporary folder, named by the test and this process.
inline std::filesystem::path fresh_folder(const std::string& name) {
  const auto folder = std::filesystem::temp_directory_path() / ("mgc-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  return folder;
}

inline std::string read(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace mgc::bench::test
