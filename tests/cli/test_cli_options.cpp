// Every binary's command line (CLI11 through exoid_common/cli.hpp), run as the user runs it: --help on stdout
// with exit 0 and every option; wrong options, values out of range and impossible requests exit 2 with one
// line on stderr, before any work starts; no crash on the inputs that used to crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

std::string bin(const std::string& name) { return std::string(EXOID_BIN_DIR) + "/" + name; }

class CliOptions : public ::testing::Test {
 protected:
  test::CommandResult run(const std::string& command) { return test::runCommand(command, dir_.path); }
  void expectError(const std::string& command, const std::string& needle) {
    const test::CommandResult r = run(command);
    EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << command << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << command << "\n" << r.err;
  }
  test::TempDir dir_{"cli_options"};
};

TEST_F(CliOptions, EveryBinaryHasGeneratedHelp) {
  const std::pair<std::string, std::vector<std::string>> binaries[] = {
      {bin("exoid") + " model", {"--model", "--floating-base", "--gravity", "default 9.81", "exit codes"}},
      {bin("exoid") + " base-params", {"--model", "--samples", "--seed", "--tolerance", "default 1e-09", "exit codes"}},
      {bin("exoid") + " regressor", {"--model", "--states", "--out", "--gravity", "base_qw", "exit codes"}},
      {bin("exoid") + " export", {"--log", "--out", "--truth", "--filter", "--model", "exit codes"}},
      {bin("exoid") + " experiment", {"--scenario", "--out", "--seed", "--moves", "INTEGER in [0, 1000]", "exit codes"}},
      {bin("exoid") + " calibrate", {"--scenario", "--out", "--duration", "--seed", "--mjcf", "NUMBER in [1, 3600]", "exit codes"}},
      {bin("exo_sim"), {"--duration", "--mode", "--hold-ticks", "INTEGER in [0, 3600000]", "exit codes"}},
      {bin("exo_controller"), {"--moves", "--seed", "--idle-timeout-ms", "--print-duration", "exit codes"}},
      {bin("exo_estimator"),
       {"--forgetting", "--checkpoint", "--row-weights", "--row-weighting", "--publish-hz", "--effects",
        "--effect-prior-factor",
        "NUMBER in [0.5, 1]", "exit codes"}},
      // The logger's default URL is the project's, ttl=0 included (it used to print it without).
      {bin("exoid_lcm_demo_publisher"), {"--count", "--rate", "--start-tick", "--url", "--channel", "exit codes"}},
      {"env -u LCM_DEFAULT_URL " + bin("exoid_logger"),
       {"--lcm-url", "default udpm://239.255.76.67:7667?ttl=0", "--out", "--recv-buf-mb", "exit codes"}},
  };
  for (const auto& [command, needles] : binaries) {
    for (const char* flag : {" --help", " -h"}) {
      const test::CommandResult r = run(command + flag);
      EXPECT_EQ(r.exit_code, 0) << command;
      EXPECT_TRUE(r.err.empty()) << command << ": " << r.err;
      EXPECT_EQ(r.out.rfind("usage: ", 0), 0u) << command << "\n" << r.out;
      EXPECT_NE(r.out.find("-h,--help"), std::string::npos) << command;
      for (const std::string& n : needles) EXPECT_NE(r.out.find(n), std::string::npos) << command << ": " << n;
    }
  }
}

