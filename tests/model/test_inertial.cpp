// The inertial-parameter maths (exoid/model/inertial.hpp) against independent computations: bodies built as
// clouds of point masses (their parameters, pseudo-inertia, kinetic energy and rigid motions follow directly
// from the points), hand-made inconsistent bodies, and central finite differences for the log-Cholesky Jacobian.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "exoid/model/inertial.hpp"
#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

struct PointCloud {
  std::vector<double> m;
  std::vector<Eigen::Vector3d> r;  // positions in the body frame
};

PointCloud randomCloud(std::mt19937_64& rng, int n = 6) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), mass(0.05, 2.0);
  PointCloud c;
  const Eigen::Vector3d centre(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng));
  for (int i = 0; i < n; ++i) {
    c.m.push_back(mass(rng));
    c.r.push_back(centre + Eigen::Vector3d(0.2 * u(rng), 0.1 * u(rng), 0.05 * u(rng)));
  }
  return c;
}

// phi of a point cloud, straight from the definitions: m, sum m r, sum m (|r|^2 E - r r^T).
Vector10d cloudParams(const PointCloud& c) {
  double m = 0.0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < c.m.size(); ++i) {
    m += c.m[i];
    h += c.m[i] * c.r[i];
    I += c.m[i] * (c.r[i].squaredNorm() * Eigen::Matrix3d::Identity() - c.r[i] * c.r[i].transpose());
  }
  Vector10d phi;
  phi << m, h, I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2);
  return phi;
}

Eigen::Matrix3d randomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

double relErr(const Vector10d& a, const Vector10d& b) { return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff(); }

TEST(Inertial, PointCloudParametersAndPseudoInertia) {
  std::mt19937_64 rng(1);
  for (int k = 0; k < 200; ++k) {
    const PointCloud c = randomCloud(rng);
    const Vector10d phi = cloudParams(c);
    // Pseudo-inertia = sum m [r; 1][r; 1]^T.
    Eigen::Matrix4d J = Eigen::Matrix4d::Zero();
    for (size_t i = 0; i < c.m.size(); ++i) {
      Eigen::Vector4d x;
      x << c.r[i], 1.0;
      J += c.m[i] * x * x.transpose();
    }
    EXPECT_LT((pseudoInertia(phi) - J).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_LT(relErr(paramsFromPseudoInertia(J), phi), 1e-13);
    // Mass, CoM, inertia about the CoM, and back through paramsFromInertial (with a rotated inertia frame).
    InertialProperties in;
    ASSERT_TRUE(inertialFromParams(phi, in));
    const Eigen::Vector3d com = cloudParams(c).segment<3>(1) / phi[0];
    EXPECT_LT((in.com - com).norm(), 1e-14);
    Eigen::Matrix3d Ic = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < c.m.size(); ++i) {
      const Eigen::Vector3d d = c.r[i] - com;
      Ic += c.m[i] * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
    }
    EXPECT_LT((in.inertia_com - Ic).cwiseAbs().maxCoeff(), 1e-13);
    const Eigen::Matrix3d Rin = randomRotation(rng);
    EXPECT_LT(relErr(paramsFromInertial(in.mass, in.com, Rin, Rin.transpose() * Ic * Rin), phi), 1e-13);
    EXPECT_TRUE(checkConsistency(phi).consistent);
  }
}

TEST(Inertial, TransformParamsMovesThePoints) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    PointCloud c = randomCloud(rng);
    const Vector10d phi = cloudParams(c);
    const Eigen::Matrix3d R = randomRotation(rng);
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    PointCloud moved = c;
    for (auto& r : moved.r) r = R * r + p;
    const Vector10d expected = cloudParams(moved);
    const Vector10d out = transformParams(phi, R, p);
    EXPECT_LT(relErr(out, expected), 1e-13);
    // The documented inverse brings it back.
    EXPECT_LT(relErr(transformParams(out, R.transpose(), -R.transpose() * p), phi), 1e-12);
  }
}

TEST(Inertial, SpatialInertiaGivesTheKineticEnergyOfThePoints) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 100; ++k) {
    const PointCloud c = randomCloud(rng);
    Eigen::Matrix<double, 6, 1> V;  // [omega; velocity of the frame origin]
    for (int i = 0; i < 6; ++i) V[i] = u(rng);
    double T = 0.0;
    Eigen::Vector3d P = Eigen::Vector3d::Zero(), L = Eigen::Vector3d::Zero();  // momentum about the origin
    for (size_t i = 0; i < c.m.size(); ++i) {
      const Eigen::Vector3d v = V.tail<3>() + V.head<3>().cross(c.r[i]);
      T += 0.5 * c.m[i] * v.squaredNorm();
      P += c.m[i] * v;
      L += c.m[i] * c.r[i].cross(v);
    }
    const Eigen::Matrix<double, 6, 6> I = spatialInertia(cloudParams(c));
    EXPECT_NEAR(0.5 * V.dot(I * V), T, 1e-13 * std::max(1.0, T));
    Eigen::Matrix<double, 6, 1> h;
    h << L, P;
    EXPECT_LT((I * V - h).norm(), 1e-13 * std::max(1.0, h.norm()));
    EXPECT_LT((momentumRegressor(V) * cloudParams(c) - h).norm(), 1e-13 * std::max(1.0, h.norm()));
  }
}

