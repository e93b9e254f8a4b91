// The default rank rule of `exoid identify` (jackknife with a per-parameter prior uncertainty) on synthetic arms
// with friction (tools/synthetic_arm.hpp), the "left at the prior" count and the held-out / training ratio
// warning (docs/identification.md, "Choosing the rank z" and "Output").
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/tools/perturb_inertials.hpp"
#include "exoid/tools/synthetic_arm.hpp"
#include "support/run_command.hpp"

using namespace exoid;

namespace {

// One arm, a training run and a validation run of another motion, as `exoid identify` reads them (CSV).
struct ArmData {
  tools::SyntheticArm arm;
  Eigen::VectorXd prior;
  std::unique_ptr<estimator::LsqAccumulator> train, validate;
  tools::ArmRun train_run;
};

std::unique_ptr<estimator::LsqAccumulator> accumulate(const tools::SyntheticArm& arm, const tools::ArmRun& run,
                                                      double rate, int folds, const std::string& path) {
  std::string err;
  EXPECT_TRUE(tools::writeArmRunCsv(path, arm.model, run, &err)) << err;
  estimator::AccumulatorOptions ao;
  ao.folds = folds;
  ao.chunk = static_cast<int>(std::lround(2.0 * rate));  // identify's --chunk-seconds 2
  auto acc = std::make_unique<estimator::LsqAccumulator>(arm.model, computeBaseParameters(arm.model), ao);
  intake::InputStats st;
  EXPECT_TRUE(tools::accumulateFile(path, arm.model, tools::SourceOptions{}, *acc, st, &err)) << err;
  acc->flush();
  return acc;
}

ArmData makeData(const test::TempDir& dir, tools::SyntheticArmOptions ao, double rate, double noise,
                 double validation_payload = 0.0, double train_seconds = 40.0) {
  ArmData d;
  std::string err;
  EXPECT_TRUE(tools::makeSyntheticArm(ao, d.arm, &err)) << err;
  EXPECT_TRUE(tools::perturbInertials(d.arm.model, 0.25, ao.seed, d.prior, &err)) << err;
  tools::ArmRunOptions ro;
  ro.rate = rate;
  ro.torque_noise = noise;
  ro.seed = 1000 * ao.seed;
  ro.duration = train_seconds;
  d.train_run = tools::simulateArmRun(d.arm, ro);
  d.train = accumulate(d.arm, d.train_run, rate, 5, dir.file("train.csv"));
  ro.seed += 1;
  ro.duration = 20.0;
  ro.payload = validation_payload;
  d.validate = accumulate(d.arm, tools::simulateArmRun(d.arm, ro), rate, 1, dir.file("validate.csv"));
  return d;
}

estimator::IdentifyResult identify(const ArmData& d, estimator::RankRule rule) {
  estimator::IdentifyOptions o;  // identify's defaults: WLS-RC-PC
  o.physically_consistent = true;
  o.rank_rule = rule;
  estimator::IdentifyResult r;
  std::string err;
  EXPECT_TRUE(estimator::identify(*d.train, d.arm.model, d.prior, o, d.validate.get(), r, &err)) << err;
  return r;
}

// The default against the best rank the validation data choose, and against the prior.
void expectDefaultNearTheValidationChoice(const ArmData& d) {
  const estimator::IdentifyResult def = identify(d, estimator::RankRule::Jackknife);
  const estimator::IdentifyResult best = identify(d, estimator::RankRule::Validation);
  EXPECT_LE(def.validation_rmse, 1.10 * best.validation_rmse)
      << "default z = " << def.rank << ", validation z = " << best.rank;
  EXPECT_LT(def.validation_rmse, def.prior_validation_rmse);
}

}  // namespace

TEST(RankRule, DefaultIsWithinTenPercentOfTheValidationChoiceOnSyntheticArms) {
  test::TempDir dir("rank_arms");
  tools::SyntheticArmOptions a;
  a.joints = 6, a.seed = 11, a.friction_ratio = 0.2;
  expectDefaultNearTheValidationChoice(makeData(dir, a, 200.0, 0.02));
  a.joints = 7, a.seed = 12, a.friction_ratio = 0.1;
  expectDefaultNearTheValidationChoice(makeData(dir, a, 100.0, 0.03));
}

TEST(RankRule, FrictionDominantArmWithAZeroFrictionPriorKeepsTheFrictionDirections) {
  // The case: friction larger than the inertial torques, torques from motor currents (10 % noise),
  // 100 Hz, friction prior 0. A +-25 % test on the friction directions cut them; the unknown prior keeps them.
  test::TempDir dir("rank_friction");
  tools::SyntheticArmOptions a;
  a.joints = 6, a.seed = 14, a.friction_ratio = 1.5;
  const ArmData d = makeData(dir, a, 100.0, 0.10);
  expectDefaultNearTheValidationChoice(d);
  const estimator::IdentifyResult r = identify(d, estimator::RankRule::Jackknife);
  for (int j = 0; j < d.arm.model.njoints; ++j) {
    const int f = d.arm.model.frictionParamIndex(j);
    EXPECT_NEAR(r.phi[f + 1], d.arm.truth[f + 1], 0.1 * d.arm.truth[f + 1]) << "Coulomb friction of joint " << j;
  }
}

