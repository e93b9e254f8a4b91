// exoid_com_trust: is the online estimate's stated CoM uncertainty (com_stddev: the covariance, inflated by the
// residuals' correlation) honest? Replays a run log of `exoid experiment` through OnlineEstimator (library
// defaults) and prints, every PERIOD seconds, the error of the estimate's CoM against the simulated robot's (EXO_TRUTH's
// CoM, payloads included; the estimate's CoM at the true state of the estimate's tick, world axes), and of the
// model's, the stated one-sigma and their ratio, and the correlation time. The ratio's
// RMS over the run near 1 means the trust rule's threshold (controller estimate.trust_sigmas) means what it says.
// Each period also prints the mass change and tau_correction against their sigmas, and how much of the estimate's
// CoM height change from the model each body carries.
// An evaluation tool: it reads the ground truth, the estimator never does.
//
// usage: exoid_com_trust LOG [PERIOD_S [K [URDF [moving]]]]   (K: the trust threshold in sigmas, default 3 on every
// axis, or KXY,KZ for the horizontal axes and the height, e.g. 1,3 as the controller ships; URDF:
// the estimator's prior and the model, default config/exo.urdf, e.g. `exoid model wearer`'s for a wearer run;
// "moving": OnlineEstimatorOptions::base_body_moves, as `exoid experiment` sets it for a wearer)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "args.hpp"
#include "truth_run.hpp"

