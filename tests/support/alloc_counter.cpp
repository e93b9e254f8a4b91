#include "support/alloc_counter.hpp"

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <new>

namespace {
std::atomic<std::size_t> g_mallocs{0};
std::atomic<std::size_t> g_news{0};

void* countedNew(std::size_t n) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  return p;
}
void* countedAlignedNew(std::size_t n, std::align_val_t a) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  void* p = nullptr;
  if (posix_memalign(&p, static_cast<std::size_t>(a), n ? n : 1) != 0) throw std::bad_alloc();
  return p;
}
}  // namespace

namespace exoid::test {
std::size_t allocationCount() { return g_mallocs.load(std::memory_order_relaxed); }
std::size_t operatorNewCount() { return g_news.load(std::memory_order_relaxed); }
}  // namespace exoid::test

void* operator new(std::size_t n) { return countedNew(n); }
void* operator new[](std::size_t n) { return countedNew(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_news.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) { return countedAlignedNew(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return countedAlignedNew(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define EXOID_ALLOC_COUNTER_ASAN 1
#endif
#endif
#ifdef EXOID_ALLOC_COUNTER_ASAN
// The sanitizer build (docs/testing.md): AddressSanitizer owns malloc, so the counter cannot interpose it;
// ASan's allocation hook sees every malloc, calloc, realloc and aligned allocation instead.
#include <sanitizer/allocator_interface.h>
namespace {
void onMalloc(const volatile void*, std::size_t) { g_mallocs.fetch_add(1, std::memory_order_relaxed); }
void onFree(const volatile void*) {}
const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(onMalloc, onFree);
}  // namespace
#else
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

static inline void countMalloc() { g_mallocs.fetch_add(1, std::memory_order_relaxed); }
void* malloc(std::size_t n) {
  countMalloc();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t s) {
  countMalloc();
  return __libc_calloc(n, s);
}
void* realloc(void* p, std::size_t n) {
  countMalloc();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t a, std::size_t n) {
  countMalloc();
  return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  countMalloc();
  return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
  countMalloc();
  *out = __libc_memalign(a, n);
  return *out ? 0 : ENOMEM;
}
void free(void* p) { __libc_free(p); }
}
#endif