TEST_F(CliOptions, UnknownOptionsAndStrayArgumentsAreRefused) {
  for (const std::string& command : {bin("exoid") + " model", bin("exoid") + " base-params",
                                     bin("exoid") + " regressor", bin("exoid") + " export",
                                     bin("exoid") + " experiment", bin("exoid") + " calibrate", bin("exo_sim"), bin("exo_controller"),
                                     bin("exo_estimator"), bin("exoid_logger"), bin("exoid_lcm_demo_publisher")}) {
    expectError(command + " --bogus 1", "unknown option '--bogus'");
    expectError(command + " --bogus=1", "unknown option '--bogus'");
    expectError(command + " stray", "unexpected argument 'stray'");
  }
  expectError(bin("exoid") + " model", "--model is required");
  expectError(bin("exoid") + " model --model", "--model: missing value");
  expectError(bin("exoid") + " model --model " + test::configPath("exo.urdf") + " --gravity 9,81",
              "--gravity: '9,81': not a number");
  expectError(bin("exoid_logger") + " --out x.lcmlog --recv-buf-mb 0", "--recv-buf-mb: '0': out of range");
  expectError(bin("exoid_logger") + " --out x.lcmlog --lcm-url 'udpm://239.255.76.67:+7667?ttl=0'",
              "--lcm-url: '239.255.76.67:+7667' is not a multicast GROUP:PORT");
  expectError(bin("exoid_lcm_demo_publisher") + " --count 1.5", "--count: '1.5': not an integer");
  expectError(bin("exoid") + " export --log a --out b --filter nan", "--filter: 'nan': not finite");
  {  // a harness scenario is a calibration set-up: refused by name before anything starts
    const std::string harness = dir_.file("harness.yaml");
    std::ofstream(harness) << "name: h\nseed: 1\nnoise: off\nharness: {lift: 0.2}\n";
    expectError(bin("exoid") + " experiment --scenario " + harness + " --out " + dir_.file("h"),
                "harness: a calibration set-up (the pelvis held, the feet free); run it with `exoid calibrate`");
  }
  expectError(bin("exo_estimator") + " --lambda 1.5", "--lambda: '1.5': out of range");
  expectError(bin("exo_estimator") + " --forgetting sometimes", "--forgetting");
  expectError(bin("exo_estimator") + " --row-weighting ols", "--row-weighting");
  expectError(bin("exo_estimator") + " --forgetting selective --row-weighting wls-r-corr",
              "--row-weighting wls-r-corr: selective forgetting keeps the weights fixed");
  expectError(bin("exo_estimator") + " --consistent-every -1", "--consistent-every: '-1': out of range");
  expectError(bin("exo_estimator") + " --consistent-tolerance x", "--consistent-tolerance");
  expectError(bin("exo_estimator") + " --row-weights '1 2 x'", "--row-weights: ");
  expectError(bin("exo_estimator") + " --row-weights '1 2 3'", "16 numbers expected");
  expectError(bin("exo_estimator") + " --checkpoint " + test::configPath("exo.urdf"),
              "not an estimator checkpoint (bad magic)");
  // --effects: a diagnose sidecar (the parser of exoid identify --effects).
  expectError(bin("exo_estimator") + " --effects " + dir_.file("none.yaml"), "none.yaml: cannot open the file");
  std::ofstream(dir_.file("joint.yaml")) << "effects:\n  - {joint: knee, kind: viscous, value: 1}\n";
  expectError(bin("exo_estimator") + " --effects " + dir_.file("joint.yaml"), "effects[0]: unknown joint 'knee'");
  std::ofstream(dir_.file("kind.yaml")) << "effects:\n  - {joint: right_knee, kind: sticky, value: 1}\n";
  expectError(bin("exo_estimator") + " --effects " + dir_.file("kind.yaml"), "effects[0]: unknown kind 'sticky'");
  std::ofstream(dir_.file("bad.yaml")) << "effects: [ {joint: right_knee\n";
  expectError(bin("exo_estimator") + " --effects " + dir_.file("bad.yaml"), "bad.yaml: not readable YAML");
  std::ofstream(dir_.file("delay.yaml")) << "effects:\n  - {joint: right_knee, kind: delay, value: 0.01}\n";
  expectError(bin("exo_estimator") + " --effects " + dir_.file("delay.yaml"), "time delay (right_knee)");
  expectError(bin("exoid") + " experiment --scenario " + test::configPath("scenarios/ideal.yaml") + " --out " +
                  dir_.file("out_fx") + " --estimator-args \"--effects " + dir_.file("delay.yaml") + "\"",
              "time delay (right_knee)");
  expectError(bin("exoid") + " experiment --scenario " + test::configPath("scenarios/ideal.yaml") + " --out " +
                  dir_.file("out_fx") + " --estimator-args --effects=" + dir_.file("joint.yaml"),
              "unknown joint 'knee'");
  // Where the soles stand: the estimator's option, read by the experiment too (its replay places the base alike).
  expectError(bin("exo_estimator") + " --sole-on-plate right:x,1", "--sole-on-plate 'right:x,1': coordinate 1: not a number");
  expectError(bin("exoid") + " experiment --scenario " + test::configPath("scenarios/ideal.yaml") + " --out " +
                  dir_.file("out_sp") + " --estimator-args \"--sole-on-plate right:0.01\"",
              "--estimator-args --sole-on-plate 'right:0.01': expected 2 or 3 coordinates, got 1");
}

