// exoid_com_budget: how far the online estimate's CoM is from the simulated robot's, and which sensor's noise puts
// it there (docs/estimator.md, "Filter"). Replays a run log of `exoid experiment` through OnlineEstimator (the
// library defaults, the given filter), with chosen sensor signals replaced by the ground truth, and prints the
// CoM error of the final estimate (and of its consistent parameters) at the run's mean posture, base frame. An
// evaluation tool: it reads the ground truth, the estimator never does.
//
// usage: exoid_com_budget LOG TRUE_URDF CUTOFF_HZ ORDER HALF_WINDOW SPEC...
//   LOG        run log (EXO_TRUTH included); the prior and tau_correction model is config/exo.urdf
//   TRUE_URDF  the simulated robot (config/exo.urdf plus the scenario's payloads)
//   CUTOFF_HZ ORDER HALF_WINDOW  the row filter and the state fit (OnlineEstimatorOptions: cutoff_hz, filter_order,
//              derivative_half_window; 1 = central differences;
//              L:G sets the gyro's gyro_half_window to G; with "gyro" in it (e.g. 20:20:gyro) the base's
//              angular rate comes from the gyro, else from the legs (base_rate_from_legs))
//   SPEC       letters of the signals taken from the ground truth: R IMU orientation, W gyro, A accelerometer,
//              Q encoders, T joint torques, F plates; '-' = all from the sensors; a 't' adds the error every 3 s
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "args.hpp"
#include "truth_run.hpp"

int main(int argc, char** argv) {
  using namespace exoid;
  if (argc < 7) {
    std::fprintf(stderr, "usage: exoid_com_budget LOG TRUE_URDF CUTOFF_HZ ORDER HALF_WINDOW SPEC... (see the source's header)\n");
    return 2;
  }
  bench::TruthRun run;
  if (!bench::loadTruthRun(argv[1], run)) return 2;
  const Model& model = run.model;
  const auto& ticks = run.ticks;
  Model truth_model;
  std::string err;
  if (!buildModelFromUrdfFile(argv[2], true, truth_model, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    return 2;
  }
  const BaseParameters base = computeBaseParameters(model);
  // The run's mean posture (true joint angles), base frame.
  State mean = State::zero(model);
  for (const auto& t : ticks) mean.q += t.truth->q / static_cast<double>(ticks.size());
  DynamicsData dd(model);
  forwardKinematics(model, dd.kin, mean);
  centroidal(model, truth_model.phi, dd);
  const Eigen::Vector3d c_true = dd.com;
  const double m_true = dd.mass;
  auto error = [&](const Eigen::VectorXd& phi) {
    centroidal(model, phi, dd);
    return Eigen::Vector3d(1e3 * (dd.com - c_true));
  };
  const Eigen::Vector3d e0 = error(model.phi);
  std::printf("robot: mass %.3f kg, CoM %.4f %.4f %.4f m (base frame, mean posture); the model's CoM error %.2f %.2f "
              "%.2f mm\n", m_true, c_true.x(), c_true.y(), c_true.z(), e0.x(), e0.y(), e0.z());
  for (int a = 6; a < argc; ++a) {
    const std::string spec = argv[a];
    auto has = [&](char c) { return spec.find(c) != std::string::npos; };
    estimator::OnlineEstimatorOptions opt;
    // HALF_WINDOW: L, L:G or L:G:gyro (the header).
    const std::string_view hw = argv[5];
    const size_t c1 = hw.find(':'), c2 = c1 == std::string_view::npos ? c1 : hw.find(':', c1 + 1);
    const char* prog = "exoid_com_budget";
    if (!bench::numberArg(prog, "CUTOFF_HZ", argv[3], 0.0, 1e6, opt.cutoff_hz) ||
        !bench::integerArg(prog, "ORDER", argv[4], 1, 8, opt.filter_order) ||
        !bench::integerArg(prog, "HALF_WINDOW", hw.substr(0, c1), 0, 100000, opt.derivative_half_window))
      return 2;
    opt.gyro_half_window = opt.derivative_half_window;
    if (c1 != std::string_view::npos &&
        !bench::integerArg(prog, "HALF_WINDOW's gyro part", hw.substr(c1 + 1, c2 == std::string_view::npos ? c2 : c2 - c1 - 1),
                           0, 100000, opt.gyro_half_window))
      return 2;
    opt.base_rate_from_legs = !(c2 != std::string_view::npos && hw.substr(c2 + 1) == "gyro");
    estimator::OnlineEstimator est(model, base, model.phi, opt);
    if (!est.ok()) {
      std::fprintf(stderr, "%s\n", est.error().c_str());
      return 2;
    }
    EstimatorOutputSample out;
    est.sizeOutput(out);
    long publications = 0;
    for (const auto& t : ticks) {
      RobotStateSample s = *t.state;
      ForcePlateSample p[2] = {*t.plate[0], *t.plate[1]};
      const GroundTruthSample& tr = *t.truth;
      if (has('R')) s.imu_orientation = tr.base_orientation;
      if (has('W')) s.imu_gyro = tr.base_omega;
      if (has('A')) s.imu_accel = tr.base_acceleration - tr.base_orientation.conjugate() * model.gravity;
      if (has('Q')) s.q = tr.q;
      if (has('T'))
        for (int j = 0; j < model.njoints; ++j)
          if (s.has_tau[j]) s.tau[j] = tr.tau_applied[j];
      if (has('F'))
        for (int i = 0; i < 2; ++i) {  // the plate's reading of MuJoCo's contact wrench (footWrenchFromPlate inverted)
          const Eigen::Matrix3d R = p[i].plate_orientation.toRotationMatrix();
          p[i].force = -(R.transpose() * tr.foot_force[i]);
          p[i].moment = R.transpose() * (p[i].plate_position.cross(tr.foot_force[i]) - tr.foot_moment[i]);
        }
      est.addState(s);
      est.addPlate(p[0]);
      est.addPlate(p[1]);
      if (est.samplesSincePublication() >= 10) {  // like exo_estimator at 100 Hz
        est.fillOutput(out);
        if (has('t') && ++publications % 300 == 0) {
          const Eigen::Vector3d e = error(out.params);
          std::printf("  t %5.1f s: CoM error %7.2f %7.2f %7.2f mm\n", 1e-3 * static_cast<double>(t.state->tick), e.x(), e.y(), e.z());
        }
      }
    }
    est.fillOutput(out);
    const Eigen::Vector3d e1 = error(out.params);
    est.reconcile(out);
    const Eigen::Vector3d e2 = error(out.params);
    std::printf("%-8s CoM error %7.2f %7.2f %7.2f mm (consistent parameters %7.2f %7.2f %7.2f)\n", spec.c_str(), e1.x(),
                e1.y(), e1.z(), e2.x(), e2.y(), e2.z());
    std::fflush(stdout);
  }
  return 0;
}
