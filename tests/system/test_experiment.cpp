// End to end, as CI runs it: `exoid experiment` starts exo_sim and exo_controller as separate processes over
// udpm:// in a private network namespace, logs every channel, and summarises. On the logged run:
//  - without noise or undeclared effects, the logged q, v, dv (the simulator's own accelerations), joint
//    torque sensors and force-plate wrenches satisfy W phi_true = y to 1e-8 (the thesis's MuJoCo GRFs did not);
//  - with an undeclared effect (joint damping + dry friction) the same check shows the error it causes;
//  - `exoid export --truth` writes a CSV whose columns reproduce the same equation, and `--help` is complete.
#include <gtest/gtest.h>

#include <fstream>

#include "exoid/estimator/measurement.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/tools/run_log.hpp"
#include "exoid/tools/run_table.hpp"
#include "exoid/tools/state_columns.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

class Experiment : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string err;
    model_ = new Model;
    ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, *model_, &err)) << err;
  }
  static void TearDownTestSuite() { delete model_; }
  /// Runs a short experiment (2 moves) and reads its log.
  test::CommandResult run(const std::string& scenario, const test::TempDir& dir, tools::RunLog& log) {
    const auto r = test::runCommand(test::exoidBinary() + " experiment --moves 2 --scenario " +
                                        test::configPath("scenarios/" + scenario) + " --out " + dir.file("run"),
                                    dir.path);
    std::string err;
    if (r.exit_code == 0) EXPECT_TRUE(tools::readRunLog(dir.file("run/run.lcmlog"), model_->joint_names, log, &err)) << err;
    return r;
  }
  static Model* model_;
};
Model* Experiment::model_ = nullptr;

TEST_F(Experiment, IdealRunSatisfiesTheEquationsOfMotionFromItsLog) {
  test::TempDir dir("exp_ideal");
  tools::RunLog log;
  const auto r = run("ideal.yaml", dir, log);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const std::string summary = test::slurp(dir.file("run/summary.json"));
  EXPECT_NE(summary.find("\"moves_done\": 2"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"fell\": false"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"missing_ticks\": 0"), std::string::npos) << summary;
  // Every tick of every sim channel is in the log, in order.
  ASSERT_GT(log.truth.size(), 5000u);
  EXPECT_EQ(log.states.size(), log.truth.size());
  EXPECT_EQ(log.plates[0].size(), log.truth.size());
  EXPECT_EQ(log.plates[1].size(), log.truth.size());
  EXPECT_EQ(log.rejected, 0);
  tools::EomResidual eom;
  std::string err;
  ASSERT_TRUE(tools::eomResidual(*model_, model_->phi, log, eom, &err)) << err;
  std::printf("EoM residual of the logged ideal run: max relative %.3e, RMS %.3e over %ld ticks\n", eom.max_relative,
              eom.rms_absolute, eom.ticks);
  EXPECT_EQ(eom.ticks, static_cast<long>(log.truth.size()));
  EXPECT_LE(eom.max_relative, 1e-8);
  // The check is sensitive: a 1 % error in one link's mass is far above the threshold.
  Eigen::VectorXd phi = model_->phi;
  phi[model_->bodyParamIndex(model_->bodyIndex("right_thigh"))] *= 1.01;
  ASSERT_TRUE(tools::eomResidual(*model_, phi, log, eom, &err)) << err;
  EXPECT_GT(eom.max_relative, 1e-4);

  // Export the truth and rebuild K phi = y from the CSV columns alone.
  const auto e = test::runCommand(test::exoidBinary() + " export --truth --log " + dir.file("run/run.lcmlog") + " --out " +
                                      dir.file("truth.csv"),
                                  dir.path);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  tools::CsvTable csv;
  ASSERT_TRUE(tools::readCsv(dir.file("truth.csv"), csv, &err)) << err;
  EXPECT_EQ(csv.rows.size(), log.truth.size());
  tools::StateColumns cols;
  ASSERT_TRUE(cols.bind(*model_, csv, &err)) << err;
  Data kin(*model_);
  State s = State::zero(*model_);
  Eigen::VectorXd tau(model_->njoints), y(model_->nv);
  double max_error = 0.0, max_y = 0.0;
  for (size_t i = 0; i < csv.rows.size(); i += 97) {
    const auto& row = csv.rows[i];
    ASSERT_TRUE(cols.read(row, s, &err)) << err;
    computeJointTorqueRegressor(*model_, kin, s);
    for (int j = 0; j < model_->njoints; ++j) {
      const int c = csv.column("tau_" + model_->joint_names[j]);
      tau[j] = c >= 0 ? row[c] : 0.0;
    }
    ExternalWrench w[2];
    const char* sides[2] = {"right", "left"};
    for (int k = 0; k < 2; ++k) {
      w[k].body = model_->bodyIndex(std::string(sides[k]) + "_foot");
      const int fx = csv.column(std::string("fp_") + sides[k] + "_fx");
      ASSERT_GE(fx, 0);
      w[k].force = Eigen::Vector3d(row[fx], row[fx + 1], row[fx + 2]);
      w[k].moment_world_origin = Eigen::Vector3d(row[fx + 3], row[fx + 4], row[fx + 5]);
    }
    generalizedForceFromMeasurements(*model_, kin, s, tau, w, 2, y);
    max_error = std::max(max_error, (kin.K * model_->phi - y).cwiseAbs().maxCoeff());
    max_y = std::max(max_y, y.cwiseAbs().maxCoeff());
  }
  EXPECT_LE(max_error, 1e-8 * max_y);
}

TEST_F(Experiment, UndeclaredFrictionShowsInTheResidual) {
  test::TempDir dir("exp_friction");
  tools::RunLog log;
  const auto r = run("undeclared_friction.yaml", dir, log);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  tools::EomResidual eom;
  std::string err;
  ASSERT_TRUE(tools::eomResidual(*model_, model_->phi, log, eom, &err)) << err;
  std::printf("EoM residual with undeclared joint damping + dry friction: max relative %.3e, RMS %.3e\n",
              eom.max_relative, eom.rms_absolute);
  EXPECT_GT(eom.max_relative, 1e-3);
}

TEST(ExperimentCli, BadInputIsRejectedWithOneLine) {
  test::TempDir dir("exp_bad");
  auto r = test::runCommand(test::exoidBinary() + " experiment --scenario " + dir.file("none.yaml") + " --out " + dir.file("o"), dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("none.yaml"), std::string::npos) << r.err;
  std::ofstream(dir.file("bad.yaml")) << "name: x\neffects: {joint_damping: {no_such_joint: 1.0}}\n";
  r = test::runCommand(test::exoidBinary() + " experiment --moves 1 --scenario " + dir.file("bad.yaml") + " --out " + dir.file("o"), dir.path);
  EXPECT_NE(r.exit_code, 0);
  r = test::runCommand(test::exoidBinary() + " experiment --help", dir.path);
  EXPECT_EQ(r.exit_code, 0);
  for (const char* s : {"--scenario", "--out", "--seed", "--moves", "summary.json", "run.lcmlog", "unshare"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

}  // namespace
}  // namespace exoid
