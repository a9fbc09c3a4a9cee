// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <stdexcept>
#include <string>

namespace mgc::planning::io {

//! A problem with an input file, as one line: "<file>:<line>: <field>: <what was expected>, got
//! <what was found>". Programs print it and exit with status 2. The line is at most
//! kMaxMessageChars long, its pieces cut and their control characters escaped (echo(),
//! input_limits.hpp); file() keeps the whole path.
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, int line, const std::string& field, const std::string& message);

  [[nodiscard]] const std::string& file() const noexcept { return file_; }
  [[nodiscard]] int line() const noexcept { return line_; }
  [[nodiscard]] const std::string& field() const noexcept { return field_; }

 private:
  std::string file_;
  int line_ = 0;
  std::string field_;
};

}  // namespace mgc::planning::io
