// The thesis's metrics (estimator/metrics.hpp): the accumulated quadratic forms against a direct per-sample
// computation through other code paths (rnea with the estimate's phi, centroidal with the estimate's phi,
// a dense SVD pseudo-inverse for eq. 4.1), and hand-computed estimation errors.
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <random>

#include "exoid/estimator/metrics.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"

namespace exoid::estimator {
namespace {

class MetricsExo : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model_, &err)) << err;
    actuated_ = actuatedJoints(model_);
  }
  Eigen::VectorXd perturbed(double frac, uint64_t seed) const {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-frac, frac);
    Eigen::VectorXd phi = model_.phi;
    for (int i = 0; i < model_.nInertialParams(); ++i) phi[i] *= 1.0 + u(rng);
    return phi;
  }
  /// Contact Jacobians' transpose [nv x 12] of both soles (wrench [moment about the sole point; force]).
  Eigen::MatrixXd contactJacobianT(Data& kin) const {
    Eigen::MatrixXd JgT(model_.nv, 12);
    int col = 0;
    for (const char* name : {"right_sole", "left_sole"}) {
      const Model::Frame& f = model_.frames[model_.frameIndex(name)];
      Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model_.nv);
      computePointJacobian(model_, kin, f.body, f.position, J);
      JgT.middleCols(col, 6) = J.transpose();
      col += 6;
    }
    return JgT;
  }
  Model model_;
  std::vector<int> actuated_;
};

TEST_F(MetricsExo, ActuatedJointsAreTheEightWithMotors) {
  EXPECT_EQ(actuated_.size(), 8u);
  for (int j : actuated_) EXPECT_EQ(model_.joint_names[j].find("ankle_ie"), std::string::npos);
}

TEST_F(MetricsExo, QuadraticFormsMatchPerSampleComputation) {
  MetricAccumulator acc(model_, model_.phi, actuated_, 16);  // small block: several flushes
  Data data(model_);
  DynamicsData dyn(model_);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::vector<State> states;
  std::vector<Eigen::VectorXd> ys;
  for (int k = 0; k < 100; ++k) {
    State s = State::zero(model_);
    randomState(model_, rng, s);
    computeJointTorqueRegressor(model_, data, s);
    Eigen::VectorXd y = data.K * model_.phi;
    for (int i = 0; i < y.size(); ++i) y[i] += noise(rng);
    ASSERT_TRUE(acc.add(s, data.K, y));
    states.push_back(s);
    ys.push_back(y);
  }
  acc.finish();
  EXPECT_EQ(acc.samples(), 100);
  for (const Eigen::VectorXd& phi : {Eigen::VectorXd(model_.phi), perturbed(0.25, 2), perturbed(0.125, 3)}) {
    double gen = 0, tq = 0, com = 0, mom = 0;
    for (size_t k = 0; k < states.size(); ++k) {
      rnea(model_, phi, dyn, states[k]);  // K phi by another algorithm
      const Eigen::VectorXd e = dyn.tau - ys[k];
      gen += e.squaredNorm();
      for (int j : actuated_) tq += e[model_.jointRow(j)] * e[model_.jointRow(j)];
      forwardKinematics(model_, dyn.kin, states[k]);
      centroidal(model_, model_.phi, dyn);
      const Eigen::Vector3d c_true = dyn.com;
      const Eigen::Matrix<double, 6, 1> h_true = dyn.momentum_origin;
      centroidal(model_, phi, dyn);
      com += (dyn.com - c_true).squaredNorm();
      // Momentum about the true CoM: angular_G = angular_O - c x linear.
      const Eigen::Vector3d kG = dyn.momentum_origin.head<3>() - c_true.cross(dyn.momentum_origin.tail<3>());
      const Eigen::Vector3d kG_true = h_true.head<3>() - c_true.cross(h_true.tail<3>());
      mom += (kG - kG_true).squaredNorm() + (dyn.momentum_origin.tail<3>() - h_true.tail<3>()).squaredNorm();
    }
    const double n = static_cast<double>(states.size());
    const Metrics m = acc.evaluate(phi);
    EXPECT_NEAR(m.generalized_force_rmse, std::sqrt(gen / (n * model_.nv)), 1e-9 * std::sqrt(gen / n));
    EXPECT_NEAR(m.joint_torque_rmse, std::sqrt(tq / (n * 8)), 1e-9 * std::sqrt(gen / n));
    EXPECT_NEAR(m.com_position_rmse_mm, 1000.0 * std::sqrt(com / (n * 3)), 1e-9 + 1e-9 * m.com_position_rmse_mm);
    EXPECT_NEAR(m.com_momentum_rmse, std::sqrt(mom / (n * 6)), 1e-10 + 1e-9 * m.com_momentum_rmse);
    EXPECT_TRUE(std::isnan(m.realistic_torque_rmse));  // no realistic samples added
  }
  // At the truth the CoM and momentum errors vanish; the generalized force error is the noise (sigma 2).
  const Metrics t = acc.evaluate(model_.phi);
  EXPECT_LT(t.com_position_rmse_mm, 1e-9);
  EXPECT_LT(t.com_momentum_rmse, 1e-10);
  EXPECT_NEAR(t.generalized_force_rmse, 2.0, 0.15);
  EXPECT_EQ(t.estimation_error_percent, 0.0);
}

