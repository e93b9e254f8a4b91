// exo_controller end to end over LCM (udpm, ttl=0, inside a private network namespace): this test plays the
// simulator in lockstep (MuJoCo on config/exo.xml publishes EXO_STATE for tick k and waits for EXO_COMMAND of
// tick k + 1), runs a short trajectory and checks the timing convention, the status stream, the exit code and the summary line.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>
#include <fstream>
#include <sstream>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/inertial.hpp"
#include "mujoco_exo.hpp"
#include "support/netns.hpp"

namespace exoid::controller {
namespace {

std::string binary() { return std::string(EXOID_BIN_DIR) + "/exo_controller"; }

/// Runs exo_controller with `args`, returns its exit code; stdout goes to `out_path`.
pid_t spawn(const std::vector<std::string>& args, const std::string& out_path) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string bin = binary();
    argv.push_back(bin.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (!freopen(out_path.c_str(), "w", stdout)) _exit(120);
    dup2(fileno(stdout), STDERR_FILENO);  // error lines land in the same file
    execv(bin.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int waitExit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The default config with a short trajectory.
std::string shortConfig() {
  std::string text = slurp(testing::configPath("controller.yaml"));
  auto set = [&](const std::string& key, const std::string& value) {
    const auto p = text.find("  " + key + ":");
    ASSERT_NE(p, std::string::npos) << key;
    const auto e = text.find('\n', p);
    text.replace(p, e - p, "  " + key + ": " + value);
  };
  set("moves", "2");
  set("move_duration", "1.0");
  set("hold_duration", "0.3");
  set("initial_hold", "0.3");
  set("final_hold", "0.2");
  const std::string path = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_controller_short.yaml";
  std::ofstream(path) << text;
  return path;
}

TEST(ExoControllerBinary, HelpAndBadInputExitCodes) {
  const std::string out = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_controller_help.txt";
  EXPECT_EQ(waitExit(spawn({"--help"}, out)), 0);
  const std::string help = slurp(out);
  for (const char* needle : {"--model", "--config", "--seed", "--lcm-url", "--idle-timeout-ms", "EXO_STATE",
                             "EXO_COMMAND", "EXO_CONTROLLER_STATUS", "EXO_ESTIMATE", "exit codes", "N m"})
    EXPECT_NE(help.find(needle), std::string::npos) << needle;
  EXPECT_EQ(waitExit(spawn({"--print-duration"}, out)), 0);
  ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  EXPECT_NEAR(std::stod(slurp(out)), plannedRunDuration(cfg), 1e-3);
  EXPECT_GT(plannedRunDuration(cfg), cfg.trajectory.moves * cfg.trajectory.move_duration);
  EXPECT_EQ(waitExit(spawn({"--model", "/nonexistent/exo.urdf"}, out)), 2);
  EXPECT_EQ(waitExit(spawn({"--seed", "abc"}, out)), 2);
  EXPECT_EQ(waitExit(spawn({"--frobnicate"}, out)), 2);
  EXPECT_NE(slurp(out).find("exo_controller: error: unknown option '--frobnicate'"), std::string::npos) << slurp(out);
  // The ranges exoid experiment also enforces (it must refuse what the controller would).
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--moves", "1001"}, {"--seed", "-1"}, {"--seed", "1.5"}, {"--idle-timeout-ms", "0"}, {"--moves"}}) {
    EXPECT_EQ(waitExit(spawn(args, out)), 2) << args[0];
    EXPECT_NE(slurp(out).find("exo_controller: error: " + args[0] + ": "), std::string::npos) << slurp(out);
  }
  const std::string bad = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_bad_controller.yaml";
  std::ofstream(bad) << "loop: {period: 0.001}\n";
  EXPECT_EQ(waitExit(spawn({"--config", bad}, out)), 2);
  std::ofstream(bad) << slurp(testing::configPath("controller.yaml")) << "solver: {eps_abs: 1.0e-9, max_iterations: 5}\n";
  EXPECT_EQ(waitExit(spawn({"--config", bad}, out)), 2);  // the second solver section used to be ignored
  EXPECT_NE(slurp(out).find(bad + ": solver: duplicate key"), std::string::npos) << slurp(out);
  // Nobody publishes (in-process memq provider): the idle timeout ends it.
  EXPECT_EQ(waitExit(spawn({"--lcm-url", "memq://", "--idle-timeout-ms", "200", "--quiet"}, out)), 3);
  EXPECT_NE(slurp(out).find("idle timeout"), std::string::npos);
}

TEST(ExoControllerBinary, RunsAShortTrajectoryInLockstepAndExitsZero) {
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  testing::MujocoExo sim;
  ASSERT_TRUE(sim.load(model, &err)) << err;
  // Two processes over udpm: only inside a private network namespace (the controller inherits it).
  if (!exoid::test::enterPrivateNetworkNamespace(&err)) GTEST_SKIP() << err;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  auto lcm = LcmEndpoint::create(url, &err);
  if (!lcm) GTEST_SKIP() << "udpm LCM unavailable here: " << err;
  {  // loopback multicast must work for two processes to talk (it does on a normal host)
    bool echoed = false;
    const int id = lcm->subscribeRaw("EXO_CTRL_TEST_PING", [&](const char*, const void*, int, int64_t) { echoed = true; });
    const char ping[4] = "hi";
    lcm->publishRaw("EXO_CTRL_TEST_PING", ping, sizeof(ping));
    for (int i = 0; i < 10 && !echoed; ++i) lcm->handleTimeout(50);
    lcm->unsubscribe(id);
    ASSERT_TRUE(echoed) << "udpm multicast does not loop back in the private namespace";
  }

  JointCommandSample command;
  command.tau = Eigen::VectorXd::Zero(model.njoints);
  command.tau_ff = Eigen::VectorXd::Zero(model.njoints);
  JointCommandSample applied = command;
  int64_t last_command_tick = -1, bad_command_ticks = 0, status_count = 0, solved_count = 0;
  lcm->subscribe<exoid_lcm::joint_command_t>(channels::kCommand, [&](const char*, const exoid_lcm::joint_command_t& m) {
    JointCommandSample c = command;
    std::string why;
    if (!fromLcm(m, model.joint_names, c, &why)) {
      ADD_FAILURE() << why;
      return;
    }
    if (c.tick != c.source_tick + 1) ++bad_command_ticks;
    command = c;
    last_command_tick = c.tick;
  });
  lcm->subscribe<exoid_lcm::controller_status_t>(channels::kControllerStatus,
                                                 [&](const char*, const exoid_lcm::controller_status_t& m) {
                                                   ++status_count;
                                                   solved_count += m.qp_status == 0;
                                                 });

  const std::string out = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_controller_run.txt";
  // --wait-estimate-ms: lockstep waits for each estimate it is due to apply, so what the controller counts does
  // not depend on when the estimates' socket is read (under ASan the refusal once arrived after the last valid
  // estimate had gone stale). The estimates stop at tick 1304: the wait for tick 1305's times out once.
  const pid_t pid = spawn({"--config", shortConfig(), "--lcm-url", url, "--seed", "4", "--idle-timeout-ms", "2000",
                           "--wait-estimate-ms", "300", "--quiet"},
                          out);
  RobotStateSample state;
  sim.sizeState(state);
  exoid_lcm::robot_state_t msg;
  // EXO_ESTIMATE at 100 Hz from tick 9 to 1299 (the model plus 1 kg on the base link), then one flagged not valid:
  // the controller takes them from LCM (its summary line counts them) and withdraws on the refusal.
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = model.phi;
  est.params.segment<kParamsPerBody>(model.bodyParamIndex(0)) += paramsFromInertial(
      1.0, Eigen::Vector3d(-0.1, 0.0, 0.3), Eigen::Matrix3d::Identity(), 0.005 * Eigen::Matrix3d::Identity());
  est.param_stddev = Eigen::VectorXd::Zero(model.nparams());
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  est.residual_rms = Eigen::VectorXd::Zero(model.nv);
  exoid_lcm::estimator_output_t est_msg;
  bool exited = false;
  int exit_code = -1;
  int64_t k = 0;
  const auto t_start = std::chrono::steady_clock::now();
  for (; k < 20000 && !exited; ++k) {
    sim.step1();
    sim.sample(state, k, testing::SensorNoise{});
    if (last_command_tick == k) applied = command;  // the answer to tick k - 1
    sim.apply(applied);
    if ((k >= 10 && k <= 1300 && k % 10 == 0) || k == 1305) {
      est.tick = k - 1;
      est.utime = 1000 * est.tick;
      est.valid = k != 1305;
      toLcm(est, model.paramNames(), model.coordinateNames(), est_msg);
      ASSERT_TRUE(lcm->publish(channels::kEstimate, est_msg));
    }
    toLcm(state, model.joint_names, msg);
    // The first states may be published before the child subscribed: resend until it answers.
    auto sent = std::chrono::steady_clock::now();
    ASSERT_TRUE(lcm->publish(channels::kState, msg));
    while (last_command_tick < k + 1) {
      lcm->handleTimeout(20);
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        exited = true;
        exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (std::chrono::steady_clock::now() - sent > std::chrono::milliseconds(100) && last_command_tick < 0) {
        ASSERT_TRUE(lcm->publish(channels::kState, msg));  // start-up only
        sent = std::chrono::steady_clock::now();
      }
      ASSERT_LT(std::chrono::steady_clock::now() - t_start, std::chrono::seconds(60)) << "lockstep stalled";
    }
    sim.step2();
  }
  if (!exited) exit_code = waitExit(pid);
  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(bad_command_ticks, 0);
  EXPECT_GT(status_count, 3000);
  EXPECT_EQ(solved_count, status_count);
  EXPECT_GT(sim.baseHeight(), 1.0);
  const std::string summary = slurp(out);
  EXPECT_NE(summary.find("exo_controller: done"), std::string::npos) << summary;
  EXPECT_NE(summary.find("moves 2/2"), std::string::npos) << summary;
  EXPECT_NE(summary.find("fallbacks 0"), std::string::npos) << summary;
  EXPECT_NE(summary.find("estimate: accepted 130, refused 1 (not valid 1), withdrawn 1 (stale 0, refused 1)"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("with tick >= 1305 within 300 ms at tick 1375"), std::string::npos) << summary;
}

}  // namespace
}  // namespace exoid::controller
