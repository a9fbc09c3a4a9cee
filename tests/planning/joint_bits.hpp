// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstring>

#include "mgc/planning/joint.hpp"

namespace mgc::test {

//! Bit-for-bit equality of two joint vectors: the oracle tests' "the same first invalid sample".
inline bool same_bits(const planning::JointVector& a, const planning::JointVector& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

}  // namespace mgc::test
