// The online estimator's per-sample path (regressor, causal filter, update, prediction) and its solve at the
// publication rate allocate nothing: the shipped library (exoid_estimator, as built) under the process-wide malloc /
// operator new counter (tests/support/alloc_counter), which sees every Eigen heap allocation (Eigen allocates through
// malloc; controller/tests/test_no_allocation.cpp has the positive control).
#include <gtest/gtest.h>

#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/estimator/online/row_filter.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/alloc_counter.hpp"
#include "synthetic_sensors.hpp"

namespace exoid::estimator {
namespace {

TEST(OnlineNoAllocation, UpdateSolveAndPredictAllocateNothing) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  const BaseParameters base = computeBaseParameters(model);
  const Eigen::VectorXd prior = model.phi;
  RecursiveLsOptions opt;
  opt.forgetting = 0.5;  // renormalisation (every ~330 samples) happens inside the counted loop too
  RecursiveLsModel rm;
  ASSERT_TRUE(makeRecursiveLs(model, base, prior, diagonalPriorInformation(model, base, prior, 0.25), opt, rm, &err))
      << err;
  RecursiveLsData rd(rm);
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(1);
  std::vector<State> states(50, s);
  for (State& st : states) randomState(model, rng, st);
  Eigen::VectorXd y(model.nv), tau(model.nv);
  Eigen::MatrixXd Kbad = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Kbad(6, base.independent[rm.active[6][0]]) = std::numeric_limits<double>::quiet_NaN();

  CausalRowFilter filter;
  filter.configure(rm, 30.0, 1000.0);
  Eigen::MatrixXd Kf = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Eigen::VectorXd yf(model.nv);

  exoid::test::AllocationCounter counter;
  long accepted = 0;
  for (int k = 0; k < 2000; ++k) {
    computeJointTorqueRegressor(model, data, states[k % states.size()]);
    y.noalias() = data.K * prior;
    filter.filter(rm, data.K, y, Kf, yf);
    accepted += updateRecursiveLs(rm, rd, k, Kf, yf) == SampleStatus::Accepted;
    updateRecursiveLs(rm, rd, k, data.K, y);   // duplicate
    updateRecursiveLs(rm, rd, k + 1, Kbad, y);  // non-finite
    predictRecursiveLs(rm, rd, data.K, tau);
    if (k % 100 == 0) solveRecursiveLs(rm, rd, k % 200 == 0);
  }
  counter.stop();
  EXPECT_EQ(counter.mallocs(), 0);
  EXPECT_EQ(counter.news(), 0);
  EXPECT_EQ(accepted, 2000);
  EXPECT_EQ(rd.rejected_duplicate, 2000);
  EXPECT_EQ(rd.rejected_nonfinite, 2000);
  EXPECT_TRUE(rd.x.allFinite());
}

// The whole loop of exo_estimator: tick assembly, state reconstruction, regressor, filter, update, rejected
// inputs, and publication (solve, covariance, standard parameters, consistency, tau_correction) with selective
// forgetting's block step and detected changes (the discount, the sensor columns' carried information), which run
// inside the counted loop too.
TEST(OnlineNoAllocation, EstimatorLoopAndPublicationAllocateNothing) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  const BaseParameters base = computeBaseParameters(model);
  // With and without a diagnose sidecar (exo_estimator --effects): extra columns of every dynamics kind, filtered
  // and folded with K, in tau_correction, and a gain correcting y.
  EffectSet sidecar;
  const int knee = model.jointIndex("right_knee"), hip = model.jointIndex("left_hip_fe"), ankle = model.jointIndex("left_ankle_pd");
  ASSERT_TRUE(knee >= 0 && hip >= 0 && ankle >= 0);
  sidecar.effects = {{EffectKind::Viscous, knee, 5.0},  {EffectKind::Coulomb, knee, 3.0}, {EffectKind::Stribeck, hip, 1.0},
                     {EffectKind::Offset, ankle, -1.0}, {EffectKind::Armature, hip, 0.2}, {EffectKind::GainError, knee, 0.1}};
  for (bool effects : {false, true})
  for (Forgetting f : {Forgetting::None, Forgetting::Stabilised, Forgetting::Selective}) {
    OnlineEstimatorOptions opt;
    opt.forgetting = f;
    opt.lambda = 0.999;
    opt.forget_every = 50;
    if (effects) {
      opt.effects = sidecar;
      opt.base_body_moves = true;  // its height sigma in the uncertainty publications too
      // A detected change inside the counted loop (every time it is armed: the threshold is out of the way), so
      // that the discount and the sensor columns' carried information run there too.
      opt.change_threshold = 1e-9;
      opt.change_hold_s = 0.1;
    }
    OnlineEstimator est(model, base, model.phi, opt);
    ASSERT_TRUE(est.ok()) << est.error();
    ASSERT_EQ(est.effectColumnCount(), effects ? 5 : 0);
    EstimatorOutputSample out;
    est.sizeOutput(out);
    testing::SensorTick t = testing::makeSensorTick(model), bad = t;
    std::mt19937_64 rng(2);
    // A consistent-parameter solve first (it allocates: exo_estimator runs it on a worker), so that the
    // publications below also judge phi_c's misfit whenever the conditional mean is inconsistent.
    const long L = opt.derivative_half_window, warm = 2 * L + 20;  // rows need the state fit's 2L + 1 ticks
    for (long k = 0; k < warm; ++k) {
      testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
      est.addState(t.state);
      est.addPlate(t.plate[0]);
      est.addPlate(t.plate[1]);
    }
    est.fillOutput(out);
    est.reconcile(out);
    exoid::test::AllocationCounter counter;
      for (long k = warm; k < warm + 600; ++k) {
      testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
      est.addState(t.state);
      est.addPlate(t.plate[0]);
      est.addState(t.state);  // duplicate
      est.addPlate(t.plate[1]);
      if (k % 97 == 0) {
        bad = t;
        bad.state.tick = k + 1;
        bad.state.q[3] = std::nan("");
        est.addState(bad.state);  // non-finite: rejected
      }
      if (k % 10 == 9) est.fillOutput(out);
    }
      counter.stop();
    EXPECT_EQ(counter.mallocs(), 0) << forgettingName(f) << (effects ? " with effects" : "");
    EXPECT_EQ(counter.news(), 0) << forgettingName(f) << (effects ? " with effects" : "");
    // Every tick is the middle of a fit window but the first and last L.
    EXPECT_EQ(out.samples_used, warm + 600 - 2 * L) << forgettingName(f);
    EXPECT_EQ(out.rejected_duplicate, 600);
    EXPECT_EQ(out.rejected_nonfinite, (warm + 599) / 97 - (warm - 1) / 97);  // the multiples of 97 among the ticks
    EXPECT_EQ(est.reconciles(), 1);
    EXPECT_TRUE(out.params.allFinite() && out.tau_correction.allFinite());
    // Base parameters, the sidecar's columns, then one offset and one gain per joint torque sensor (defaults);
    // base_body_moves adds no column (it widens the published height's sigma).
    EXPECT_EQ(est.sensorOffsetColumnCount(), 2 * model.njoints);
    EXPECT_EQ(out.base_params.size(), base.rank + (effects ? 5 : 0) + 2 * model.njoints);
    if (effects) {
      EXPECT_GE(est.changesDetected(), 2) << forgettingName(f);
    }
  }
}

}  // namespace
}  // namespace exoid::estimator
