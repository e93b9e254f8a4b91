// exo_sim over LCM: the loop in-process against a fake controller on memq:// (timing convention, gate,
// fallbacks), and the binary's command line (help, exit codes, one-line errors).
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <chrono>
#include <thread>
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
  // The loop's timing is filled (docs/sim.md, "Loop timing"), not judged: the figures of a timed unit test say
  // what the machine did, not what the code does (scripts/bench-realtime.sh measures them).
  const LoopTiming& t = s.timing;
  EXPECT_GT(t.tick_ms_max, 0.0);
  EXPECT_GT(t.tick_ms_mean, 0.0);
  EXPECT_LE(t.tick_ms_mean, t.tick_ms_max);
  EXPECT_LE(t.tick_ms_mean * 1e-3 * static_cast<double>(s.ticks - 1), s.wall_time_s);  // work fits in the run
  EXPECT_GT(t.tick_cpu_ms_max, 0.0);
  EXPECT_GE(t.start_delay_ms_max, 0.0);  // realtime: every tick has a slot
  EXPECT_GE(t.deadline_misses, 0);
  EXPECT_LE(t.deadline_misses, s.ticks);
  EXPECT_LE(t.overruns, s.ticks);
  EXPECT_GE(t.preemptions, 0);
  EXPECT_GE(t.page_faults, 0);
  EXPECT_EQ(t.plugin_calls, 0);  // no plugin
  EXPECT_EQ(t.plugin_call_us_max, 0.0);
}

