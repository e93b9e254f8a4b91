// The calibration run (exoid calibrate): the leg-swing reference, the run itself (pelvis held, feet free), and the
// held-base dataset rows it feeds to `exoid diagnose --calibration` (docs/diagnose.md "Calibration run").
#include <gtest/gtest.h>

#include <cmath>

#include "exoid/controller/leg_swing.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/calibration_run.hpp"
#include "exoid/tools/identify_input.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

Model exoModel() {
  Model m;
  std::string err;
  EXPECT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, m, &err)) << err;
  return m;
}

// q_d starts at the start pose at rest, moves to mid-range, then swings inside the limits; v_d and a_d are its
// derivatives (central differences of q_d and v_d agree to the differences' own O(h^2) error); unactuated joints
// stay where they started.
TEST(LegSwing, ReferenceStartsAtRestStaysInsideTheLimitsAndItsDerivativesAreConsistent) {
  const Model model = exoModel();
  const int nj = model.njoints;
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(nj);
  controller::LegSwingTrajectory tr;
  std::string err;
  ASSERT_TRUE(controller::makeLegSwingTrajectory(model, q0, controller::LegSwingOptions(), tr, &err)) << err;
  Eigen::VectorXd q(nj), v(nj), a(nj), qm(nj), vm(nj), am(nj), qp(nj), vp(nj), ap(nj);
  controller::legSwingReference(tr, 0.0, q, v, a);
  EXPECT_LE((q - q0).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LE(v.cwiseAbs().maxCoeff(), 1e-15);
  const double h = 1e-4;
  double dq = 0.0, dv = 0.0, vmax = 0.0, amax = 0.0;
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(nj, 1e9), hi = Eigen::VectorXd::Constant(nj, -1e9);
  for (double t = 0.05; t < 60.0; t += 0.0371) {
    controller::legSwingReference(tr, t, q, v, a);
    controller::legSwingReference(tr, t - h, qm, vm, am);
    controller::legSwingReference(tr, t + h, qp, vp, ap);
    dq = std::max(dq, ((qp - qm) / (2 * h) - v).cwiseAbs().maxCoeff());
    dv = std::max(dv, ((vp - vm) / (2 * h) - a).cwiseAbs().maxCoeff());
    vmax = std::max(vmax, v.cwiseAbs().maxCoeff());
    amax = std::max(amax, a.cwiseAbs().maxCoeff());
    lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  }
  EXPECT_LE(dq, 1e-6 * vmax);
  EXPECT_LE(dv, 1e-5 * amax);
  for (int j = 0; j < nj; ++j) {
    const std::string& n = model.joint_names[j];
    if (model.effort_limit[j] <= 0.0) {
      EXPECT_EQ(lo[j], 0.0) << n;
      EXPECT_EQ(hi[j], 0.0) << n;
      continue;
    }
    EXPECT_GE(lo[j], model.position_lower[j]) << n;
    EXPECT_LE(hi[j], model.position_upper[j]) << n;
    // Large swings: more than the peak excursion (60 % of the half range; hip abduction 30 %, and outward only,
    // on one side of the start, so that the soles never meet).
    const bool hip_aa = n.find("hip_aa") != std::string::npos;
    const double half = 0.5 * (model.position_upper[j] - model.position_lower[j]);
    EXPECT_GT(hi[j] - lo[j], (hip_aa ? 0.3 : 0.6) * half) << n;
    if (hip_aa) {
      EXPECT_TRUE(lo[j] >= -1e-12 || hi[j] <= 1e-12) << n << " " << lo[j] << " .. " << hi[j];
    }
  }
  // A joint without finite limits cannot be swung within them: a clear error.
  Model bad = model;
  bad.position_upper[1] = INFINITY;
  EXPECT_FALSE(controller::makeLegSwingTrajectory(bad, q0, controller::LegSwingOptions(), tr, &err));
  EXPECT_NE(err.find(model.joint_names[1]), std::string::npos) << err;
}

sim::Scenario quietScenario() {
  sim::Scenario sc;
  sc.name = "calibration_test";
  sc.noise = sim::NoiseMode::Off;
  return sc;
}

// A run of the shipped robot into dir/run.lcmlog.
tools::CalibrationRunOptions runOptions(const test::TempDir& dir, double duration_s) {
  tools::CalibrationRunOptions opt;
  opt.mjcf = test::configPath("exo.xml");
  opt.log_path = dir.file("run.lcmlog");
  opt.duration_s = duration_s;
  return opt;
}

// The log of a noise-free calibration run through the dataset pipeline as a held-base run: the unmeasured rows (base,
// pinned passive ankles) are zero rows, and the measured joint rows satisfy the URDF's equations, K phi = y, to
// the harness's fixed-base approximation (truth pipeline, no filter) and to the state fit's and filter's
// approximation (sensors pipeline as diagnose runs it: 5 Hz, parallel, trimmed).
TEST(CalibrationRun, HeldBaseRowsOfTheLogHoldTheUrdfEquations) {
  const Model model = exoModel();
  test::TempDir dir("calibration_run");
  const tools::CalibrationRunOptions opt = runOptions(dir, 8.0);  // the sines fade in over 3-6 s
  tools::CalibrationRunResult res;
  std::string err;
  ASSERT_TRUE(tools::runCalibration(model, quietScenario(), sim::SensorConfig(), opt, res, &err)) << err;
  EXPECT_EQ(res.ticks, 8000);
  EXPECT_EQ(res.events, 5 * 8000);
  EXPECT_LT(res.base_drift_m, 1e-4);
  EXPECT_LT(res.tracking_rms_rad, 0.01);
  EXPECT_EQ(res.mujoco_warnings, 0);
  for (const intake::LogPipeline pipe : {intake::LogPipeline::Truth, intake::LogPipeline::Sensors}) {
    const bool truth = pipe == intake::LogPipeline::Truth;
    tools::SourceOptions so;
    so.pipeline = pipe;
    so.held_base = true;
    if (!truth) {
      so.dataset.cutoff_hz = 5.0;
      so.dataset.filter = estimator::FilterMode::Parallel;
      so.dataset.trim_edges = true;
    }
    intake::InputStats stats;
    double worst = 0.0, scale = 0.0, unmeasured = 0.0;
    long rows = 0;
    ASSERT_TRUE(tools::streamFileRows(
        opt.log_path, model, so,
        [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
          ++rows;
          for (int r = 0; r < model.nv; ++r) {
            if (!estimator::heldBaseRowMeasured(model, r)) {
              unmeasured = std::max({unmeasured, K.row(r).cwiseAbs().maxCoeff(), std::abs(y[r])});
              continue;
            }
            worst = std::max(worst, std::abs(K.row(r).dot(model.phi) - y[r]));
            scale = std::max(scale, std::abs(y[r]));
          }
        },
        stats, &err))
        << err;
    std::printf("[ calibration ] %s: %ld rows, max |K phi - y| %.2e N m of |y| up to %.1f N m\n",
                truth ? "truth" : "sensors", rows, worst, scale);
    EXPECT_GT(rows, truth ? 7999 : 6500);
    EXPECT_EQ(unmeasured, 0.0);
    EXPECT_GT(scale, 10.0);
    EXPECT_LT(worst, (truth ? 2e-5 : 5e-4) * scale);  // measured 2.1e-6 and 6.9e-5 of the scale
  }
  // Without the held-base flag the same log breaks the equations (the harness's wrench is in the base rows).
  tools::SourceOptions plain;
  plain.pipeline = intake::LogPipeline::Truth;
  intake::InputStats stats;
  double base_err = 0.0;
  ASSERT_TRUE(tools::streamFileRows(
      opt.log_path, model, plain,
      [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
        for (int r = 0; r < 6; ++r) base_err = std::max(base_err, std::abs(K.row(r).dot(model.phi) - y[r]));
      },
      stats, &err))
      << err;
  EXPECT_GT(base_err, 100.0);  // the robot's weight, ~400 N
}

// Feet that reach the plates make the run fail with a message saying what to change.
TEST(CalibrationRun, AFootOnAPlateFailsTheRun) {
  const Model model = exoModel();
  test::TempDir dir("calibration_touch");
  const tools::CalibrationRunOptions opt = runOptions(dir, 2.0);
  sim::Scenario sc = quietScenario();
  sc.harness.enabled = true;
  sc.harness.lift = 0.0;  // the feet start on the plates
  tools::CalibrationRunResult res;
  std::string err;
  EXPECT_FALSE(tools::runCalibration(model, sc, sim::SensorConfig(), opt, res, &err));
  EXPECT_NE(err.find("a foot touched a plate"), std::string::npos) << err;
}

}  // namespace
}  // namespace exoid
