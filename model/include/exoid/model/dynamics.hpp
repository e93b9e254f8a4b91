#pragma once
// Rigid-body dynamics on the same forward pass as the regressor. Generalized velocity (floating base):
//   nu = [omega_b; v_b; dq]  (base angular and linear velocity of the base origin, base coordinates),
// and its "acceleration" dnu = [domega_b; a_b; ddq] with a_b the CLASSICAL acceleration of the base origin
// in base coordinates (State::base_acceleration), exactly as the regressor takes it. With this choice
//   M(q) dnu + h(q, nu) = K(q, nu, dnu) phi        (generalized forces, same rows as K)
// and Galilean invariance makes h independent of v_b. Fixed base: nu = dq.
#include "exoid/model/model.hpp"

namespace exoid {

/// Scratch for the dynamics algorithms (one per thread, sized once).
struct DynamicsData {
  explicit DynamicsData(const Model& model);
  Data kin;                                 ///< forward-pass scratch (positions, velocities, accelerations)
  AlignedVector<Eigen::Matrix<double, 6, 6>> composite;  ///< [nbodies] composite spatial inertia about the
                                                          ///< reference origin, [angular; linear] ordering
  AlignedVector<Eigen::Matrix<double, 6, 1>> wrench;     ///< [nbodies] subtree wrench about the reference origin
  Eigen::MatrixXd M;    ///< [nv x nv] joint-space inertia matrix (crba)
  Eigen::VectorXd tau;  ///< [nv] generalized force (rnea)
  double mass = 0.0;                          ///< total mass (centroidal)
  Eigen::Vector3d com = Eigen::Vector3d::Zero();         ///< CoM, reference coordinates (centroidal)
  Eigen::Matrix<double, 6, 1> momentum_origin;          ///< [angular; linear] momentum about the reference origin
};

/// Inverse dynamics by the recursive Newton-Euler algorithm: out.tau = M dnu + h (+ friction from phi),
/// using the model's parameters. Allocation-free.
void rnea(const Model& model, DynamicsData& out, const State& state);

/// Inverse dynamics for an arbitrary parameter vector phi [nparams] (e.g. an estimate).
void rnea(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out, const State& state);

/// Joint-space inertia matrix M(q) by the composite rigid body algorithm: out.M (full, symmetric).
/// Uses state.q and state.base_orientation only. Allocation-free.
void crba(const Model& model, DynamicsData& out, const State& state);

/// The same for an arbitrary parameter vector phi [nparams] (e.g. an estimate; friction entries unused).
void crba(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out, const State& state);

/// Mass, centre of mass and total spatial momentum about the reference origin (reference coordinates).
/// Requires forwardKinematics on out.kin. Allocation-free.
void centroidal(const Model& model, DynamicsData& out);

/// The same for an arbitrary parameter vector phi [nparams] (e.g. an estimate, for the CoM and momentum
/// metrics). out.com is first moment / mass and is not finite when the total mass of phi is 0.
void centroidal(const Model& model, const Eigen::VectorXd& phi, DynamicsData& out);

}  // namespace exoid
