// CoMTrajectory and SupportPolygon: the thesis's move protocol (20 straight-line moves, cubic time law,
// targets inside the shrunk support polygon, deterministic in the seed).
#include <gtest/gtest.h>

#include <cmath>

#include "controller_test_util.hpp"
#include "exoid/controller/com_trajectory.hpp"

namespace exoid::controller {
namespace {

// The standing soles of config/exo.urdf: centres at x = 0.03, y = -+0.11, axes = world axes.
SupportPolygon standingPolygon(const ControllerConfig& cfg) {
  return SupportPolygon::fromSoles({0.03, -0.11}, 0.0, {0.03, 0.11}, 0.0, cfg.contact.sole_half_length,
                                   cfg.contact.sole_half_width);
}

class CoMTrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadConfig(cfg_, &err)) << err;
    poly_ = standingPolygon(cfg_);
  }
  ControllerConfig cfg_;
  SupportPolygon poly_;
  const Eigen::Vector3d start_{-0.028, 0.002, 0.92};  // the standing CoM of the exoskeleton
};

TEST(SupportPolygon, HullOfTwoParallelSolesIsTheirBoundingRectangle) {
  const SupportPolygon p = SupportPolygon::fromSoles({0.03, -0.11}, 0.0, {0.03, 0.11}, 0.0, 0.14, 0.06);
  ASSERT_EQ(p.count, 4);
  EXPECT_NEAR(p.lower().x(), -0.11, 1e-12);
  EXPECT_NEAR(p.upper().x(), 0.17, 1e-12);
  EXPECT_NEAR(p.lower().y(), -0.17, 1e-12);
  EXPECT_NEAR(p.upper().y(), 0.17, 1e-12);
  // Signed distance: centre is 0.14 from the front/back edges and 0.17 from the sides; outside is negative.
  EXPECT_NEAR(p.insideDistance({0.03, 0.0}), 0.14, 1e-12);
  EXPECT_NEAR(p.insideDistance({0.27, 0.0}), -0.10, 1e-12);
  EXPECT_TRUE(p.contains({0.1, 0.1}, 0.05));
  EXPECT_FALSE(p.contains({0.1, 0.16}, 0.05));
}

TEST(SupportPolygon, RotatedSoleCornersAreOnTheHull) {
  const double yaw = 0.3;
  const SupportPolygon p = SupportPolygon::fromSoles({0.0, -0.1}, yaw, {0.0, 0.1}, -yaw, 0.14, 0.06);
  ASSERT_GE(p.count, 4);
  // The right sole's front-outer corner must lie on the boundary (distance 0).
  const Eigen::Vector2d corner = Eigen::Vector2d(0.0, -0.1) + Eigen::Rotation2Dd(yaw) * Eigen::Vector2d(0.14, -0.06);
  EXPECT_NEAR(p.insideDistance(corner), 0.0, 1e-12);
}

TEST_F(CoMTrajectoryTest, TwentyMovesAllTargetsInsideTheShrunkPolygon) {
  CoMTrajectory traj(cfg_.trajectory.moves);
  ASSERT_EQ(traj.generate(cfg_.trajectory, 1, start_, poly_), CoMTrajectory::Status::Ok);
  ASSERT_EQ(traj.moves(), 20);
  for (int i = 0; i < traj.moves(); ++i) {
    const Eigen::Vector3d& t = traj.target(i);
    EXPECT_GE(poly_.insideDistance(t.head<2>()), cfg_.trajectory.polygon_margin - 1e-12) << "target " << i;
    const Eigen::Vector3d& prev = i == 0 ? traj.start() : traj.target(i - 1);
    const double d = (t - prev).head<2>().norm();
    EXPECT_GE(d, cfg_.trajectory.min_move_distance) << "move " << i;
    EXPECT_LE(d, cfg_.trajectory.max_move_distance) << "move " << i;
    EXPECT_GE(t.z() - start_.z(), cfg_.trajectory.vertical_min - 1e-12);
    EXPECT_LE(t.z() - start_.z(), cfg_.trajectory.vertical_max + 1e-12);
  }
  EXPECT_DOUBLE_EQ(traj.duration(), cfg_.trajectory.initial_hold +
                                        20 * (cfg_.trajectory.move_duration + cfg_.trajectory.hold_duration));
}

