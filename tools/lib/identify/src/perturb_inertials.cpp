#include "exoid/tools/perturb_inertials.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <random>

#include "exoid/model/inertial.hpp"

namespace exoid::tools {

bool perturbInertials(const Model& model, double relative, uint64_t seed, Eigen::VectorXd& phi, std::string* error) {
  if (!(relative >= 0.0 && relative <= 0.9)) {
    if (error) *error = "relative perturbation must be in [0, 0.9]";
    return false;
  }
  std::mt19937_64 rng(seed);
  const auto u = [&]() {  // uniform in [-relative, relative]
    const double unit = static_cast<double>(rng() >> 11) * 0x1.0p-53;
    return relative * (2.0 * unit - 1.0);
  };
  phi = model.phi;
  for (int b = 0; b < model.nbodies; ++b) {
    const Vector10d nominal = model.phi.segment<kParamsPerBody>(model.bodyParamIndex(b));
    if (!(nominal[0] > 0.0)) continue;  // a massless body (lumped elsewhere) stays massless
    InertialProperties in;
    if (!inertialFromParams(nominal, in) || !checkConsistency(nominal).consistent) {
      if (error) *error = "body '" + model.body_names[static_cast<size_t>(b)] + "': nominal parameters not consistent";
      return false;
    }
    const double mass = in.mass * (1.0 + u());
    Eigen::Vector3d com = in.com;
    for (int i = 0; i < 3; ++i) com[i] *= 1.0 + u();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(in.inertia_com);
    Eigen::Vector3d l;
    for (int attempt = 0;; ++attempt) {
      for (int k = 0; k < 3; ++k) l[k] = es.eigenvalues()[k] * (1.0 + u());
      // Ascending nominal moments; the binding triangle inequality after scaling is on the sorted values.
      Eigen::Vector3d s = l;
      std::sort(s.data(), s.data() + 3);
      if (s[0] + s[1] > s[2] * (1.0 + 1e-9)) break;
      if (attempt == 1000) {  // a degenerate body (a rod): scale its moments together instead
        l = es.eigenvalues() * (1.0 + u());
        break;
      }
    }
    const Eigen::Matrix3d V = es.eigenvectors();
    phi.segment<kParamsPerBody>(model.bodyParamIndex(b)) =
        paramsFromInertial(mass, com, Eigen::Matrix3d::Identity(), V * l.asDiagonal() * V.transpose());
  }
  return true;
}

}  // namespace exoid::tools
