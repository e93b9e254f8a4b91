// staticMomentReach (move_reach.hpp): which joint carries the moves' static moment, and the reach it allows, on
// the exoskeleton's URDF, against the hand-computed budget x limit / (m g) and with its limits changed.
#include <gtest/gtest.h>

#include <cmath>

#include "controller_test_util.hpp"
#include "exoid/controller/com_trajectory.hpp"
#include "exoid/controller/move_reach.hpp"
#include "exoid/model/kinematics.hpp"

namespace exoid::controller {
namespace {

class StaticMomentReach : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadModel(model_, &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, "right_sole", soles_[0], &err)) << err;
    ASSERT_TRUE(resolveSoleFrame(model_, "left_sole", soles_[1], &err)) << err;
    // The URDF's link masses summed by hand (not Model::totalMass).
    for (int b = 0; b < model_.nbodies; ++b) mass_ += model_.phi[model_.bodyParamIndex(b)];
    ASSERT_NEAR(mass_, 41.0, 2.0);
  }
  MoveReach full(double budget) {
    Data kin(model_);
    forwardKinematics(model_, kin, State::zero(model_));  // standing, straight legs, base at the origin
    return staticMomentReach(model_, kin, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), soles_, budget);
  }
  Eigen::Vector2d reach(double budget) { return full(budget).half; }
  void setLimit(const char* joint, double limit) { model_.effort_limit[model_.jointIndex(joint)] = limit; }
  Model model_;
  std::array<SoleFrame, 2> soles_{};
  double mass_ = 0.0;
};

TEST_F(StaticMomentReach, AnklePitchCarriesForwardOffsetsAndHipAbductionSidewaysOnes) {
  const double w = mass_ * 9.81;
  const Eigen::Vector2d r = reach(0.4);
  EXPECT_NEAR(r.x(), 0.4 * 100.0 / w, 1e-12);  // ankle_pd: 100 N m (the knee and hip_fe, 150, are further up)
  EXPECT_NEAR(r.y(), 0.4 * 150.0 / w, 1e-12);  // hip_aa: 150 N m (the ankle in/eversion is passive, effort 0)
  EXPECT_NEAR(reach(0.2).x(), 0.5 * r.x(), 1e-15);
  // Measured from the ankles' line forward and the pelvis's middle sideways: in config/exo.urdf's straight stance
  // the hip_aa joints sit at y = -+0.11 and every joint origin below them lies straight down the leg (x = 0).
  const MoveReach m = full(0.4);
  EXPECT_NEAR(m.centre.x(), 0.0, 1e-12);
  EXPECT_NEAR(m.centre.y(), 0.0, 1e-12);
  EXPECT_TRUE(m.admits(m.centre + Eigen::Vector2d(0.99 * r.x(), -0.99 * r.y())));
  EXPECT_FALSE(m.admits(m.centre + Eigen::Vector2d(1.01 * r.x(), 0.0)));
  EXPECT_FALSE(m.admits(m.centre + Eigen::Vector2d(0.0, -1.01 * r.y())));
}

TEST_F(StaticMomentReach, TheWeakerLegCountsAndAJointFurtherUpTakesOverFromAPassiveOne) {
  setLimit("left_ankle_pd", 60.0);
  const double w = mass_ * 9.81;
  EXPECT_NEAR(reach(0.4).x(), 0.4 * 60.0 / w, 1e-12);
  // Ankle pitch passive in both legs: the knee (150 N m) is the pitch joint nearest the sole.
  setLimit("left_ankle_pd", 0.0);
  setLimit("right_ankle_pd", 0.0);
  setLimit("right_knee", 120.0);
  EXPECT_NEAR(reach(0.4).x(), 0.4 * 120.0 / w, 1e-12);
  // No actuated roll joint in either leg: nothing to protect, no bound sideways.
  setLimit("left_hip_aa", 0.0);
  setLimit("right_hip_aa", 0.0);
  EXPECT_TRUE(std::isinf(reach(0.4).y()));
  EXPECT_TRUE(std::isinf(reach(0.0).x()));  // budget 0: off
}

TEST_F(StaticMomentReach, AHeavierSystemGetsAShorterReachInProportion) {
  const Eigen::Vector2d light = reach(0.4);
  for (int b = 0; b < model_.nbodies; ++b) model_.phi.segment(model_.bodyParamIndex(b), 10) *= 151.0 / mass_;
  const Eigen::Vector2d heavy = reach(0.4);
  EXPECT_NEAR(heavy.x(), light.x() * mass_ / 151.0, 1e-12);
  EXPECT_NEAR(heavy.y(), light.y() * mass_ / 151.0, 1e-12);
  EXPECT_NEAR(heavy.y(), 0.4 * 150.0 / (151.0 * 9.81), 1e-12);  // the 110 kg wearer in the exoskeleton: 0.041 m
}

// The standing soles of config/exo.urdf (as in test_com_trajectory.cpp).
TEST(CoMTrajectoryReach, TargetsStayWithinTheReachAndAReachBeyondThePolygonChangesNothing) {
  ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  const SupportPolygon poly = SupportPolygon::fromSoles({0.03, -0.11}, 0.0, {0.03, 0.11}, 0.0,
                                                        cfg.contact.sole_half_length, cfg.contact.sole_half_width);
  const Eigen::Vector3d start(-0.028, 0.002, 0.92);
  for (uint64_t seed : {1u, 2u, 3u, 7u}) {
    CoMTrajectory free(cfg.trajectory.moves), far(cfg.trajectory.moves), near(cfg.trajectory.moves);
    ASSERT_EQ(free.generate(cfg.trajectory, seed, start, poly), CoMTrajectory::Status::Ok);
    // The 110 kg wearer's reach about the exoskeleton's ankles' line (x = 0) and middle (y = 0).
    MoveReach reach, wide;
    reach.half = {0.027, 0.041};
    wide.half = {0.3, 0.3};
    ASSERT_EQ(far.generate(cfg.trajectory, seed, start, poly, wide), CoMTrajectory::Status::Ok);
    ASSERT_EQ(near.generate(cfg.trajectory, seed, start, poly, reach), CoMTrajectory::Status::Ok);
    double widest = 0.0;
    for (int i = 0; i < free.moves(); ++i) {
      EXPECT_EQ(far.target(i), free.target(i)) << "seed " << seed << " target " << i;
      const Eigen::Vector2d d = near.target(i).head<2>();
      EXPECT_LE(std::abs(d.x()), reach.half.x()) << "seed " << seed << " target " << i;
      EXPECT_LE(std::abs(d.y()), reach.half.y()) << "seed " << seed << " target " << i;
      widest = std::max(widest, std::abs(free.target(i).y()));
    }
    EXPECT_GT(widest, reach.half.y()) << "the unbounded protocol goes beyond the reach (else the test shows nothing)";
  }
}

}  // namespace
}  // namespace exoid::controller
