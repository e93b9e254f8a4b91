#include "support/alloc_counter.hpp"

#include <atomic>
#include <cstddef>

// Counts every heap allocation of the process by interposing malloc/calloc/realloc (glibc): operator new
// and Eigen's aligned allocator both end up here, so nothing escapes the count.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
}

namespace {
std::atomic<std::size_t> g_allocations{0};
}

namespace exoid::test {
std::size_t allocationCount() { return g_allocations.load(std::memory_order_relaxed); }
}  // namespace exoid::test

extern "C" {
void* malloc(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
}
