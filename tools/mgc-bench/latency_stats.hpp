// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "planning_bench.hpp"

namespace mgc::bench {

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

}  // namespace mgc::bench
