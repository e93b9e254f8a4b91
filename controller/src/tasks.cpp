#include "exoid/controller/tasks.hpp"

#include <Eigen/Geometry>
#include <limits>

namespace exoid::controller {

namespace {
Eigen::Matrix3d skew(const Eigen::Vector3d& x) {
  Eigen::Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}
}  // namespace

// ---------------------------------------------------------------------------------------------------------
MomentumTask::MomentumTask(const MomentumTaskConfig& config) : cfg_(config) {}

void MomentumTask::compute(const CoMReference& ref, const RobotDynamicsData& dyn, LinearAngular6d& desired) const {
  desired.head<3>() = dyn.mass * (cfg_.kp_com.cwiseProduct(ref.position - dyn.com) +
                                  cfg_.kd_com.cwiseProduct(ref.velocity - dyn.com_velocity) + ref.acceleration);
  desired.tail<3>() = -cfg_.kd_angular.cwiseProduct(dyn.momentum.tail<3>());
}

void MomentumTask::wrenchMap(const RobotDynamicsData& dyn, Eigen::Matrix<double, 6, 12>& A) {
  A.setZero();
  for (int i = 0; i < 2; ++i) {
    A.block<3, 3>(0, 6 * i).setIdentity();
    A.block<3, 3>(3, 6 * i) = skew(dyn.foot_position[static_cast<size_t>(i)] - dyn.com);
    A.block<3, 3>(3, 6 * i + 3).setIdentity();
  }
}

LinearAngular6d MomentumTask::weights() const {
  LinearAngular6d w;
  w << cfg_.weight_linear, cfg_.weight_angular;
  return w;
}

// ---------------------------------------------------------------------------------------------------------
PostureRegularization::PostureRegularization(const PostureConfig& config, int njoints)
    : cfg_(config), q0_(Eigen::VectorXd::Zero(njoints)) {}

void PostureRegularization::compute(const State& s, Eigen::Ref<Eigen::VectorXd> dnu_desired,
                                    Eigen::Ref<Eigen::VectorXd> weights) const {
  const Eigen::Index nj = q0_.size();
  dnu_desired.head<6>().setZero();
  dnu_desired.tail(nj) = cfg_.kp * (q0_ - s.q) - cfg_.kd * s.v;
  weights.head<6>().setConstant(cfg_.weight_base);
  weights.tail(nj).setConstant(cfg_.weight_joint);
}

// ---------------------------------------------------------------------------------------------------------
ContactSixD::ContactSixD(const ContactConfig& config, int foot) : cfg_(config), foot_(foot) {}

void ContactSixD::setReference(const Eigen::Vector3d& position, const Eigen::Matrix3d& rotation) {
  p_ref_ = position;
  R_ref_ = rotation;
}

void ContactSixD::motionRhs(const RobotDynamicsData& dyn, LinearAngular6d& rhs) const {
  const size_t i = static_cast<size_t>(foot_);
  LinearAngular6d e;
  e.head<3>() = dyn.foot_position[i] - p_ref_;
  const Eigen::AngleAxisd rot_err(dyn.foot_rotation[i] * R_ref_.transpose());  // world-frame rotation error
  e.tail<3>() = rot_err.angle() * rot_err.axis();
  rhs = -dyn.drift[i] - cfg_.kp * e - cfg_.kd * dyn.foot_velocity[i];
}

void ContactSixD::wrenchConstraints(InequalityMatrix& C, InequalityVector& lower, InequalityVector& upper) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const double mu = cfg_.friction_coefficient;
  const double X = cfg_.sole_half_length - cfg_.cop_margin;
  const double Y = cfg_.sole_half_width - cfg_.cop_margin;
  const double kz = cfg_.yaw_moment_coefficient;
  // Rows on the local wrench [fx fy fz mx my mz].
  InequalityMatrix L;
  // clang-format off
  L << 0, 0, 1,    0, 0, 0,   // fz >= f_min
       1, 0, -mu,  0, 0, 0,   // fx - mu fz <= 0
       1, 0, mu,   0, 0, 0,   // fx + mu fz >= 0
       0, 1, -mu,  0, 0, 0,   // fy - mu fz <= 0
       0, 1, mu,   0, 0, 0,   // fy + mu fz >= 0
       0, 0, -X,   0, 1, 0,   // my - X fz <= 0    (CoP x = -my / fz >= -X)
       0, 0, X,    0, 1, 0,   // my + X fz >= 0    (CoP x <= X)
       0, 0, -Y,   1, 0, 0,   // mx - Y fz <= 0    (CoP y = mx / fz <= Y)
       0, 0, Y,    1, 0, 0,   // mx + Y fz >= 0
       0, 0, -kz,  0, 0, 1,   // mz - kz fz <= 0
       0, 0, kz,   0, 0, 1;   // mz + kz fz >= 0
  lower << cfg_.min_normal_force, -inf, 0, -inf, 0, -inf, 0, -inf, 0, -inf, 0;
  upper << inf, 0, inf, 0, inf, 0, inf, 0, inf, 0, inf;
  // clang-format on
  // World wrench -> local: f_l = R^T F, m_l = R^T M.
  C.leftCols<3>().noalias() = L.leftCols<3>() * R_ref_.transpose();
  C.rightCols<3>().noalias() = L.rightCols<3>() * R_ref_.transpose();
}

}  // namespace exoid::controller