TEST_F(CliOptions, ExperimentRefusesWhatTheControllerWouldBeforeStarting) {
  const std::string base = bin("exoid") + " experiment --scenario " + test::configPath("scenarios/ideal.yaml") +
                           " --out " + dir_.file("out");
  expectError(base + " --moves 1001", "--moves: '1001': out of range, expected an integer in [0, 1000]");
  expectError(base + " --moves -1", "--moves: '-1': out of range");
  expectError(base + " --seed -1", "--seed: '-1': out of range, expected an integer >= 0");
  expectError(base + " --seed 99999999999999999999", "--seed: '99999999999999999999': integer too large");
  expectError(base + " --seed 1.5", "--seed: '1.5': not an integer");
  // A controller model with a mass of "13,5" used to load as 0 kg and the robot fell during the run.
  std::string urdf = test::slurp(test::configPath("exo.urdf"));
  const size_t mass = urdf.find("<mass value=\"");
  ASSERT_NE(mass, std::string::npos);
  urdf.replace(mass, urdf.find('"', mass + 13) - mass + 1, "<mass value=\"13,5\"");
  std::ofstream(dir_.file("comma.urdf")) << urdf;
  expectError(base + " --model " + dir_.file("comma.urdf"), "comma.urdf': link '");
  expectError(base + " --model " + dir_.file("comma.urdf"), "<mass value='13,5'>");
  EXPECT_FALSE(std::filesystem::exists(dir_.file("out"))) << "nothing started";
}

TEST_F(CliOptions, BaseParamsRefusesImpossibleRequests) {
  const std::string base = bin("exoid") + " base-params --model " + test::configPath("exo.urdf") + " --floating-base";
  // --tolerance 1 used to keep no pivot and segfault on the empty combination matrix.
  expectError(base + " --tolerance 1", "--tolerance: '1': out of range, expected in (0, 1)");
  expectError(base + " --tolerance 0", "--tolerance: '0': out of range");
  expectError(base + " --tolerance -1e-9", "--tolerance: '-1e-9': out of range");
  // --samples 1 stacked 16 rows for 130 parameters and reported rank 16 as if it were the answer.
  expectError(base + " --samples 1", "--samples 1: 16 regressor rows (16 per sample) cannot reveal 130 parameters; "
                                     "use at least 9");
  // --samples 100000000 aborted on bad_alloc.
  expectError(base + " --samples 100000000", "would not fit in 2 GiB");
  expectError(base + " --samples 0", "--samples: '0': out of range");
  // The smallest accepted count gives the structural answer (100 of 130, README) like the default does.
  const test::CommandResult r = run(base + " --samples 9");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(": 100 of 130 standard parameters"), std::string::npos) << r.out;
  const test::CommandResult kuka =
      run(bin("exoid") + " base-params --samples 12 --model " + test::dataPath("kuka_lwr4/kuka_lwr4.urdf"));
  ASSERT_EQ(kuka.exit_code, 0) << kuka.err;
  EXPECT_NE(kuka.out.find(": 57 of 84 standard parameters"), std::string::npos) << kuka.out;
  expectError(bin("exoid") + " base-params --samples 11 --model " + test::dataPath("kuka_lwr4/kuka_lwr4.urdf"),
              "use at least 12");
}

TEST_F(CliOptions, OneBodyModelsDoNotCrash) {
  const std::string body =
      "<link name='a'><inertial><origin xyz='0 0 0.1'/><mass value='2'/>"
      "<inertia ixx='0.1' iyy='0.2' izz='0.3' ixy='0' ixz='0' iyz='0'/></inertial></link>";
  std::ofstream(dir_.file("one.urdf")) << "<robot name='one'>" << body << "</robot>";
  std::ofstream(dir_.file("fixed.urdf"))
      << "<robot name='fixed'>" << body
      << "<link name='b'><inertial><mass value='1'/><inertia ixx='1' iyy='1' izz='1' ixy='0' ixz='0' iyz='0'/>"
         "</inertial></link><joint name='j' type='fixed'><parent link='a'/><child link='b'/>"
         "<origin xyz='0 0 1'/></joint></robot>";
  for (const char* urdf : {"one.urdf", "fixed.urdf"}) {
    // A free-floating rigid body: all 10 inertial parameters are identifiable from the base wrench.
    for (const char* cmd : {" model", " base-params"}) {
      const test::CommandResult r = run(bin("exoid") + cmd + " --floating-base --model " + dir_.file(urdf));
      EXPECT_EQ(r.exit_code, 0) << urdf << cmd << "\n" << r.err;
      EXPECT_NE(r.out.find("10 of 10"), std::string::npos) << urdf << cmd << "\n" << r.out;
      // Fixed to the world with no movable joint: nothing moves, nothing to identify, said in one line.
      expectError(bin("exoid") + cmd + " --model " + dir_.file(urdf), "no moving link");
    }
  }
}

}  // namespace
}  // namespace exoid
