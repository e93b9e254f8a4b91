#include "exoid/common/process_main.hpp"

#include <cstdio>

#include "exoid/common/cli.hpp"

#ifndef EXOID_CONFIG_DIR
#define EXOID_CONFIG_DIR "config"
#endif

namespace exoid::common {
namespace {
volatile std::sig_atomic_t g_stop_signal = 0;
void onStopSignal(int sig) { g_stop_signal = sig; }
}  // namespace

const char* installedConfigDir() { return EXOID_CONFIG_DIR; }

std::string configPath(const char* file) { return defaultConfigPath(file, installedConfigDir()); }

int badInput(const char* prog, const std::string& message) {
  std::fprintf(stderr, "%s: error: %s\n", prog, message.c_str());
  return kExitBadInput;
}

volatile std::sig_atomic_t* installStopSignals() {
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  return &g_stop_signal;
}

const volatile std::sig_atomic_t* stopFlag() { return &g_stop_signal; }

}  // namespace exoid::common
