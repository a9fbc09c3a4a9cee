// SPDX-License-Identifier: Apache-2.0
// The transports the host's conformance run covers: those that need no CAN in the kernel.
#include "transport_support.hpp"

namespace mgc::test {

const std::vector<std::string>& conformance_transports() {
  static const std::vector<std::string> kinds{"loop", "udp"};
  return kinds;
}

}  // namespace mgc::test
