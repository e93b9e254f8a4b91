#pragma once
// The one allocation counter of exoid's tests (link tests/support/alloc_counter.cpp into the test binary):
// global operator new / new[] (all variants) are replaced and counted, and glibc's malloc, calloc, realloc,
// memalign, aligned_alloc and posix_memalign are interposed and counted, so Eigen's, MuJoCo's and any C
// library's heap use is seen too (operator new itself allocates through malloc).
#include <cstddef>

namespace exoid::test {

/// malloc-family calls so far in this process.
std::size_t allocationCount();
/// Global operator new / new[] calls so far in this process.
std::size_t operatorNewCount();

/// Counts what is allocated between construction and stop() (or now, before stop()).
class AllocationCounter {
 public:
  AllocationCounter() : mallocs0_(allocationCount()), news0_(operatorNewCount()) {}
  void stop() {
    if (!stopped_) mallocs1_ = allocationCount(), news1_ = operatorNewCount(), stopped_ = true;
  }
  long mallocs() const { return static_cast<long>((stopped_ ? mallocs1_ : allocationCount()) - mallocs0_); }
  long news() const { return static_cast<long>((stopped_ ? news1_ : operatorNewCount()) - news0_); }

 private:
  std::size_t mallocs0_, news0_, mallocs1_ = 0, news1_ = 0;
  bool stopped_ = false;
};

}  // namespace exoid::test
