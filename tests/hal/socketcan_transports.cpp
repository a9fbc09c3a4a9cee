// SPDX-License-Identifier: Apache-2.0
// The transport the vcan VM's conformance run covers (scripts/vcan-vm/run-in-vm.sh brings vcan0 up).
#include "transport_support.hpp"

namespace mgc::test {

const std::vector<std::string>& conformance_transports() {
  static const std::vector<std::string> kinds{"socketcan"};
  return kinds;
}

}  // namespace mgc::test
