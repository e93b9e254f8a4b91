#pragma once
// Child processes for `exoid experiment`: spawn with argv (no shell), wait with a deadline, stop. Children
// run in their own process group (a terminal's Ctrl-C reaches only the supervisor, which stops them in
// order) and get SIGTERM when the supervisor dies, however it dies (no orphan keeps running).
#include <sys/types.h>

#include <string>
#include <vector>

namespace exoid::tools {

/// Where and how a child runs (set in the child before exec, so it holds from the program's first instruction and
/// for every thread it starts). Best effort: a refusal (no CAP_SYS_NICE, a CPU not allowed) only costs timing.
struct Placement {
  std::vector<int> cpus;  ///< pinned to these CPUs (empty: wherever the parent may run)
  int fifo_priority = 0;  ///< > 0: SCHED_FIFO at this priority (real time); 0: normal scheduling
};

/// Starts argv[0] (searched in PATH) with the given arguments. Output goes to log_path (appended) if not
/// empty, otherwise it is inherited. Returns the pid, or -1 with *error.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log_path, std::string* error,
            const Placement& placement = {});

/// Pins the calling process (its threads started later too) to `cpus`; false if refused.
bool pinTo(const std::vector<int>& cpus);

/// CPUs this process may run on, in increasing order.
std::vector<int> allowedCpus();

/// Waits up to timeout_ms for the process to exit (timeout_ms < 0: forever). Returns true and its exit
/// code (128 + signal if killed by one) when it exited; false on timeout. pid <= 0: true at once, code -1.
bool waitFor(pid_t pid, int timeout_ms, int* exit_code);

/// Sends sig (and SIGCONT, so that a stopped process sees it), then waits up to grace_ms; if still running,
/// kills it (SIGKILL). Always reaps it. Returns its exit code as waitFor does (-1 for pid <= 0, no signal).
int stop(pid_t pid, int sig, int grace_ms);

/// "exited with code N" or "was killed by signal N (SIGNAME)" for an exit code from waitFor.
std::string describeExit(int exit_code);

}  // namespace exoid::tools
