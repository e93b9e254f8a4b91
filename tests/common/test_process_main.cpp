// The process mains' shared preamble (exoid/common/process_main.hpp): a bad input is one line "PROG: error: ..."
// and exit code 2; SIGINT/SIGTERM set the polled stop flag to their number instead of ending the process; a
// configuration file's default path is config/FILE below the working directory, else the installed one.
#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>

#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"

namespace exoid::common {
namespace {

TEST(ProcessMain, BadInputIsOneLineAndExitTwo) {
  testing::internal::CaptureStderr();
  const int code = badInput("exo_test", "--model x.urdf: no such file");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "exo_test: error: --model x.urdf: no such file\n");
  EXPECT_EQ(code, kExitBadInput);
  EXPECT_EQ(code, 2);
}

TEST(ProcessMain, StopSignalsSetTheFlagAndTheProcessGoesOn) {
  volatile std::sig_atomic_t* flag = installStopSignals();
  ASSERT_EQ(flag, stopFlag());
  *flag = 0;
  ASSERT_EQ(std::raise(SIGTERM), 0);  // without the handler the test process would end here
  EXPECT_EQ(*stopFlag(), SIGTERM);
  *flag = 0;
  ASSERT_EQ(std::raise(SIGINT), 0);
  EXPECT_EQ(*stopFlag(), SIGINT);
  *flag = 0;
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
}

TEST(ProcessMain, ConfigPathPrefersTheWorkingDirectorysConfig) {
  const std::string installed = installedConfigDir();
  EXPECT_FALSE(installed.empty());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("exoid_process_main_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "config");
  const std::filesystem::path cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  EXPECT_EQ(configPath("only_installed.yaml"), installed + "/only_installed.yaml");
  std::ofstream(dir / "config" / "local.yaml") << "a: 1\n";
  EXPECT_EQ(configPath("local.yaml"), "config/local.yaml");
  std::filesystem::current_path(cwd);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace exoid::common
