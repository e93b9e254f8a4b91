// BalanceFormulation + ProxQpSolver on a standing state: the QP solution satisfies the equalities (floating-base
// dynamics on the unactuated rows, stationary soles) and the inequalities (friction, CoP, unilateral, torque
// limits), the contact wrenches carry the weight, and the feedforward enters the dynamics.
#include <gtest/gtest.h>

#include "controller_test_util.hpp"
#include "exoid/controller/formulation.hpp"
#include "exoid/controller/proxqp_solver.hpp"

namespace exoid::controller {
namespace {

class FormulationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadModel(model_, &err)) << err;
    ASSERT_TRUE(testing::loadConfig(cfg_, &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, cfg_.contact.right_sole_frame, soles_[0], &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, cfg_.contact.left_sole_frame, soles_[1], &err)) << err;
    state_ = State::zero(model_);
    state_.base_position = Eigen::Vector3d(0.0, 0.0, 1.04);  // config/exo.urdf standing: soles on z = 0
    dyn_ = std::make_unique<RobotDynamicsData>(model_);
    form_ = std::make_unique<BalanceFormulation>(model_, cfg_.contact, cfg_.torque);
    right_ = std::make_unique<ContactSixD>(cfg_.contact, 0);
    left_ = std::make_unique<ContactSixD>(cfg_.contact, 1);
    solver_ = makeProxQpSolver({cfg_.solver.eps_abs, cfg_.solver.max_iterations});
    qp_.resize(form_->dimensions());
    res_.resize(form_->dimensions());
    ASSERT_TRUE(solver_->setup(form_->dimensions()));
  }

  /// Builds and solves the QP for state_ with the CoM reference offset by `com_offset` (world).
  void solve(const Eigen::Vector3d& com_offset) {
    computeRobotDynamics(model_, soles_, *dyn_, state_);
    right_->setReference(dyn_->foot_position[0], dyn_->foot_rotation[0]);
    left_->setReference(dyn_->foot_position[1], dyn_->foot_rotation[1]);
    CoMReference ref;
    ref.position = dyn_->com + com_offset;
    MomentumTask momentum(cfg_.momentum);
    momentum.compute(ref, *dyn_, rate_);
    PostureRegularization posture(cfg_.posture, model_.njoints);
    posture.setReference(state_.q);
    Eigen::VectorXd dnu_des(model_.nv), w(model_.nv);
    posture.compute(state_, dnu_des, w);
    form_->build(*dyn_, rate_, momentum.weights(), dnu_des, w, *right_, *left_, qp_);
    solver_->solve(qp_, res_);
  }

  Model model_;
  ControllerConfig cfg_;
  std::array<SoleFrame, 2> soles_{};
  State state_;
  std::unique_ptr<RobotDynamicsData> dyn_;
  std::unique_ptr<BalanceFormulation> form_;
  std::unique_ptr<ContactSixD> right_, left_;
  std::unique_ptr<QpSolver> solver_;
  QpProblem qp_;
  QpResult res_;
  LinearAngular6d rate_ = LinearAngular6d::Zero();
};

TEST_F(FormulationTest, SizesFollowTheModel) {
  const QpDimensions d = form_->dimensions();
  EXPECT_EQ(d.n, 16 + 12);
  EXPECT_EQ(form_->unactuatedRows().size(), 8u);  // 6 base rows + the two passive ankle in/eversion joints
  EXPECT_EQ(form_->actuatedRows().size(), 8u);
  EXPECT_EQ(d.n_eq, 8 + 12);
  EXPECT_EQ(d.n_in, 2 * ContactSixD::kInequalities + 8);
  EXPECT_EQ(form_->unactuatedRows()[6], model_.jointRow(model_.jointIndex("right_ankle_ie")));
  EXPECT_EQ(form_->unactuatedRows()[7], model_.jointRow(model_.jointIndex("left_ankle_ie")));
  EXPECT_DOUBLE_EQ(form_->torqueLimits()[3], 100.0);  // right_ankle_pd effort
}

TEST_F(FormulationTest, StandingSolutionSatisfiesConstraintsAndCarriesTheWeight) {
  solve(Eigen::Vector3d::Zero());
  ASSERT_EQ(res_.status, QpStatus::Solved);
  const Eigen::VectorXd& x = res_.x;
  const int nv = model_.nv;
  // Equalities to 1e-8.
  EXPECT_LE((qp_.A * x - qp_.b).lpNorm<Eigen::Infinity>(), 1e-8);
  // Inequalities (friction, CoP, unilateral, torsion, torque limits).
  const Eigen::VectorXd cx = qp_.C * x;
  EXPECT_LE((qp_.l - cx).maxCoeff(), 1e-8);
  EXPECT_LE((cx - qp_.u).maxCoeff(), 1e-8);
  // Physical meaning of the equalities: no generalized force on the unactuated rows...
  Eigen::VectorXd tau(nv);
  form_->generalizedForce(*dyn_, x, tau);
  for (int r : form_->unactuatedRows()) EXPECT_NEAR(tau[r], 0.0, 1e-8) << "row " << r;
  // ...and the soles do not accelerate (standing at rest: zero drift, zero velocity feedback).
  for (int i = 0; i < 2; ++i) EXPECT_LE((dyn_->Jc[static_cast<size_t>(i)] * x.head(nv)).norm(), 1e-8);
  // The contact wrenches carry the weight: sum of forces = m g up, no net horizontal force.
  const Eigen::Vector3d F = x.segment<3>(nv) + x.segment<3>(nv + 6);
  const double weight = dyn_->mass * 9.81;
  EXPECT_NEAR(dyn_->mass, model_.totalMass(), 1e-12);
  EXPECT_NEAR(F.z(), weight, 1e-3 * weight);
  EXPECT_NEAR(F.head<2>().norm(), 0.0, 1e-3 * weight);
  // Both feet loaded, each CoP inside its sole.
  for (int i = 0; i < 2; ++i) {
    const LinearAngular6d w = x.segment<6>(nv + 6 * i);
    EXPECT_GE(w[2], cfg_.contact.min_normal_force - 1e-8);
    EXPECT_LE(std::abs(-w[4] / w[2]), cfg_.contact.sole_half_length - cfg_.contact.cop_margin + 1e-9);
    EXPECT_LE(std::abs(w[3] / w[2]), cfg_.contact.sole_half_width - cfg_.contact.cop_margin + 1e-9);
  }
  // At rest hardly anything accelerates (the wrench regularisation trades a few mrad/s^2 for smaller wrenches).
  EXPECT_LE(x.head(nv).norm(), 1e-2);
  // The symmetric stance has one unreachable sole direction (relative yaw): handled by the range gauge.
  EXPECT_EQ(form_->droppedContactDirections(), 1);
}

