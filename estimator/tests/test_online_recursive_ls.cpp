// The recursive estimator against independent computations: the batch regularised least-squares solution
// from the batch accumulator's factor (a stacked QR, never the information matrix), the structural
// nullspace of the data, long runs, standing still with forgetting, and rejected samples.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <filesystem>
#include <unistd.h>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/estimator/online/row_filter.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::estimator {
namespace {

struct Exo {
  Model model;
  BaseParameters base;
};

const Exo& exo() {
  static const Exo e = [] {
    Exo x;
    std::string err;
    EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, x.model, &err)) << err;
    x.base = computeBaseParameters(x.model);
    return x;
  }();
  return e;
}

// The model's own parameters scaled by a random factor in [1 - spread, 1 + spread] (friction: 0.1 / 0.5).
Eigen::VectorXd perturbed(const Model& model, double spread, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-spread, spread);
  Eigen::VectorXd phi = model.phi;
  for (int i = 0; i < phi.size(); ++i) phi[i] = (phi[i] == 0.0 ? 0.05 : phi[i]) * (1.0 + u(rng));
  return phi;
}

TEST(RecursiveLs, NoForgettingEqualsTheBatchRegularisedSolution) {
  const Exo& e = exo();
  const Model& model = e.model;
  const int nv = model.nv, m = e.base.rank;
  const Eigen::VectorXd phi_true = perturbed(model, 0.1, 3);
  const Eigen::VectorXd prior = perturbed(model, 0.25, 4);
  const Eigen::MatrixXd Lambda0 = diagonalPriorInformation(model, e.base, prior, 0.25);
  RecursiveLsOptions opt;
  std::vector<double> noise(nv);
  for (int c = 0; c < nv; ++c) noise[c] = 0.05 * (1 + c % 4);  // per-coordinate noise level
  for (int c = 0; c < nv; ++c) opt.row_weight.push_back(1.0 / noise[c]);
  RecursiveLsModel rm;
  std::string err;
  ASSERT_TRUE(makeRecursiveLs(model, e.base, prior, Lambda0, opt, rm, &err)) << err;
  RecursiveLsData rd(rm);

  AccumulatorOptions ao;
  ao.folds = 1;
  ao.threads = 1;
  LsqAccumulator acc(model, e.base, ao);

  // Random states with the left leg frozen (constant q, no motion): its bodies move rigidly with the base, so
  // some base-parameter directions are not excited at all.
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::VectorXd y(nv);
  for (int k = 0; k < 3000; ++k) {
    randomState(model, rng, s);
    for (int j = 0; j < model.njoints; ++j)
      if (model.joint_names[j].rfind("left_", 0) == 0) s.q[j] = 0.3, s.v[j] = 0.0, s.a[j] = 0.0;
    computeJointTorqueRegressor(model, data, s);
    y = data.K * phi_true;
    for (int c = 0; c < nv; ++c) y[c] += noise[c] * gauss(rng);
    ASSERT_EQ(updateRecursiveLs(rm, rd, k, data.K, y), SampleStatus::Accepted);
    ASSERT_TRUE(acc.add(data.K, y));
  }
  ASSERT_TRUE(solveRecursiveLs(rm, rd, true));

  // Batch: the accumulator's weighted factor (||G(W_B x - y)||^2 = ||R x - z||^2 + rss) stacked with the
  // prior's square root, solved by QR.
  acc.flush();
  const LsqFactor f = acc.mergedBase(opt.row_weight);
  const Eigen::VectorXd L0 = Lambda0.diagonal().cwiseSqrt();
  Eigen::MatrixXd M(2 * m, m);
  Eigen::VectorXd r(2 * m);
  M << f.R, Eigen::MatrixXd(L0.asDiagonal());
  r << f.z, L0.cwiseProduct(rm.x0);
  const Eigen::VectorXd x_batch = M.householderQr().solve(r);
  EXPECT_LE((rd.x - x_batch).norm(), 1e-8 * x_batch.norm());

  // Whitened coordinates xi = L0 (x - x0): the regularised solution lies in the row space of R L0^-1.
  const Eigen::MatrixXd RL = f.R * L0.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(RL, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  int excited = 0;
  while (excited < m && sv[excited] > 1e-9 * sv[0]) ++excited;
  ASSERT_LT(excited, m) << "the frozen leg must leave directions unexcited";
  ASSERT_GT(excited, m / 2);
  const Eigen::MatrixXd Ve = svd.matrixV().leftCols(excited), Vn = svd.matrixV().rightCols(m - excited);
  const Eigen::VectorXd xi_online = L0.cwiseProduct(rd.x - rm.x0), xi_batch = L0.cwiseProduct(x_batch - rm.x0);
  EXPECT_LE((Ve.transpose() * (xi_online - xi_batch)).norm(), 1e-8 * (Ve.transpose() * xi_batch).norm());
  // Unexcited directions stay at the prior (to the round-off of the smallest kept singular value).
  EXPECT_LE((Vn.transpose() * xi_online).norm(), 1e-8 * xi_batch.norm());
  EXPECT_GT((Ve.transpose() * xi_online).norm(), 1.0);  // and the data did move the excited ones

  // Uncertainty: A^-1 against the stacked factor's (M^T M)^-1.
  const Eigen::MatrixXd cov = (M.transpose() * M).inverse();
  EXPECT_LE((rd.sigma - cov.diagonal().cwiseSqrt()).cwiseAbs().maxCoeff(),
            1e-8 * cov.diagonal().cwiseSqrt().maxCoeff());
  // Residual RMS per coordinate against the accumulator's residual (unweighted).
  for (int c = 0; c < nv; ++c) {
    const double batch_rms = std::sqrt(acc.residual(c, rd.x) / 3000.0);
    EXPECT_NEAR(rd.residual_rms[c], batch_rms, 1e-6 * batch_rms + 1e-9) << "coordinate " << c;
  }
  // Prediction = K_B x.
  Eigen::VectorXd tau(nv);
  predictRecursiveLs(rm, rd, data.K, tau);
  Eigen::VectorXd phi_std = Eigen::VectorXd::Zero(model.nparams());
  for (int j = 0; j < m; ++j) phi_std[e.base.independent[j]] = rd.x[j];
  EXPECT_LE((tau - data.K * phi_std).norm(), 1e-10 * tau.norm());
}

// A small synthetic problem (the estimator's maths do not depend on where K comes from): 2 coordinates,
// 3 parameters, row 0 touches parameters {0, 1}, row 1 touches {1, 2}.
RecursiveLsModel smallModel(double forgetting) {
  RecursiveLsModel rm;
  rm.nv = 2;
  rm.p = 3;
  rm.m = 3;
  rm.independent = {0, 1, 2};
  rm.active = {{0, 1}, {1, 2}};
  rm.x0 = Eigen::Vector3d(1.0, -2.0, 0.5);
  rm.prior_information = Eigen::Vector3d(4.0, 1.0, 100.0).asDiagonal();
  rm.prior_rhs = rm.prior_information * rm.x0;
  rm.row_weight = Eigen::Vector2d(1.0, 2.0);
  rm.forgetting = forgetting;
  return rm;
}

TEST(RecursiveLs, TenMillionUpdatesStayPositiveDefiniteAndFinite) {
  const RecursiveLsModel rm = smallModel(0.9995);  // memory 2000 samples: renormalises every ~460k samples
  RecursiveLsData rd(rm);
  const Eigen::Vector3d x_true(1.3, -1.1, 0.7);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(2, 3);
  Eigen::Vector2d y;
  int checked = 0;
  for (long k = 0; k < 10000000; ++k) {
    // Regressor magnitudes spanning 1e-3..1e3 (slow drift), with long quiet stretches (no excitation).
    const double mag = std::pow(10.0, 3.0 * std::sin(1e-5 * k));
    const bool quiet = (k / 300000) % 3 == 2;
    K(0, 0) = quiet ? 0.0 : mag * u(rng);
    K(0, 1) = mag * u(rng);
    K(1, 1) = quiet ? 0.0 : mag * u(rng);
    K(1, 2) = mag * u(rng);
    y = K * x_true;
    y[0] += 1e-3 * u(rng);
    y[1] += 1e-3 * u(rng);
    ASSERT_EQ(updateRecursiveLs(rm, rd, k, K, y), SampleStatus::Accepted);
    if (k % 250000 == 249999) {
      ASSERT_TRUE(solveRecursiveLs(rm, rd, true)) << "sample " << k;
      ASSERT_TRUE(rd.x.allFinite() && rd.sigma.allFinite()) << "sample " << k;
      // A = Lambda0 + D with D >= 0: every eigenvalue of A at least Lambda0's smallest (4 - round-off).
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(rd.A.selfadjointView<Eigen::Upper>());
      ASSERT_GE(eig.eigenvalues().minCoeff(), 1.0 * (1 - 1e-9)) << "sample " << k;
      if (!quiet && mag > 10.0) {
        EXPECT_LE((rd.x - x_true).norm(), 1e-2) << "sample " << k;
        ++checked;
      }
    }
  }
  EXPECT_EQ(rd.accepted, 10000000);
  EXPECT_GE(checked, 8);  // the estimate was checked while excited, not only the definiteness
}

TEST(RecursiveLs, StandingStillWithForgettingKeepsTheUncertaintyBounded) {
  const Exo& e = exo();
  const Model& model = e.model;
  const Eigen::VectorXd prior = perturbed(model, 0.25, 4);
  const Eigen::MatrixXd Lambda0 = diagonalPriorInformation(model, e.base, prior, 0.25);
  RecursiveLsOptions opt;
  opt.forgetting = 0.999;  // 1 s memory at 1 kHz
  RecursiveLsModel rm;
  std::string err;
  ASSERT_TRUE(makeRecursiveLs(model, e.base, prior, Lambda0, opt, rm, &err)) << err;
  RecursiveLsData rd(rm);
  const Eigen::VectorXd prior_sigma = Lambda0.diagonal().cwiseInverse().cwiseSqrt();

  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(2);
  randomState(model, rng, s);
  // First 2 s of random motion (excites), then 60 s standing still at 1 kHz: one fixed pose, no motion.
  Eigen::VectorXd y(model.nv);
  long tick = 0;
  for (; tick < 2000; ++tick) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    y = data.K * model.phi;
    updateRecursiveLs(rm, rd, tick, data.K, y);
  }
  ASSERT_TRUE(solveRecursiveLs(rm, rd, true));
  const double excited_trace = rd.sigma.squaredNorm();
  s.base_omega.setZero();
  s.base_velocity.setZero();
  s.base_domega.setZero();
  s.base_acceleration.setZero();
  s.v.setZero();
  s.a.setZero();
  computeJointTorqueRegressor(model, data, s);
  y = data.K * model.phi;
  for (int sec = 1; sec <= 60; ++sec) {
    for (int k = 0; k < 1000; ++k, ++tick) ASSERT_EQ(updateRecursiveLs(rm, rd, tick, data.K, y), SampleStatus::Accepted);
    ASSERT_TRUE(solveRecursiveLs(rm, rd, true));
    ASSERT_TRUE(rd.x.allFinite());
    // A >= Lambda0 => A^-1 <= Lambda0^-1: no parameter more uncertain than the prior made it.
    for (int j = 0; j < rm.m; ++j) ASSERT_LE(rd.sigma[j], prior_sigma[j] * (1 + 1e-9)) << "t " << sec << " s, j " << j;
  }
  // Forgetting did act (the motion's information decayed) but the bound held.
  EXPECT_GT(rd.sigma.squaredNorm(), 2.0 * excited_trace);
}

