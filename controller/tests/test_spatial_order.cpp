// The order of spatial 6-vectors (docs/conventions.md, "Spatial vectors"), against computations that do not
// use any 6-vector: finite differences of positions and rotations, and Newton's law for a robot at rest.
// The model's vectors are [angular; linear] (Jacobian rows, momentum, the regressor's base rows); the
// controller's task space is [linear; angular] (contact Jacobians, centroidal momentum). Each assertion
// fails if its vector's halves were swapped.
#include <gtest/gtest.h>

#include <random>

#include "controller_test_util.hpp"
#include "exoid/controller/robot_dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::controller {
namespace {

class SpatialOrder : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadModel(model_, &err)) << err;
    ASSERT_TRUE(testing::loadConfig(cfg_, &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, cfg_.contact.right_sole_frame, soles_[0], &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, cfg_.contact.left_sole_frame, soles_[1], &err)) << err;
  }

  /// The state moved on by t along its velocities (base: exp of its angular velocity, base coordinates).
  State advance(const State& s, double t) const {
    State r = s;
    r.q = s.q + t * s.v;
    const Eigen::Vector3d th = t * s.base_omega;
    r.base_orientation = s.base_orientation * Eigen::Quaterniond(Eigen::AngleAxisd(th.norm(), th.normalized()));
    r.base_position = s.base_position + s.base_orientation * (t * s.base_velocity);
    return r;
  }

  /// World position and rotation of sole i, and the world CoM, at state s (positions only).
  void pose(const State& s, int i, Eigen::Vector3d& p, Eigen::Matrix3d& R, Eigen::Vector3d& com) const {
    DynamicsData d(model_);
    forwardKinematics(model_, d.kin, s);
    const SoleFrame& sole = soles_[static_cast<size_t>(i)];
    const Eigen::Matrix3d Rwb = s.base_orientation.toRotationMatrix();
    p = s.base_position + Rwb * (d.kin.p[sole.body] + d.kin.R[sole.body] * sole.position);
    R = Rwb * d.kin.R[sole.body] * sole.rotation;
    centroidal(model_, d);
    com = s.base_position + Rwb * d.com;
  }

  Model model_;
  ControllerConfig cfg_;
  std::array<SoleFrame, 2> soles_{};
};

TEST_F(SpatialOrder, VelocitiesAndMomentumAgainstFiniteDifferences) {
  std::mt19937_64 rng(19);
  RobotDynamicsData dyn(model_);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model_.nv);
  const double h = 1e-6;
  for (int k = 0; k < 20; ++k) {
    State s = State::zero(model_);
    randomState(model_, rng, s);
    computeRobotDynamics(model_, soles_, dyn, s);
    const Eigen::Matrix3d Rwb = s.base_orientation.toRotationMatrix();
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector3d p1, p0, c1, c0;
      Eigen::Matrix3d R1, R0;
      pose(advance(s, h), i, p1, R1, c1);
      pose(advance(s, -h), i, p0, R0, c0);
      const Eigen::Vector3d v = (p1 - p0) / (2.0 * h);                // world linear velocity of the sole
      const Eigen::AngleAxisd turn(R1 * R0.transpose());
      const Eigen::Vector3d w = turn.angle() * turn.axis() / (2.0 * h);  // world angular velocity
      // The controller's task space: [linear; angular], world.
      const LinearAngular6d sole_velocity = dyn.Jc[i] * dyn.nu;
      EXPECT_LT((sole_velocity.head<3>() - v).norm(), 1e-6) << "sample " << k << " sole " << i;
      EXPECT_LT((sole_velocity.tail<3>() - w).norm(), 1e-6) << "sample " << k << " sole " << i;
      // The model: [angular; linear], reference (base) coordinates.
      computePointJacobian(model_, dyn.dyn.kin, soles_[i].body, soles_[i].position, J);
      const Eigen::Matrix<double, 6, 1> sole_velocity_base = J * dyn.nu;
      EXPECT_LT((Rwb * sole_velocity_base.head<3>() - w).norm(), 1e-6) << "sample " << k << " sole " << i;
      EXPECT_LT((Rwb * sole_velocity_base.tail<3>() - v).norm(), 1e-6) << "sample " << k << " sole " << i;
      if (i == 1) {
        // Linear momentum = mass x CoM velocity: first in the controller's momentum, last in the model's.
        const Eigen::Vector3d P = dyn.mass * (c1 - c0) / (2.0 * h);
        EXPECT_LT((dyn.momentum.head<3>() - P).norm(), 1e-5 * std::max(1.0, P.norm())) << "sample " << k;
        EXPECT_LT((Rwb * dyn.dyn.momentum_origin.tail<3>() - P).norm(), 1e-5 * std::max(1.0, P.norm()))
            << "sample " << k;
      }
    }
  }
}

TEST_F(SpatialOrder, RegressorBaseRowsAreMomentThenForce) {
  // At rest the base's generalized force holds the robot against gravity: force -m R^T g (base coordinates),
  // moment c x (-m R^T g) about the base origin, c the CoM in base coordinates.
  std::mt19937_64 rng(20);
  Data data(model_);
  DynamicsData d(model_);
  for (int k = 0; k < 5; ++k) {
    State s = State::zero(model_);
    randomState(model_, rng, s);
    s.v.setZero();
    s.a.setZero();
    s.base_omega.setZero();
    s.base_velocity.setZero();
    s.base_domega.setZero();
    s.base_acceleration.setZero();
    computeJointTorqueRegressor(model_, data, s);
    const Eigen::VectorXd tau = data.K * model_.phi;
    forwardKinematics(model_, d.kin, s);
    centroidal(model_, d);
    const Eigen::Vector3d force = -d.mass * (s.base_orientation.conjugate() * model_.gravity);
    EXPECT_LT((tau.segment<3>(3) - force).norm(), 1e-9 * force.norm()) << "sample " << k;
    EXPECT_LT((tau.head<3>() - d.com.cross(force)).norm(), 1e-9 * force.norm()) << "sample " << k;
  }
}

}  // namespace
}  // namespace exoid::controller
