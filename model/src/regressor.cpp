#include "exoid/model/regressor.hpp"

#include "exoid/model/kinematics.hpp"
#include "spatial.hpp"

namespace exoid {

namespace {

/// Body regressor about the reference origin, reference coordinates (thesis eq. (11) moved by eq. (14)):
///   m   : [p x acc; acc]
///   h   : [S(p) B - S(acc); B] R,   B = S(alpha) + S(omega)^2        (h = m c in body coordinates)
///   I   : [R (L(alpha_b) + S(omega_b) L(omega_b)); 0]               (alpha_b, omega_b body coordinates)
void bodyRegressor(const Eigen::Matrix3d& R, const Eigen::Vector3d& p, const Eigen::Vector3d& w,
                   const Eigen::Vector3d& dw, const Eigen::Vector3d& acc, Matrix6x10& Y) {
  Y.block<3, 1>(0, 0) = p.cross(acc);
  Y.block<3, 1>(3, 0) = acc;
  const Eigen::Matrix3d Sw = skew(w);
  const Eigen::Matrix3d B = skew(dw) + Sw * Sw;
  Eigen::Matrix<double, 6, 3> H;
  H.topRows<3>().noalias() = skew(p) * B;
  H.topRows<3>() -= skew(acc);
  H.bottomRows<3>() = B;
  Y.block<6, 3>(0, 1).noalias() = H * R;
  const Eigen::Vector3d wb = R.transpose() * w;
  const Eigen::Vector3d dwb = R.transpose() * dw;
  Eigen::Matrix<double, 3, 6> N = lmap(dwb);
  const Eigen::Matrix<double, 3, 6> Lw = lmap(wb);
  for (int k = 0; k < 6; ++k) N.col(k) += wb.cross(Lw.col(k));
  Y.block<3, 6>(0, 4).noalias() = R * N;
  // Y.block<3, 6>(3, 4) is structurally zero (set at construction).
}

}  // namespace

void computeJointTorqueRegressor(const Model& model, Data& d, const State& s) {
  forwardKinematics(model, d, s);
  const int free_joint_rows = model.floating_base ? 6 : 0;
  for (int b = 0; b < model.nbodies; ++b) {
    Matrix6x10& Y = d.body_regressor[b];
    bodyRegressor(d.R[b], d.p[b], d.omega[b], d.alpha[b], d.acc[b], Y);
    const int col = model.bodyParamIndex(b);
    if (model.floating_base) d.K.block<6, 10>(0, col) = Y;
  }
  // Joint rows: torque of joint j = S_j^T (wrench of every body in its subtree about the reference origin).
  for (int j = 0; j < model.njoints; ++j) {
    const int c = model.joint_body[j];
    const int row = free_joint_rows + j;
    const Eigen::Vector3d& ax = d.axis[c];
    const Eigen::Vector3d pxa = d.p[c].cross(ax);
    for (int b : model.subtree[c]) {
      const Matrix6x10& Y = d.body_regressor[b];
      const int col = model.bodyParamIndex(b);
      d.K.block<1, 4>(row, col).noalias() =
          ax.transpose() * Y.block<3, 4>(0, 0) + pxa.transpose() * Y.block<3, 4>(3, 0);
      d.K.block<1, 6>(row, col + 4).noalias() = ax.transpose() * Y.block<3, 6>(0, 4);
    }
    const double v = s.v[j];
    const int f = model.frictionParamIndex(j);
    d.K(row, f) = v;
    d.K(row, f + 1) = static_cast<double>((v > 0.0) - (v < 0.0));
  }
}

}  // namespace exoid
