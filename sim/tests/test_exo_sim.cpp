// exo_sim over LCM: the loop in-process against a fake controller on memq:// (timing convention, gate,
// fallbacks), and the binary's command line (help, exit codes, one-line errors).
#include <unistd.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/sim/runner.hpp"

namespace exoid::sim {
namespace {

std::string cfg(const std::string& rel) { return std::string(EXOID_CONFIG_DIR) + "/" + rel; }

// Lockstep closed loop with a fake controller that answers state k with the command for tick k+1 (a joint
// PD on the encoder readings), misbehaving on purpose at a few ticks.
TEST(ExoSimLoop, LockstepClosedLoopAppliesTheCommandOfEachTick) {
  std::string err;
  Scenario sc;
  sc.noise = NoiseMode::Off;
  SimModel sm;
  SimData sd;
  ASSERT_TRUE(simLoad(cfg("exo.xml"), SensorConfig(), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  LcmEndpoint ep("memq://");

  constexpr int kTicks = 600;
  std::vector<Eigen::VectorXd> sent(kTicks + 2, Eigen::VectorXd::Zero(sm.nj));  // valid command per tick
  std::vector<Eigen::VectorXd> applied(kTicks, Eigen::VectorXd::Constant(sm.nj, NAN));
  std::vector<int64_t> state_ticks;
  JointCommandSample cmd;
  cmd.tau.setZero(sm.nj);
  cmd.tau_ff.setZero(sm.nj);
  exoid_lcm::joint_command_t msg;
  int expected_accepted = 0;
  ep.subscribe<exoid_lcm::robot_state_t>(channels::kState, [&](const char*, const exoid_lcm::robot_state_t& s) {
    state_ticks.push_back(s.tick);
    const int64_t k = s.tick + 1;
    if (k >= kTicks || (k >= 400 && k < 403)) return;  // 400-402: the controller is late (no answer)
    cmd.tick = k;
    cmd.source_tick = s.tick;
    for (int j = 0; j < sm.nj; ++j) cmd.tau[j] = -1000.0 * s.q[static_cast<size_t>(j)];
    if (k == 200) {  // a NaN first: rejected; the valid one follows
      cmd.tau[0] = NAN;
      toLcm(cmd, sm.joint_names, msg);
      ep.publish(channels::kCommand, msg);
      cmd.tau[0] = -1000.0 * s.q[0];
    }
    toLcm(cmd, sm.joint_names, msg);
    ep.publish(channels::kCommand, msg);
    ++expected_accepted;
    sent[static_cast<size_t>(k)] = cmd.tau;
    if (k == 100) ep.publish(channels::kCommand, msg);  // duplicate
    if (k == 300) {                                      // a stale one after the fresh one: out of order
      cmd.tick = 250;
      toLcm(cmd, sm.joint_names, msg);
      ep.publish(channels::kCommand, msg);
    }
  });
  ep.subscribe<exoid_lcm::ground_truth_t>(channels::kTruth, [&](const char*, const exoid_lcm::ground_truth_t& t) {
    if (t.tick < kTicks)
      applied[static_cast<size_t>(t.tick)] = Eigen::Map<const Eigen::VectorXd>(t.tau_applied.data(), sm.nj);
  });

  RunOptions opt;
  opt.duration_s = kTicks * 1e-3;
  opt.command_timeout_ms = 20;
  opt.hold_ticks = 2;
  opt.start_timeout_s = 1.0;
  opt.quiet = true;
  RunSummary s;
  ASSERT_TRUE(runSim(sm, sd, ep, opt, &s, &err)) << err;
  ep.handleAvailable();  // the last tick's messages

  EXPECT_EQ(s.ticks, kTicks);
  ASSERT_EQ(state_ticks.size(), static_cast<size_t>(kTicks));
  for (int k = 0; k < kTicks; ++k) EXPECT_EQ(state_ticks[static_cast<size_t>(k)], k);
  EXPECT_EQ(s.accepted, static_cast<uint64_t>(expected_accepted));
  EXPECT_EQ(s.rejected_by_reason[static_cast<int>(RejectReason::Duplicate)], 1u);
  EXPECT_EQ(s.rejected_by_reason[static_cast<int>(RejectReason::OutOfOrder)], 1u);
  EXPECT_EQ(s.rejected_by_reason[static_cast<int>(RejectReason::NonFinite)], 1u);
  EXPECT_EQ(s.rejected, 3u);
  EXPECT_EQ(s.timeouts, 3);  // ticks 400-402 waited in vain
  EXPECT_EQ(s.held_ticks, 2);
  EXPECT_EQ(s.zero_ticks, 1);
  EXPECT_EQ(s.fresh_ticks, kTicks - 1 - 3);
  EXPECT_FALSE(s.fell);
  // Tick k applied exactly the command for tick k (clamped to the actuator ranges): tick 0 zero torque,
  // 400-401 held the command of 399, 402 zero torque.
  for (int k = 0; k < kTicks; ++k) {
    Eigen::VectorXd expect = k == 0 || k == 402 ? Eigen::VectorXd::Zero(sm.nj)
                             : (k == 400 || k == 401) ? sent[399] : sent[static_cast<size_t>(k)];
    for (int j = 0; j < sm.nj; ++j) {
      const int a = sm.actuator[static_cast<size_t>(j)];
      if (a < 0) {
        expect[j] = 0.0;
        continue;
      }
      expect[j] = std::min(sm.m->actuator_ctrlrange[2 * a + 1], std::max(sm.m->actuator_ctrlrange[2 * a], expect[j]));
    }
    ASSERT_LT((applied[static_cast<size_t>(k)] - expect).cwiseAbs().maxCoeff(), 1e-12) << "tick " << k;
  }
}

TEST(ExoSimLoop, RealtimeRunsAtWallClockAndCountsStaleTicks) {
  std::string err;
  Scenario sc;
  SimModel sm;
  SimData sd;
  ASSERT_TRUE(simLoad(cfg("exo.xml"), SensorConfig(), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  LcmEndpoint ep("memq://");
  RunOptions opt;
  opt.mode = SimMode::Realtime;
  opt.duration_s = 0.2;
  opt.hold_ticks = 10;
  opt.quiet = true;
  RunSummary s;
  ASSERT_TRUE(runSim(sm, sd, ep, opt, &s, &err)) << err;
  EXPECT_EQ(s.ticks, 200);
  EXPECT_NEAR(s.wall_time_s, 0.2, 0.05);  // paced by the wall clock
  EXPECT_EQ(s.fresh_ticks, 0);            // no controller: every tick after 0 is stale, zero torque
  EXPECT_EQ(s.zero_ticks, 199);
  EXPECT_EQ(s.timeouts, 0);               // realtime never waits for a command
}

// --- the binary ------------------------------------------------------------------------------------------
struct CliRun {
  int code = -1;
  std::string out;
};
CliRun runExoSim(const std::string& args) {
  CliRun r;
  const std::string cmd = std::string(EXO_SIM_BIN) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string writeFile(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_sim_cli_" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(ExoSimCli, HelpListsEveryOptionChannelAndExitCode) {
  const CliRun r = runExoSim("--help");
  EXPECT_EQ(r.code, 0);
  for (const char* s : {"--model", "--sensors", "--scenario", "--mode", "--duration", "--lcm-url",
                        "--command-timeout-ms", "--hold-ticks", "--start-timeout-s", "--quiet", "--help", "EXO_STATE",
                        "EXO_PLATE_RIGHT", "EXO_PLATE_LEFT", "EXO_TRUTH", "EXO_COMMAND", "exit codes", "ttl=0"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

TEST(ExoSimCli, BadInputExitsWithTwoAndOneLine) {
  const std::string bad_scenario = writeFile("bad.yaml", "name: x\nseed: 1\nnoise: off\neffects: {dampin: {all: 1}}\n");
  const std::string bad_mjcf = writeFile("bad.xml", "<mujoco><worldbody><body></mujoco>");
  const std::string unknown_joint =
      writeFile("joint.yaml", "name: x\nseed: 1\nnoise: off\neffects: {joint_damping: {knee: 1}}\n");
  struct Case {
    std::string args, expect;
  };
  const std::vector<Case> cases = {
      {"--bogus 1", "unknown option '--bogus'"},
      {"--duration -1", "--duration: '-1': out of range"},
      {"--duration nan", "--duration: 'nan': not finite"},
      {"--duration 1e400", "--duration: '1e400': too large for a double"},
      {"--duration 2 stray", "unexpected argument 'stray'"},
      {"--duration", "--duration: missing value"},
      {"--mode fast", "--mode: fast not in {lockstep,realtime}"},
      {"--command-timeout-ms x", "--command-timeout-ms: 'x': not an integer"},
      {"--hold-ticks -1", "--hold-ticks: '-1': out of range, expected an integer in [0, 1000000000]"},
      {"--scenario " + bad_scenario, bad_scenario + ": effects.dampin: unknown key"},
      {"--scenario " + unknown_joint, unknown_joint + ": effects.joint_damping.knee: unknown joint 'knee'"},
      {"--model " + bad_mjcf, bad_mjcf + ": MuJoCo cannot load the model"},
      {"--sensors /nonexistent/s.yaml", "/nonexistent/s.yaml: cannot open file"},
      {"--lcm-url udpm://239.255.76.67:7667?ttl=1", "--lcm-url: "},
  };
  for (const Case& c : cases) {
    const CliRun r = runExoSim(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.args << "\n" << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << "one line: " << r.out;
  }
}

TEST(ExoSimCli, OpenLoopRunPrintsProgressAndSummary) {
  // No controller on memq:// and no start wait: open loop at zero torque (the robot folds up).
  const CliRun r = runExoSim("--lcm-url memq:// --start-timeout-s 0 --duration 2 --scenario " +
                          cfg("scenarios/ideal.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("exo_sim: t 1.0 s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("exo_sim: t 2.0 s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("exo_sim: summary: ticks 2000, simulated 2.000 s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fallback ticks 1999 (held 0, zero 1999, timeouts 1999)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fell yes"), std::string::npos) << r.out;
  const CliRun q = runExoSim("--quiet --lcm-url memq:// --start-timeout-s 0 --duration 0.05");
  EXPECT_EQ(q.code, 0) << q.out;
  EXPECT_EQ(q.out.rfind("exo_sim: summary: ticks 50,", 0), 0u) << q.out;  // only the summary line
}

}  // namespace
}  // namespace exoid::sim
