// Dataset assembly: block-wise zero-phase filtering equals filtering the whole run at once; without a
// filter the pipeline reproduces K(q, v, dv) and y exactly; the base position from leg kinematics equals
// the true one when the feet are where the footholds say; the base orientation fused from legs and IMU removes
// the IMU noise and the legs' tilt bias; the base's rate and acceleration from the legs are the derivatives of the
// base's trajectory, and the IMU below the fusion cutoff gives back what a tilting sole hides from the legs; the
// soles' tilt fitted to the plates' wrenches finds the load's column and averages the IMU's noise away.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/sole_tilt.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/signal/filters.hpp"

namespace exoid::estimator {
namespace {

Model exo() {
  Model m;
  std::string err;
  EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, m, &err)) << err;
  return m;
}

// A smooth motion with exact derivatives, and wrenches on both feet.
MeasuredSample sampleAt(const Model& m, double t) {
  MeasuredSample s;
  s.t = t;
  const int nj = m.njoints;
  s.q.resize(nj), s.v.resize(nj), s.a.resize(nj), s.tau.resize(nj);
  for (int j = 0; j < nj; ++j) {
    const double w = 2.0 + 0.7 * j, A = 0.1 + 0.01 * j;
    s.q[j] = A * std::sin(w * t + j);
    s.v[j] = A * w * std::cos(w * t + j);
    s.a[j] = -A * w * w * std::sin(w * t + j);
    s.tau[j] = 10.0 * std::cos(1.3 * t + j);
  }
  s.base_orientation = Eigen::AngleAxisd(0.05 * std::sin(t), Eigen::Vector3d::UnitX()) *
                       Eigen::AngleAxisd(0.03 * std::sin(2 * t), Eigen::Vector3d::UnitY());
  s.base_position = Eigen::Vector3d(0.01 * std::sin(t), 0.0, 1.0);
  s.base_omega = Eigen::Vector3d(0.05 * std::cos(t), 0.06 * std::cos(2 * t), 0.0);
  s.base_domega = Eigen::Vector3d(-0.05 * std::sin(t), -0.12 * std::sin(2 * t), 0.0);
  s.base_acceleration = Eigen::Vector3d(-0.01 * std::sin(t), 0.0, 0.0);
  s.has_base_position = s.has_base_domega = true;
  s.ncontacts = 2;
  const int feet[2] = {m.bodyIndex("right_foot"), m.bodyIndex("left_foot")};
  for (int i = 0; i < 2; ++i) {
    s.contact[i].body = feet[i];
    s.contact[i].force = Eigen::Vector3d(5 * std::sin(t), 2.0, 350.0 + 20 * std::sin(3 * t + i));
    s.contact[i].moment_world_origin = Eigen::Vector3d(3 * std::cos(t), -1.0, 0.5);
  }
  return s;
}

struct Rows {
  std::vector<double> t;
  std::vector<Eigen::MatrixXd> K;
  std::vector<Eigen::VectorXd> y;
};

// The right sole as a foothold at a fixed world point.
DatasetOptions::Foothold rightSole(const Model& m) {
  const int sole = m.frameIndex("right_sole");
  EXPECT_GE(sole, 0);
  const Model::Frame& fr = m.frames[static_cast<size_t>(std::max(sole, 0))];
  DatasetOptions::Foothold f;
  f.body = fr.body, f.point_in_body = fr.position, f.rotation_in_body = fr.rotation;
  f.world = Eigen::Vector3d(0.1, -0.1, 0.0);
  return f;
}

// The rows of a sequence of samples.
Rows rowsOf(const Model& m, const std::vector<MeasuredSample>& in, const DatasetOptions& o) {
  Rows r;
  DatasetBuilder b(m, o, [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    r.t.push_back(t), r.K.push_back(K), r.y.push_back(y);
  });
  std::string err;
  for (const MeasuredSample& x : in) EXPECT_TRUE(b.add(x, &err)) << err;
  EXPECT_TRUE(b.finish(&err)) << err;
  return r;
}

// RMS of the base rows' y error of r against the truth's rows t, 500 samples away from either end.
double baseRowError(const Rows& r, const Rows& t) {
  const int n = static_cast<int>(t.y.size());
  double sse = 0.0;
  for (int i = 500; i < n - 500; ++i) sse += (r.y[i] - t.y[i]).head<6>().squaredNorm();
  return std::sqrt(sse / (n - 1000));
}

