// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <cstdarg>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "planning_bench.hpp"

namespace mgc::bench {

//! The timing suites' (bus, loop) shared reporting.

//! A latency distribution as the timing suites (bus, loop) tabulate it: nearest-rank percentiles,
//! as the planning suites compute theirs; all zero for no samples.
struct LatencyStats {
  std::size_t n = 0;
  double median = 0.0, p95 = 0.0, p99 = 0.0, p999 = 0.0, max = 0.0;
};

[[nodiscard]] inline LatencyStats latency_stats(const std::vector<double>& values) {
  LatencyStats s;
  if (values.empty()) return s;
  s.n = values.size();
  s.median = percentile(values, 0.5);
  s.p95 = percentile(values, 0.95);
  s.p99 = percentile(values, 0.99);
  s.p999 = percentile(values, 0.999);
  s.max = *std::max_element(values.begin(), values.end());
  return s;
}

//! /proc/loadavg's first three fields: how busy the shared machine was around the run.
[[nodiscard]] inline std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  if (!(in >> one >> five >> fifteen)) return "unknown";
  return one + " " + five + " " + fifteen;
}

//! printf into a std::string of whatever length it takes.
[[gnu::format(printf, 1, 2)]] inline std::string fmt(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  std::string text(static_cast<std::size_t>(std::max(n, 0)) + 1, '\0');
  std::vsnprintf(text.data(), text.size(), format, args);
  va_end(args);
  text.resize(static_cast<std::size_t>(std::max(n, 0)));
  return text;
}

}  // namespace mgc::bench