int main(int argc, char** argv) {
  using namespace exoid;
  if (argc < 2) {
    std::fprintf(stderr, "usage: exoid_com_trust LOG [PERIOD_S [K [URDF [moving]]]] (see the source's header)\n");
    return 2;
  }
  bench::TruthRun run;
  if (!bench::loadTruthRun(argv[1], run, argc > 4 ? argv[4] : nullptr)) return 2;
  const Model& model = run.model;
  double period = 1.0;
  if (argc > 2 && !bench::numberArg("exoid_com_trust", "PERIOD_S", argv[2], 1e-3, 1e6, period)) return 2;
  const BaseParameters base = computeBaseParameters(model);
  estimator::OnlineEstimatorOptions opt;
  opt.base_body_moves = argc > 5 && std::string(argv[5]) == "moving";
  estimator::OnlineEstimator est(model, base, model.phi, opt);
  if (!est.ok()) {
    std::fprintf(stderr, "%s\n", est.error().c_str());
    return 2;
  }
  EstimatorOutputSample out;
  est.sizeOutput(out);
  DynamicsData dd(model);
  State s = State::zero(model);
  auto worldCom = [&](const Eigen::VectorXd& phi) {
    forwardKinematics(model, dd.kin, s);
    centroidal(model, phi, dd);
    return Eigen::Vector3d(s.base_position + s.base_orientation.toRotationMatrix() * dd.com);
  };
  const long first_tick = run.ticks.front().state->tick;
  double sum_z2[3] = {0, 0, 0}, sum_e2[3] = {0, 0, 0}, z_max[3] = {0, 0, 0}, leak2[3] = {0, 0, 0};
  long over3[3] = {0, 0, 0};
  double k_axis[3] = {3.0, 3.0, 3.0};  // KXY,KZ or one K for all (controller estimate.trust_sigmas[_horizontal_com])
  if (argc > 3) {
    const std::string a = argv[3];
    const size_t comma = a.find(',');
    if (!bench::numberArg("exoid_com_trust", "K", std::string_view(a).substr(0, comma), 0.0, 1e6, k_axis[0]))
      return 2;
    k_axis[1] = k_axis[2] = k_axis[0];
    if (comma != std::string::npos &&
        !bench::numberArg("exoid_com_trust", "KZ", std::string_view(a).substr(comma + 1), 0.0, 1e6, k_axis[2]))
      return 2;
  }
  long n = 0, printed = -1;
  for (const auto& t : run.ticks) {
    est.addState(*t.state);
    est.addPlate(*t.plate[0]);
    est.addPlate(*t.plate[1]);
    if (est.samplesSincePublication() < 10) continue;
    est.fillOutput(out);
    if (est.reconcileDue()) est.reconcile(out);  // exo_estimator's consistent parameters (synchronously here)
    if (!out.valid || out.com_stddev.maxCoeff() <= 0.0) continue;  // the controller takes valid ones only
    const long at = static_cast<long>(out.tick) - first_tick;  // the truth of the estimate's tick
    if (at < 0 || at >= static_cast<long>(run.ticks.size()) || run.ticks[at].truth->tick != out.tick) continue;
    const GroundTruthSample& tr = *run.ticks[at].truth;
    s.q = tr.q;
    s.base_orientation = tr.base_orientation;
    s.base_position = tr.base_position;
    const Eigen::Vector3d e = 1e3 * (worldCom(out.params) - tr.com), e0 = 1e3 * (worldCom(model.phi) - tr.com);
    const Eigen::Vector3d sd = 1e3 * out.com_stddev;
    for (int i = 0; i < 3; ++i) {
      sum_z2[i] += (e[i] / sd[i]) * (e[i] / sd[i]);
      sum_e2[i] += e[i] * e[i];
      const double z = std::abs(e[i] / sd[i]);
      z_max[i] = std::max(z_max[i], z);
      const double k = k_axis[i];
      if (z > k) ++over3[i];
      const double w = z > k ? 1.0 - (k / z) * (k / z) : 0.0;  // the trust rule's weight
      leak2[i] += (w * e[i]) * (w * e[i]);
    }
    ++n;
    const long slot = static_cast<long>(1e-3 * static_cast<double>(out.tick) / period);
    if (slot != printed) {
      printed = slot;
      std::printf("t %6.2f s  model %7.2f %7.2f %7.2f  error %7.3f %7.3f %7.3f mm  sigma %7.3f %7.3f %7.3f mm  "
                  "z %6.2f %6.2f %6.2f  T %.0f\n",
                  1e-3 * static_cast<double>(out.tick), e0.x(), e0.y(), e0.z(), e.x(), e.y(), e.z(), sd.x(), sd.y(),
                  sd.z(), e.x() / sd.x(), e.y() / sd.y(), e.z() / sd.z(), est.residualCorrelation());
      double mass_change = 0.0;
      for (int b = 0; b < model.nbodies; ++b)
        mass_change += out.params[model.bodyParamIndex(b)] - model.phi[model.bodyParamIndex(b)];
      std::printf("          mass change %.3f kg (sigma %.4f); tau_correction / sigma:", mass_change, out.mass_stddev);
      for (int r = 0; r < model.nv; ++r) std::printf(" %.2f/%.3f", out.tau_correction[r], out.tau_correction_stddev[r]);
      std::printf("\n");
      {  // where the height error sits: per body (m z_com)_estimate - (m z_com)_model, world, over the model's mass

        forwardKinematics(model, dd.kin, s);
        const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
        double M = 0.0;
        for (int b = 0; b < model.nbodies; ++b) M += model.phi[model.bodyParamIndex(b)];
        std::printf("          CoM height change per body, mm:");
        for (int b = 0; b < model.nbodies; ++b) {
          auto h = [&](const Eigen::VectorXd& phi) {
            const int i = model.bodyParamIndex(b);
            const Eigen::Vector3d mc(phi[i + 1], phi[i + 2], phi[i + 3]);
            return (R * (dd.kin.p[b] * phi[i] + dd.kin.R[b] * mc)).z();
          };
          std::printf(" %s %.2f", model.body_names[b].c_str(), 1e3 * (h(out.params) - h(model.phi)) / M);
        }
        std::printf("\n");
      }
    }
  }
  if (n > 0)
    std::printf("k %.1f %.1f %.1f: max |z| %.2f %.2f %.2f, publications over k %ld %ld %ld, RMS of the error let "
                "through %.3f %.3f %.3f mm\n",
                k_axis[0], k_axis[1], k_axis[2], z_max[0], z_max[1], z_max[2], over3[0], over3[1], over3[2],
                std::sqrt(leak2[0] / n), std::sqrt(leak2[1] / n), std::sqrt(leak2[2] / n));
  if (n > 0)
    std::printf("over %ld publications: RMS error %.3f %.3f %.3f mm, RMS z %.2f %.2f %.2f\n", n,
                std::sqrt(sum_e2[0] / n), std::sqrt(sum_e2[1] / n), std::sqrt(sum_e2[2] / n), std::sqrt(sum_z2[0] / n),
                std::sqrt(sum_z2[1] / n), std::sqrt(sum_z2[2] / n));
  return 0;
}