// The base moving as the legs of sampleAt say, one sole f fixed on a ground whose orientation is sole_world(t).
// truth: the base's orientation, position, omega, domega and classical acceleration R^T p'' from differencing R_wb(t)
// and p_b(t) at a 1e-4 s step (independent of the pipeline's filters and sampling); sensors: the same with the
// base's position and angular acceleration left to the pipeline, gyro_sigma / accel_sigma white noise on the rate
// and the acceleration.
void legsDrivenRun(const Model& m, const DatasetOptions::Foothold& f,
                   const std::function<Eigen::Matrix3d(double)>& sole_world, int n, double gyro_sigma,
                   double accel_sigma, std::vector<MeasuredSample>& truth, std::vector<MeasuredSample>& sensors) {
  Data kin(m);
  State st = State::zero(m);
  struct Pose {
    Eigen::Matrix3d R;
    Eigen::Vector3d p;
  };
  auto basePose = [&](double t) {
    st.q = sampleAt(m, t).q;
    forwardKinematics(m, kin, st);
    Pose x;
    x.R = sole_world(t) * (kin.R[f.body] * f.rotation_in_body).transpose();
    x.p = f.world - x.R * (kin.p[f.body] + kin.R[f.body] * f.point_in_body);
    return x;
  };
  auto vee = [](const Eigen::Matrix3d& M) {
    return Eigen::Vector3d(0.5 * (M(2, 1) - M(1, 2)), 0.5 * (M(0, 2) - M(2, 0)), 0.5 * (M(1, 0) - M(0, 1)));
  };
  const double dt = 1e-3, h = 1e-4;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> unit(0.0, 1.0);
  truth.resize(n), sensors.resize(n);
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    MeasuredSample s = sampleAt(m, t);
    const Pose x = basePose(t), xp = basePose(t + h), xm = basePose(t - h);
    s.base_orientation = Eigen::Quaterniond(x.R);
    s.base_position = x.p;
    s.base_omega = vee(x.R.transpose() * (xp.R - xm.R) / (2.0 * h));
    s.base_domega = vee(x.R.transpose() * (xp.R - 2.0 * x.R + xm.R) / (h * h));
    s.base_acceleration = x.R.transpose() * (xp.p - 2.0 * x.p + xm.p) / (h * h);
    truth[i] = s;
    MeasuredSample y = s;
    y.base_omega += gyro_sigma * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    y.base_acceleration += accel_sigma * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    y.base_domega.setZero();
    y.has_base_position = y.has_base_domega = false;
    sensors[i] = y;
  }
}

Rows run(const Model& m, const DatasetOptions& o, int n, double dt, bool measured_va) {
  Rows r;
  DatasetBuilder b(m, o, [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    r.t.push_back(t), r.K.push_back(K), r.y.push_back(y);
  });
  std::string err;
  for (int i = 0; i < n; ++i) {
    MeasuredSample s = sampleAt(m, i * dt);
    if (!measured_va) s.v.resize(0), s.a.resize(0), s.has_base_domega = false;
    EXPECT_TRUE(b.add(s, &err)) << err;
  }
  EXPECT_TRUE(b.finish(&err)) << err;
  EXPECT_EQ(b.samples(), n);
  return r;
}

TEST(Dataset, WithoutFilterTheRowsAreTheRegressorAndTheMeasuredForces) {
  const Model m = exo();
  DatasetOptions o;
  o.block = 100;
  const Rows r = run(m, o, 250, 1e-3, true);
  ASSERT_EQ(r.K.size(), 250u);
  Data kin(m);
  Eigen::VectorXd y(m.nv);
  for (int i : {0, 99, 100, 249}) {
    const MeasuredSample s = sampleAt(m, i * 1e-3);
    State st = State::zero(m);
    st.q = s.q, st.v = s.v, st.a = s.a;
    st.base_orientation = s.base_orientation, st.base_position = s.base_position;
    st.base_omega = s.base_omega, st.base_domega = s.base_domega, st.base_acceleration = s.base_acceleration;
    computeJointTorqueRegressor(m, kin, st);
    generalizedForceFromMeasurements(m, kin, st, s.tau, s.contact, 2, y);
    EXPECT_EQ((r.K[i] - kin.K).cwiseAbs().maxCoeff(), 0.0) << i;
    EXPECT_EQ((r.y[i] - y).cwiseAbs().maxCoeff(), 0.0) << i;
    EXPECT_DOUBLE_EQ(r.t[i], i * 1e-3);
  }
}

