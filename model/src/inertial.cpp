#include "exoid/model/inertial.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "spatial.hpp"

namespace exoid {

namespace {

Vector10d pack(double m, const Eigen::Vector3d& h, const Eigen::Matrix3d& I) {
  Vector10d phi;
  phi << m, h.x(), h.y(), h.z(), I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2);
  return phi;
}

}  // namespace

Eigen::Matrix3d inertiaTensor(const Vector10d& phi) {
  Eigen::Matrix3d I;
  I << phi[4], phi[5], phi[6], phi[5], phi[7], phi[8], phi[6], phi[8], phi[9];
  return I;
}

Vector10d paramsFromInertial(double m, const Eigen::Vector3d& c, const Eigen::Matrix3d& R,
                             const Eigen::Matrix3d& Ic) {
  const Eigen::Matrix3d I =
      R * Ic * R.transpose() + m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  return pack(m, m * c, I);
}

bool inertialFromParams(const Vector10d& phi, InertialProperties& out) {
  const double m = phi[0];
  if (!(m > 0.0) || !std::isfinite(m)) return false;
  out.mass = m;
  out.com = phi.segment<3>(1) / m;
  out.inertia_com =
      inertiaTensor(phi) - m * (out.com.squaredNorm() * Eigen::Matrix3d::Identity() - out.com * out.com.transpose());
  return true;
}

Vector10d transformParams(const Vector10d& phi, const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  const double m = phi[0];
  const Eigen::Vector3d h = R * phi.segment<3>(1);
  const Eigen::Matrix3d E = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d I = R * inertiaTensor(phi) * R.transpose() + m * (p.squaredNorm() * E - p * p.transpose()) +
                            2.0 * p.dot(h) * E - h * p.transpose() - p * h.transpose();
  return pack(m, h + m * p, I);
}

Eigen::Matrix<double, 6, 6> spatialInertia(const Vector10d& phi) {
  Eigen::Matrix<double, 6, 6> out;
  const Eigen::Matrix3d Sh = skew(phi.segment<3>(1));
  out.topLeftCorner<3, 3>() = inertiaTensor(phi);
  out.topRightCorner<3, 3>() = Sh;
  out.bottomLeftCorner<3, 3>() = Sh.transpose();
  out.bottomRightCorner<3, 3>() = phi[0] * Eigen::Matrix3d::Identity();
  return out;
}

Eigen::Matrix<double, 6, 10> momentumRegressor(const Eigen::Matrix<double, 6, 1>& V) {
  const Eigen::Vector3d w = V.head<3>(), v = V.tail<3>();
  Eigen::Matrix<double, 6, 10> Y = Eigen::Matrix<double, 6, 10>::Zero();
  Y.block<3, 3>(0, 1) = -skew(v);
  Y.block<3, 6>(0, 4) = lmap(w);
  Y.block<3, 1>(3, 0) = v;
  Y.block<3, 3>(3, 1) = skew(w);
  return Y;
}

Eigen::Matrix4d pseudoInertia(const Vector10d& phi) {
  const Eigen::Matrix3d I = inertiaTensor(phi);
  Eigen::Matrix4d J;
  J.topLeftCorner<3, 3>() = 0.5 * I.trace() * Eigen::Matrix3d::Identity() - I;
  J.topRightCorner<3, 1>() = phi.segment<3>(1);
  J.bottomLeftCorner<1, 3>() = phi.segment<3>(1).transpose();
  J(3, 3) = phi[0];
  return J;
}

Vector10d paramsFromPseudoInertia(const Eigen::Matrix4d& Jin) {
  const Eigen::Matrix4d J = 0.5 * (Jin + Jin.transpose());
  const Eigen::Matrix3d S = J.topLeftCorner<3, 3>();
  // Sigma = 0.5 tr(I) E - I  =>  tr(Sigma) = 0.5 tr(I)  =>  I = tr(Sigma) E - Sigma.
  const Eigen::Matrix3d I = S.trace() * Eigen::Matrix3d::Identity() - S;
  return pack(J(3, 3), J.topRightCorner<3, 1>(), I);
}

