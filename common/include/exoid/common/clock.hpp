#pragma once
// Clock readings in nanoseconds (clock_gettime: no allocation, no system call on Linux's vDSO for the monotonic clock).
#include <time.h>

#include <cstdint>

namespace exoid::common {

inline int64_t clockNs(clockid_t clock) {
  timespec ts;
  clock_gettime(clock, &ts);
  return int64_t{ts.tv_sec} * 1000000000 + ts.tv_nsec;
}
inline int64_t monoNs() { return clockNs(CLOCK_MONOTONIC); }
/// CPU time of the calling thread: wall time minus this is time it was not running (preempted, or the hypervisor ran
/// something else on its CPU).
inline int64_t threadCpuNs() { return clockNs(CLOCK_THREAD_CPUTIME_ID); }

}  // namespace exoid::common
