// rnea, crba, point Jacobians, acceleration drift and centroidal quantities against MuJoCo on the
// floating-base exoskeleton (random states), converted through the free joint's velocity convention.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "support/mujoco_fixture.hpp"
#include "support/mujoco_state.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

class DynamicsVsMujoco : public test::ExoMujocoTest {
 protected:
  /// nu_mujoco = T nu_exoid: MuJoCo's free joint is [v world; omega local], ours [omega base; v base].
  Eigen::MatrixXd velocityMap(const State& s) const {
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(m_->nv, model_.nv);
    const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
    T.block<3, 3>(map_.free_dof, 3) = R;
    T.block<3, 3>(map_.free_dof + 3, 0).setIdentity();
    for (int j = 0; j < model_.njoints; ++j) T(map_.dof[j], model_.jointRow(j)) = 1.0;
    return T;
  }
};

TEST_F(DynamicsVsMujoco, RneaAndCrbaMatchMuJoCo) {
  DynamicsData dyn(model_);
  std::mt19937_64 rng(3);
  double worst_tau = 0.0, worst_M = 0.0;
  for (int k = 0; k < 200; ++k) {
    const State s = test::randomState(model_, rng);
    test::toMujoco(s, map_, m_, d_);
    mj_inverse(m_, d_);
    rnea(model_, dyn, s);
    worst_tau = std::max(worst_tau, test::relError(dyn.tau, test::fromMujocoForce(d_->qfrc_inverse, s, map_, model_.nv)));
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Mmj(m_->nv, m_->nv);
    mj_fullM(m_, Mmj.data(), d_->qM);
    const Eigen::MatrixXd T = velocityMap(s);
    const Eigen::MatrixXd expected = T.transpose() * Mmj * T;
    crba(model_, dyn, s);
    worst_M = std::max(worst_M, (dyn.M - expected).cwiseAbs().maxCoeff() / expected.cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst_tau, 1e-9);
  EXPECT_LT(worst_M, 1e-9);
}

TEST_F(DynamicsVsMujoco, PointJacobianMatchesMjJac) {
  DynamicsData dyn(model_);
  std::mt19937_64 rng(4);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model_.nv);
  for (int k = 0; k < 100; ++k) {
    const State s = test::randomState(model_, rng);
    test::toMujoco(s, map_, m_, d_);
    mj_forward(m_, d_);
    forwardKinematics(model_, dyn.kin, s);
    for (const char* foot : {"right_foot", "left_foot"}) {
      const int b = model_.bodyIndex(foot);
      const int id = mj_name2id(m_, mjOBJ_BODY, foot);
      const Eigen::Vector3d point(0.06, 0.01, 0.1);  // a point on the sole, foot coordinates
      computePointJacobian(model_, dyn.kin, b, point, J);
      Eigen::Matrix3d Rb = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d_->xmat + 9 * id);
      const Eigen::Vector3d pw = Eigen::Vector3d(d_->xpos + 3 * id) + Rb * point;
      Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> jacp(3, m_->nv), jacr(3, m_->nv);
      mj_jac(m_, d_, jacp.data(), jacr.data(), pw.data(), id);
      const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
      const Eigen::MatrixXd T = velocityMap(s);
      EXPECT_LT((R * J.topRows<3>() - jacr * T).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_LT((R * J.bottomRows<3>() - jacp * T).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
}

TEST_F(DynamicsVsMujoco, AccelerationDriftByFiniteDifferences) {
  // Fixed-base check: P(q(t)) with q(t) = q0 + v t + a t^2 / 2 has acceleration J a + drift at t = 0.
  Model fixed;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), false, fixed, &err)) << err;
  fixed.gravity.setZero();
  DynamicsData dyn(fixed);
  std::mt19937_64 rng(5);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, fixed.nv);
  const int b = fixed.bodyIndex("left_foot");
  const Eigen::Vector3d point(0.06, 0.0, -0.1);
  for (int k = 0; k < 20; ++k) {
    State s = test::randomState(fixed, rng);
    auto position = [&](double t) {
      State st = s;
      st.q = s.q + s.v * t + 0.5 * s.a * t * t;
      forwardKinematics(fixed, dyn.kin, st);
      return Eigen::Vector3d(dyn.kin.p[b] + dyn.kin.R[b] * point);
    };
    const double h = 1e-4;
    const Eigen::Vector3d fd = (position(h) - 2.0 * position(0.0) + position(-h)) / (h * h);
    forwardKinematics(fixed, dyn.kin, s);
    computePointJacobian(fixed, dyn.kin, b, point, J);
    forwardKinematicsDrift(fixed, dyn.kin, s);
    const Eigen::Matrix<double, 6, 1> drift = pointAccelerationDrift(dyn.kin, b, point);
    const Eigen::Vector3d acc = J.bottomRows<3>() * s.a + drift.tail<3>();
    EXPECT_LT((acc - fd).norm() / fd.norm(), 1e-5);
  }
}

