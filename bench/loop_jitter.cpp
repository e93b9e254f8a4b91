// exoid_loop_jitter: the machine's floor under a 1 kHz real-time loop (docs/sim.md, "Loop timing"). A bare loop placed
// as `exoid experiment --realtime` places exo_sim (the last allowed CPU, SCHED_FIFO 50, mlockall) sleeps to each
// 1 ms slot (clock_nanosleep, absolute) and spins BUSY_US of work (no system call): what it loses is what the
// machine takes from any loop there. Prints how late the wake-ups were, the slots a tick of BUSY_US would have
// missed, and the gaps inside the busy work, split by whether the thread's CPU clock ran through them (interrupt
// work charged to the thread) or not (preempted, or the hypervisor ran something else).
//
// usage: exoid_loop_jitter [SECONDS=10] [BUSY_US=250] [CPU=-1: the last allowed]   (root for SCHED_FIFO)
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "exoid/common/clock.hpp"

namespace {

using exoid::common::clockNs;

/// A whole number in [lo, hi] from argv[i] (default when absent); false on anything else.
bool argument(int argc, char** argv, int i, long lo, long hi, long* v) {
  if (i >= argc) return true;
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(argv[i], &end, 10);
  if (errno || end == argv[i] || *end || x < lo || x > hi) return false;
  *v = x;
  return true;
}

struct Floor {
  int64_t ticks = 0, late_max = 0, late_100us = 0, late_500us = 0, missed = 0;
  int64_t gap_max = 0, gaps_charged = 0, gaps_away = 0, charged_ns = 0, away_ns = 0;
};

/// Slot k: sleep to its start, then BUSY_US of spinning, watching for gaps over 200 us.
void runSlots(int64_t n, int64_t busy_ns, Floor& f) {
  const int64_t t0 = clockNs(CLOCK_MONOTONIC) + 1000000;
  for (int64_t k = 0; k < n; ++k, ++f.ticks) {
    const int64_t slot = t0 + k * 1000000;
    const timespec ts{static_cast<time_t>(slot / 1000000000), static_cast<long>(slot % 1000000000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    const int64_t start = clockNs(CLOCK_MONOTONIC), late = start - slot;
    f.late_max = std::max(f.late_max, late);
    f.late_100us += late > 100000;
    f.late_500us += late > 500000;
    int64_t prev = start, prev_cpu = clockNs(CLOCK_THREAD_CPUTIME_ID);
    while (prev < start + busy_ns) {
      const int64_t now = clockNs(CLOCK_MONOTONIC), cpu = clockNs(CLOCK_THREAD_CPUTIME_ID), gap = now - prev;
      if (gap > 200000) {
        const bool charged = cpu - prev_cpu > gap / 2;
        ++(charged ? f.gaps_charged : f.gaps_away);
        (charged ? f.charged_ns : f.away_ns) += gap;
      }
      f.gap_max = std::max(f.gap_max, gap);
      prev = now;
      prev_cpu = cpu;
    }
    f.missed += prev > slot + 1000000;
  }
}

}  // namespace

int main(int argc, char** argv) {
  long seconds = 10, busy_us = 250, cpu = -1;
  if (!argument(argc, argv, 1, 1, 3600, &seconds) || !argument(argc, argv, 2, 0, 900, &busy_us) ||
      !argument(argc, argv, 3, -1, CPU_SETSIZE - 1, &cpu) || argc > 4) {
    std::fprintf(stderr, "usage: exoid_loop_jitter [SECONDS=10 (1-3600)] [BUSY_US=250 (0-900)] [CPU=-1]\n");
    return 2;
  }
  cpu_set_t set;
  CPU_ZERO(&set);
  if (cpu < 0 && sched_getaffinity(0, sizeof set, &set) == 0)
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) cpu = c;
  CPU_ZERO(&set);
  CPU_SET(static_cast<int>(cpu), &set);
  sched_param sp{};
  sp.sched_priority = 50;
  if (sched_setaffinity(0, sizeof set, &set) != 0 || sched_setscheduler(0, SCHED_FIFO, &sp) != 0 ||
      mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    std::fprintf(stderr, "exoid_loop_jitter: warning: CPU %ld, SCHED_FIFO 50, mlockall: %s\n", cpu, std::strerror(errno));
  Floor f;
  runSlots(seconds * 1000, busy_us * 1000, f);
  std::printf("exoid_loop_jitter: CPU %ld, %lld slots, %ld us busy each: wake-up late max %.3f ms (> 0.1 ms: %lld, "
              "> 0.5 ms: %lld), slots missed %lld; gaps in the busy work max %.3f ms, over 0.2 ms: %lld charged to "
              "the thread (%.1f ms), %lld away from it (%.1f ms)\n",
              cpu, static_cast<long long>(f.ticks), busy_us, f.late_max * 1e-6, static_cast<long long>(f.late_100us),
              static_cast<long long>(f.late_500us), static_cast<long long>(f.missed), f.gap_max * 1e-6,
              static_cast<long long>(f.gaps_charged), f.charged_ns * 1e-6, static_cast<long long>(f.gaps_away),
              f.away_ns * 1e-6);
  return 0;
}
