#include "exoid/model/dynamics.hpp"

#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"
#include "spatial.hpp"

namespace exoid {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Spatial inertia of a body about the reference origin, reference coordinates, [angular; linear]: the body's
/// parameters moved rigidly from its frame (R, p) to the reference frame.
Matrix6d spatialInertiaInReference(const Vector10d& phi, const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  return spatialInertia(transformParams(phi, R, p));
}

}  // namespace

DynamicsData::DynamicsData(const Model& model)
    : kin(model),
      composite(model.nbodies, Matrix6d::Zero()),
      wrench(model.nbodies, Vector6d::Zero()),
      M(Eigen::MatrixXd::Zero(model.nv, model.nv)),
      tau(Eigen::VectorXd::Zero(model.nv)),
      momentum_origin(Vector6d::Zero()) {}

void rnea(const Model& model, DynamicsData& out, const State& state) { rnea(model, model.phi, out, state); }

void rnea(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out, const State& state) {
  Data& d = out.kin;
  forwardKinematics(model, d, state);
  for (int b = 0; b < model.nbodies; ++b) {
    const Vector10d phib = phi.segment<kParamsPerBody>(model.bodyParamIndex(b));
    const Eigen::Matrix3d& R = d.R[b];
    const Eigen::Vector3d h = R * phib.segment<3>(1);
    Eigen::Matrix3d Il;
    Il << phib[4], phib[5], phib[6], phib[5], phib[7], phib[8], phib[6], phib[8], phib[9];
    const Eigen::Matrix3d I = R * Il * R.transpose();
    const Eigen::Vector3d& w = d.omega[b];
    const Eigen::Vector3d& dw = d.alpha[b];
    const Eigen::Vector3d& a = d.acc[b];
    // Newton-Euler about the body origin (thesis eq. (2.36)), then moved to the reference origin.
    const Eigen::Vector3d f = phib[0] * a + dw.cross(h) + w.cross(w.cross(h));
    const Eigen::Vector3d n = I * dw + w.cross(I * w) + h.cross(a) + d.p[b].cross(f);
    out.wrench[b] << n, f;
  }
  for (int b = model.nbodies - 1; b > 0; --b)
    if (model.parent[b] >= 0) out.wrench[model.parent[b]] += out.wrench[b];
  if (model.floating_base) out.tau.head<6>() = out.wrench[0];
  for (int j = 0; j < model.njoints; ++j) {
    const int c = model.joint_body[j];
    const Eigen::Vector3d& ax = d.axis[c];
    const double v = state.v[j];
    const int fi = model.frictionParamIndex(j);
    out.tau[model.jointRow(j)] = ax.dot(out.wrench[c].head<3>()) + d.p[c].cross(ax).dot(out.wrench[c].tail<3>()) +
                                 phi[fi] * v + phi[fi + 1] * static_cast<double>((v > 0.0) - (v < 0.0));
  }
}

void crba(const Model& model, DynamicsData& out, const State& state) { crba(model, model.phi, out, state); }

void crba(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out, const State& state) {
  Data& d = out.kin;
  forwardKinematics(model, d, state);
  for (int b = 0; b < model.nbodies; ++b)
    out.composite[b] = spatialInertiaInReference(phi.segment<kParamsPerBody>(model.bodyParamIndex(b)), d.R[b], d.p[b]);
  for (int b = model.nbodies - 1; b > 0; --b)
    if (model.parent[b] >= 0) out.composite[model.parent[b]] += out.composite[b];
  if (model.floating_base) out.M.topLeftCorner<6, 6>() = out.composite[0];
  for (int j = 0; j < model.njoints; ++j) {
    const int c = model.joint_body[j];
    Vector6d S;
    S << d.axis[c], d.p[c].cross(d.axis[c]);
    const Vector6d F = out.composite[c] * S;  // subtree wrench per unit acceleration of joint j
    const int row = model.jointRow(j);
    out.M(row, row) = S.dot(F);
    if (model.floating_base) {
      out.M.block<6, 1>(0, row) = F;
      out.M.block<1, 6>(row, 0) = F.transpose();
    }
    for (int a = model.parent[c]; a >= 0; a = model.parent[a]) {
      const int i = model.jointOfBody(a);
      if (i < 0) break;
      Vector6d Sa;
      Sa << d.axis[a], d.p[a].cross(d.axis[a]);
      const int ri = model.jointRow(i);
      out.M(ri, row) = out.M(row, ri) = Sa.dot(F);
    }
  }
}

void centroidal(const Model& model, DynamicsData& out) { centroidal(model, model.phi, out); }

void centroidal(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out) {
  const Data& d = out.kin;
  out.mass = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  out.momentum_origin.setZero();
  Matrix6d I;  // body spatial inertia about the reference origin
  for (int b = 0; b < model.nbodies; ++b) {
    const Vector10d phib = phi.segment<kParamsPerBody>(model.bodyParamIndex(b));
    out.mass += phib[0];
    first_moment += phib[0] * d.p[b] + d.R[b] * phib.segment<3>(1);
    I = spatialInertiaInReference(phib, d.R[b], d.p[b]);
    Vector6d V;  // spatial velocity at the reference origin
    V << d.omega[b], d.vel[b] - d.omega[b].cross(d.p[b]);
    out.momentum_origin.noalias() += I * V;
  }
  out.com = first_moment / out.mass;
}

}  // namespace exoid