TEST_F(DynamicsVsMujoco, CentroidalMatchesSubtreeComAndMomentum) {
  DynamicsData dyn(model_);
  std::mt19937_64 rng(6);
  for (int k = 0; k < 100; ++k) {
    const State s = test::randomState(model_, rng);
    test::toMujoco(s, map_, m_, d_);
    mj_forward(m_, d_);
    mj_subtreeVel(m_, d_);
    forwardKinematics(model_, dyn.kin, s);
    centroidal(model_, dyn);
    const int root = mj_name2id(m_, mjOBJ_BODY, "body");
    const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
    const Eigen::Vector3d com_world = s.base_position + R * dyn.com;
    EXPECT_LT((com_world - Eigen::Vector3d(d_->subtree_com + 3 * root)).norm(), 1e-12);
    EXPECT_NEAR(dyn.mass, m_->body_subtreemass[root], 1e-12);
    // Linear momentum = m * CoM velocity; angular momentum about the CoM.
    const Eigen::Vector3d P = R * dyn.momentum_origin.tail<3>();
    EXPECT_LT((P - dyn.mass * Eigen::Vector3d(d_->subtree_linvel + 3 * root)).norm(), 1e-9 * std::max(1.0, P.norm()));
    const Eigen::Vector3d LG = R * (dyn.momentum_origin.head<3>() - dyn.com.cross(dyn.momentum_origin.tail<3>()));
    const Eigen::Vector3d LG_mj(d_->subtree_angmom + 3 * root);
    EXPECT_LT((LG - LG_mj).norm(), 1e-9 * std::max(1.0, LG_mj.norm()));
  }
}

// crba and centroidal with an arbitrary phi (an estimate): a different consistent parameter vector written
// into MuJoCo's body inertials (mass, CoM, principal moments and frame) gives MuJoCo's mass matrix, CoM and
// momentum for those parameters.
TEST_F(DynamicsVsMujoco, CrbaAndCentroidalWithAnotherPhiMatchMuJoCo) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd phi = model_.phi;
  for (int b = 0; b < model_.nbodies; ++b) {
    Vector10d theta;
    ASSERT_TRUE(logCholeskyFromParams(model_.phi.segment<10>(model_.bodyParamIndex(b)), theta));
    for (int i = 0; i < 10; ++i) theta[i] += 0.2 * u(rng);  // log-Cholesky: every point is a real body
    phi.segment<10>(model_.bodyParamIndex(b)) = paramsFromLogCholesky(theta);
    InertialProperties in;
    ASSERT_TRUE(inertialFromParams(phi.segment<10>(model_.bodyParamIndex(b)), in));
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(in.inertia_com);
    Eigen::Matrix3d V = es.eigenvectors();
    if (V.determinant() < 0) V.col(2) = -V.col(2);
    const Eigen::Quaterniond q(V);
    const int id = mj_name2id(m_, mjOBJ_BODY, model_.body_names[b].c_str());
    ASSERT_GT(id, 0);
    m_->body_mass[id] = in.mass;
    for (int i = 0; i < 3; ++i) {
      m_->body_ipos[3 * id + i] = in.com[i];
      m_->body_inertia[3 * id + i] = es.eigenvalues()[i];
    }
    m_->body_iquat[4 * id + 0] = q.w();
    m_->body_iquat[4 * id + 1] = q.x();
    m_->body_iquat[4 * id + 2] = q.y();
    m_->body_iquat[4 * id + 3] = q.z();
  }
  mj_setConst(m_, d_);  // subtree masses from the new body masses
  DynamicsData dyn(model_), dyn_model(model_);
  double worst_M = 0.0, differs = 0.0;
  for (int k = 0; k < 100; ++k) {
    const State s = test::randomState(model_, rng);
    test::toMujoco(s, map_, m_, d_);
    mj_forward(m_, d_);
    mj_subtreeVel(m_, d_);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Mmj(m_->nv, m_->nv);
    mj_fullM(m_, Mmj.data(), d_->qM);
    const Eigen::MatrixXd T = velocityMap(s);
    const Eigen::MatrixXd expected = T.transpose() * Mmj * T;
    crba(model_, phi, dyn, s);
    worst_M = std::max(worst_M, (dyn.M - expected).cwiseAbs().maxCoeff() / expected.cwiseAbs().maxCoeff());
    crba(model_, dyn_model, s);
    differs = std::max(differs, (dyn_model.M - expected).cwiseAbs().maxCoeff() / expected.cwiseAbs().maxCoeff());
    // The default overload is the model.phi path exactly.
    crba(model_, model_.phi, dyn, s);
    EXPECT_EQ((dyn.M - dyn_model.M).cwiseAbs().maxCoeff(), 0.0);

    forwardKinematics(model_, dyn.kin, s);
    centroidal(model_, phi, dyn);
    const int root = mj_name2id(m_, mjOBJ_BODY, "body");
    const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
    EXPECT_NEAR(dyn.mass, m_->body_subtreemass[root], 1e-12);
    EXPECT_LT((s.base_position + R * dyn.com - Eigen::Vector3d(d_->subtree_com + 3 * root)).norm(), 1e-12);
    const Eigen::Vector3d P = R * dyn.momentum_origin.tail<3>();
    EXPECT_LT((P - dyn.mass * Eigen::Vector3d(d_->subtree_linvel + 3 * root)).norm(), 1e-9 * std::max(1.0, P.norm()));
    const Eigen::Vector3d LG = R * (dyn.momentum_origin.head<3>() - dyn.com.cross(dyn.momentum_origin.tail<3>()));
    const Eigen::Vector3d LG_mj(d_->subtree_angmom + 3 * root);
    EXPECT_LT((LG - LG_mj).norm(), 1e-9 * std::max(1.0, LG_mj.norm()));
  }
  EXPECT_LT(worst_M, 1e-9);
  EXPECT_GT(differs, 1e-2);  // the other phi really is different
}

}  // namespace
}  // namespace exoid