TEST(RankRule, UnknownPriorUncertaintyIsTheDataScale) {
  // priorUncertainty against the stacked problem: sigma_j = relative |prior_j| / sqrt(3) where the prior is
  // meaningful (h the column scale), ||G y_j|| / ||G W_j|| over joint j's torque for its friction columns.
  test::TempDir dir("rank_sigma");
  tools::SyntheticArmOptions a;
  a.joints = 5, a.seed = 15;
  const ArmData d = makeData(dir, a, 100.0, 0.02, 0.0, 10.0);
  const Model& m = d.arm.model;
  const estimator::WeightedFactor wf = estimator::weightedFactor(*d.train, m, true);
  const Eigen::VectorXd sigma = estimator::priorUncertainty(m, d.prior, wf, 0.25);
  // Dense G W and G y from the run (the accumulator reads the same CSV: q, v, a and tau as written).
  const tools::ArmRun& run = d.train_run;
  Data data(m);
  State s = State::zero(m);
  Eigen::VectorXd col2 = Eigen::VectorXd::Zero(m.nparams()), y2 = Eigen::VectorXd::Zero(m.nv);
  for (Eigen::Index i = 0; i < run.t.size(); ++i) {
    s.q = run.q.row(i).transpose(), s.v = run.v.row(i).transpose(), s.a = run.a.row(i).transpose();
    computeJointTorqueRegressor(m, data, s);
    for (int c = 0; c < m.nv; ++c) {
      const double g = wf.row_weight[c];
      col2 += (g * data.K.row(c).transpose()).cwiseAbs2();
      y2[c] += g * g * run.tau(i, c) * run.tau(i, c);
    }
  }
  const Eigen::VectorXd h = estimator::columnScale(m, d.prior);
  for (int i = 0; i < m.nInertialParams(); ++i) EXPECT_NEAR(sigma[i], 0.25 / std::sqrt(3.0) * h[i], 1e-12 * h[i]) << i;
  // WLS-RC's column scale of the unknown kind is the same data scale (the stated kinds keep columnScale's).
  const estimator::ScaledProblem sp = estimator::scaleProblem(*d.train, m, d.prior, estimator::Method::WlsRC);
  for (int i = 0; i < m.nInertialParams(); ++i) EXPECT_EQ(sp.h[i], h[i]) << i;
  for (int j = 0; j < m.njoints; ++j)  // a joint's friction acts on that joint's torque alone
    for (int k = 0; k < 2; ++k) {
      const int i = m.frictionParamIndex(j) + k;
      EXPECT_NEAR(sigma[i], std::sqrt(y2[j] / col2[i]), 1e-6 * sigma[i]) << i;
      EXPECT_NEAR(sp.h[i], sigma[i], 1e-12 * sigma[i]) << i;
    }
}

TEST(RankRule, NotExcitedCountsWhatStayedAtThePrior) {
  // A short run with the last two joints still: their links' inertia cannot show, yet the fill moves many
  // parameters the kept directions barely reach. "Left at the prior" is what did not move, no more.
  test::TempDir dir("rank_still");
  tools::SyntheticArmOptions a;
  a.joints = 6, a.seed = 16;
  ArmData d = makeData(dir, a, 100.0, 0.02, 0.0, 12.0);
  for (int j = 4; j < 6; ++j) {
    d.train_run.q.col(j).setConstant(d.train_run.q(0, j));
    d.train_run.v.col(j).setZero();
    d.train_run.a.col(j).setZero();
  }
  d.train = accumulate(d.arm, d.train_run, 100.0, 5, dir.file("still.csv"));
  const estimator::IdentifyResult r = identify(d, estimator::RankRule::Jackknife);
  const estimator::ScaledProblem sp = estimator::scaleProblem(*d.train, d.arm.model, d.prior, estimator::Method::WlsRC);
  std::vector<bool> at_prior(d.prior.size(), false);
  for (int i : r.unexcited) at_prior[i] = true;
  int moved = 0;
  for (int i = 0; i < d.prior.size(); ++i) {
    const double change = std::abs(r.phi[i] - d.prior[i]);
    if (at_prior[i]) {
      EXPECT_LE(change, 1e-9 * sp.fill[i]) << i;
    } else {
      EXPECT_GT(change, 1e-9 * sp.fill[i]) << i;
      ++moved;
    }
  }
  EXPECT_GT(r.unexcited.size(), 0u);  // the still joints' viscous and Coulomb columns are zero
  EXPECT_GT(moved, 0);
  for (int j = 4; j < 6; ++j)  // a still joint's friction stays at its prior, 0
    for (int k = 0; k < 2; ++k) EXPECT_TRUE(at_prior[d.arm.model.frictionParamIndex(j) + k]) << j;
}