TEST_F(FormulationTest, CoMOffsetProducesTheDesiredMomentumRate) {
  const Eigen::Vector3d offset(0.02, -0.01, 0.0);
  solve(offset);
  ASSERT_EQ(res_.status, QpStatus::Solved);
  const Eigen::VectorXd& x = res_.x;
  const int nv = model_.nv;
  EXPECT_LE((qp_.A * x - qp_.b).lpNorm<Eigen::Infinity>(), 1e-7);
  // Desired linear rate = m Kp offset; the achieved horizontal rate = sum of horizontal contact forces.
  const Eigen::Vector3d desired = dyn_->mass * cfg_.momentum.kp_com.cwiseProduct(offset);
  EXPECT_NEAR((rate_.head<3>() - desired).norm(), 0.0, 1e-9);
  // The horizontal contact force points the same way and carries most of it (the angular momentum damping
  // and the posture regularisation take the rest: the body must tilt to move the CoM).
  const Eigen::Vector2d F = (x.segment<3>(nv) + x.segment<3>(nv + 6)).head<2>();
  EXPECT_GT(F.dot(desired.head<2>()) / (F.norm() * desired.head<2>().norm()), 0.99);
  EXPECT_NEAR(F.norm(), desired.head<2>().norm(), 0.1 * desired.norm());
}

TEST_F(FormulationTest, FeedforwardEntersTheDynamics) {
  solve(Eigen::Vector3d::Zero());
  ASSERT_EQ(res_.status, QpStatus::Solved);
  const int nv = model_.nv;
  Eigen::VectorXd tau0(nv);
  form_->generalizedForce(*dyn_, res_.x, tau0);
  const Eigen::VectorXd x0 = res_.x;
  // A feedforward on an actuated joint only shifts that joint's torque bounds: same (dnu, f), and the
  // generalized force of the solution moves by exactly the feedforward.
  const int knee = model_.jointRow(model_.jointIndex("right_knee"));
  Eigen::VectorXd ff = Eigen::VectorXd::Zero(nv);
  ff[knee] = 3.0;
  dyn_->tau_correction = ff;
  right_->setReference(dyn_->foot_position[0], dyn_->foot_rotation[0]);
  CoMReference ref;
  ref.position = dyn_->com;
  MomentumTask momentum(cfg_.momentum);
  momentum.compute(ref, *dyn_, rate_);
  PostureRegularization posture(cfg_.posture, model_.njoints);
  posture.setReference(state_.q);
  Eigen::VectorXd dnu_des(nv), w(nv);
  posture.compute(state_, dnu_des, w);
  form_->build(*dyn_, rate_, momentum.weights(), dnu_des, w, *right_, *left_, qp_);
  solver_->solve(qp_, res_);
  ASSERT_EQ(res_.status, QpStatus::Solved);
  EXPECT_LE((res_.x - x0).norm(), 1e-6);
  Eigen::VectorXd tau1(nv);
  form_->generalizedForce(*dyn_, res_.x, tau1);
  EXPECT_NEAR(tau1[knee] - tau0[knee], 3.0, 1e-5);
  // A feedforward on the passive ankle in/eversion row must be balanced by the contact wrenches.
  const int ie = model_.jointRow(model_.jointIndex("right_ankle_ie"));
  dyn_->tau_correction.setZero();
  dyn_->tau_correction[ie] = 0.5;
  form_->build(*dyn_, rate_, momentum.weights(), dnu_des, w, *right_, *left_, qp_);
  solver_->solve(qp_, res_);
  ASSERT_EQ(res_.status, QpStatus::Solved);
  Eigen::VectorXd tau2(nv);
  form_->generalizedForce(*dyn_, res_.x, tau2);  // includes tau_correction
  EXPECT_NEAR(tau2[ie], 0.0, 1e-8);
  EXPECT_GT((res_.x.tail<12>() - x0.tail<12>()).norm(), 0.1);
}

TEST_F(FormulationTest, ImpossibleMinimumNormalForceIsReportedInfeasible) {
  cfg_.contact.min_normal_force = 5000.0;  // more than ten times the weight on each foot
  right_ = std::make_unique<ContactSixD>(cfg_.contact, 0);
  left_ = std::make_unique<ContactSixD>(cfg_.contact, 1);
  solve(Eigen::Vector3d::Zero());
  EXPECT_NE(res_.status, QpStatus::Solved);
}

}  // namespace
}  // namespace exoid::controller
