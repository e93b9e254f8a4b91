#pragma once
// Everything the balance formulation needs about the robot at one tick, computed from an estimated State by
// the model library (Pinocchio-like: computeRobotDynamics(model, soles, data, state) fills preallocated data).
//
// Coordinates: M, h and the generalized forces follow the model's convention (nu = [omega_b; v_b; dq] in base
// coordinates, classical base acceleration). Contact quantities are re-expressed in the WORLD frame in the
// task-space order [linear; angular] (LinearAngular6d below), wrenches [force; moment]:
//   Jc_i = [R J_i,lin; R J_i,ang]   (6 x nv)   so that   [a_i; alpha_i] = Jc_i dnu + drift_i   (world),
//   and a world wrench f_i = [F; M about the sole origin] produces the generalized force Jc_i^T f_i.
#include <Eigen/Core>
#include <array>

#include "exoid/controller/base_state_observer.hpp"
#include "exoid/model/dynamics.hpp"

namespace exoid::controller {

/// The controller's task-space 6-vectors and 6-row Jacobians: world, [linear; angular] (velocities,
/// accelerations, momentum; wrenches [force; moment]). The model's are [angular; linear]: computeRobotDynamics
/// is the one place that converts (docs/conventions.md, "Spatial vectors").
using LinearAngular6d = Eigen::Matrix<double, 6, 1>;
using LinearAngular6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

struct RobotDynamicsData {
  explicit RobotDynamicsData(const Model& model);

  DynamicsData dyn;               ///< model-library scratch (M in dyn.M)
  Eigen::VectorXd h;              ///< [nv] nonlinear effects C(q, nu) nu + g(q) (rnea at dnu = 0)
  Eigen::VectorXd tau_correction; ///< [nv] generalized-force correction: the estimate's and the disturbance observer's (0 by default)
  Eigen::VectorXd nu;             ///< [nv] generalized velocity of the state
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  ///< world <- base
  std::array<LinearAngular6Xd, 2> Jc;    ///< [right, left] world contact Jacobians [linear; angular]
  std::array<LinearAngular6d, 2> drift{};         ///< world [linear; angular] classical acceleration at dnu = 0
  std::array<LinearAngular6d, 2> foot_velocity{};  ///< world [linear; angular] velocity of the sole frames
  std::array<Eigen::Vector3d, 2> foot_position{};  ///< world, from the base estimate and the kinematics
  std::array<Eigen::Matrix3d, 2> foot_rotation{};  ///< world <- sole
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();  ///< world
  // The controller's CoM: the URDF model's, or blended toward the online estimate's (BalanceController).
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();           ///< world
  Eigen::Vector3d com_velocity = Eigen::Vector3d::Zero();  ///< world
  LinearAngular6d momentum = LinearAngular6d::Zero();  ///< world, [linear; angular about com]
  // The URDF model's mass and CoM: where the gravity of h acts (tau_correction carries the rest).
  double model_mass = 0.0;
  Eigen::Vector3d model_com = Eigen::Vector3d::Zero();  ///< world
  Eigen::Matrix<double, 6, Eigen::Dynamic> J_scratch;  ///< base-frame Jacobian scratch (the model's [angular; linear])
};

/// Fills `data` for `state` (model parameters, gravity from the model). Allocation-free.
/// Order: rnea (h, with dnu = 0), crba (M), zero-gravity drift kinematics, sole Jacobians and drifts,
/// centroidal momentum.
void computeRobotDynamics(const Model& model, const std::array<SoleFrame, 2>& soles, RobotDynamicsData& data,
                          const State& state);

/// World mass, CoM, CoM velocity and momentum [linear; angular about the CoM] of the parameters phi at the
/// state of the last computeRobotDynamics (its kinematics). data.dyn's centroidal fields are left as they were.
/// Allocation-free.
void centroidalWorld(const Model& model, const Eigen::VectorXd& phi, RobotDynamicsData& data, double& mass,
                     Eigen::Vector3d& com, Eigen::Vector3d& com_velocity, LinearAngular6d& momentum);

}  // namespace exoid::controller
