// URDF loader (buildModelFromUrdfString), fixed and floating base, and the algorithms on what it accepts.
// Properties: a rejection is one line; an accepted model is consistent (sizes, tree order, unit axes,
// frames on existing bodies), and the regressor reproduces RNEA (K phi = tau) on it.
#include <cmath>
#include <string>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "fuzz_support.hpp"

namespace {

using exoid::Model;

void checkModel(const Model& m) {
  const size_t nb = static_cast<size_t>(m.nbodies), nj = static_cast<size_t>(m.njoints);
  EXOID_FUZZ_CHECK(m.nbodies >= 0 && m.njoints >= 0, "counts are non-negative");
  EXOID_FUZZ_CHECK(m.nbodies == m.njoints + (m.floating_base ? 1 : 0), "one joint per body except the base");
  EXOID_FUZZ_CHECK(m.nv == m.njoints + (m.floating_base ? 6 : 0), "nv = njoints (+ 6)");
  EXOID_FUZZ_CHECK(m.body_names.size() == nb && m.parent.size() == nb && m.tree_rotation.size() == nb &&
                       m.tree_position.size() == nb && m.joint_axis.size() == nb && m.subtree.size() == nb,
                   "per-body arrays have nbodies entries");
  EXOID_FUZZ_CHECK(m.joint_names.size() == nj && m.joint_body.size() == nj && m.joint_type.size() == nj &&
                       static_cast<size_t>(m.position_lower.size()) == nj &&
                       static_cast<size_t>(m.position_upper.size()) == nj &&
                       static_cast<size_t>(m.effort_limit.size()) == nj,
                   "per-joint arrays have njoints entries");
  EXOID_FUZZ_CHECK(m.phi.size() == m.nparams(), "phi has nparams entries");
  EXOID_FUZZ_CHECK(m.phi.allFinite(), "parameters are finite");
  for (int b = 0; b < m.nbodies; ++b) {
    EXOID_FUZZ_CHECK(m.parent[b] >= -1 && m.parent[b] < b, "parent[b] < b (tree order)");
    EXOID_FUZZ_CHECK(!m.subtree[b].empty() && m.subtree[b].front() == b, "a subtree starts with its body");
    EXOID_FUZZ_CHECK(m.tree_rotation[b].allFinite() && m.tree_position[b].allFinite(), "finite placements");
    const bool base = m.floating_base && b == 0;
    EXOID_FUZZ_CHECK(base ? m.joint_axis[b].isZero() : std::abs(m.joint_axis[b].norm() - 1.0) < 1e-9,
                     "unit joint axes (zero for the base)");
  }
  for (int j = 0; j < m.njoints; ++j)
    EXOID_FUZZ_CHECK(m.joint_body[j] == j + (m.floating_base ? 1 : 0), "joint j moves body j (+1)");
  for (const Model::Frame& f : m.frames)
    EXOID_FUZZ_CHECK(f.body >= -1 && f.body < m.nbodies, "frames sit on existing bodies");
}

// K phi = rnea tau at a generic state, where the numbers are small enough for a relative comparison.
void checkDynamics(const Model& m) {
  if (m.nbodies > 64) return;  // bounded time per input
  exoid::State s = exoid::State::zero(m);
  for (int j = 0; j < m.njoints; ++j) {
    s.q[j] = 0.3 + 0.1 * j;
    s.v[j] = -0.2 + 0.05 * j;
    s.a[j] = 0.7 - 0.1 * j;
  }
  s.base_orientation = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
  s.base_omega << 0.1, -0.2, 0.3;
  s.base_velocity << 0.2, 0.1, -0.1;
  s.base_domega << -0.3, 0.2, 0.1;
  s.base_acceleration << 0.5, -0.4, 0.3;
  exoid::Data data(m);
  exoid::computeJointTorqueRegressor(m, data, s);
  exoid::DynamicsData dyn(m);
  exoid::rnea(m, dyn, s);
  exoid::crba(m, dyn, s);
  exoid::centroidal(m, dyn);
  double scale = m.phi.cwiseAbs().maxCoeff();
  for (int b = 0; b < m.nbodies; ++b) scale = std::max(scale, m.tree_position[b].cwiseAbs().maxCoeff());
  if (!(scale < 1e4)) return;  // huge values: cancellation makes a relative bound meaningless
  const Eigen::VectorXd Kphi = data.K * m.phi;
  const double tol = 1e-9 * (1.0 + (data.K.cwiseAbs() * m.phi.cwiseAbs()).maxCoeff());
  EXOID_FUZZ_CHECK(dyn.tau.size() == m.nv && (Kphi - dyn.tau).cwiseAbs().maxCoeff() <= tol,
                   "regressor times phi equals RNEA");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  for (const bool floating : {false, true}) {
    Model model;
    std::string error;
    if (!exoid::buildModelFromUrdfString(xml, floating, model, &error)) {
      exoid::fuzz::checkOneLine(error, "a rejected URDF gets a one-line error");
      continue;
    }
    EXOID_FUZZ_CHECK(model.floating_base == floating, "base type as asked");
    checkModel(model);
    checkDynamics(model);
  }
  return 0;
}
