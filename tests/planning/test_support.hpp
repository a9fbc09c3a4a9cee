// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include <unistd.h>

namespace mgc::test {

inline constexpr double kDeg = std::numbers::pi / 180.0;

inline std::filesystem::path source_path(const std::string& relative) {
  return std::filesystem::path(MGC_SOURCE_DIR) / relative;
}

//! A scratch file under the system temp folder, removed when the object goes.
class TempFile {
 public:
  TempFile(const std::string& name, const std::string& text)
      : path_(std::filesystem::temp_directory_path() / ("mgc-test-" + std::to_string(::getpid()) + "-" + name)) {
    std::ofstream(path_) << text;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

//! text with its first occurrence of from replaced by to; the test fails when there is none.
//! (Catch2's REQUIRE: include this after catch.hpp.)
inline std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  REQUIRE(pos != std::string::npos);
  return text.replace(pos, from.size(), to);
}

}  // namespace mgc::test
