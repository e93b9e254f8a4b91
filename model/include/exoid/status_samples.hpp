#pragma once
// Plain, transport-free mirrors of exoid_lcm.controller_status_t and exoid_lcm.estimator_output_t (the
// adapters in lcmtypes/adapters convert). Units SI unless a field says otherwise. Names (joints, parameters)
// are not stored here: like samples.hpp, arrays follow an order fixed at setup and the adapters take the
// expected name lists. Vectors are sized once on setup, so filling a sample in a loop does not allocate.
#include <Eigen/Core>
#include <cstdint>

namespace exoid {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Outcome of the controller's QP in one tick (controller_status_t.qp_status).
enum class QpStatus : int8_t { Solved = 0, MaxIterations = 1, Infeasible = 2, NotRun = 3 };

/// Controller diagnostics at one tick (exoid_lcm.controller_status_t, channel EXO_CONTROLLER_STATUS).
struct ControllerStatusSample {
  int64_t utime = 0;
  int64_t tick = 0;
  QpStatus qp_status = QpStatus::NotRun;
  int32_t qp_iterations = 0;
  double qp_solve_us = 0.0;  ///< QP solve time, microseconds
  double tick_us = 0.0;      ///< whole control tick (dynamics + QP), microseconds
  int32_t move_index = -1;   ///< current CoM move (0-based), -1 before the first, = count when done
  int32_t moves_done = 0;
  Eigen::Vector3d com_ref = Eigen::Vector3d::Zero();      ///< CoM reference, world, m
  Eigen::Vector3d com = Eigen::Vector3d::Zero();          ///< CoM estimate, world, m
  Eigen::Vector3d com_vel_ref = Eigen::Vector3d::Zero();  ///< world, m/s
  Eigen::Vector3d com_vel = Eigen::Vector3d::Zero();      ///< world, m/s
  Vector6d momentum_rate_ref = Vector6d::Zero();  ///< desired centroidal momentum rate [N; N m], world, about CoM
  Vector6d momentum = Vector6d::Zero();           ///< centroidal momentum [kg m/s; kg m^2/s], world, about CoM
  Vector6d wrench_right = Vector6d::Zero();  ///< QP contact wrench on the right foot [force; moment about sole origin], world
  Vector6d wrench_left = Vector6d::Zero();   ///< same, left foot
  int32_t fallbacks = 0;        ///< ticks on a fallback command so far
  int32_t rejected_inputs = 0;  ///< rejected input messages so far (NaN, out of order, duplicate, wrong size)
  int32_t stale_inputs = 0;     ///< ticks without a fresh state so far
};

/// Estimator output (exoid_lcm.estimator_output_t, channel EXO_ESTIMATE).
struct EstimatorOutputSample {
  int64_t utime = 0;
  int64_t tick = 0;              ///< last tick folded into the estimate (tau_ff is evaluated at its state)
  bool valid = false;            ///< finite, physically consistent and excited: the controller may use it
  bool consistent = false;       ///< every link's pseudo-inertia positive definite (model/inertial.hpp)
  int64_t samples_used = 0;      ///< accepted samples
  int32_t samples_rejected = 0;  ///< rejected_nonfinite + rejected_out_of_order + rejected_duplicate
  int32_t rejected_nonfinite = 0;
  int32_t rejected_out_of_order = 0;
  int32_t rejected_duplicate = 0;
  int64_t samples_missing = 0;   ///< ticks skipped between accepted samples
  double excitation = 0.0;       ///< excited fraction of the base-parameter information, [0, 1]
  double effective_samples = 0.0;  ///< memory length sum lambda^(N-k)
  Eigen::VectorXd params;        ///< [nparams] estimated standard parameters (base parameters mapped back)
  Eigen::VectorXd param_stddev;  ///< [nparams] one-sigma uncertainty of each (>= 0)
  Eigen::VectorXd base_params;   ///< [nbase] estimated base parameters
  Eigen::VectorXd base_stddev;   ///< [nbase] one-sigma uncertainty of each (>= 0)
  Eigen::VectorXd tau_ff;        ///< [nv] generalized-force correction K(q, v, dnu)(phi_hat - phi_model), N / N m
  Eigen::VectorXd residual_rms;  ///< [nv] per-coordinate residual RMS over the estimate's memory (>= 0)
};

}  // namespace exoid
