// SPDX-License-Identifier: Apache-2.0
#pragma once

// Number checks for the programs' command lines. CLI11's PositiveNumber and NonNegativeNumber
// refuse a value by naming their range up to the largest double; these say in words what was
// expected: "--runs: expected a number above 0, got '0'".

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <string>

namespace mgc::tools {

namespace detail {

inline CLI::Validator number_check(bool zero_allowed) {
  return CLI::Validator(
      [zero_allowed](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        const bool number = end != text.c_str() && *end == '\0' && std::isfinite(v);
        if (number && (zero_allowed ? v >= 0.0 : v > 0.0)) return {};
        return std::string("expected a number ") + (zero_allowed ? "of 0 or more" : "above 0") + ", got '" + text + "'";
      },
      zero_allowed ? "NONNEGATIVE" : "POSITIVE");
}

}  // namespace detail

//! A finite number above 0.
inline CLI::Validator positive_number() { return detail::number_check(false); }
//! A finite number of 0 or more.
inline CLI::Validator nonnegative_number() { return detail::number_check(true); }

}  // namespace mgc::tools
