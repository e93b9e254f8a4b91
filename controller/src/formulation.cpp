#include "exoid/controller/formulation.hpp"

namespace exoid::controller {

BalanceFormulation::BalanceFormulation(const Model& model, const ContactConfig& contact, const TorqueConfig& torque)
    : nv_(model.nv),
      force_weight_(contact.force_weight),
      range_tolerance_(contact.range_tolerance),
      gravity_(model.gravity),
      Jc_(Eigen::Matrix<double, 12, Eigen::Dynamic>::Zero(12, model.nv)),
      UJc_(Eigen::Matrix<double, 12, Eigen::Dynamic>::Zero(12, model.nv)) {
  const int free_joint_rows = model.floating_base ? 6 : 0;  // the floating base's six rows
  for (int r = 0; r < free_joint_rows; ++r) unactuated_.push_back(r);
  std::vector<double> limits;
  for (int j = 0; j < model.njoints; ++j) {
    const double effort = model.effort_limit[j];
    if (effort > 0.0) {
      actuated_.push_back(model.jointRow(j));
      limits.push_back(effort * torque.limit_scale);
    } else {
      unactuated_.push_back(model.jointRow(j));
    }
  }
  tau_max_ = Eigen::Map<const Eigen::VectorXd>(limits.data(), static_cast<Eigen::Index>(limits.size()));
}

void BalanceFormulation::build(const RobotDynamicsData& dyn, const LinearAngular6d& rate_desired, const LinearAngular6d& w_mom,
                               const Eigen::VectorXd& dnu_desired, const Eigen::VectorXd& dnu_weights,
                               const ContactSixD& right, const ContactSixD& left, QpProblem& qp) {
  buildCost(dyn, rate_desired, w_mom, dnu_desired, dnu_weights, qp);
  const int nu_rows = buildUnactuatedDynamics(dyn, qp);
  buildStationarySoles(dyn, right, left, nu_rows, qp);
  buildContactWrenchLimits(right, left, qp);
  buildTorqueLimits(dyn, qp);
}

void BalanceFormulation::buildCost(const RobotDynamicsData& dyn, const LinearAngular6d& rate_desired, const LinearAngular6d& w_mom,
                                   const Eigen::VectorXd& dnu_desired, const Eigen::VectorXd& dnu_weights,
                                   QpProblem& qp) {
  const int nv = nv_;
  qp.H.setZero();
  qp.H.topLeftCorner(nv, nv).diagonal() = dnu_weights;
  qp.g.head(nv) = -dnu_weights.cwiseProduct(dnu_desired);
  MomentumTask::wrenchMap(dyn, Af_);
  // Newton-Euler about the controller's CoM c (the model's, or the estimate's): the gravity of h acts at the
  // model's CoM, the correction's base rows [moment; force] (base coordinates, about the base origin) are an
  // external wrench -tau_correction on the robot (with an estimate: the payload's weight). The contact wrenches must
  // produce the desired rate against both (else the dynamics could absorb a CoM error into the correction).
  LinearAngular6d target = rate_desired;
  const Eigen::Vector3d weight = dyn.model_mass * gravity_;
  target.head<3>() -= weight;
  target.tail<3>() -= (dyn.model_com - dyn.com).cross(weight);
  const Eigen::Vector3d F = -(dyn.R * dyn.tau_correction.segment<3>(3));
  target.head<3>() -= F;
  target.tail<3>() -= -(dyn.R * dyn.tau_correction.head<3>()) + (dyn.base_position - dyn.com).cross(F);
  // H_ff = A_f^T W A_f + w_f I,  g_f = -A_f^T W target
  const Eigen::Matrix<double, 6, 12> WAf = w_mom.asDiagonal() * Af_;
  Hff_.noalias() = Af_.transpose() * WAf;
  qp.H.bottomRightCorner<12, 12>() = 0.5 * (Hff_ + Hff_.transpose());  // exactly symmetric
  qp.H.bottomRightCorner<12, 12>().diagonal().array() += force_weight_;
  qp.g.tail<12>().noalias() = -WAf.transpose() * target;
}

int BalanceFormulation::buildUnactuatedDynamics(const RobotDynamicsData& dyn, QpProblem& qp) const {
  const int nv = nv_;
  const Eigen::MatrixXd& M = dyn.dyn.M;
  const int nu_rows = static_cast<int>(unactuated_.size());
  for (int k = 0; k < nu_rows; ++k) {
    const int r = unactuated_[static_cast<size_t>(k)];
    qp.A.row(k).head(nv) = M.row(r);
    qp.A.block<1, 6>(k, nv) = -dyn.Jc[0].col(r).transpose();
    qp.A.block<1, 6>(k, nv + 6) = -dyn.Jc[1].col(r).transpose();
    qp.b[k] = -(dyn.h[r] + dyn.tau_correction[r]);
  }
  return nu_rows;
}

void BalanceFormulation::buildStationarySoles(const RobotDynamicsData& dyn, const ContactSixD& right,
                                              const ContactSixD& left, int nu_rows, QpProblem& qp) {
  const int nv = nv_;
  // Jc dnu = rhs, rotated into the eigenbasis U of Jc Jc^T (eigenvalue = sigma^2). A direction u_k with
  // sigma_k < range_tolerance is one the soles cannot move along relative to each other (neither leg has a
  // yaw joint, so the stacked 12 x 16 Jacobian has rank 11 when the legs are symmetric): its row
  // u_k^T Jc dnu = u_k^T rhs would be (nearly) zero = (numerically) inconsistent and make the equality
  // system rank deficient. It is replaced by the gauge u_k^T f = 0 on the matching internal wrench, which
  // neither the dynamics nor the torques see (Jc^T u_k = sigma_k v_k ~ 0).
  Jc_.topRows<6>() = dyn.Jc[0];
  Jc_.bottomRows<6>() = dyn.Jc[1];
  LinearAngular6d rhs_i;
  right.motionRhs(dyn, rhs_i);
  rhs_.head<6>() = rhs_i;
  left.motionRhs(dyn, rhs_i);
  rhs_.tail<6>() = rhs_i;
  G_.noalias() = Jc_ * Jc_.transpose();
  eig_.compute(G_);
  const auto& U = eig_.eigenvectors();
  UJc_.noalias() = U.transpose() * Jc_;
  Urhs_.noalias() = U.transpose() * rhs_;
  dropped_ = 0;
  const double tol2 = range_tolerance_ * range_tolerance_;
  for (int k = 0; k < 12; ++k) {
    const int row = nu_rows + k;
    if (eig_.eigenvalues()[k] < tol2) {
      qp.A.row(row).head(nv).setZero();
      qp.A.row(row).tail<12>() = U.col(k).transpose();
      qp.b[row] = 0.0;
      ++dropped_;
    } else {
      qp.A.row(row).head(nv) = UJc_.row(k);
      qp.A.row(row).tail<12>().setZero();
      qp.b[row] = Urhs_[k];
    }
  }
}

void BalanceFormulation::buildContactWrenchLimits(const ContactSixD& right, const ContactSixD& left, QpProblem& qp) {
  const int nv = nv_;
  const int nf = kContactVars;
  const ContactSixD* contacts[2] = {&right, &left};
  constexpr int ni = ContactSixD::kInequalities;
  for (int i = 0; i < 2; ++i) {
    contacts[i]->wrenchConstraints(Cf_, lf_, uf_);
    qp.C.block(ni * i, 0, ni, nv + nf).setZero();
    qp.C.block<ni, 6>(ni * i, nv + 6 * i) = Cf_;
    qp.l.segment<ni>(ni * i) = lf_;
    qp.u.segment<ni>(ni * i) = uf_;
  }
}

void BalanceFormulation::buildTorqueLimits(const RobotDynamicsData& dyn, QpProblem& qp) const {
  const int nv = nv_;
  const Eigen::MatrixXd& M = dyn.dyn.M;
  constexpr int ni = ContactSixD::kInequalities;
  const int row0 = 2 * ni;
  for (size_t k = 0; k < actuated_.size(); ++k) {
    const int r = actuated_[k];
    const int row = row0 + static_cast<int>(k);
    qp.C.row(row).head(nv) = M.row(r);
    qp.C.block<1, 6>(row, nv) = -dyn.Jc[0].col(r).transpose();
    qp.C.block<1, 6>(row, nv + 6) = -dyn.Jc[1].col(r).transpose();
    const double bias = dyn.h[r] + dyn.tau_correction[r];
    qp.l[row] = -tau_max_[static_cast<Eigen::Index>(k)] - bias;
    qp.u[row] = tau_max_[static_cast<Eigen::Index>(k)] - bias;
  }
}

void BalanceFormulation::generalizedForce(const RobotDynamicsData& dyn, const Eigen::VectorXd& x,
                                          Eigen::VectorXd& tau) const {
  tau.noalias() = dyn.dyn.M * x.head(nv_);
  tau += dyn.h + dyn.tau_correction;
  tau.noalias() -= dyn.Jc[0].transpose() * x.segment<6>(nv_);
  tau.noalias() -= dyn.Jc[1].transpose() * x.segment<6>(nv_ + 6);
}

}  // namespace exoid::controller
