// One free rigid body, checked by hand against Newton-Euler about its origin (thesis eq. (2.36)).
#include <gtest/gtest.h>

#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid {
namespace {

// m = 2 kg, c = (0.1, -0.2, 0.3) m, inertia about the CoM diag(0.04, 0.05, 0.06) kg m^2, no rotation.
constexpr char kOneBody[] = R"(<robot name="one"><link name="b"><inertial><origin xyz="0.1 -0.2 0.3"/>
  <mass value="2"/><inertia ixx="0.04" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.06"/></inertial></link></robot>)";

class SingleBody : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfString(kOneBody, true, model_, &err)) << err;
    ASSERT_EQ(model_.nbodies, 1);
    ASSERT_EQ(model_.nv, 6);
  }
  Eigen::VectorXd solve(const State& s) {
    Data d(model_);
    computeJointTorqueRegressor(model_, d, s);
    return d.K * model_.phi;
  }
  Model model_;
  const double m = 2.0, cx = 0.1, cy = -0.2, cz = 0.3, g = 9.81;
  // Inertia about the origin by hand: I_o = I_c + m (|c|^2 E - c c^T).
  const double Ixx = 0.04 + m * (cy * cy + cz * cz), Iyy = 0.05 + m * (cx * cx + cz * cz),
               Izz = 0.06 + m * (cx * cx + cy * cy), Ixy = -m * cx * cy, Ixz = -m * cx * cz, Iyz = -m * cy * cz;
};

TEST_F(SingleBody, ParametersAboutTheOrigin) {
  Vector10d expected;
  expected << m, m * cx, m * cy, m * cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz;
  EXPECT_LT((model_.phi - expected).cwiseAbs().maxCoeff(), 1e-15);
}

TEST_F(SingleBody, HangingInGravity) {
  // Support wrench = m (0,0,g) at the CoM: force m g z, moment c x (0, 0, m g) about the origin.
  Eigen::VectorXd expected(6);
  expected << m * g * cy, -m * g * cx, 0.0, 0.0, 0.0, m * g;
  EXPECT_LT((solve(State::zero(model_)) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(SingleBody, SpinningAboutZ) {
  model_.gravity.setZero();
  State s = State::zero(model_);
  const double w = 3.0;
  s.base_omega = Eigen::Vector3d(0, 0, w);
  // moment = w x (I w) = w^2 (-Iyz, Ixz, 0); force = m w x (w x c) = -m w^2 (cx, cy, 0).
  Eigen::VectorXd expected(6);
  expected << -w * w * Iyz, w * w * Ixz, 0.0, -m * w * w * cx, -m * w * w * cy, 0.0;
  EXPECT_LT((solve(s) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(SingleBody, AngularAccelerationAboutZ) {
  model_.gravity.setZero();
  State s = State::zero(model_);
  const double a = 5.0;
  s.base_domega = Eigen::Vector3d(0, 0, a);
  // moment = I alpha = a (Ixz, Iyz, Izz); force = alpha x (m c) = a m (-cy, cx, 0).
  Eigen::VectorXd expected(6);
  expected << a * Ixz, a * Iyz, a * Izz, -a * m * cy, a * m * cx, 0.0;
  EXPECT_LT((solve(s) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(SingleBody, LinearAccelerationAlongX) {
  model_.gravity.setZero();
  State s = State::zero(model_);
  const double a = 4.0;
  s.base_acceleration = Eigen::Vector3d(a, 0, 0);
  // force = m a x; moment = (m c) x (a x) = a m (0, cz, -cy).
  Eigen::VectorXd expected(6);
  expected << 0.0, a * m * cz, -a * m * cy, m * a, 0.0, 0.0;
  EXPECT_LT((solve(s) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(SingleBody, LinearVelocityDoesNotEnter) {
  // Classical accelerations make the dynamics independent of the base's linear velocity (Galilean invariance).
  State s = State::zero(model_);
  s.base_omega = Eigen::Vector3d(0.3, -0.2, 0.5);
  const Eigen::VectorXd a = solve(s);
  s.base_velocity = Eigen::Vector3d(1.0, 2.0, -3.0);
  EXPECT_EQ((solve(s) - a).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace exoid
