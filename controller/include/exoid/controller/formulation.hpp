#pragma once
// BalanceFormulation: stacks the tasks and contacts into one dense QP (docs/controller.md, "Formulation").
//
// Variables   x = [dnu (nv); f_R (6); f_L (6)],  f_i = [force; moment about the sole origin], world.
// Equalities  (n_u + 12 rows)
//   floating-base dynamics on the unactuated rows U (6 base rows + passive joints, URDF effort = 0):
//     M_U dnu - Jc_R,U^T f_R - Jc_L,U^T f_L = -(h_U + tau_correction_U)
//   stationary soles:  U^T [Jc_R; Jc_L] dnu = U^T [rhs_R; rhs_L] in the eigenbasis U of Jc Jc^T; a direction
//   whose singular value is below contact.range_tolerance (the soles cannot move along it relative to each
//   other) is replaced by the gauge u_k^T f = 0 on its internal wrench, so the rows stay independent and
//   consistent where the legs lose rank.
// Inequalities (22 + n_a rows)
//   per foot (ContactSixD): unilateral, friction pyramid, CoP, torsion;
//   actuated rows A:  -tau_max <= M_A dnu + h_A + tau_correction_A - Jc_A^T f <= tau_max  (URDF effort * scale).
// Cost  ||A_f f - (dh* - [m g; 0])||^2_W + sum_k w_k (dnu_k - dnu*_k)^2 + w_f ||f||^2.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <vector>

#include "exoid/controller/qp_solver.hpp"
#include "exoid/controller/tasks.hpp"

namespace exoid::controller {

class BalanceFormulation {
 public:
  static constexpr int kContactVars = 12;  ///< two 6-D wrenches

  BalanceFormulation(const Model& model, const ContactConfig& contact, const TorqueConfig& torque);

  QpDimensions dimensions() const { return {nv_ + kContactVars, static_cast<int>(unactuated_.size()) + 12,
                                            2 * ContactSixD::kInequalities + static_cast<int>(actuated_.size())}; }
  int nv() const { return nv_; }
  /// Rows of the generalized force vector that are unactuated (base + passive joints) / actuated (joints).
  const std::vector<int>& unactuatedRows() const { return unactuated_; }
  const std::vector<int>& actuatedRows() const { return actuated_; }
  /// Torque bound of each actuated row (N m).
  const Eigen::VectorXd& torqueLimits() const { return tau_max_; }

  /// Fills `qp` (sized with dimensions()). Allocation-free.
  void build(const RobotDynamicsData& dyn, const LinearAngular6d& momentum_rate_desired, const LinearAngular6d& momentum_weights,
             const Eigen::VectorXd& dnu_desired, const Eigen::VectorXd& dnu_weights,
             const ContactSixD& right, const ContactSixD& left, QpProblem& qp);

  /// Generalized force M dnu + h + tau_correction - Jc^T f for a solution x (rows: all nv). Allocation-free.
  void generalizedForce(const RobotDynamicsData& dyn, const Eigen::VectorXd& x, Eigen::VectorXd& tau) const;

  /// Number of contact-constraint directions dropped by the range projection in the last build().
  int droppedContactDirections() const { return dropped_; }

 private:
  // The blocks of build(), each a part of the QP (x = [dnu (nv); f_right (6); f_left (6)]):
  /// Cost: posture/regularization on dnu and the momentum task on the contact wrenches,
  /// H_ff = A_f^T W A_f + w_f I, g_f = -A_f^T W target (target: the desired rate less gravity and -tau_correction).
  void buildCost(const RobotDynamicsData& dyn, const LinearAngular6d& momentum_rate_desired,
                 const LinearAngular6d& momentum_weights, const Eigen::VectorXd& dnu_desired,
                 const Eigen::VectorXd& dnu_weights, QpProblem& qp);
  /// Equalities: the unactuated rows of M dnu + h + tau_correction = Jc^T f. Returns their number.
  int buildUnactuatedDynamics(const RobotDynamicsData& dyn, QpProblem& qp) const;
  /// Equalities after the first nu_rows: Jc dnu = rhs in the eigenbasis of Jc Jc^T (gauge rows where rank-deficient).
  void buildStationarySoles(const RobotDynamicsData& dyn, const ContactSixD& right, const ContactSixD& left,
                            int nu_rows, QpProblem& qp);
  /// Inequalities: each sole's friction pyramid, CoP and normal-force bounds.
  void buildContactWrenchLimits(const ContactSixD& right, const ContactSixD& left, QpProblem& qp);
  /// Inequalities: |M dnu + h + tau_correction - Jc^T f| <= tau_max on the actuated rows.
  void buildTorqueLimits(const RobotDynamicsData& dyn, QpProblem& qp) const;

  int nv_;
  double force_weight_;
  double range_tolerance_;
  Eigen::Vector3d gravity_;
  std::vector<int> unactuated_, actuated_;
  Eigen::VectorXd tau_max_;
  // scratch
  Eigen::Matrix<double, 6, 12> Af_;
  Eigen::Matrix<double, 12, 12> Hff_;
  Eigen::Matrix<double, 12, 12> G_;
  Eigen::Matrix<double, 12, 1> rhs_;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> eig_;
  ContactSixD::InequalityMatrix Cf_;
  ContactSixD::InequalityVector lf_, uf_;
  Eigen::Matrix<double, 12, Eigen::Dynamic> Jc_;   // stacked world contact Jacobians
  Eigen::Matrix<double, 12, Eigen::Dynamic> UJc_;  // U^T Jc
  Eigen::Matrix<double, 12, 1> Urhs_;              // U^T rhs
  int dropped_ = 0;
};

}  // namespace exoid::controller
