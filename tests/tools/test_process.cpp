// Child processes of `exoid experiment` (tools/process.hpp): exit codes and their wording, stopping a
// process that ignores nothing but is stopped (SIGSTOP), and the pid <= 0 guards (kill(-1)/waitpid(-1)
// would reach every process / reap any child).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>

#include "exoid/tools/process.hpp"

namespace exoid {
namespace {

TEST(Process, ExitCodesAndTheirWording) {
  std::string err;
  pid_t pid = tools::spawn({"sh", "-c", "exit 7"}, "", &err);
  ASSERT_GT(pid, 0) << err;
  int code = 0;
  ASSERT_TRUE(tools::waitFor(pid, 5000, &code));
  EXPECT_EQ(code, 7);
  EXPECT_EQ(tools::describeExit(code), "exited with code 7");
  pid = tools::spawn({"sleep", "30"}, "", &err);
  ASSERT_GT(pid, 0) << err;
  EXPECT_FALSE(tools::waitFor(pid, 50, &code));  // still running
  EXPECT_EQ(tools::stop(pid, SIGTERM, 2000), 128 + SIGTERM);
  EXPECT_EQ(tools::describeExit(128 + SIGTERM), "was killed by signal 15 (SIGTERM)");
  EXPECT_EQ(tools::describeExit(128 + SIGKILL), "was killed by signal 9 (SIGKILL)");
  pid = tools::spawn({"no_such_program_exoid"}, "", &err);
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(tools::waitFor(pid, 5000, &code));
  EXPECT_EQ(code, 127);
}

TEST(Process, AStoppedProcessIsStillStoppedPromptly) {
  std::string err;
  const pid_t pid = tools::spawn({"sleep", "30"}, "", &err);
  ASSERT_GT(pid, 0) << err;
  ASSERT_EQ(::kill(pid, SIGSTOP), 0);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(tools::stop(pid, SIGTERM, 5000), 128 + SIGTERM);  // SIGCONT lets it see the SIGTERM at once
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 4.0);
  EXPECT_EQ(::kill(pid, 0), -1);  // reaped: the pid is gone
}

TEST(Process, NonPositivePidsAreNeverSignalledOrWaitedFor) {
  std::string err;
  const pid_t other = tools::spawn({"sh", "-c", "exit 3"}, "", &err);  // a child that must stay unreaped
  ASSERT_GT(other, 0) << err;
  int code = 0;
  for (const pid_t bad : {0, -1}) {
    EXPECT_TRUE(tools::waitFor(bad, 1000, &code));
    EXPECT_EQ(code, -1);
    EXPECT_EQ(tools::stop(bad, SIGTERM, 100), -1);
  }
  ASSERT_TRUE(tools::waitFor(other, 5000, &code));  // still ours to reap, with its own code
  EXPECT_EQ(code, 3);
}

}  // namespace
}  // namespace exoid
