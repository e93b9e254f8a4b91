// WLS-RC-PC (estimator/batch/consistent.hpp) against known consistent truths and independent optima:
// exact recovery of a fully identifiable body, a fit of exact exoskeleton data that stays consistent, the
// nearest positive semi-definite pseudo-inertia (Higham: eigenvalue clipping) as the known optimum of a
// Frobenius target, a noisy case where least squares gives inconsistent links and WLS-RC-PC does not, and
// convergence from a bad, inconsistent start.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/consistent.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"

namespace exoid::estimator {
namespace {

const char* kSingleBody = R"(<robot name="one">
  <link name="box"><inertial><origin xyz="0.05 -0.02 0.1" rpy="0.3 0.2 0.1"/><mass value="2.5"/>
    <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.06"/></inertial></link>
</robot>)";

/// Stacked regressor and exact y of random states.
void stack(const Model& model, int samples, uint64_t seed, Eigen::MatrixXd& W, Eigen::VectorXd& y) {
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(seed);
  W.resize(samples * model.nv, model.nparams());
  for (int k = 0; k < samples; ++k) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    W.middleRows(k * model.nv, model.nv) = data.K;
  }
  y = W * model.phi;
}

/// Prior within +-frac of the truth (thesis IV-B), friction priors 0.
Eigen::VectorXd randomPrior(const Model& model, double frac, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-frac, frac);
  Eigen::VectorXd prior = model.phi;
  for (int i = 0; i < model.nInertialParams(); ++i) prior[i] *= 1.0 + u(rng);
  return prior;
}

/// WLS-C scaled problem by a dense SVD of the stacked W H (independent of the streaming factor).
struct Dense {
  Eigen::VectorXd s, d, h, phi_fit;
  Eigen::MatrixXd V;
  int rank = 0;
};
Dense denseScaled(const Eigen::MatrixXd& W, const Eigen::VectorXd& y, const Eigen::VectorXd& prior, int z = -1) {
  Dense out;
  out.h = prior.cwiseAbs().cwiseMax(0.01);  // friction priors are 0: scale 0.01
  Eigen::BDCSVD<Eigen::MatrixXd> svd(W * out.h.asDiagonal(), Eigen::ComputeThinU | Eigen::ComputeThinV);
  out.s = svd.singularValues();
  out.V = svd.matrixV();
  out.d = svd.matrixU().transpose() * (y - W * prior);
  for (int i = 0; i < out.s.size(); ++i) out.rank += out.s[i] > 1e-10 * out.s[0] ? 1 : 0;
  if (z < 0) z = out.rank;
  out.phi_fit = prior + out.h.asDiagonal() *
                            (out.V.leftCols(z) * (out.d.head(z).array() / out.s.head(z).array()).matrix());
  return out;
}

TEST(Consistent, RecoversAFullyIdentifiableBodyFromExactData) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfString(kSingleBody, true, model, &err)) << err;
  ASSERT_EQ(model.nparams(), 10);
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  stack(model, 50, 1, W, y);
  const Eigen::VectorXd prior = randomPrior(model, 0.25, 2);
  const Dense D = denseScaled(W, y, prior);
  ASSERT_EQ(D.rank, 10);
  const QuadraticTarget t = consistentTarget(D.s, D.V, D.d, D.h, prior, prior, D.rank, 0.0);
  // From the prior, from an inconsistent start (negative mass, inertia breaking the triangle inequality)
  // and from a far consistent body (log-Cholesky coordinates of the truth moved by up to 2: mass x e^-4..e^4).
  Eigen::VectorXd bad = model.phi;
  bad[0] = -3.0;
  bad[4] = 10.0;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Eigen::VectorXd far = consistentCoordinates(model, model.phi);
  for (int i = 0; i < 10; ++i) far[i] += i < 4 ? u(rng) : 0.1 * u(rng);
  far = paramsFromConsistentCoordinates(model, far);
  ASSERT_EQ(countInconsistent(checkConsistency(model, far)), 0);
  for (const Eigen::VectorXd& start : {prior, bad, far}) {
    const ConsistentResult r = solveConsistent(model, t, prior, start);
    EXPECT_TRUE(r.converged) << r.iterations;
    EXPECT_EQ(countInconsistent(r.consistency), 0);
    EXPECT_LT((r.phi - model.phi).cwiseAbs().maxCoeff() / model.phi.cwiseAbs().maxCoeff(), 1e-9)
        << r.phi.transpose() << "\n" << model.phi.transpose();
  }
}