TEST(Dataset, BlockwiseZeroPhaseFilteringEqualsFilteringTheWholeRun) {
  const Model m = exo();
  for (FilterMode mode : {FilterMode::Inputs, FilterMode::Parallel}) {
    DatasetOptions whole;
    whole.cutoff_hz = 30.0;
    whole.filter = mode;
    whole.block = 1 << 20;
    DatasetOptions blocks = whole;
    blocks.block = 300;
    const int n = 2500;
    const Rows a = run(m, whole, n, 1e-3, false), b = run(m, blocks, n, 1e-3, false);
    double worst = 0.0;
    for (int i = 0; i < n; ++i) {
      worst = std::max(worst, (a.K[i] - b.K[i]).cwiseAbs().maxCoeff() / std::max(1.0, a.K[i].cwiseAbs().maxCoeff()));
      worst = std::max(worst, (a.y[i] - b.y[i]).cwiseAbs().maxCoeff() / std::max(1.0, a.y[i].cwiseAbs().maxCoeff()));
    }
    EXPECT_LT(worst, 1e-12) << (mode == FilterMode::Inputs ? "inputs" : "parallel");
  }
}

// trim_edges drops exactly the filter's settling time (transient below e^-14) at both ends of the run and
// leaves every other row as it was, across block boundaries.
TEST(Dataset, TrimmedEdgesAreTheFiltersSettlingTimeAndTheOtherRowsAreUnchanged) {
  const Model m = exo();
  for (FilterMode mode : {FilterMode::Inputs, FilterMode::Parallel}) {
    DatasetOptions o;
    o.cutoff_hz = 20.0;
    o.filter = mode;
    o.block = 300;
    const int n = 2500;
    const Rows all = run(m, o, n, 1e-3, false);
    o.trim_edges = true;
    Rows cut;
    DatasetBuilder b(m, o, [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
      cut.t.push_back(t), cut.K.push_back(K), cut.y.push_back(y);
    });
    std::string err;
    for (int i = 0; i < n; ++i) {
      MeasuredSample s = sampleAt(m, i * 1e-3);
      s.v.resize(0), s.a.resize(0), s.has_base_domega = false;
      ASSERT_TRUE(b.add(s, &err)) << err;
    }
    ASSERT_TRUE(b.finish(&err)) << err;
    // Settling time of the biquad: its poles have modulus sqrt(a2); e^-14 after ceil(14 / -ln r) samples.
    const Biquad lp = Biquad::butterworthLowPass(20.0, 1000.0);
    const int edge = static_cast<int>(std::ceil(14.0 / -std::log(std::sqrt(lp.a2)))) + 8;
    ASSERT_EQ(b.trimmed(), 2 * edge);
    ASSERT_EQ(static_cast<int>(cut.t.size()), n - 2 * edge);
    for (int i = 0; i < n - 2 * edge; ++i) {
      ASSERT_EQ(cut.t[i], all.t[i + edge]);
      ASSERT_EQ((cut.K[i] - all.K[i + edge]).cwiseAbs().maxCoeff(), 0.0) << i;
      ASSERT_EQ((cut.y[i] - all.y[i + edge]).cwiseAbs().maxCoeff(), 0.0) << i;
    }
  }
}

TEST(Dataset, DerivativesOfASmoothMotionMatchTheExactOnes) {
  const Model m = exo();
  DatasetOptions o;
  o.cutoff_hz = 50.0;
  const Rows f = run(m, o, 3000, 1e-3, false);
  DatasetOptions exact;
  const Rows e = run(m, exact, 3000, 1e-3, true);
  double worst = 0.0;
  for (int i = 100; i < 2900; ++i)
    worst = std::max(worst, (f.K[i] - e.K[i]).cwiseAbs().maxCoeff() / e.K[i].cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 2e-3);  // 2nd-order Butterworth at 50 Hz on motions of 0.3-1.5 Hz plus differencing
}