TEST(Inertial, ConsistencyVerdictNamesTheViolatedCondition) {
  const Eigen::Matrix3d E = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d c(0.1, -0.05, 0.2);
  // A consistent box-like body.
  const Vector10d good = paramsFromInertial(2.0, c, E, Eigen::Vector3d(0.02, 0.03, 0.04).asDiagonal());
  EXPECT_TRUE(checkConsistency(good).consistent);
  EXPECT_GT(checkConsistency(good).min_eigenvalue, 0.0);
  // Negative mass (as OLS gives for the thesis's ankle links, Appendix D).
  Vector10d neg = good;
  neg[0] = -0.0569;
  EXPECT_FALSE(checkConsistency(neg).consistent);
  EXPECT_STREQ(checkConsistency(neg).reason, "mass <= 0");
  // Inertia about the CoM with a negative principal moment.
  const Vector10d notpd = paramsFromInertial(2.0, c, E, Eigen::Vector3d(-0.01, 0.03, 0.04).asDiagonal());
  EXPECT_STREQ(checkConsistency(notpd).reason, "inertia about the CoM not positive definite");
  // Positive principal moments that break the triangle inequality (no real body: 0.01 + 0.02 < 0.05).
  const Vector10d tri = paramsFromInertial(2.0, c, E, Eigen::Vector3d(0.01, 0.02, 0.05).asDiagonal());
  EXPECT_STREQ(checkConsistency(tri).reason, "triangle inequality");
  EXPECT_LT(checkConsistency(tri).min_eigenvalue, 0.0);
  Vector10d nan = good;
  nan[3] = std::nan("");
  EXPECT_FALSE(checkConsistency(nan).consistent);
  // The verdict agrees with the pseudo-inertia's eigenvalues and with the log-Cholesky map's domain for
  // arbitrary (mostly inconsistent) parameter vectors.
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int consistent = 0;
  for (int k = 0; k < 2000; ++k) {
    Vector10d phi = good;
    for (int i = 0; i < 10; ++i) phi[i] *= 1.0 + 0.8 * u(rng);
    const LinkConsistency v = checkConsistency(phi);
    Vector10d theta;
    EXPECT_EQ(v.consistent, v.min_eigenvalue > 0.0);
    EXPECT_EQ(v.consistent, logCholeskyFromParams(phi, theta));
    consistent += v.consistent ? 1 : 0;
  }
  EXPECT_GT(consistent, 100);
  EXPECT_LT(consistent, 1900);
}

TEST(Inertial, ModelReportOnTheExoskeleton) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  EXPECT_EQ(countInconsistent(checkConsistency(model, model.phi)), 0);
  // Appendix D's OLS estimate gives link 5 (right ankle) a mass of -0.0569 kg.
  Eigen::VectorXd phi = model.phi;
  phi[model.bodyParamIndex(model.bodyIndex("right_ankle"))] = -0.0569;
  const std::vector<LinkConsistency> report = checkConsistency(model, phi);
  EXPECT_EQ(countInconsistent(report), 1);
  EXPECT_FALSE(report[static_cast<size_t>(model.bodyIndex("right_ankle"))].consistent);
}

TEST(Inertial, LogCholeskyRoundTripAndEveryPointIsConsistent) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 500; ++k) {
    const Vector10d phi = cloudParams(randomCloud(rng));
    Vector10d theta;
    ASSERT_TRUE(logCholeskyFromParams(phi, theta));
    EXPECT_LT(relErr(paramsFromLogCholesky(theta), phi), 1e-12);
    EXPECT_NEAR(std::exp(2.0 * theta[0]), phi[0], 1e-12 * phi[0]);            // m = e^(2 alpha)
    EXPECT_LT((theta.tail<3>() - phi.segment<3>(1) / phi[0]).norm(), 1e-12);  // t = CoM
    Vector10d any;
    for (int i = 0; i < 10; ++i) any[i] = 3.0 * u(rng);
    const Vector10d p = paramsFromLogCholesky(any);
    EXPECT_TRUE(checkConsistency(p).consistent) << any.transpose();
    // log det J = 8 alpha + 2 (d1 + d2 + d3) (J can be badly conditioned here: LU's determinant to 1e-6).
    EXPECT_NEAR(std::log(pseudoInertia(p).determinant()), 8.0 * any[0] + 2.0 * any.segment<3>(1).sum(), 1e-6);
    Vector10d back;
    ASSERT_TRUE(logCholeskyFromParams(p, back));
    EXPECT_LT((back - any).cwiseAbs().maxCoeff(), 1e-7);
  }
}

TEST(Inertial, LogCholeskyJacobianMatchesFiniteDifferences) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int k = 0; k < 100; ++k) {
    Vector10d theta;
    for (int i = 0; i < 10; ++i) theta[i] = u(rng);
    const Matrix10d D = logCholeskyJacobian(theta);
    Matrix10d fd;
    const double h = 1e-6;
    for (int i = 0; i < 10; ++i) {
      Vector10d tp = theta, tm = theta;
      tp[i] += h;
      tm[i] -= h;
      fd.col(i) = (paramsFromLogCholesky(tp) - paramsFromLogCholesky(tm)) / (2.0 * h);
    }
    worst = std::max(worst, (D - fd).cwiseAbs().maxCoeff() / fd.cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-8);
}

}  // namespace
}  // namespace exoid