TEST(RankRule, HeldOutToTrainingRatioWarnsWhenTheValidationRunCarriesALoad) {
  test::TempDir dir("rank_ratio");
  tools::SyntheticArmOptions a;
  a.joints = 6, a.seed = 17;
  const ArmData same = makeData(dir, a, 100.0, 0.02);
  const estimator::IdentifyResult r0 = identify(same, estimator::RankRule::Jackknife);
  EXPECT_FALSE(r0.data_differ) << r0.heldout_ratio;
  EXPECT_NEAR(r0.heldout_ratio, r0.validation_rmse / r0.training_rmse, 1e-12);
  // The validation run with a payload of a third of the arm's mass at the last link.
  const ArmData loaded = makeData(dir, a, 100.0, 0.02, same.arm.model.totalMass() / 3.0);
  const estimator::IdentifyResult r1 = identify(loaded, estimator::RankRule::Jackknife);
  EXPECT_TRUE(r1.data_differ) << r1.heldout_ratio;
  EXPECT_GT(r1.heldout_ratio, 2.0);
}

TEST(RankRule, ProcessingAlternativesChangeOneChoiceEach) {
  // exoid identify's sensors pipeline on a floating base's logs, the fused orientation: half the cutoff, and the IMU
  // below the fusion cutoff (the legs' rate and acceleration are the default); with the gyro's rate, the IMU's
  // orientation; a CSV (its orientation recorded) or an unfiltered run has fewer.
  tools::SourceOptions so;
  so.dataset.cutoff_hz = 30.0;
  so.dataset.orientation_from_legs = so.dataset.base_rate_from_legs = so.dataset.base_acceleration_from_legs = true;
  auto names = [](const std::vector<tools::ProcessingAlternative>& a) {
    std::vector<std::string> n;
    for (const tools::ProcessingAlternative& x : a) n.push_back(x.what);
    return n;
  };
  const std::vector<tools::ProcessingAlternative> legs = tools::processingAlternatives(so, true);
  ASSERT_EQ(names(legs), (std::vector<std::string>{"cutoff 15 Hz", "IMU below the fusion cutoff"}));
  EXPECT_EQ(legs[0].source.dataset.cutoff_hz, 15.0);
  EXPECT_TRUE(legs[0].source.dataset.base_rate_from_legs && !legs[0].source.dataset.imu_below_fusion_cutoff);
  EXPECT_TRUE(legs[1].source.dataset.imu_below_fusion_cutoff);
  EXPECT_EQ(legs[1].source.dataset.cutoff_hz, 30.0);
  EXPECT_TRUE(legs[1].source.dataset.orientation_from_legs && legs[1].source.dataset.base_rate_from_legs);
  EXPECT_EQ(names(tools::processingAlternatives(so, false)), (std::vector<std::string>{"cutoff 15 Hz"}));
  tools::SourceOptions gyro = so;
  gyro.dataset.base_rate_from_legs = gyro.dataset.base_acceleration_from_legs = false;
  const std::vector<tools::ProcessingAlternative> g = tools::processingAlternatives(gyro, true);
  ASSERT_EQ(names(g), (std::vector<std::string>{"cutoff 15 Hz", "IMU orientation"}));
  EXPECT_FALSE(g[1].source.dataset.orientation_from_legs);
  tools::SourceOptions unfiltered = so;
  unfiltered.dataset.cutoff_hz = 0.0;
  EXPECT_EQ(names(tools::processingAlternatives(unfiltered, true)), (std::vector<std::string>{"IMU below the fusion cutoff"}));
  // The soles' tilt fitted to the plates (the default orientation): the tilt is modelled, so the IMU's band is no
  // alternative, only the filter; the gyro's rate keeps the IMU's orientation.
  tools::SourceOptions plates = so;
  plates.fit_sole_tilt = true;
  EXPECT_EQ(names(tools::processingAlternatives(plates, true)), (std::vector<std::string>{"cutoff 15 Hz"}));
  plates.dataset.cutoff_hz = 0.0;
  EXPECT_TRUE(tools::processingAlternatives(plates, true).empty());
  plates.dataset.cutoff_hz = 30.0;
  plates.dataset.base_rate_from_legs = plates.dataset.base_acceleration_from_legs = false;
  EXPECT_EQ(names(tools::processingAlternatives(plates, true)), (std::vector<std::string>{"cutoff 15 Hz", "IMU orientation"}));
}
