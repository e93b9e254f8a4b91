// The regressor against MuJoCo's inverse dynamics (mj_inverse and mj_rne) on the floating-base exoskeleton:
// K(q, v, dv) * phi_true must equal MuJoCo's generalized forces for 1000 random states to 1e-9 relative.
#include <gtest/gtest.h>

#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/mujoco_fixture.hpp"
#include "support/mujoco_state.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

using RegressorVsMujoco = test::ExoMujocoTest;

TEST_F(RegressorVsMujoco, ThousandRandomStatesMatchMjInverseAndMjRne) {
  ASSERT_EQ(model_.nv, m_->nv);
  Data data(model_);
  std::mt19937_64 rng(20261121);
  double worst_inverse = 0.0, worst_rne = 0.0;
  for (int sample = 0; sample < 1000; ++sample) {
    const State s = test::randomState(model_, rng);
    test::toMujoco(s, map_, m_, d_);
    mj_inverse(m_, d_);
    const Eigen::VectorXd tau_inverse = test::fromMujocoForce(d_->qfrc_inverse, s, map_, model_.nv);
    std::vector<mjtNum> rne(m_->nv);
    mj_rne(m_, d_, 1, rne.data());
    const Eigen::VectorXd tau_rne = test::fromMujocoForce(rne.data(), s, map_, model_.nv);

    computeJointTorqueRegressor(model_, data, s);
    const Eigen::VectorXd tau = data.K * model_.phi;
    worst_inverse = std::max(worst_inverse, test::relError(tau, tau_inverse));
    worst_rne = std::max(worst_rne, test::relError(tau, tau_rne));
  }
  RecordProperty("max_rel_error_mj_inverse", std::to_string(worst_inverse));
  std::printf("max relative error of K*phi vs mj_inverse: %.3e, vs mj_rne: %.3e (1000 states)\n", worst_inverse,
              worst_rne);
  EXPECT_LT(worst_inverse, 1e-9);
  EXPECT_LT(worst_rne, 1e-9);
}

TEST_F(RegressorVsMujoco, ErrorWouldBeVisible) {
  // Sensitivity check of the comparison itself: a 0.1 % change of one small parameter is detected.
  Data data(model_);
  std::mt19937_64 rng(7);
  const State s = test::randomState(model_, rng);
  test::toMujoco(s, map_, m_, d_);
  mj_inverse(m_, d_);
  const Eigen::VectorXd tau_mj = test::fromMujocoForce(d_->qfrc_inverse, s, map_, model_.nv);
  computeJointTorqueRegressor(model_, data, s);
  Eigen::VectorXd phi = model_.phi;
  phi[model_.bodyParamIndex(model_.bodyIndex("left_ankle")) + 4] *= 1.001;  // left_ankle.Ixx
  EXPECT_GT(test::relError(data.K * phi, tau_mj), 1e-9);
}

TEST_F(RegressorVsMujoco, FrictionColumnsAreVelocityAndSign) {
  Data data(model_);
  State s = State::zero(model_);
  for (int j = 0; j < model_.njoints; ++j) s.v[j] = (j % 3 - 1) * 0.7;  // negative, zero, positive
  computeJointTorqueRegressor(model_, data, s);
  for (int j = 0; j < model_.njoints; ++j) {
    const int f = model_.frictionParamIndex(j);
    const double sign = s.v[j] > 0 ? 1.0 : (s.v[j] < 0 ? -1.0 : 0.0);
    for (int r = 0; r < model_.nv; ++r) {
      EXPECT_EQ(data.K(r, f), r == model_.jointRow(j) ? s.v[j] : 0.0);
      EXPECT_EQ(data.K(r, f + 1), r == model_.jointRow(j) ? sign : 0.0);
    }
  }
}

TEST_F(RegressorVsMujoco, BaseRowsAreMomentThenForceInBaseCoordinates) {
  // Standing still, upright: base force = total weight upward in base coordinates; rotate the base by 90
  // degrees about x and the support force appears along base +y: m * (0 - R^T g) = m g R^T z.
  Data data(model_);
  State s = State::zero(model_);
  s.base_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
  computeJointTorqueRegressor(model_, data, s);
  const Eigen::VectorXd tau = data.K * model_.phi;
  const double mg = model_.totalMass() * 9.81;
  EXPECT_NEAR(tau[3], 0.0, 1e-9);
  EXPECT_NEAR(tau[4], mg, 1e-9);  // world up = base +y after +90 deg about x
  EXPECT_NEAR(tau[5], 0.0, 1e-9);
}

}  // namespace
}  // namespace exoid