// Every field of the summary, the loop timing's included, survives exo_sim --result -> exoid experiment; a
// result without one of the timing fields is refused (naming it), and lockstep reports no slot figures.
TEST(ExoSimLoop, TheTimingFiguresRoundTripAndLockstepHasNoSlots) {
  std::string err;
  Scenario sc;
  SimModel sm;
  SimData sd;
  ASSERT_TRUE(simLoad(cfg("exo.xml"), SensorConfig(), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  LcmEndpoint ep("memq://");
  RunOptions opt;
  opt.duration_s = 0.05;
  opt.start_timeout_s = 0.0;  // open loop at once
  opt.quiet = true;
  RunSummary s;
  ASSERT_TRUE(runSim(sm, sd, ep, opt, &s, &err)) << err;
  EXPECT_EQ(s.timing.deadline_misses, -1);  // lockstep: no wall-clock slot
  EXPECT_EQ(s.timing.start_delay_ms_max, -1.0);
  EXPECT_GT(s.timing.tick_ms_max, 0.0);
  EXPECT_GT(s.timing.tick_cpu_ms_max, 0.0);

  LoopTiming& t = s.timing;  // distinct values, so that a field read into another one shows
  t = {3, 5, 7.25, 0.5, 6.75, 1.125, 11, 13, 17, 19.5, 2.25, 23.5, 29, 31};
  RunSummary back;
  ASSERT_TRUE(parseRunSummaryJson(runSummaryJson(s), &back, &err)) << err;
  int fields = 0;
  forEachTimingField(t, [&](const char* key, const auto& v) {
    ++fields;
    forEachTimingField(back.timing, [&](const char* key2, const auto& w) {
      if (std::string(key) == key2) {
        EXPECT_EQ(static_cast<double>(v), static_cast<double>(w)) << key;
      }
    });
  });
  EXPECT_EQ(fields, 14);
  const std::string json = runSummaryJson(s);
  for (const char* key : {"\"overruns\"", "\"deadline_misses\"", "\"tick_ms_max\"", "\"plugin_call_us_max\"",
                          "\"plugin_call_us_mean\"", "\"plugin_fallback_ticks\""}) {
    std::string cut = json;
    const size_t at = cut.find(key);
    ASSERT_NE(at, std::string::npos) << key;
    cut.replace(at, std::string(key).size(), "\"renamed\"");
    EXPECT_FALSE(parseRunSummaryJson(cut, &back, &err)) << key;
    EXPECT_NE(err.find(std::string(key).substr(1, std::string(key).size() - 2)), std::string::npos) << err;
  }
}

// A fall ends the run at the fall tick (the floor does not collide: without this the robot dropped to
// z = -300 m while the run went on); the tick is reported and the last published tick is the fall tick.
TEST(ExoSimLoop, AFallEndsTheRunAtTheFallTick) {
  std::string err;
  Scenario sc;
  sc.noise = NoiseMode::Off;
  SimModel sm;
  SimData sd;
  ASSERT_TRUE(simLoad(cfg("exo.xml"), SensorConfig(), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  const double z0 = sd.d->qpos[sm.base_qpos + 2];
  LcmEndpoint ep("memq://");
  std::vector<double> z;  // truth base height per tick
  ep.subscribe<exoid_lcm::ground_truth_t>(channels::kTruth, [&](const char*, const exoid_lcm::ground_truth_t& t) {
    ASSERT_EQ(t.tick, static_cast<int64_t>(z.size()));
    z.push_back(t.base_position[2]);
  });
  RunOptions opt;
  opt.duration_s = 5.0;
  opt.start_timeout_s = 0.0;  // no controller: open loop at zero torque, the robot folds up
  opt.quiet = true;
  RunSummary s;
  ASSERT_TRUE(runSim(sm, sd, ep, opt, &s, &err)) << err;
  while (ep.handleAvailable() > 0) {
  }
  EXPECT_EQ(s.outcome, RunOutcome::Fell);
  EXPECT_TRUE(s.fell);
  EXPECT_EQ(s.ticks_planned, 5000);
  ASSERT_GT(s.fall_tick, 0);
  EXPECT_LT(s.fall_tick, 2000);  // folds within a fraction of a second; 5 s were planned
  EXPECT_EQ(s.ticks, s.fall_tick + 1);
  ASSERT_EQ(static_cast<int64_t>(z.size()), s.ticks);
  // Independent check on the published truth: every tick before the fall tick was above the threshold, and
  // the state after the fall tick (z of the fall tick + one step at most ~5 mm) is below it.
  for (int64_t k = 0; k < s.fall_tick; ++k) ASSERT_GE(z[static_cast<size_t>(k)], z0 - kFallDrop) << k;
  EXPECT_LT(z.back(), z0 - kFallDrop + 0.005);
  EXPECT_EQ(s.zero_ticks, s.ticks - 1);
  EXPECT_EQ(s.timeouts, 0);  // open loop never waits
  EXPECT_NE(formatSummary(s).find("fell (fall at tick " + std::to_string(s.fall_tick)), std::string::npos)
      << formatSummary(s);
}

// A controller that answered and then went silent ends the run after max_missing_commands consecutive
// missing commands, instead of a command_timeout_ms wait on every remaining tick (an hour for a 20-move run).
TEST(ExoSimLoop, ASilentControllerEndsTheRunAfterMaxMissingCommands) {
  std::string err;
  Scenario sc;
  sc.noise = NoiseMode::Off;
  SimModel sm;
  SimData sd;
  ASSERT_TRUE(simLoad(cfg("exo.xml"), SensorConfig(), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  LcmEndpoint ep("memq://");
  JointCommandSample cmd;
  cmd.tau.setZero(sm.nj);
  cmd.tau_ff.setZero(sm.nj);
  exoid_lcm::joint_command_t msg;
  ep.subscribe<exoid_lcm::robot_state_t>(channels::kState, [&](const char*, const exoid_lcm::robot_state_t& st) {
    if (st.tick + 1 > 100) return;  // the controller dies after sending the command for tick 100
    cmd.tick = st.tick + 1;
    cmd.source_tick = st.tick;
    for (int j = 0; j < sm.nj; ++j) cmd.tau[j] = -1000.0 * st.q[static_cast<size_t>(j)];
    toLcm(cmd, sm.joint_names, msg);
    ep.publish(channels::kCommand, msg);
  });
  RunOptions opt;
  opt.duration_s = 3600.0;  // an hour planned: only the missing-command limit can end it in time
  opt.command_timeout_ms = 20;
  opt.max_missing_commands = 5;
  opt.quiet = true;
  RunSummary s;
  ASSERT_TRUE(runSim(sm, sd, ep, opt, &s, &err)) << err;
  EXPECT_EQ(s.outcome, RunOutcome::ControllerLost);
  EXPECT_EQ(s.last_fresh_tick, 100);
  EXPECT_EQ(s.missing_commands, 5);
  EXPECT_EQ(s.ticks, 105);  // ticks 101..104 stepped on the fallback, tick 105 would have been the 5th miss
  EXPECT_EQ(s.timeouts, 5);
  EXPECT_EQ(s.held_ticks, 4);
  EXPECT_LT(s.wall_time_s, 2.0);  // 5 waits of 20 ms, not 3.6 million
  EXPECT_FALSE(s.fell);
  // The summary survives the JSON round trip exo_sim --result -> exoid experiment.
  RunSummary back;
  ASSERT_TRUE(parseRunSummaryJson(runSummaryJson(s), &back, &err)) << err;
  EXPECT_EQ(back.outcome, RunOutcome::ControllerLost);
  EXPECT_EQ(back.ticks, s.ticks);
  EXPECT_EQ(back.last_fresh_tick, 100);
  EXPECT_EQ(back.held_ticks, 4);
  EXPECT_EQ(back.wall_time_s, s.wall_time_s);
  EXPECT_FALSE(parseRunSummaryJson("{\"outcome\": \"completed\"}", &back, &err));
  EXPECT_NE(err.find("ticks_planned"), std::string::npos) << err;
  EXPECT_FALSE(parseRunSummaryJson("{\"outcome\": ", &back, &err));
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
                        "--command-timeout-ms", "--hold-ticks", "--start-timeout-s", "--max-missing-commands",
                        "--result", "--quiet", "--help", "EXO_STATE",
                        "EXO_PLATE_RIGHT", "EXO_PLATE_LEFT", "EXO_TRUTH", "EXO_COMMAND", "exit codes", "ttl=0",
                        "3 the robot fell", "4 the controller stopped answering", "5 interrupted"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

TEST(ExoSimCli, BadInputExitsWithTwoAndOneLine) {
  const std::string bad_scenario = writeFile("bad.yaml", "name: x\nseed: 1\nnoise: off\neffects: {dampin: {all: 1}}\n");
  const std::string bad_mjcf = writeFile("bad.xml", "<mujoco><worldbody><body></mujoco>");
  std::ifstream in(cfg("exo.xml"));
  std::string mjcf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  mjcf.replace(mjcf.find("mass=\""), mjcf.find('"', mjcf.find("mass=\"") + 6) - mjcf.find("mass=\"") + 1, "mass=\"nan\"");
  const std::string nan_mjcf = writeFile("nan.xml", mjcf);  // MuJoCo 2.2 alone accepts it with a warning
  mjcf.replace(mjcf.find("mass=\"nan\""), 10, "mass=\"inf\"");
  const std::string inf_mjcf = writeFile("inf.xml", mjcf);  // and this one silently
  const std::string duplicate =
      writeFile("dup.yaml", "name: x\nseed: 1\nnoise: off\neffects: {joint_damping: {all: 1, all: 2}}\n");
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
      {"--scenario " + duplicate, duplicate + ": effects.joint_damping.all: duplicate key (line 4; first on line 4)"},
      {"--scenario " + unknown_joint, unknown_joint + ": effects.joint_damping.knee: unknown joint 'knee'"},
      {"--model " + bad_mjcf, bad_mjcf + ": MuJoCo cannot load the model"},
      {"--model " + nan_mjcf, nan_mjcf + ": body 'right_plate' <inertial mass='nan'> (line 14): not finite"},
      {"--model " + inf_mjcf, inf_mjcf + ": body 'right_plate' <inertial mass='inf'> (line 14): not finite"},
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
  // No controller on memq:// and no start wait: open loop at zero torque; the robot folds up and the run
  // ends at the fall with exit code 3 (a 0.3 s run ends standing, exit 0).
  const std::string result = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_sim_result.json";
  const CliRun r = runExoSim("--lcm-url memq:// --start-timeout-s 0 --duration 2 --result " + result + " --scenario " +
                             cfg("scenarios/ideal.yaml"));
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("exo_sim: summary: fell (fall at tick "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" of 2000, simulated"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(held 0, zero "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("timeouts 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fell yes"), std::string::npos) << r.out;
  std::ifstream in(result);
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  RunSummary s;
  std::string err;
  ASSERT_TRUE(parseRunSummaryJson(json, &s, &err)) << err << json;
  EXPECT_EQ(s.outcome, RunOutcome::Fell);
  EXPECT_EQ(s.ticks, s.fall_tick + 1);
  EXPECT_NE(r.out.find("fall at tick " + std::to_string(s.fall_tick) + ","), std::string::npos) << r.out;
  std::remove(result.c_str());
  const CliRun q = runExoSim("--quiet --lcm-url memq:// --start-timeout-s 0 --duration 0.3");
  EXPECT_EQ(q.code, 0) << q.out;
  EXPECT_EQ(q.out.rfind("exo_sim: summary: completed, ticks 300 of 300,", 0), 0u) << q.out;  // only the summary
  EXPECT_EQ(runExoSim("--result /nonexistent/dir/r.json --quiet --lcm-url memq:// --start-timeout-s 0 --duration 0.01").code, 1);
}

// SIGTERM (here during the start handshake, waiting for a controller) ends the run cleanly: exit 5, the
// result says interrupted. A SIGTERM while the model loads is honoured too (the handler is installed first).
TEST(ExoSimCli, SigtermEndsTheRunWithExitFiveAndItsResult) {
  const std::string result = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "_exo_sim_sigterm.json";
  for (const int delay_ms : {600, 0}) {
    std::remove(result.c_str());
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, STDOUT_FILENO);
      ::execl(EXO_SIM_BIN, EXO_SIM_BIN, "--lcm-url", "memq://", "--duration", "10", "--result", result.c_str(),
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    ::kill(pid, SIGTERM);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    if (delay_ms == 0 && WIFSIGNALED(status)) continue;  // killed before main() installed the handler
    ASSERT_TRUE(WIFEXITED(status)) << delay_ms;
    EXPECT_EQ(WEXITSTATUS(status), 5) << delay_ms;
    std::ifstream in(result);
    const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    RunSummary s;
    std::string err;
    ASSERT_TRUE(parseRunSummaryJson(json, &s, &err)) << err << json;
    EXPECT_EQ(s.outcome, RunOutcome::Interrupted);
    EXPECT_LT(s.ticks, 10000);
  }
  std::remove(result.c_str());
}

}  // namespace
}  // namespace exoid::sim
