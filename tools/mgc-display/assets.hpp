// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <vector>

namespace mgc::display {

//! One file of the page (tools/mgc-display/web/), built into the binary.
struct Asset {
  const char* path;  //!< as served, e.g. "/app.js"
  const char* data;
  std::size_t size;  //!< [bytes]
};

//! Every embedded file of the page.
[[nodiscard]] const std::vector<Asset>& assets();

}  // namespace mgc::display
