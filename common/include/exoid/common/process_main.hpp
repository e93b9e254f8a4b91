#pragma once
// The preamble every process main shares (exo_sim, exo_controller, exo_estimator, `exoid experiment`; the exoid
// commands report bad input through badInput too): the default path of a configuration file, a bad input reported
// as one line "PROG: error: ..." with exit code 2, and SIGINT/SIGTERM turned into a stop request the main loop
// polls (the process then ends its run cleanly, writes what it owes and exits with its own code) instead of
// killing the process.
#include <csignal>
#include <string>

namespace exoid::common {

/// The configuration directory compiled into the binaries (the checkout's config/, EXOID_CONFIG_DIR).
const char* installedConfigDir();

/// Default path of a configuration file: config/FILE below the working directory when it exists (a checkout),
/// else FILE in installedConfigDir() (defaultConfigPath of cli.hpp).
std::string configPath(const char* file);

/// Prints "PROG: error: MESSAGE" on stderr; returns kExitBadInput (2), for `return badInput(...)`.
int badInput(const char* prog, const std::string& message);

/// From now on SIGINT and SIGTERM do not end the process: they store their number in the flag returned (0 until
/// then; async-signal-safe), which the main loop polls (e.g. runSim's `stop`). The flag is process-wide.
volatile std::sig_atomic_t* installStopSignals();

/// The stop flag (the number of the signal received, 0 if none).
const volatile std::sig_atomic_t* stopFlag();

}  // namespace exoid::common
