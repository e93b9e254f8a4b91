#pragma once
// Small 3-D helpers shared by the model algorithms (internal header).
#include <Eigen/Core>

namespace exoid {

/// Skew-symmetric matrix: skew(x) y = x cross y (thesis eq. (12)).
inline Eigen::Matrix3d skew(const Eigen::Vector3d& x) {
  Eigen::Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}

/// L(x) of thesis eq. (13): L(x) [Ixx Ixy Ixz Iyy Iyz Izz]^T = I x for the symmetric tensor I.
inline Eigen::Matrix<double, 3, 6> lmap(const Eigen::Vector3d& x) {
  Eigen::Matrix<double, 3, 6> L;
  L << x.x(), x.y(), x.z(), 0.0, 0.0, 0.0,
       0.0, x.x(), 0.0, x.y(), x.z(), 0.0,
       0.0, 0.0, x.x(), 0.0, x.y(), x.z();
  return L;
}

}  // namespace exoid