TEST(Consistent, NearestPositiveSemidefinitePseudoInertia) {
  // Target ||J(phi) - J_b||_F^2: its minimum over consistent bodies is the eigenvalue clipping of J_b
  // (Higham 1988), reached on the boundary; every iterate stays strictly inside.
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfString(kSingleBody, true, model, &err)) << err;
  QuadraticTarget t;
  t.A.resize(16, 10);
  for (int k = 0; k < 10; ++k) {
    Vector10d e = Vector10d::Zero();
    e[k] = 1.0;
    const Eigen::Matrix4d J = pseudoInertia(e);
    t.A.col(k) = Eigen::Map<const Eigen::Matrix<double, 16, 1>>(J.data());
  }
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Vector10d b = model.phi;
    for (int i = 0; i < 10; ++i) b[i] += 0.5 * std::abs(b[i]) * u(rng) + 0.01 * u(rng);
    b[0] = trial % 2 ? -0.5 : b[0];
    const Eigen::Matrix4d Jb = pseudoInertia(b);
    t.b = Eigen::Map<const Eigen::Matrix<double, 16, 1>>(Jb.data());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(Jb);
    const Eigen::Matrix4d Jclip =
        es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
    const double optimum = (Jclip - Jb).squaredNorm();
    ConsistentOptions opt;
    opt.max_iterations = 2000;
    const ConsistentResult r = solveConsistent(model, t, model.phi, b, opt);
    EXPECT_EQ(countInconsistent(r.consistency), 0);
    EXPECT_GE(r.target_cost, optimum - 1e-15);
    EXPECT_LE(r.target_cost, optimum + 1e-6 * std::max(optimum, 1e-6)) << "trial " << trial;
  }
}

class ConsistentExo : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model_, &err)) << err;
  }
  Model model_;
};

TEST_F(ConsistentExo, FitsExactDataAndStaysConsistent) {
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  stack(model_, 200, 4, W, y);
  const Eigen::VectorXd prior = randomPrior(model_, 0.25, 5);
  const Dense D = denseScaled(W, y, prior);
  EXPECT_EQ(D.rank, 100);  // structural base parameters (80 inertial + 20 friction)
  EXPECT_LT((W * D.phi_fit - y).norm() / y.norm(), 1e-10);
  const double sz2 = D.s[D.rank - 1] * D.s[D.rank - 1];
  const QuadraticTarget t = consistentTarget(D.s, D.V, D.d, D.h, prior, prior, D.rank, 1e-10 * sz2);
  ConsistentOptions opt;
  opt.prior_weight = 1e-12 * sz2;
  const ConsistentResult r = solveConsistent(model_, t, prior, D.phi_fit, opt);
  EXPECT_EQ(countInconsistent(r.consistency), 0);
  EXPECT_LT((W * r.phi - y).norm() / y.norm(), 1e-6);
}

TEST_F(ConsistentExo, ConsistentWhereLeastSquaresIsNot) {
  // Slow, small motions (the exoskeleton balancing: distal links barely move) and noisy torques: the
  // least-squares fit gives physically impossible links; WLS-RC-PC does not, at a small cost in the fit.
  Data data(model_);
  State s = State::zero(model_);
  std::mt19937_64 rng(6);
  std::normal_distribution<double> noise(0.0, 1.0);
  const int samples = 400;
  Eigen::MatrixXd W(samples * model_.nv, model_.nparams());
  for (int k = 0; k < samples; ++k) {
    randomState(model_, rng, s);
    s.q *= 0.2;
    s.v *= 0.1;
    s.a *= 0.1;
    computeJointTorqueRegressor(model_, data, s);
    W.middleRows(k * model_.nv, model_.nv) = data.K;
  }
  Eigen::VectorXd y = W * model_.phi;
  for (int i = 0; i < y.size(); ++i) y[i] += 0.5 * noise(rng);
  const Eigen::VectorXd prior = randomPrior(model_, 0.25, 7);
  const Dense D = denseScaled(W, y, prior);
  const Eigen::VectorXd& ls = D.phi_fit;  // full-rank least squares, nullspace at the prior
  const int bad = countInconsistent(checkConsistency(model_, ls));
  ASSERT_GT(bad, 0) << "the setup must make least squares inconsistent";
  const double sz2 = D.s[D.rank - 1] * D.s[D.rank - 1];
  const QuadraticTarget t = consistentTarget(D.s, D.V, D.d, D.h, prior, prior, D.rank, 1e-2 * sz2);
  ConsistentOptions opt;
  opt.prior_weight = 1e-6 * sz2;
  opt.max_iterations = 1000;
  const ConsistentResult r = solveConsistent(model_, t, prior, ls, opt);
  EXPECT_EQ(countInconsistent(r.consistency), 0);
  const double rms_ls = (W * ls - y).norm(), rms_pc = (W * r.phi - y).norm();
  EXPECT_LT(rms_pc, 1.05 * rms_ls) << bad << " inconsistent links in LS; iterations " << r.iterations << " converged " << r.converged << " start " << r.start_cost;
  // Better than the naive repair (each bad link's pseudo-inertia clipped), in the fit's own metric.
  const Eigen::VectorXd clipped = projectConsistent(model_, ls);
  EXPECT_LT(r.target_cost, (t.A * clipped - t.b).squaredNorm());
  // A bad start reaches the same cost: every mass negated (inconsistent) or every body 3 times too heavy.
  Eigen::VectorXd start = 3.0 * model_.phi;
  for (int b = 0; b < model_.nbodies; b += 2) start[model_.bodyParamIndex(b)] *= -1.0;
  const ConsistentResult r2 = solveConsistent(model_, t, prior, start, opt);
  EXPECT_EQ(countInconsistent(r2.consistency), 0);
  const double F1 = r.target_cost + opt.prior_weight * (r.x - consistentCoordinates(model_, prior)).squaredNorm();
  const double F2 = r2.target_cost + opt.prior_weight * (r2.x - consistentCoordinates(model_, prior)).squaredNorm();
  EXPECT_NEAR(F2, F1, 1e-2 * F1);  // near the boundary the last digits come slowly (theta diverging)
}