TEST(Dataset, BasePositionFromLegKinematicsEqualsTheTrueOne) {
  const Model m = exo();
  const MeasuredSample truth = sampleAt(m, 0.37);
  // Footholds placed where the true state puts two sole points.
  Data kin(m);
  State st = State::zero(m);
  st.q = truth.q, st.base_orientation = truth.base_orientation;
  forwardKinematics(m, kin, st);
  DatasetOptions o;
  const Eigen::Matrix3d R = truth.base_orientation.toRotationMatrix();
  for (const char* foot : {"right_foot", "left_foot"}) {
    DatasetOptions::Foothold f;
    f.body = m.bodyIndex(foot);
    f.point_in_body = Eigen::Vector3d(0.06, 0.0, 0.03);
    f.world = truth.base_position + R * (kin.p[f.body] + kin.R[f.body] * f.point_in_body);
    o.footholds.push_back(f);
  }
  Rows with, without;
  DatasetBuilder a(m, {}, [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { with.K.push_back(K), with.y.push_back(y); });
  DatasetBuilder b(m, o, [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { without.K.push_back(K), without.y.push_back(y); });
  MeasuredSample s = truth;
  std::string err;
  ASSERT_TRUE(a.add(s, &err) && a.finish(&err)) << err;
  s.has_base_position = false;
  s.base_position = Eigen::Vector3d(9, 9, 9);  // must not be used
  ASSERT_TRUE(b.add(s, &err) && b.finish(&err)) << err;
  ASSERT_EQ(with.y.size(), 1u);
  ASSERT_EQ(without.y.size(), 1u);
  EXPECT_LT((with.y[0] - without.y[0]).cwiseAbs().maxCoeff(), 1e-11 * with.y[0].cwiseAbs().maxCoeff());
}

TEST(Dataset, FusedBaseOrientationRemovesImuNoiseAndLegBias) {
  // One foot (right sole) on the ground whose world orientation tilts slowly (contact compliance: the legs'
  // orientation is biased by it), the base orientation following from the legs exactly; the IMU reports it
  // with white noise (3.5 mrad), the accelerometer's gravity term with the same error. Rows from the fused
  // orientation must be far closer to the true rows than rows from the IMU alone.
  const Model m = exo();
  const DatasetOptions::Foothold f = rightSole(m);
  const int n = 6000;
  const double dt = 1e-3;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 3.5e-3);
  std::vector<MeasuredSample> truth(n), imu(n);
  Data kin(m);
  State st = State::zero(m);
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    MeasuredSample s = sampleAt(m, t);
    st.q = s.q;
    forwardKinematics(m, kin, st);
    const Eigen::Matrix3d Rbs = kin.R[f.body] * f.rotation_in_body;
    const Eigen::Matrix3d Rws = (Eigen::AngleAxisd(0.02 * std::sin(0.8 * t), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ())).toRotationMatrix();
    const Eigen::Matrix3d Rwb = Rws * Rbs.transpose();
    s.base_orientation = Eigen::Quaterniond(Rwb);
    s.base_position = f.world - Rwb * (kin.p[f.body] + kin.R[f.body] * f.point_in_body);
    truth[i] = s;
    MeasuredSample x = s;
    const Eigen::Vector3d e(noise(rng), noise(rng), noise(rng));
    x.base_orientation = (s.base_orientation * Eigen::Quaterniond(Eigen::AngleAxisd(e.norm(), e.normalized()))).normalized();
    x.base_acceleration += x.base_orientation.conjugate() * m.gravity - s.base_orientation.conjugate() * m.gravity;
    x.has_base_position = false;
    imu[i] = x;
  }
  auto rows = [&](const std::vector<MeasuredSample>& in, const DatasetOptions& o) { return rowsOf(m, in, o); };
  DatasetOptions plain;
  plain.footholds = {f};
  DatasetOptions fused = plain;
  fused.orientation_from_legs = true;
  const Rows t = rows(truth, {}), a = rows(imu, plain), b = rows(imu, fused);
  ASSERT_EQ(b.y.size(), static_cast<size_t>(n));
  auto error = [&](const Rows& r) { return baseRowError(r, t); };
  const double e_imu = error(a), e_fused = error(b);
  std::printf("base-row y error: IMU alone %.4g, fused %.4g\n", e_imu, e_fused);
  EXPECT_LT(e_fused, 0.2 * e_imu);
  // Blockwise equals one block (the sole orientation is estimated once, from the first 1000 samples).
  DatasetOptions small = fused;
  small.block = 300;
  const Rows c = rows(imu, small);
  double worst = 0.0;
  for (int i = 0; i < n; ++i) worst = std::max(worst, (c.y[i] - b.y[i]).cwiseAbs().maxCoeff() / b.y[i].cwiseAbs().maxCoeff());
  std::printf("block 300 vs 4096: max relative y difference %.3g\n", worst);
  EXPECT_LT(worst, 1e-12);
}

