// exoid_noise_budget: the residual the sensor noise alone leaves on a clean run, per generalized coordinate
// (docs/diagnose.md, "Expected noise level"). Reads a run log of `exoid experiment` on a scenario whose robot
// equals the URDF (nominal.yaml), builds the sensors-only samples, replaces chosen signals by the ground truth,
// streams them through the dataset pipeline exactly as `exoid diagnose --floating-base` does (parallel
// zero-phase filtering, run ends trimmed) and prints the RMS of y - K phi_URDF: the true parameters, so the
// identification plays no part. An evaluation tool: it reads the ground truth, the diagnosis never does.
//
// usage: exoid_noise_budget LOG CUTOFF_HZ SPEC...   SPEC: letters of the signals taken from the ground truth
//   R IMU orientation, W gyro (and its derivative), A base acceleration, Q joint q/v/a, T joint torques,
//   P base position, F foot wrenches; '-' = every signal from the sensors (the expected level).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "exoid/estimator/dataset.hpp"
#include "args.hpp"
#include "truth_run.hpp"

int main(int argc, char** argv) {
  using namespace exoid;
  if (argc < 4) {
    std::fprintf(stderr, "usage: exoid_noise_budget LOG CUTOFF_HZ SPEC... (see the source's header)\n");
    return 2;
  }
  bench::TruthRun run;
  if (!bench::loadTruthRun(argv[1], run)) return 2;
  const Model& model = run.model;
  const auto& ticks = run.ticks;
  std::string err;
  const int feet[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  estimator::DatasetOptions opt;  // as exoid diagnose --floating-base (tools::streamFileRows's footholds)
  if (!bench::numberArg("exoid_noise_budget", "CUTOFF_HZ", argv[2], 0.0, 1e6, opt.cutoff_hz)) return 2;
  opt.filter = estimator::FilterMode::Parallel;
  opt.trim_edges = true;
  const char* soles[2] = {"right_sole", "left_sole"};
  for (int i = 0; i < 2; ++i) {
    const int f = model.frameIndex(soles[i]);
    estimator::DatasetOptions::Foothold h;
    h.body = model.frames[f].body;
    h.point_in_body = model.frames[f].position;
    h.plate = i;
    opt.footholds.push_back(h);
  }
  std::printf("%-8s", "truth");
  for (int r = 0; r < model.nv; ++r) std::printf(" %8.8s", r < 6 ? "base" : model.joint_names[r - 6].c_str());
  std::printf("   (RMS of y - K phi_URDF, N m / N; %ld ticks, cutoff %s Hz)\n", static_cast<long>(ticks.size()), argv[2]);
  for (int a = 3; a < argc; ++a) {
    const std::string spec = argv[a];
    auto has = [&](char c) { return spec.find(c) != std::string::npos; };
    Eigen::VectorXd ss = Eigen::VectorXd::Zero(model.nv);
    long n = 0;
    estimator::DatasetBuilder b(model, opt, [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
      ss += (y - K * model.phi).cwiseAbs2();
      ++n;
    });
    estimator::MeasuredSample m, tr;
    for (const estimator::AlignedTick& t : ticks) {
      const ForcePlateSample* pl[2] = {t.plate[0], t.plate[1]};
      estimator::measuredFromSensors(model, *t.state, pl, feet, m);
      estimator::measuredFromTruth(model, *t.truth, has('F') ? nullptr : pl, feet, tr);  // F: MuJoCo's contact wrenches
      if (has('F'))
        for (int i = 0; i < 2; ++i) m.contact[i] = tr.contact[i];
      if (has('R')) {  // keep the accelerometer's specific force, with the true orientation
        m.base_acceleration += tr.base_orientation.conjugate() * model.gravity - m.base_orientation.conjugate() * model.gravity;
        m.base_orientation = tr.base_orientation;
      }
      if (has('W')) m.base_omega = tr.base_omega, m.base_domega = tr.base_domega, m.has_base_domega = true;
      if (has('A')) m.base_acceleration = tr.base_acceleration;
      if (has('Q')) m.q = tr.q, m.v = tr.v, m.a = tr.a;
      if (has('T')) m.tau = tr.tau;
      if (has('P')) m.base_position = tr.base_position, m.has_base_position = true;
      if (!b.add(m, &err)) {
        std::fprintf(stderr, "%s\n", err.c_str());
        return 1;
      }
    }
    if (!b.finish(&err)) {
      std::fprintf(stderr, "%s\n", err.c_str());
      return 1;
    }
    std::printf("%-8s", spec.c_str());
    for (int r = 0; r < model.nv; ++r) std::printf(" %8.4f", std::sqrt(ss[r] / std::max(n, 1L)));
    std::printf("\n");
  }
  return 0;
}