TEST(RecursiveLs, DiscountKeepsTheGivenFractionOfTheDataAndAllOfThePrior) {
  // A one-off discount kappa: the data information and rhs become exactly kappa x what they were (A - Lambda0
  // and b - Lambda0 x0), the effective samples too; later samples then count fully against the discounted past.
  const Exo& e = exo();
  RecursiveLsModel rm;
  std::string err;
  const Eigen::VectorXd prior = perturbed(e.model, 0.2, 3);
  ASSERT_TRUE(makeRecursiveLs(e.model, e.base, prior,
                              diagonalPriorInformation(e.model, e.base, prior, 0.25), {}, rm, &err)) << err;
  RecursiveLsData a(rm), b(rm);
  std::mt19937_64 rng(5);
  Data kin(e.model);
  Eigen::VectorXd y(e.model.nv);
  State s = State::zero(e.model);
  for (long t = 0; t < 300; ++t) {
    randomState(e.model, rng, s);
    computeJointTorqueRegressor(e.model, kin, s);
    y = kin.K * e.model.phi;
    ASSERT_EQ(updateRecursiveLs(rm, a, t, kin.K, y), SampleStatus::Accepted);
  }
  b = a;
  discountRecursiveLs(rm, b, 0.25);
  ASSERT_TRUE(solveRecursiveLs(rm, a, false));
  ASSERT_TRUE(solveRecursiveLs(rm, b, false));
  const Eigen::MatrixXd Da = (a.A - rm.prior_information).selfadjointView<Eigen::Upper>();
  const Eigen::MatrixXd Db = (b.A - rm.prior_information).selfadjointView<Eigen::Upper>();
  EXPECT_LT((Db - 0.25 * Da).norm(), 1e-12 * Da.norm());
  EXPECT_LT(((b.b - rm.prior_rhs) - 0.25 * (a.b - rm.prior_rhs)).norm(), 1e-12 * (a.b - rm.prior_rhs).norm());
  EXPECT_DOUBLE_EQ(b.effective_samples, 0.25 * a.effective_samples);
  // The discounted estimate sits between the prior and the data's: closer to the prior than the undiscounted.
  EXPECT_GT((a.x - b.x).norm(), 0.0);
  discountRecursiveLs(rm, b, 0.0);  // out of range: ignored
  EXPECT_DOUBLE_EQ(b.effective_samples, 0.25 * a.effective_samples);
}