TEST_F(CoMTrajectoryTest, CubicLawEndpointsAndMidpoint) {
  CoMTrajectory traj(cfg_.trajectory.moves);
  ASSERT_EQ(traj.generate(cfg_.trajectory, 3, start_, poly_), CoMTrajectory::Status::Ok);
  const double T = traj.moveDuration();
  CoMReference r;
  for (int i = 0; i < traj.moves(); ++i) {
    const Eigen::Vector3d a = i == 0 ? traj.start() : traj.target(i - 1);
    const Eigen::Vector3d b = traj.target(i);
    const double t0 = traj.moveStartTime(i);
    traj.sample(t0, r);  // start of the move: at the previous target, at rest, s'' = 6/T^2
    EXPECT_NEAR((r.position - a).norm(), 0.0, 1e-12);
    EXPECT_NEAR(r.velocity.norm(), 0.0, 1e-12);
    EXPECT_NEAR((r.acceleration - 6.0 / (T * T) * (b - a)).norm(), 0.0, 1e-9);
    EXPECT_EQ(r.move_index, i);
    traj.sample(t0 + 0.5 * T, r);  // midpoint: half way, peak speed 1.5 |d| / T, no acceleration
    EXPECT_NEAR((r.position - 0.5 * (a + b)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((r.velocity - 1.5 / T * (b - a)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(r.acceleration.norm(), 0.0, 1e-9);
    traj.sample(t0 + T, r);  // end of the move: at the target, at rest, then holding it
    EXPECT_NEAR((r.position - b).norm(), 0.0, 1e-12);
    EXPECT_NEAR(r.velocity.norm(), 0.0, 1e-12);
    EXPECT_EQ(r.moves_done, i + 1);
    traj.sample(t0 + T + 0.5 * traj.holdDuration(), r);
    EXPECT_NEAR((r.position - b).norm(), 0.0, 1e-12);
    EXPECT_EQ(r.acceleration.norm(), 0.0);
  }
  traj.sample(traj.duration() + 1.0, r);
  EXPECT_TRUE(r.done);
  EXPECT_EQ(r.move_index, traj.moves());
  EXPECT_NEAR((r.position - traj.target(traj.moves() - 1)).norm(), 0.0, 1e-12);
  traj.sample(0.5 * cfg_.trajectory.initial_hold, r);
  EXPECT_EQ(r.move_index, -1);
  EXPECT_NEAR((r.position - start_).norm(), 0.0, 1e-12);
}

TEST_F(CoMTrajectoryTest, ContinuousAndDerivativesConsistentAtOneKilohertz) {
  CoMTrajectory traj(cfg_.trajectory.moves);
  ASSERT_EQ(traj.generate(cfg_.trajectory, 5, start_, poly_), CoMTrajectory::Status::Ok);
  const double dt = 1e-3;
  CoMReference prev, cur;
  traj.sample(0.0, prev);
  double max_jump = 0.0, max_vel_err = 0.0, max_acc_err = 0.0;
  for (double t = dt; t <= traj.duration() + 0.5; t += dt) {
    traj.sample(t, cur);
    max_jump = std::max(max_jump, (cur.position - prev.position).norm());
    // Trapezoidal consistency: dp = (v0 + v1)/2 dt + O(dt^3 jerk); dv = (a0 + a1)/2 dt.
    max_vel_err = std::max(max_vel_err, (cur.position - prev.position - 0.5 * dt * (cur.velocity + prev.velocity)).norm());
    max_acc_err = std::max(max_acc_err, (cur.velocity - prev.velocity - 0.5 * dt * (cur.acceleration + prev.acceleration)).norm());
    prev = cur;
  }
  const double vmax = 1.5 * cfg_.trajectory.max_move_distance / cfg_.trajectory.move_duration;
  EXPECT_LE(max_jump, vmax * dt * 1.0001);  // no position jump anywhere, including move/hold boundaries
  EXPECT_LE(max_vel_err, 1e-9);
  // The acceleration steps at move boundaries (cubic law): one step of at most 6 |d| / T^2 * dt / 2.
  EXPECT_LE(max_acc_err, 6.0 * cfg_.trajectory.max_move_distance / std::pow(cfg_.trajectory.move_duration, 2) * dt);
}

TEST_F(CoMTrajectoryTest, SameSeedSameMovesDifferentSeedsDiffer) {
  CoMTrajectory a(20), b(20), c(20);
  ASSERT_EQ(a.generate(cfg_.trajectory, 42, start_, poly_), CoMTrajectory::Status::Ok);
  ASSERT_EQ(b.generate(cfg_.trajectory, 42, start_, poly_), CoMTrajectory::Status::Ok);
  ASSERT_EQ(c.generate(cfg_.trajectory, 43, start_, poly_), CoMTrajectory::Status::Ok);
  double same = 0.0, diff = 0.0;
  for (int i = 0; i < 20; ++i) {
    same = std::max(same, (a.target(i) - b.target(i)).norm());
    diff = std::max(diff, (a.target(i) - c.target(i)).norm());
  }
  EXPECT_EQ(same, 0.0);
  EXPECT_GT(diff, 0.02);  // training and validation runs see different moves
}

TEST_F(CoMTrajectoryTest, VerticalComponentWithinConfiguredBounds) {
  TrajectoryConfig t = cfg_.trajectory;
  t.vertical_min = -0.02;
  t.vertical_max = 0.01;
  CoMTrajectory traj(t.moves);
  ASSERT_EQ(traj.generate(t, 9, start_, poly_), CoMTrajectory::Status::Ok);
  double lo = 1.0, hi = -1.0;
  for (int i = 0; i < traj.moves(); ++i) {
    const double dz = traj.target(i).z() - start_.z();
    lo = std::min(lo, dz);
    hi = std::max(hi, dz);
  }
  EXPECT_GE(lo, -0.02);
  EXPECT_LE(hi, 0.01);
  EXPECT_LT(lo, -0.005);  // the range is actually used
}

TEST_F(CoMTrajectoryTest, ImpossibleRequestsFailInsteadOfLeavingThePolygon) {
  CoMTrajectory traj(20);
  EXPECT_EQ(traj.generate(cfg_.trajectory, 1, Eigen::Vector3d(0.5, 0.0, 0.9), poly_),
            CoMTrajectory::Status::StartOutside);
  EXPECT_FALSE(traj.ready());
  TrajectoryConfig t = cfg_.trajectory;
  t.polygon_margin = 0.2;  // larger than the polygon's half width: no admissible target
  t.max_sampling_attempts = 1000;
  EXPECT_EQ(traj.generate(t, 1, start_, poly_), CoMTrajectory::Status::NoTarget);
  EXPECT_FALSE(traj.ready());
  CoMReference r;
  traj.sample(10.0, r);  // not ready: holds the start
  EXPECT_NEAR((r.position - start_).norm(), 0.0, 1e-12);
  EXPECT_EQ(r.move_index, -1);
}

}  // namespace
}  // namespace exoid::controller
