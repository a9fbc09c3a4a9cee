// SPDX-License-Identifier: Apache-2.0
// Every no-allocation suite links this: a counter that counted nothing would make their zeros
// meaningless, so each suite first shows that it counts.
#include <catch2/catch.hpp>

#include <memory>

#include "allocation_counter.hpp"

TEST_CASE("the allocation counter sees allocations (a zero below means something)", "[unit]") {
  const long before = mgc::test::allocation_count();
  auto p = std::make_unique<int>(42);
  CHECK(*p == 42);
  CHECK(mgc::test::allocation_count() > before);
}