TEST(RecursiveLs, BadSamplesAreRejectedCountedAndLeaveTheStateUntouched) {
  const RecursiveLsModel rm = smallModel(0.99);
  RecursiveLsData rd(rm);
  Eigen::MatrixXd K(2, 3);
  K << 1.0, 2.0, 0.0, 0.0, -1.0, 3.0;
  Eigen::Vector2d y(0.5, 1.5);
  ASSERT_EQ(updateRecursiveLs(rm, rd, 10, K, y), SampleStatus::Accepted);
  ASSERT_EQ(updateRecursiveLs(rm, rd, 12, K, y), SampleStatus::Accepted);  // tick 11 missing: counted
  EXPECT_EQ(rd.missing, 1);
  const RecursiveLsData before = rd;
  auto same = [&] {
    for (int c = 0; c < rm.nv; ++c) {
      EXPECT_EQ(rd.D[c], before.D[c]);
      EXPECT_EQ(rd.d[c], before.d[c]);
    }
    EXPECT_EQ(rd.yy, before.yy);
    EXPECT_EQ(rd.scale, before.scale);
    EXPECT_EQ(rd.effective_samples, before.effective_samples);
    EXPECT_EQ(rd.last_tick, before.last_tick);
    EXPECT_EQ(rd.accepted, before.accepted);
  };
  Eigen::MatrixXd Kbad = K;
  Kbad(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(updateRecursiveLs(rm, rd, 13, Kbad, y), SampleStatus::NonFinite);
  Kbad = K;
  Kbad(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(updateRecursiveLs(rm, rd, 13, Kbad, y), SampleStatus::NonFinite);
  EXPECT_EQ(updateRecursiveLs(rm, rd, 13, K, Eigen::Vector2d(std::nan(""), 0.0)), SampleStatus::NonFinite);
  EXPECT_EQ(rd.rejected_nonfinite, 3);
  EXPECT_EQ(updateRecursiveLs(rm, rd, 12, K, y), SampleStatus::Duplicate);
  EXPECT_EQ(rd.rejected_duplicate, 1);
  EXPECT_EQ(updateRecursiveLs(rm, rd, 5, K, y), SampleStatus::OutOfOrder);
  EXPECT_EQ(rd.rejected_out_of_order, 1);
  same();
  // A non-finite entry in a column the row cannot touch is never read (structural zero): accepted.
  Kbad = K;
  Kbad(0, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(updateRecursiveLs(rm, rd, 13, Kbad, y), SampleStatus::Accepted);
  ASSERT_TRUE(solveRecursiveLs(rm, rd, true));
  EXPECT_TRUE(rd.x.allFinite());
}

TEST(RecursiveLs, CheckpointResumesExactlyAndRefusesAnotherEstimator) {
  const RecursiveLsModel rm = smallModel(0.999);
  RecursiveLsData running(rm);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(2, 3);
  Eigen::Vector2d y;
  auto sample = [&] {
    K(0, 0) = u(rng), K(0, 1) = u(rng), K(1, 1) = u(rng), K(1, 2) = u(rng);
    y = K * Eigen::Vector3d(0.5, 1.5, -1.0) + 0.01 * Eigen::Vector2d(u(rng), u(rng));
  };
  long tick = 0;
  for (; tick < 5000; ++tick) sample(), updateRecursiveLs(rm, running, tick, K, y);
  updateRecursiveLs(rm, running, tick - 1, K, y);  // a duplicate, counted
  const std::string path = ::testing::TempDir() + "rls_checkpoint_" + std::to_string(::getpid()) + ".bin";
  std::string err;
  ASSERT_TRUE(saveRecursiveLs(rm, running, path, &err)) << err;
  RecursiveLsData restarted(rm);
  ASSERT_TRUE(loadRecursiveLs(rm, restarted, path, &err)) << err;
  EXPECT_EQ(restarted.rejected_duplicate, 1);
  // Both continue on the same samples: bit-identical estimates; a stale tick stays rejected after restart.
  EXPECT_EQ(updateRecursiveLs(rm, restarted, 10, K, y), SampleStatus::OutOfOrder);
  running.rejected_out_of_order++;
  for (; tick < 6000; ++tick) {
    sample();
    updateRecursiveLs(rm, running, tick, K, y);
    updateRecursiveLs(rm, restarted, tick, K, y);
  }
  ASSERT_TRUE(solveRecursiveLs(rm, running, false));
  ASSERT_TRUE(solveRecursiveLs(rm, restarted, false));
  EXPECT_EQ(running.x, restarted.x);
  EXPECT_EQ(running.rejected_out_of_order, restarted.rejected_out_of_order);
  // Another estimator (different forgetting) or a damaged file: refused, state untouched.
  const RecursiveLsModel other = smallModel(0.99);
  RecursiveLsData fresh(other);
  EXPECT_FALSE(loadRecursiveLs(other, fresh, path, &err));
  EXPECT_NE(err.find("different estimator"), std::string::npos) << err;
  EXPECT_EQ(fresh.accepted, 0);
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 5);
  EXPECT_FALSE(loadRecursiveLs(rm, fresh, path, &err));
  EXPECT_NE(err.find("truncated"), std::string::npos) << err;
  EXPECT_FALSE(loadRecursiveLs(rm, fresh, path + ".missing", &err));
  std::filesystem::remove(path);
}

TEST(RecursiveLs, BadConfigurationIsRefusedWithAMessage) {
  const Exo& e = exo();
  const Eigen::VectorXd prior = e.model.phi;
  const Eigen::MatrixXd Lambda0 = diagonalPriorInformation(e.model, e.base, prior, 0.25);
  RecursiveLsModel rm;
  std::string err;
  RecursiveLsOptions opt;
  opt.forgetting = 1.5;
  EXPECT_FALSE(makeRecursiveLs(e.model, e.base, prior, Lambda0, opt, rm, &err));
  EXPECT_NE(err.find("forgetting"), std::string::npos) << err;
  opt.forgetting = 1.0;
  Eigen::MatrixXd bad = Lambda0;
  bad(0, 0) = -1.0;
  EXPECT_FALSE(makeRecursiveLs(e.model, e.base, prior, bad, opt, rm, &err));
  EXPECT_NE(err.find("positive definite"), std::string::npos) << err;
  opt.row_weight = {1.0, 2.0};
  EXPECT_FALSE(makeRecursiveLs(e.model, e.base, prior, Lambda0, opt, rm, &err));
  EXPECT_NE(err.find("row weights"), std::string::npos) << err;
}

TEST(CausalRowFilter, SameFilterOnRowsAndYKeepsTheEquationsExact) {
  const Exo& e = exo();
  const Model& model = e.model;
  RecursiveLsModel rm;
  std::string err;
  const Eigen::VectorXd phi = model.phi;
  ASSERT_TRUE(makeRecursiveLs(model, e.base, phi, diagonalPriorInformation(model, e.base, phi, 0.25), {}, rm, &err));
  CausalRowFilter filter;
  filter.configure(rm, 30.0, 1000.0);
  LowPassFilter one;  // an independent single-channel filter on one entry, at rest on zero like the row filter
  one.configure(1, 30.0, 1000.0);
  one.reset(Eigen::VectorXd::Zero(1));
  const int c = 8, col = e.base.independent[rm.active[8].back()];
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(3);
  Eigen::MatrixXd Kf = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Eigen::VectorXd y(model.nv), yf(model.nv), single(1);
  // K phi = K_B x (W = W_B B): the base parameters on the independent columns, zeros elsewhere.
  Eigen::VectorXd phi_b = Eigen::VectorXd::Zero(model.nparams());
  for (int j = 0; j < rm.m; ++j) phi_b[e.base.independent[j]] = rm.x0[j];
  double worst = 0.0, moved = 0.0;
  for (int k = 0; k < 500; ++k) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    y = data.K * phi;
    filter.filter(rm, data.K, y, Kf, yf);
    single[0] = data.K(c, col);
    one.filter(single, single);
    EXPECT_NEAR(Kf(c, col), single[0], 1e-12 * (1 + std::abs(single[0])));
    worst = std::max(worst, (Kf * phi_b - yf).norm() / yf.norm());
    moved = std::max(moved, (Kf - data.K).norm() / data.K.norm());
  }
  EXPECT_LE(worst, 1e-12);  // F(K) phi = F(y)
  EXPECT_GT(moved, 0.1);    // while K itself was changed a lot (random states: broadband)
}

}  // namespace
}  // namespace exoid::estimator