TEST_F(ConsistentExo, WlsRcPcOnTheStreamedFactorsStaysCloseToWlsRc) {
  // The batch pipeline: rows streamed into the QR accumulator, WLS-RC prepared (row weights from the OLS
  // residual, columns by the prior), full numerical rank; WLS-RC-PC on the same problem.
  Data data(model_);
  State s = State::zero(model_);
  std::mt19937_64 rng(12);
  std::normal_distribution<double> noise(0.0, 1.0);
  const BaseParameters base = computeBaseParameters(model_);
  AccumulatorOptions ao;
  ao.folds = 1;
  LsqAccumulator acc(model_, base, ao);
  for (int k = 0; k < 400; ++k) {
    randomState(model_, rng, s);
    s.q *= 0.2;
    s.v *= 0.1;
    s.a *= 0.1;
    computeJointTorqueRegressor(model_, data, s);
    Eigen::VectorXd y = data.K * model_.phi;
    for (int i = 0; i < y.size(); ++i) y[i] += 0.5 * noise(rng);
    ASSERT_TRUE(acc.add(data.K, y));
  }
  acc.flush();
  const Eigen::VectorXd prior = randomPrior(model_, 0.25, 13);
  const ScaledProblem sp = scaleProblem(acc, model_, prior, Method::WlsRC);
  const int z = sp.numericalRank();
  const Eigen::VectorXd rc = solveAtRank(sp, z);
  ASSERT_GT(countInconsistent(checkConsistency(model_, rc)), 0) << "the setup must make WLS-RC inconsistent";
  const ConsistentResult pc = solveConsistentAtRank(model_, sp, z);
  EXPECT_EQ(countInconsistent(pc.consistency), 0);
  const LsqFactor train = toStandard(acc.mergedBase(), base.base_map);
  EXPECT_LT(rmse(train, pc.phi), 1.10 * rmse(train, rc)) << rmse(train, pc.phi) << " vs " << rmse(train, rc);
}

TEST(Consistent, ConsistentFitIsLeftAlone) {
  // A consistent truncated WLS-C fit (6 of 10 directions) is the minimiser of its own target: WLS-RC-PC
  // returns it.
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfString(kSingleBody, true, model, &err)) << err;
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  stack(model, 50, 8, W, y);
  const Eigen::VectorXd prior = randomPrior(model, 0.05, 9);
  const Dense D = denseScaled(W, y, prior, 6);
  ASSERT_EQ(countInconsistent(checkConsistency(model, D.phi_fit)), 0);
  const double sz2 = D.s[5] * D.s[5];
  const QuadraticTarget t = consistentTarget(D.s, D.V, D.d, D.h, prior, prior, 6, 1e-2 * sz2);
  EXPECT_LT((t.A * D.phi_fit - t.b).norm(), 1e-9 * t.b.norm());
  const ConsistentResult r = solveConsistent(model, t, prior, prior);
  EXPECT_LT((r.phi - D.phi_fit).cwiseAbs().maxCoeff() / model.phi.cwiseAbs().maxCoeff(), 1e-8);
}

}  // namespace
}  // namespace exoid::estimator
