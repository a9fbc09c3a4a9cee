// SPDX-License-Identifier: Apache-2.0
// Malformed-frame sweeps shared by the codec tests.
#pragma once

#include <catch2/catch.hpp>

#include "mgc/hal/can_frame.hpp"
#include "mgc/hal/status.hpp"

namespace mgc::test {

//! Every dlc 0..8 but the good frame's own decodes to WrongLength; extended, RTR and error
//! variants of the id decode to WrongId.
template <class Decoder>
void check_malformed_framing(const hal::CanFrame& good, Decoder decode) {
  REQUIRE(decode(good).ok());
  for (std::uint8_t dlc = 0; dlc <= hal::kCanMaxDlc; ++dlc) {
    if (dlc == good.dlc) continue;
    hal::CanFrame f = good;
    f.dlc = dlc;
    CAPTURE(static_cast<int>(dlc));
    CHECK(decode(f).status == hal::Status::WrongLength);
  }
  for (const std::uint32_t flag : {hal::kCanEffFlag, hal::kCanRtrFlag, hal::kCanErrFlag}) {
    hal::CanFrame f = good;
    f.can_id |= flag;
    CAPTURE(flag);
    CHECK(decode(f).status == hal::Status::WrongId);
  }
}

}  // namespace mgc::test
