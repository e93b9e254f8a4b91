// Plugin mode = process mode, end to end: `exoid experiment --controller process` (exo_controller over LCM)
// and `--controller plugin` (the same controller inside exo_sim's loop) on the same scenario and move seed
// log the same commands tick by tick, bit for bit (every input is a double copied exactly, on both paths),
// hence the same simulated robot, controller status and summary. Also under an undeclared payload, where the
// balance controller's disturbance observer reads the force plates (plugin ABI version 2 passes them).
// --no-estimator: the estimate's arrival depends on scheduling (docs/estimator.md), so only runs without it
// can be bit-identical.
#include <gtest/gtest.h>

#include <cstring>

#include "exoid/model/urdf.hpp"
#include "exoid/intake/run_log.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

bool sameBits(const Eigen::Ref<const Eigen::VectorXd>& a, const Eigen::Ref<const Eigen::VectorXd>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
}

void sameInBothModes(const std::string& scenario) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  test::TempDir dir("plugin_equivalence_" + scenario);
  intake::RunLog logs[2];
  std::string summaries[2];
  const char* modes[2] = {"process", "plugin"};
  for (int m = 0; m < 2; ++m) {
    const std::string out = dir.file(modes[m]);
    const auto r = test::runCommand(test::exoidBinary() + " experiment --moves 1 --seed 7 --no-estimator --controller " + modes[m] +
                                        " --scenario " + test::configPath("scenarios/" + scenario + ".yaml") + " --out " + out,
                                    dir.path);
    ASSERT_EQ(r.exit_code, 0) << modes[m] << "\n" << r.out << r.err;
    ASSERT_TRUE(intake::readRunLog(out + "/run.lcmlog", model.joint_names, logs[m], &err)) << err;
    summaries[m] = test::slurp(out + "/summary.json");
    EXPECT_EQ(logs[m].rejected, 0) << logs[m].first_rejection;
  }
  const intake::RunLog &proc = logs[0], &plug = logs[1];
  // 5.2 s planned (latch, hold, one move, holds): one command per state.
  ASSERT_GT(plug.commands.size(), 5000u);
  ASSERT_EQ(proc.commands.size(), plug.commands.size());
  long differ = 0;
  for (size_t i = 0; i < plug.commands.size(); ++i) {
    const JointCommandSample &a = proc.commands[i], &b = plug.commands[i];
    const bool same = a.tick == b.tick && a.source_tick == b.source_tick && a.mode == b.mode &&
                      a.utime == b.utime && sameBits(a.tau, b.tau) && sameBits(a.tau_ff, b.tau_ff);
    if (!same && differ++ < 3)
      ADD_FAILURE() << "command " << i << " (tick " << b.tick << ") differs: process tau " << a.tau.transpose()
                    << ", plugin tau " << b.tau.transpose();
  }
  EXPECT_EQ(differ, 0);
  // The controllers' status and the simulated robot follow.
  ASSERT_EQ(proc.status.size(), plug.status.size());
  for (size_t i = 0; i < plug.status.size(); i += 1)
    ASSERT_TRUE(proc.status[i].com == plug.status[i].com && proc.status[i].moves_done == plug.status[i].moves_done &&
                proc.status[i].qp_iterations == plug.status[i].qp_iterations)
        << "status " << i;
  ASSERT_EQ(proc.truth.size(), plug.truth.size());
  for (size_t i = 0; i < plug.truth.size(); ++i)
    ASSERT_TRUE(sameBits(proc.truth[i].q, plug.truth[i].q) && proc.truth[i].base_position == plug.truth[i].base_position)
        << "truth " << i;
  // Summary: every figure but the timings is the same.
  for (const char* key : {"\"outcome\": \"completed\"", "\"moves_done\": 1", "\"fell\": false", "\"missing_ticks\": 0",
                          "\"controller_fallbacks\": 0", "\"sim_held_ticks\": 0", "\"sim_zero_ticks\": 0"})
    for (int m = 0; m < 2; ++m) EXPECT_NE(summaries[m].find(key), std::string::npos) << modes[m] << ": " << key;
  auto field = [](const std::string& json, const std::string& key) {
    const size_t p = json.find("\"" + key + "\": ");
    return p == std::string::npos ? std::string("?") : json.substr(p, json.find_first_of(",\n}", p) - p);
  };
  for (const char* key : {"com_rmse_m", "com_max_error_m", "max_foot_slip_m", "eom_residual_max_rel"})
    EXPECT_EQ(field(summaries[0], key), field(summaries[1], key));
}

TEST(PluginVsProcess, SameCommandsTickByTick) { sameInBothModes("nominal"); }

// An undeclared payload on both legs: the disturbance observer leans on the force plates here (docs/controller.md
// "Model error"), so this holds only if the plugin gets the same plates at the same tick as exo_controller.
TEST(PluginVsProcess, SameCommandsUnderAnUndeclaredPayload) { sameInBothModes("payload_two_legs"); }

}  // namespace
}  // namespace exoid