TEST_F(MetricsExo, EstimationErrorByHand) {
  Eigen::VectorXd phi = model_.phi;
  phi[0] *= 1.5;                                  // body mass +50 %
  phi[model_.bodyParamIndex(4) + 9] *= 0.9;       // right ankle Izz -10 %
  phi[model_.frictionParamIndex(0)] = 123.0;      // friction is not part of the metric
  EXPECT_NEAR(estimationErrorPercent(model_, phi, model_.phi), 60.0 / 110.0, 1e-12);
  const Eigen::VectorXd link = linkEstimationErrorPercent(model_, phi, model_.phi);
  EXPECT_NEAR(link[0], 5.0, 1e-12);
  EXPECT_NEAR(link[4], 1.0, 1e-12);
  EXPECT_EQ(link[1], 0.0);
}

TEST_F(MetricsExo, RealisticTorquePredictionEq41) {
  MetricAccumulator acc(model_, model_.phi, actuated_);
  Data data(model_);
  DynamicsData dyn(model_);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  struct Sample {
    Eigen::MatrixXd K, JgT;
    Eigen::VectorXd prev, fa;
  };
  std::vector<Sample> samples;
  std::vector<int> passive;  // rows that carry no actuator: base + unactuated joints
  for (int r = 0; r < 6; ++r) passive.push_back(r);
  for (int j = 0; j < model_.njoints; ++j)
    if (std::find(actuated_.begin(), actuated_.end(), j) == actuated_.end()) passive.push_back(model_.jointRow(j));
  for (int k = 0; k < 50; ++k) {
    State s = State::zero(model_);
    randomState(model_, rng, s);
    s.q *= 0.3;
    computeJointTorqueRegressor(model_, data, s);
    forwardKinematics(model_, dyn.kin, s);
    Sample smp{data.K, contactJacobianT(dyn.kin), Eigen::VectorXd::Zero(model_.njoints),
               Eigen::VectorXd::Zero(model_.njoints)};
    // Contact wrenches that make K phi_true = S^T f_a + J^T f_e exact: the passive rows fix 8 of 12 unknowns.
    const Eigen::VectorXd tau = data.K * model_.phi;
    Eigen::MatrixXd Ap(passive.size(), 12);
    Eigen::VectorXd bp(passive.size());
    for (size_t i = 0; i < passive.size(); ++i) {
      Ap.row(static_cast<Eigen::Index>(i)) = smp.JgT.row(passive[i]);
      bp[static_cast<Eigen::Index>(i)] = tau[passive[i]];
    }
    const Eigen::VectorXd fe = Ap.completeOrthogonalDecomposition().solve(bp);
    ASSERT_LT((Ap * fe - bp).norm(), 1e-9 * bp.norm());
    const Eigen::VectorXd r = tau - smp.JgT * fe;
    for (int j : actuated_) smp.fa[j] = r[model_.jointRow(j)];
    smp.prev = smp.fa;  // steady torques: the previous tick's equal this one's
    ASSERT_TRUE(acc.addRealistic(smp.K, smp.JgT, smp.prev, smp.fa));
    samples.push_back(smp);
  }
  acc.finish();
  // Exact parameters and steady torques: eq. 4.1 reproduces the torques.
  const double scale = samples[0].fa.norm();
  EXPECT_LT(acc.evaluate(model_.phi).realistic_torque_rmse, 1e-9 * scale);
  // Any phi with changing torques: against a direct computation with a dense SVD pseudo-inverse.
  MetricAccumulator acc2(model_, model_.phi, actuated_);
  for (Sample& smp : samples) {
    for (int j : actuated_) smp.prev[j] = smp.fa[j] + 5.0 * u(rng);
    acc2.addRealistic(smp.K, smp.JgT, smp.prev, smp.fa);
  }
  acc2.finish();
  for (const Eigen::VectorXd& phi : {Eigen::VectorXd(model_.phi), perturbed(0.25, 5)}) {
    double sum = 0.0;
    for (const Sample& smp : samples) {
      Eigen::VectorXd Sfa = Eigen::VectorXd::Zero(model_.nv);
      for (int j : actuated_) Sfa[model_.jointRow(j)] = smp.prev[j];
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(smp.JgT, Eigen::ComputeThinU | Eigen::ComputeThinV);
      const Eigen::VectorXd fe = svd.solve(smp.K * phi - Sfa);
      const Eigen::VectorXd pred = smp.K * phi - smp.JgT * fe;
      for (int j : actuated_) sum += std::pow(pred[model_.jointRow(j)] - smp.fa[j], 2);
    }
    const double direct = std::sqrt(sum / (samples.size() * actuated_.size()));
    EXPECT_NEAR(acc2.evaluate(phi).realistic_torque_rmse, direct, 1e-9 * std::max(direct, 1.0));
  }
}

TEST_F(MetricsExo, RejectsNonFiniteSamplesAndANonPositiveMass) {
  MetricAccumulator acc(model_, model_.phi, actuated_);
  Data data(model_);
  State s = State::zero(model_);
  computeJointTorqueRegressor(model_, data, s);
  Eigen::VectorXd y = data.K * model_.phi;
  y[3] = std::nan("");
  EXPECT_FALSE(acc.add(s, data.K, y));
  y[3] = 0.0;
  EXPECT_TRUE(acc.add(s, data.K, y));
  acc.finish();
  EXPECT_EQ(acc.samples(), 1);
  Eigen::VectorXd phi = model_.phi;
  for (int b = 0; b < model_.nbodies; ++b) phi[model_.bodyParamIndex(b)] = -1.0;
  EXPECT_TRUE(std::isinf(acc.evaluate(phi).com_position_rmse_mm));
}

}  // namespace
}  // namespace exoid::estimator
