// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

namespace mgc::tools {

//! Draws what a controller run did: the scenario, the path of the tool point as `mgc --trace-csv`
//! recorded it, and the tracked dynamic obstacles where they were at the end of the trace. Returns
//! the exit code: 0 written, 2 bad input (a one-line message names the file, line and column).
[[nodiscard]] int run_trace_view(const std::string& scenario_file, const std::string& trace_csv, const std::string& svg);

}  // namespace mgc::tools
