#pragma once
// Disturbance observer on the whole-body dynamics: the generalized force d [nv] that the URDF model misses
// (undeclared payloads, joint friction, rotor inertia, actuation errors), defined by
//   M dnu + h + d = S^T tau + Jc^T f          (true robot, model M and h).
// The QP plans dnu* with the current estimate in its dynamics (h + d_hat), so whatever the robot does
// differently is the error of the estimate, seen through the mass matrix:
//   d_hat <- d_hat + (dt / T) M (dnu* - dnu_measured),
// a first-order convergence with time constant T (an integrator of the acceleration error: the sum of
// velocity differences telescopes, so encoder noise is not amplified by the differentiation). With stationary
// feet, dnu* - dnu lies in the motion space (Jc dnu = rhs for both): the motion shows only the part of d that
// moves the robot. The part in the range of Jc^T (e.g. the weight of a payload carried by straight legs) only
// changes the contact wrenches: with the force plates, their measured-minus-planned wrenches add
// Jc^T (f - f*) to the innovation (M dnu + h + d = S^T tau + Jc^T f with the applied tau = the plan's):
//   d_hat <- d_hat + (dt / T) [M (dnu* - dnu) + Jc^T (f - f*)].
// Allocation-free per tick.
#include <Eigen/Core>
#include <cstdint>

#include "exoid/controller/config.hpp"

namespace exoid::controller {

class DisturbanceObserver {
 public:
  DisturbanceObserver(const DisturbanceConfig& config, double period, int nv);

  /// Forget the estimate and the history.
  void reset();
  /// Folds in the state of one tick: nu [nv] (model convention: base omega and velocity in base coordinates,
  /// joint velocities), M [nv x nv] at that state, `ticks_since_last` >= 1 since the previous update. Uses the
  /// acceleration planned by the last setPlanned() (none: the history restarts).
  /// `wrench_residual` [nv], if not null: sum_i Jc_i^T (f_i,measured - f_i,planned), the contact wrenches the
  /// force plates measured minus those the QP planned for the same tick (what the motion cannot show).
  void update(const Eigen::MatrixXd& M, const Eigen::VectorXd& nu, int64_t ticks_since_last,
              const Eigen::VectorXd* wrench_residual = nullptr);
  /// The acceleration [nv] the command just sent will produce according to the model (the QP's dnu*).
  void setPlanned(const Eigen::Ref<const Eigen::VectorXd>& dnu);
  /// The command just sent is not the QP's (fallback): the next update does not integrate.
  void clearPlanned() { has_planned_ = false; }
  /// Current estimate [nv] (N m on joint rows; base rows [moment; force] in base coordinates).
  const Eigen::VectorXd& estimate() const { return d_; }

 private:
  DisturbanceConfig cfg_;
  double period_;
  Eigen::VectorXd d_, nu_prev_, planned_, acc_, err_;
  bool has_prev_ = false, has_planned_ = false;
};

}  // namespace exoid::controller