TEST(Dataset, SoleTiltFittedToThePlatesRemovesTheImusLowBandNoise) {
  // One sole on the ground that rolls into its contact in proportion to the moment on it (base pitch error
  // 2e-4 + 1.2e-5 rad per N m of the right foot's y moment, up to 0.3 mrad; constant roll and heading errors),
  // the legs exact otherwise; the IMU reports the true orientation with 3.5 mrad white noise. The fit
  // (SoleTiltFit, BIC per axis) must find the pitch's moment column and nothing else, within 10 % of its
  // coefficient, and the rows from it must be several times closer to the true rows than the 5 Hz band's.
  const Model m = exo();
  const DatasetOptions::Foothold f = rightSole(m);
  const int n = 6000;
  const double dt = 1e-3, k_pitch = 1.2e-5;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 3.5e-3);
  std::vector<MeasuredSample> truth(n), imu(n);
  Data kin(m);
  State st = State::zero(m);
  const Eigen::Matrix3d Rws(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()));
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    MeasuredSample s = sampleAt(m, t);
    const double ny = 20.0 * std::sin(0.9 * t) + 5.0 * std::sin(2.3 * t);
    s.contact[0].moment_world_origin.y() = ny;
    st.q = s.q;
    forwardKinematics(m, kin, st);
    const Eigen::Matrix3d Rbs = kin.R[f.body] * f.rotation_in_body;
    const Eigen::Vector3d e(1e-4, 2e-4 + k_pitch * ny, -3e-4);  // base coordinates
    const Eigen::Matrix3d Rwb = Rws * Rbs.transpose() * Eigen::AngleAxisd(e.norm(), e.normalized()).toRotationMatrix();
    s.base_orientation = Eigen::Quaterniond(Rwb);
    s.base_position = f.world - Rwb * (kin.p[f.body] + kin.R[f.body] * f.point_in_body);
    truth[i] = s;
    MeasuredSample x = s;
    const Eigen::Vector3d w(noise(rng), noise(rng), noise(rng));
    x.base_orientation = (s.base_orientation * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))).normalized();
    x.has_base_position = false;
    imu[i] = x;
  }
  SoleTiltFit fit(m, {f});
  for (const MeasuredSample& x : imu) fit.add(x);
  const SoleTilt tilt = fit.finish();
  ASSERT_TRUE(tilt.fitted);
  EXPECT_EQ(tilt.samples, n);
  const int ny_col = 5;  // right_ny
  EXPECT_EQ(soleTiltColumnName(ny_col), "right_ny");
  EXPECT_EQ(tilt.columns[0], 1) << describeSoleTilt(tilt);  // the constant only
  EXPECT_EQ(tilt.columns[1], 1 | (1 << ny_col)) << describeSoleTilt(tilt);
  EXPECT_EQ(tilt.columns[2], 1) << describeSoleTilt(tilt);
  EXPECT_NEAR(tilt.coefficients(1, ny_col), k_pitch, 0.1 * k_pitch);
  EXPECT_NEAR(tilt.residual_rms[1], 3.5e-3, 0.2e-3);  // what is left is the IMU's noise
  DatasetOptions band;
  band.footholds = {f};
  band.orientation_from_legs = true;
  DatasetOptions fitted = band;
  fitted.sole_tilt = tilt;
  const Rows t = rowsOf(m, truth, {}), a = rowsOf(m, imu, band), b = rowsOf(m, imu, fitted);
  ASSERT_EQ(b.y.size(), static_cast<size_t>(n));
  auto error = [&](const Rows& r) { return baseRowError(r, t); };
  const double e_band = error(a), e_fit = error(b);
  std::printf("base-row y error: the IMU's band below 5 Hz %.4g, the tilt fitted to the plates %.4g\n", e_band, e_fit);
  EXPECT_LT(e_fit, 0.3 * e_band);
}

