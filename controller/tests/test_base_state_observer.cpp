// BaseStateObserver: the stationary-feet kinematics on synthetic samples (its filter: tests/model/test_filters.cpp).
#include <gtest/gtest.h>

#include <cmath>

#include "controller_test_util.hpp"
#include "exoid/controller/base_state_observer.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::controller {
namespace {

class EstimatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadModel(model_, &err)) << err;
    ASSERT_TRUE(testing::loadConfig(cfg_, &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, "right_sole", soles_[0], &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, "left_sole", soles_[1], &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, "imu", imu_, &err)) << err;
    sample_.q = Eigen::VectorXd::Zero(model_.njoints);
    sample_.tau = Eigen::VectorXd::Zero(model_.njoints);
    sample_.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model_.njoints, true);
  }
  Model model_;
  ControllerConfig cfg_;
  std::array<SoleFrame, 2> soles_{};
  SoleFrame imu_{};
  RobotStateSample sample_;
};

TEST_F(EstimatorTest, StandingStartLatchesSolesOnTheGround) {
  BaseStateObserver est(model_, cfg_.observer, cfg_.loop.period, soles_, imu_);
  for (int k = 0; k < cfg_.observer.latch_ticks + 10; ++k) {
    sample_.tick = k;
    est.update(sample_, 1);
  }
  ASSERT_TRUE(est.latched());
  const State& s = est.state();
  // config/exo.urdf standing: base 1.04 m above the soles, soles at x = 0.03, y = -+0.11.
  EXPECT_NEAR((s.base_position - Eigen::Vector3d(0.0, 0.0, 1.04)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((est.solePosition(0) - Eigen::Vector3d(0.03, -0.11, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((est.solePosition(1) - Eigen::Vector3d(0.03, 0.11, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(s.base_velocity.norm(), 0.0, 1e-12);
  EXPECT_NEAR(s.v.norm(), 0.0, 1e-12);
  EXPECT_NEAR(est.legDisagreement(), 0.0, 1e-12);
}

TEST_F(EstimatorTest, JointVelocityOfARampIsExactAfterTheTransient) {
  BaseStateObserver est(model_, cfg_.observer, cfg_.loop.period, soles_, imu_);
  const double rate = 0.3;  // rad/s on every joint
  for (int k = 0; k < 300; ++k) {
    sample_.tick = k;
    sample_.q.setConstant(rate * k * cfg_.loop.period);
    est.update(sample_, 1);
  }
  EXPECT_NEAR((est.state().v - Eigen::VectorXd::Constant(model_.njoints, rate)).norm(), 0.0, 1e-9);
  // A skipped tick: the difference spans two periods, the velocity stays right.
  sample_.tick = 301;
  sample_.q.setConstant(rate * 301 * cfg_.loop.period);
  est.update(sample_, 2);
  EXPECT_NEAR((est.state().v - Eigen::VectorXd::Constant(model_.njoints, rate)).norm(), 0.0, 1e-9);
}

TEST_F(EstimatorTest, BaseVelocityIsTheDerivativeOfTheKinematicBasePosition) {
  // Symmetric sagittal motion of both legs with the base orientation constant: the feet stay latched, so the
  // estimated base velocity (from J dq) must equal the derivative of the estimated base position.
  BaseStateObserver est(model_, cfg_.observer, cfg_.loop.period, soles_, imu_);
  const int knee_r = model_.jointIndex("right_knee"), knee_l = model_.jointIndex("left_knee");
  const int hip_r = model_.jointIndex("right_hip_fe"), hip_l = model_.jointIndex("left_hip_fe");
  const double dt = cfg_.loop.period, w = 2.0 * M_PI * 0.5;
  double max_err = 0.0, max_speed = 0.0;
  Eigen::Vector3d prev = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3000; ++k) {
    const double t = k * dt;
    const double a = 0.2 * (1.0 - std::cos(w * t));
    sample_.tick = k;
    sample_.q.setZero();
    sample_.q[knee_r] = sample_.q[knee_l] = a;
    sample_.q[hip_r] = sample_.q[hip_l] = 0.5 * a;
    est.update(sample_, 1);
    const Eigen::Vector3d p = est.state().base_position;
    if (k > cfg_.observer.latch_ticks + 100) {
      // Backward difference of p is centred half a period back; the filtered velocity lags ~2.3 ms: compare
      // with a tolerance of 2 % of the peak speed.
      const Eigen::Vector3d fd = (p - prev) / dt;
      const Eigen::Vector3d v = est.baseRotation() * est.state().base_velocity;
      max_err = std::max(max_err, (fd - v).norm());
      max_speed = std::max(max_speed, fd.norm());
    }
    prev = p;
  }
  ASSERT_GT(max_speed, 0.02);  // the base really moves
  EXPECT_LT(max_err, 0.02 * max_speed);
}

TEST_F(EstimatorTest, ComplementaryFilterTracksAConstantRateRotation) {
  ObserverConfig ec = cfg_.observer;
  ec.latch_ticks = 1;
  BaseStateObserver est(model_, ec, cfg_.loop.period, soles_, imu_);
  const Eigen::Vector3d omega(0.0, 0.0, 0.4);  // rad/s about the base z axis
  Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
  for (int k = 0; k < 1000; ++k) {
    sample_.tick = k;
    sample_.imu_orientation = q;
    sample_.imu_gyro = omega;
    est.update(sample_, 1);
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(omega.norm() * cfg_.loop.period, omega.normalized()));
  }
  const Eigen::Quaterniond last = q * Eigen::Quaterniond(Eigen::AngleAxisd(-omega.norm() * cfg_.loop.period,
                                                                             omega.normalized()));
  EXPECT_LT(est.state().base_orientation.angularDistance(last), 1e-9);
  EXPECT_NEAR((est.state().base_omega - omega).norm(), 0.0, 1e-9);
}

}  // namespace
}  // namespace exoid::controller
