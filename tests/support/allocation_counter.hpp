// SPDX-License-Identifier: Apache-2.0
#pragma once

// Linking allocation_counter.cpp into a test executable replaces global operator new/delete with
// versions that count every allocation, so a test can prove that code run every control cycle
// never touches the heap. One per executable: the replacement is program-wide.

namespace mgc::test {

//! Allocations through operator new since the program started.
[[nodiscard]] long allocation_count() noexcept;

}  // namespace mgc::test
