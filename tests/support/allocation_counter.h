// Counts heap allocations so tests can assert that a hot path is
// allocation-free. It replaces the global operator new/delete of the whole
// test binary (they only count, then defer to malloc/free), so include it in
// exactly one source file of a binary.
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

namespace quadhand::testing {
inline std::atomic<long> g_allocations{0};

// Heap allocations made so far by the binary.
inline long AllocationCount() { return g_allocations.load(); }
}  // namespace quadhand::testing

void* operator new(std::size_t size) {
  quadhand::testing::g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
