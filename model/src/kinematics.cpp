#include "exoid/model/kinematics.hpp"

#include "spatial.hpp"

namespace exoid {

namespace {

/// One forward pass. drift = true: accelerations and gravity set to zero (velocity-product terms only).
void forwardPass(const Model& model, Data& d, const State& s, bool drift) {
  const double ka = drift ? 0.0 : 1.0;
  for (int b = 0; b < model.nbodies; ++b) {
    const int parent = model.parent[b];
    const int j = model.jointOfBody(b);
    if (j < 0) {  // floating base: the reference frame itself
      d.R[b].setIdentity();
      d.p[b].setZero();
      d.axis[b].setZero();
      d.omega[b] = s.base_omega;
      d.vel[b] = s.base_velocity;
      d.alpha[b] = ka * s.base_domega;
      d.acc[b] = ka * (s.base_acceleration - s.base_orientation.conjugate() * model.gravity);
      continue;
    }
    const double q = s.q[j], v = s.v[j], a = ka * s.a[j];
    const Eigen::Matrix3d joint_rotation =
        Eigen::AngleAxisd(q, model.joint_axis[b]).toRotationMatrix();
    if (parent < 0) {  // child of the fixed root: the root does not move, gravity is its acceleration
      d.R[b].noalias() = model.tree_rotation[b] * joint_rotation;
      d.p[b] = model.tree_position[b];
      d.axis[b].noalias() = d.R[b] * model.joint_axis[b];
      d.omega[b] = d.axis[b] * v;
      d.vel[b].setZero();
      d.alpha[b] = d.axis[b] * a;
      d.acc[b] = -ka * model.gravity;
      continue;
    }
    const Eigen::Matrix3d Rp = d.R[parent] * model.tree_rotation[b];
    d.R[b].noalias() = Rp * joint_rotation;
    const Eigen::Vector3d r = d.R[parent] * model.tree_position[b];  // parent origin -> body origin
    d.p[b] = d.p[parent] + r;
    d.axis[b].noalias() = Rp * model.joint_axis[b];
    const Eigen::Vector3d& wp = d.omega[parent];
    const Eigen::Vector3d w_rel = d.axis[b] * v;
    d.omega[b] = wp + w_rel;
    d.vel[b] = d.vel[parent] + wp.cross(r);
    d.alpha[b] = d.alpha[parent] + d.axis[b] * a + wp.cross(w_rel);
    d.acc[b] = d.acc[parent] + d.alpha[parent].cross(r) + wp.cross(wp.cross(r));
  }
}

}  // namespace

void forwardKinematics(const Model& model, Data& d, const State& s) { forwardPass(model, d, s, false); }
void forwardKinematicsDrift(const Model& model, Data& d, const State& s) { forwardPass(model, d, s, true); }

void computePointJacobian(const Model& model, const Data& kin, int body, const Eigen::Vector3d& point_in_body,
                          Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J) {
  J.setZero();
  const Eigen::Vector3d P = kin.p[body] + kin.R[body] * point_in_body;
  if (model.floating_base) {
    J.block<3, 3>(0, 0).setIdentity();
    J.block<3, 3>(3, 0) = -skew(P);
    J.block<3, 3>(3, 3).setIdentity();
  }
  for (int a = body; a >= 0; a = model.parent[a]) {
    const int i = model.jointOfBody(a);
    if (i < 0) break;
    const int col = model.jointRow(i);
    J.block<3, 1>(0, col) = kin.axis[a];
    J.block<3, 1>(3, col) = kin.axis[a].cross(P - kin.p[a]);
  }
}

Eigen::Matrix<double, 6, 1> pointAccelerationDrift(const Data& kin, int body, const Eigen::Vector3d& point_in_body) {
  const Eigen::Vector3d r = kin.R[body] * point_in_body;
  const Eigen::Vector3d& w = kin.omega[body];
  Eigen::Matrix<double, 6, 1> out;
  out << kin.alpha[body], kin.acc[body] + kin.alpha[body].cross(r) + w.cross(w.cross(r));
  return out;
}

}  // namespace exoid