TEST(Dataset, SoleTiltIsNotUsedWhereItCannotBeFitted) {
  // Too few samples, no footholds, or a non-finite wrench (the intake never hands one on; a library caller might):
  // not fitted, so the builder keeps the IMU's band (DatasetOptions::sole_tilt is used only where fitted).
  const Model m = exo();
  const DatasetOptions::Foothold f = rightSole(m);
  SoleTiltFit few(m, {f}), none(m, {}), absurd(m, {f});
  for (int i = 0; i < 300; ++i) {
    MeasuredSample s = sampleAt(m, 1e-3 * i);
    if (i < 50) few.add(s);
    none.add(s);
    if (i == 200) s.contact[0].force.z() = std::nan("");
    absurd.add(s);
  }
  const SoleTilt a = few.finish(), b = none.finish(), c = absurd.finish();
  EXPECT_FALSE(a.fitted);
  EXPECT_EQ(a.samples, 50);
  EXPECT_FALSE(b.fitted);
  EXPECT_EQ(b.samples, 0);
  EXPECT_FALSE(c.fitted) << describeSoleTilt(c);
  EXPECT_EQ(describeSoleTilt(a), "not fitted (50 samples)");
}

TEST(Dataset, BaseMotionFromTheLegsIsTheBaseTrajectorysDerivatives) {
  // One sole fixed on level ground, the base moving as the legs say; the gyro reports omega with white noise
  // (3.6e-3 rad/s), the accelerometer the acceleration with 0.02 m/s^2 (the simulated IMU's). Rows from the legs
  // (joints' v, a measured, no filter: central differences at 1 kHz) equal the truth's (legsDrivenRun) to O(dt^2),
  // those from the IMU carry its differentiated noise.
  const Model m = exo();
  const DatasetOptions::Foothold f = rightSole(m);
  const int n = 4000;
  std::vector<MeasuredSample> truth, sensors;
  legsDrivenRun(m, f, [](double) { return Eigen::Matrix3d(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ())); }, n,
                3.6e-3, 0.02, truth, sensors);
  auto error = [&](const Rows& r, const Rows& ref, int edge) {  // largest base-row K error over its scale
    double e = 0.0, scale = 0.0;
    for (int i = edge; i < n - edge; ++i) {
      e = std::max(e, (r.K[i] - ref.K[i]).topRows<6>().cwiseAbs().maxCoeff());
      scale = std::max(scale, ref.K[i].topRows<6>().cwiseAbs().maxCoeff());
    }
    return e / scale;
  };
  DatasetOptions imu;
  imu.footholds = {f};
  DatasetOptions rate = imu, motion = imu;
  rate.base_rate_from_legs = true;
  motion.base_rate_from_legs = motion.base_acceleration_from_legs = true;
  const Rows t = rowsOf(m, truth, {}), a = rowsOf(m, sensors, imu), r = rowsOf(m, sensors, rate),
             l = rowsOf(m, sensors, motion);
  ASSERT_EQ(l.K.size(), static_cast<size_t>(n));
  const double e_imu = error(a, t, 50), e_rate = error(r, t, 50), e_legs = error(l, t, 50);
  std::printf("base-row K error, no filter: IMU %.3g, legs' rate %.3g, legs' rate and acceleration %.3g\n", e_imu,
              e_rate, e_legs);
  EXPECT_LT(e_legs, 1e-5);
  EXPECT_GT(e_imu, 1e3 * e_legs);
  // The rate alone leaves the accelerometer's noise: between the two.
  EXPECT_GT(e_rate, 100.0 * e_legs);
  EXPECT_LT(e_rate, 0.2 * e_imu);
  // With a 30 Hz zero-phase filter the legs' signals pass the filter as the joints' q (same attenuation): against
  // the truth's rows through the same filter the base rows stay far closer than the IMU's.
  DatasetOptions imu30 = imu, legs30 = motion, truth30;
  imu30.cutoff_hz = legs30.cutoff_hz = truth30.cutoff_hz = 30.0;
  imu30.derive = legs30.derive = truth30.derive = true;
  const Rows t30 = rowsOf(m, truth, truth30), a30 = rowsOf(m, sensors, imu30), l30 = rowsOf(m, sensors, legs30);
  const double e_imu30 = error(a30, t30, 500), e_legs30 = error(l30, t30, 500);  // past the filters' start-up
  std::printf("base-row K error, 30 Hz: IMU %.3g, legs %.3g\n", e_imu30, e_legs30);
  EXPECT_LT(e_legs30, 0.05 * e_imu30);
  // Blockwise equals one block (the filters' margins carry the legs' signals across the blocks too).
  DatasetOptions small = legs30;
  small.block = 300;
  const Rows c = rowsOf(m, sensors, small);
  double worst = 0.0;
  for (int i = 0; i < n; ++i) worst = std::max(worst, (c.K[i] - l30.K[i]).cwiseAbs().maxCoeff() / l30.K[i].cwiseAbs().maxCoeff());
  std::printf("block 300 vs 4096: max relative K difference %.3g\n", worst);
  EXPECT_LT(worst, 1e-10);  // rounding of p_b (1e-16 m) differentiated twice at 1 kHz: ~1e-10 m/s^2
}

