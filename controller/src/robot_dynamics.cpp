#include "exoid/controller/robot_dynamics.hpp"

#include "exoid/model/kinematics.hpp"

namespace exoid::controller {

RobotDynamicsData::RobotDynamicsData(const Model& model)
    : dyn(model),
      h(Eigen::VectorXd::Zero(model.nv)),
      tau_correction(Eigen::VectorXd::Zero(model.nv)),
      nu(Eigen::VectorXd::Zero(model.nv)),
      Jc{LinearAngular6Xd::Zero(6, model.nv), LinearAngular6Xd::Zero(6, model.nv)},
      J_scratch(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model.nv)) {}

namespace {
// d.dyn's centroidal fields (base coordinates, momentum [angular; linear] about the base origin) -> world,
// [linear; angular about the CoM].
void toWorld(const RobotDynamicsData& d, double& mass, Eigen::Vector3d& com, Eigen::Vector3d& com_velocity,
             LinearAngular6d& momentum) {
  const Eigen::Vector3d P = d.dyn.momentum_origin.tail<3>();  // linear momentum, base coordinates
  const Eigen::Vector3d L_origin = d.dyn.momentum_origin.head<3>();
  mass = d.dyn.mass;
  com = d.base_position + d.R * d.dyn.com;
  com_velocity = d.R * P / mass;
  momentum.head<3>() = d.R * P;
  momentum.tail<3>() = d.R * (L_origin - d.dyn.com.cross(P));
}
}  // namespace

void computeRobotDynamics(const Model& model, const std::array<SoleFrame, 2>& soles, RobotDynamicsData& d,
                          const State& state) {
  // h = M*0 + C nu + g: rnea with zero accelerations (the State's base/joint accelerations are ignored here).
  d.nu.head<3>() = state.base_omega;
  d.nu.segment<3>(3) = state.base_velocity;
  d.nu.tail(model.njoints) = state.v;
  rnea(model, d.dyn, state);
  d.h = d.dyn.tau;
  crba(model, d.dyn, state);
  // Kinematics at zero acceleration and zero gravity: velocity-product accelerations only (the drifts).
  forwardKinematicsDrift(model, d.dyn.kin, state);
  d.R = state.base_orientation.toRotationMatrix();
  const Eigen::Matrix3d& R = d.R;
  for (size_t i = 0; i < 2; ++i) {
    const SoleFrame& s = soles[i];
    computePointJacobian(model, d.dyn.kin, s.body, s.position, d.J_scratch);
    // The model's [angular; linear] (base coordinates) -> the task space's [linear; angular] (world).
    d.Jc[i].topRows<3>().noalias() = R * d.J_scratch.bottomRows<3>();
    d.Jc[i].bottomRows<3>().noalias() = R * d.J_scratch.topRows<3>();
    const Eigen::Matrix<double, 6, 1> drift_b = pointAccelerationDrift(d.dyn.kin, s.body, s.position);
    d.drift[i].head<3>() = R * drift_b.tail<3>();
    d.drift[i].tail<3>() = R * drift_b.head<3>();
    d.foot_velocity[i].noalias() = d.Jc[i] * d.nu;
    const size_t b = static_cast<size_t>(s.body);
    d.foot_position[i] = state.base_position + R * (d.dyn.kin.p[b] + d.dyn.kin.R[b] * s.position);
    d.foot_rotation[i] = R * d.dyn.kin.R[b] * s.rotation;
  }
  d.base_position = state.base_position;
  centroidal(model, d.dyn);
  toWorld(d, d.mass, d.com, d.com_velocity, d.momentum);
  d.model_mass = d.mass;
  d.model_com = d.com;
}

void centroidalWorld(const Model& model, const Eigen::VectorXd& phi, RobotDynamicsData& d, double& mass,
                     Eigen::Vector3d& com, Eigen::Vector3d& com_velocity, LinearAngular6d& momentum) {
  const double mass0 = d.dyn.mass;
  const Eigen::Vector3d com0 = d.dyn.com;
  const Eigen::Matrix<double, 6, 1> momentum0 = d.dyn.momentum_origin;  // the model's [angular; linear]
  centroidal(model, phi, d.dyn);
  toWorld(d, mass, com, com_velocity, momentum);
  d.dyn.mass = mass0;
  d.dyn.com = com0;
  d.dyn.momentum_origin = momentum0;
}

}  // namespace exoid::controller
