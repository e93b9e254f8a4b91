#include "exoid/tools/process.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/prctl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

namespace exoid::tools {

std::vector<int> allowedCpus() {
  std::vector<int> cpus;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof(set), &set) == 0)
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) cpus.push_back(c);
  return cpus;
}

bool pinTo(const std::vector<int>& cpus) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus)
    if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
  return !cpus.empty() && ::sched_setaffinity(0, sizeof(set), &set) == 0;
}

pid_t spawn(const std::vector<std::string>& argv, const std::string& log_path, std::string* error,
            const Placement& placement) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int fd = -1;
  if (!log_path.empty()) {
    fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd < 0) {
      if (error) *error = "cannot write '" + log_path + "': " + std::strerror(errno);
      return -1;
    }
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    if (error) *error = std::string("fork failed: ") + std::strerror(errno);
    if (fd >= 0) ::close(fd);
    return -1;
  }
  if (pid == 0) {
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(127);  // the supervisor died before prctl took effect
    if (!placement.cpus.empty()) pinTo(placement.cpus);  // best effort: a failure only costs speed
    if (placement.fifo_priority > 0) {
      sched_param sp{};
      sp.sched_priority = placement.fifo_priority;
      ::sched_setscheduler(0, SCHED_FIFO, &sp);
    }
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      ::close(fd);
    }
    ::execvp(args[0], args.data());
    std::fprintf(stderr, "cannot start '%s': %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  if (fd >= 0) ::close(fd);
  return pid;
}

bool waitFor(pid_t pid, int timeout_ms, int* exit_code) {
  if (pid <= 0) {  // waitpid(-1 or 0, ...) would reap any child
    if (exit_code) *exit_code = -1;
    return true;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, timeout_ms < 0 ? 0 : WNOHANG);
    if (r == pid) {
      if (exit_code) *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      return true;
    }
    if (r < 0 && errno != EINTR) {
      if (exit_code) *exit_code = -1;
      return true;
    }
    if (timeout_ms >= 0 && std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

int stop(pid_t pid, int sig, int grace_ms) {
  int code = -1;
  if (pid <= 0) return code;  // kill(0 or -1, ...) would signal the group or everything
  ::kill(pid, sig);
  ::kill(pid, SIGCONT);
  if (waitFor(pid, grace_ms, &code)) return code;
  ::kill(pid, SIGKILL);
  waitFor(pid, -1, &code);
  return code;
}

std::string describeExit(int code) {
  if (code > 128 && code < 128 + 65) {
    const int sig = code - 128;
    const char* name = sig == SIGKILL ? "SIGKILL" : sig == SIGTERM ? "SIGTERM" : sig == SIGINT ? "SIGINT"
                       : sig == SIGSEGV ? "SIGSEGV" : sig == SIGABRT ? "SIGABRT" : sig == SIGBUS ? "SIGBUS"
                       : sig == SIGFPE ? "SIGFPE" : nullptr;
    return "was killed by signal " + std::to_string(sig) + (name ? std::string(" (") + name + ")" : "");
  }
  return "exited with code " + std::to_string(code);
}

}  // namespace exoid::tools
