// SPDX-License-Identifier: Apache-2.0
#include "allocation_counter.hpp"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<long> g_allocations{0};
}

long mgc::test::allocation_count() noexcept { return g_allocations.load(std::memory_order_relaxed); }

#if defined(__SANITIZE_ADDRESS__)
// The counting operator new/delete pair malloc with free; ASan, whose own operator new is
// interposed alongside, misreads some of those pairs as mismatched. Every other check stays on. A
// default of the binary itself, so that it holds wherever the binary runs (ctest's discovery at
// build time included).
extern "C" const char* __asan_default_options() { return "alloc_dealloc_mismatch=0"; }
#endif

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
