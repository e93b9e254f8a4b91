#pragma once
// The inertial-parameter maths of one rigid body, written once: the standard parameters
//   phi = [m, mcx, mcy, mcz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz]      (docs/conventions.md, thesis eq. (7))
// (mass, first moments m c, inertia tensor about the LINK ORIGIN in link coordinates, tensor convention)
// <-> mass, centre of mass and inertia about the CoM; moving parameters between frames; the spatial inertia;
// the 4x4 pseudo-inertia matrix and its positive definiteness (physical consistency, Wensing, Kim and
// Slotine, RA-L 2018); and the log-Cholesky parametrisation of the pseudo-inertia (Rucker and Wensing,
// "Smooth parameterization of rigid-body inertia", RA-L 2022) with its Jacobian.
// All functions are fixed-size and allocation-free except the Model-level consistency report.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"

namespace exoid {

using Matrix10d = Eigen::Matrix<double, 10, 10>;

/// Inertia tensor about the link origin (link coordinates) from phi[4..9].
Eigen::Matrix3d inertiaTensor(const Vector10d& phi);

/// Mass, centre of mass (link coordinates) and inertia tensor about the centre of mass (link axes).
struct InertialProperties {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia_com = Eigen::Matrix3d::Zero();
};

/// Standard parameters about a link origin (link coordinates) from a URDF/MJCF-style inertial: mass, centre of
/// mass c, and inertia tensor about the centre of mass in a frame rotated by R_inertial from the link frame.
/// Parallel-axis theorem: I_origin = R Ic R^T + m (|c|^2 E - c c^T).
Vector10d paramsFromInertial(double mass, const Eigen::Vector3d& com, const Eigen::Matrix3d& R_inertial,
                             const Eigen::Matrix3d& inertia_com);

/// The inverse of paramsFromInertial (R_inertial = identity). False when mass <= 0 or not finite: the centre
/// of mass is then undefined and `out` is left unchanged.
bool inertialFromParams(const Vector10d& phi, InertialProperties& out);

/// Parameters of a body moved rigidly into the frame of another: the body's frame sits at (R, p) in the new
/// frame (x_new = R x_body + p). Inverse: transformParams(phi, R^T, -R^T p).
///   I'_o = R I_o R^T + m(|p|^2 E - p p^T) + 2 (p . Rh) E - (Rh) p^T - p (Rh)^T,  h' = Rh + m p.
Vector10d transformParams(const Vector10d& phi, const Eigen::Matrix3d& R, const Eigen::Vector3d& p);

/// 6x6 spatial inertia about the frame origin, [angular; linear] ordering: [I_o, S(h); S(h)^T, m E].
/// Linear in phi; positive semi-definite for a consistent body.
Eigen::Matrix<double, 6, 6> spatialInertia(const Vector10d& phi);

/// Spatial momentum [angular about the frame origin; linear] of a body moving with V = [omega; velocity of
/// the frame origin] (frame coordinates) as a linear map of its parameters:
///   momentumRegressor(V) phi = spatialInertia(phi) V = [I_o omega + h x v; m v + omega x h].
Eigen::Matrix<double, 6, 10> momentumRegressor(const Eigen::Matrix<double, 6, 1>& V);

/// 4x4 pseudo-inertia J = [Sigma, h; h^T, m] with Sigma = integral(r r^T dm) = 0.5 tr(I_o) E - I_o.
/// Linear in phi. J is positive definite iff some positive mass density realises phi (physical consistency:
/// m > 0, I_com positive definite, triangle inequalities of the principal moments).
Eigen::Matrix4d pseudoInertia(const Vector10d& phi);

/// The inverse of pseudoInertia (uses the symmetric part of J).
Vector10d paramsFromPseudoInertia(const Eigen::Matrix4d& J);

/// Physical-consistency verdict of one body.
struct LinkConsistency {
  bool consistent = false;        ///< pseudo-inertia positive definite (smallest eigenvalue > 0)
  double min_eigenvalue = 0.0;    ///< smallest eigenvalue of the pseudo-inertia, kg m^2 (kg for a point mass)
  const char* reason = "";        ///< first violated condition: "mass <= 0", "inertia about the CoM not
                                  ///< positive definite", "triangle inequality", "pseudo-inertia not positive
                                  ///< definite"; "" when consistent
};

/// Verdict for one body's parameters.
LinkConsistency checkConsistency(const Vector10d& phi);

/// Verdict per moving body of the model for the parameter vector phi [nparams] (friction entries ignored).
std::vector<LinkConsistency> checkConsistency(const Model& model, const Eigen::VectorXd& phi);

/// Number of inconsistent bodies in a report.
int countInconsistent(const std::vector<LinkConsistency>& report);

// ---- log-Cholesky parametrisation (Rucker & Wensing 2022) -------------------------------------------------
// theta = [alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3] and
//   U = e^alpha [e^d1 s12 s13 t1; 0 e^d2 s23 t2; 0 0 e^d3 t3; 0 0 0 1],   J = U U^T.
// Every theta in R^10 gives a positive definite J (a consistent body) and every consistent body has exactly
// one theta: the constraint disappears, so unconstrained Gauss-Newton / Levenberg-Marquardt stays consistent.
// m = e^(2 alpha), c = t (the centre of mass), log det J = 8 alpha + 2 (d1 + d2 + d3).

/// Parameters of a log-Cholesky point.
Vector10d paramsFromLogCholesky(const Vector10d& theta);

/// The log-Cholesky coordinates of a consistent body. False (theta unchanged) when the pseudo-inertia is not
/// positive definite.
bool logCholeskyFromParams(const Vector10d& phi, Vector10d& theta);

/// Jacobian d phi / d theta [10 x 10] at theta (exact, from dJ = dU U^T + U dU^T).
Matrix10d logCholeskyJacobian(const Vector10d& theta);

}  // namespace exoid
