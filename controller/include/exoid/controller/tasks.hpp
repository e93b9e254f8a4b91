#pragma once
// TSID-style pieces of the balance controller: each computes its own rows from the robot dynamics snapshot;
// BalanceFormulation stacks them into one QP. None of them knows the solver.
#include <Eigen/Core>

#include "exoid/controller/com_trajectory.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/controller/robot_dynamics.hpp"

namespace exoid::controller {

/// Centroidal momentum task (Vallinas et al., ICORR 2023): desired rate of the centroidal momentum (world,
/// about the CoM, [linear; angular]):
///   dl* = m (Kp (c_ref - c) + Kd (dc_ref - dc) + ddc_ref),     dk* = -K_L k_G.
/// The rate produced by the contact wrenches f = [f_R; f_L] (world, [force; moment about the sole origin]) is
///   rate(f) = A_f f + [m g; 0],  A_f = [ I              I            ]
///                                      [ S(p_R - c)  I  S(p_L - c)  I ],
/// so the task's cost is || A_f f - (dh* - [m g; 0]) ||^2_W.
class MomentumTask {
 public:
  explicit MomentumTask(const MomentumTaskConfig& config);

  /// Desired momentum rate for the reference `ref` and the current estimate in `dyn`. Allocation-free.
  void compute(const CoMReference& ref, const RobotDynamicsData& dyn, LinearAngular6d& desired_rate) const;
  /// A_f (6 x 12) for the sole positions and the CoM in `dyn`.
  static void wrenchMap(const RobotDynamicsData& dyn, Eigen::Matrix<double, 6, 12>& A);
  /// Cost weights, [linear; angular].
  LinearAngular6d weights() const;

 private:
  MomentumTaskConfig cfg_;
};

/// Posture regularisation: small weight on dnu toward
///   ddq* = Kp (q0 - q) - Kd dq   (joints),   0   (base),
/// i.e. damping of the joint velocities and a weak pull to the start-up posture q0.
class PostureRegularization {
 public:
  PostureRegularization(const PostureConfig& config, int njoints);
  void setReference(const Eigen::VectorXd& q0) { q0_ = q0; }
  const Eigen::VectorXd& reference() const { return q0_; }
  /// Desired dnu [nv] and the per-coordinate weights [nv]. Allocation-free.
  void compute(const State& state, Eigen::Ref<Eigen::VectorXd> dnu_desired, Eigen::Ref<Eigen::VectorXd> weights) const;

 private:
  PostureConfig cfg_;
  Eigen::VectorXd q0_;
};

/// Rigid, stationary 6-D foot contact:
///  - motion: the sole frame does not accelerate,  Jc dnu + drift = -Kp e - Kd de  (6 rows, world), with e the
///    position / orientation (log map) error from the latched pose and de the sole velocity;
///  - wrench (sole frame, f_l = R^T F, m_l = R^T M): min normal force, friction pyramid |f_x|,|f_y| <= mu f_z,
///    centre of pressure inside the sole rectangle shrunk by cop_margin (|m_y| <= X f_z, |m_x| <= Y f_z) and a
///    torsional bound |m_z| <= k_z f_z  (kInequalities rows, each lower <= row . f <= upper).
class ContactSixD {
 public:
  static constexpr int kInequalities = 11;
  using InequalityMatrix = Eigen::Matrix<double, kInequalities, 6>;
  using InequalityVector = Eigen::Matrix<double, kInequalities, 1>;

  ContactSixD(const ContactConfig& config, int foot);
  int foot() const { return foot_; }
  /// Latched sole pose (world) the contact holds.
  void setReference(const Eigen::Vector3d& position, const Eigen::Matrix3d& rotation);
  const Eigen::Vector3d& referencePosition() const { return p_ref_; }
  const Eigen::Matrix3d& referenceRotation() const { return R_ref_; }

  /// Right-hand side of Jc dnu = rhs (world [linear; angular]). Allocation-free.
  void motionRhs(const RobotDynamicsData& dyn, LinearAngular6d& rhs) const;
  /// Rows on the world wrench [F; M] and their bounds (infinite where one-sided). Allocation-free.
  void wrenchConstraints(InequalityMatrix& C, InequalityVector& lower, InequalityVector& upper) const;

 private:
  ContactConfig cfg_;
  int foot_;
  Eigen::Vector3d p_ref_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_ref_ = Eigen::Matrix3d::Identity();
};

}  // namespace exoid::controller