LinkConsistency checkConsistency(const Vector10d& phi) {
  LinkConsistency out;
  if (!phi.allFinite()) {
    out.min_eigenvalue = std::nan("");
    out.reason = "not finite";
    return out;
  }
  out.min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudoInertia(phi), Eigen::EigenvaluesOnly)
                           .eigenvalues()
                           .minCoeff();
  InertialProperties in;
  if (!inertialFromParams(phi, in)) {
    out.reason = "mass <= 0";
    return out;
  }
  const Eigen::Vector3d l =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(in.inertia_com, Eigen::EigenvaluesOnly).eigenvalues();
  if (!(l.minCoeff() > 0.0)) {
    out.reason = "inertia about the CoM not positive definite";
    return out;
  }
  // Principal moments ascending: the binding triangle inequality is l0 + l1 > l2.
  if (!(l[0] + l[1] > l[2])) {
    out.reason = "triangle inequality";
    return out;
  }
  if (!(out.min_eigenvalue > 0.0)) {
    out.reason = "pseudo-inertia not positive definite";
    return out;
  }
  out.consistent = true;
  return out;
}

std::vector<LinkConsistency> checkConsistency(const Model& model, const Eigen::VectorXd& phi) {
  std::vector<LinkConsistency> out;
  out.reserve(static_cast<size_t>(model.nbodies));
  for (int b = 0; b < model.nbodies; ++b)
    out.push_back(checkConsistency(Vector10d(phi.segment<kParamsPerBody>(model.bodyParamIndex(b)))));
  return out;
}

int countInconsistent(const std::vector<LinkConsistency>& report) {
  int n = 0;
  for (const LinkConsistency& l : report) n += l.consistent ? 0 : 1;
  return n;
}

namespace {

/// U / e^alpha for theta (upper triangular, unit (3,3) entry).
Eigen::Matrix4d unscaledFactor(const Vector10d& t) {
  Eigen::Matrix4d V;
  V << std::exp(t[1]), t[4], t[6], t[7],  //
      0.0, std::exp(t[2]), t[5], t[8],     //
      0.0, 0.0, std::exp(t[3]), t[9],      //
      0.0, 0.0, 0.0, 1.0;
  return V;
}

}  // namespace

Vector10d paramsFromLogCholesky(const Vector10d& theta) {
  const Eigen::Matrix4d V = unscaledFactor(theta);
  return paramsFromPseudoInertia(std::exp(2.0 * theta[0]) * V * V.transpose());
}

bool logCholeskyFromParams(const Vector10d& phi, Vector10d& theta) {
  if (!phi.allFinite()) return false;
  // J = U U^T with U upper triangular: the lower Cholesky factor of the index-reversed J, reversed back.
  const Eigen::Matrix4d J = pseudoInertia(phi);
  const Eigen::Matrix4d Jr = J.reverse();
  Eigen::LLT<Eigen::Matrix4d> llt(Jr);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix4d L = llt.matrixL();
  const Eigen::Matrix4d U = L.reverse();
  if (!(U.diagonal().minCoeff() > 0.0)) return false;
  const double ea = U(3, 3);
  const Eigen::Matrix4d V = U / ea;
  theta << std::log(ea), std::log(V(0, 0)), std::log(V(1, 1)), std::log(V(2, 2)), V(0, 1), V(1, 2), V(0, 2), V(0, 3),
      V(1, 3), V(2, 3);
  return theta.allFinite();
}

Matrix10d logCholeskyJacobian(const Vector10d& theta) {
  const double s = std::exp(theta[0]);
  const Eigen::Matrix4d U = s * unscaledFactor(theta);
  Matrix10d D;
  // dU / dtheta_k: alpha scales all of U; d_i the diagonal entry; s and t one entry each (times e^alpha).
  static const int row[10] = {-1, 0, 1, 2, 0, 1, 0, 0, 1, 2};
  static const int col[10] = {-1, 0, 1, 2, 1, 2, 2, 3, 3, 3};
  for (int k = 0; k < 10; ++k) {
    Eigen::Matrix4d dU = Eigen::Matrix4d::Zero();
    if (k == 0)
      dU = U;
    else if (k <= 3)
      dU(row[k], col[k]) = U(row[k], col[k]);
    else
      dU(row[k], col[k]) = s;
    const Eigen::Matrix4d dJ = dU * U.transpose() + U * dU.transpose();
    D.col(k) = paramsFromPseudoInertia(dJ);
  }
  return D;
}

}  // namespace exoid