TEST(Dataset, TheImuBelowTheFusionCutoffGivesBackTheFeetsTilt) {
  // The sole's world orientation tilts slowly (0.13 Hz, 20 mrad: contact compliance), which the legs cannot see:
  // their rate and acceleration miss the tilt's derivatives. The IMU (exact here) sees them; taken below the
  // fusion cutoff (imu_below_fusion_cutoff, the rank rule's processing alternative) the rows come back to the
  // truth's, while the IMU's share above it stays the legs'.
  const Model m = exo();
  const DatasetOptions::Foothold f = rightSole(m);
  const int n = 6000;
  std::vector<MeasuredSample> truth, sensors;
  legsDrivenRun(m, f, [](double t) { return Eigen::Matrix3d(Eigen::AngleAxisd(0.02 * std::sin(0.8 * t), Eigen::Vector3d::UnitX())); },
                n, 0.0, 0.0, truth, sensors);
  auto error = [&](const Rows& r, const Rows& ref) {  // RMS of the base rows' K error over its RMS, past the start-up
    double e = 0.0, scale = 0.0;
    for (int i = 1000; i < n - 1000; ++i) {
      e += (r.K[i] - ref.K[i]).topRows<6>().squaredNorm();
      scale += ref.K[i].topRows<6>().squaredNorm();
    }
    return std::sqrt(e / scale);
  };
  DatasetOptions legs, truth30;
  legs.footholds = {f};
  legs.cutoff_hz = truth30.cutoff_hz = 30.0;
  legs.derive = truth30.derive = true;
  legs.orientation_from_legs = legs.base_rate_from_legs = legs.base_acceleration_from_legs = true;
  DatasetOptions fused = legs;
  fused.imu_below_fusion_cutoff = true;
  const Rows t = rowsOf(m, truth, truth30), l = rowsOf(m, sensors, legs), u = rowsOf(m, sensors, fused);
  const double e_legs = error(l, t), e_fused = error(u, t);
  std::printf("base-row K error with a tilting sole: legs %.3g, IMU below the fusion cutoff %.3g\n", e_legs, e_fused);
  EXPECT_LT(e_fused, 0.1 * e_legs);
}

TEST(Dataset, CutoffAboveNyquistIsAnError) {
  const Model m = exo();
  DatasetOptions o;
  o.cutoff_hz = 600.0;
  DatasetBuilder b(m, o, [](double, const Eigen::MatrixXd&, const Eigen::VectorXd&) {});
  std::string err;
  bool ok = true;
  for (int i = 0; i < 50 && ok; ++i) ok = b.add(sampleAt(m, i * 1e-3), &err);
  if (ok) ok = b.finish(&err);
  EXPECT_FALSE(ok);
  EXPECT_NE(err.find("Nyquist"), std::string::npos) << err;
}

}  // namespace
}  // namespace exoid::estimator
