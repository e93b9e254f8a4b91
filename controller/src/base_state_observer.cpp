#include "exoid/controller/base_state_observer.hpp"

#include <algorithm>
#include <cmath>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"

namespace exoid::controller {

bool resolveSoleFrame(const Model& model, const std::string& name, SoleFrame& out, std::string* error) {
  const int f = model.frameIndex(name);
  if (f >= 0) {
    const Model::Frame& frame = model.frames[static_cast<size_t>(f)];
    if (frame.body < 0) {
      if (error) *error = "frame '" + name + "' is attached to the fixed world, not to a body";
      return false;
    }
    out.body = frame.body;
    out.position = frame.position;
    out.rotation = frame.rotation;
    return true;
  }
  const int b = model.bodyIndex(name);
  if (b >= 0) {
    out.body = b;
    out.position.setZero();
    out.rotation.setIdentity();
    return true;
  }
  if (error) *error = "the model has no frame or link named '" + name + "'";
  return false;
}

bool resolveObserverFrames(const Model& model, const ContactConfig& contact, std::array<SoleFrame, 2>& soles,
                           SoleFrame& imu, std::string* error) {
  std::string why;
  if (!resolveSoleFrame(model, contact.right_sole_frame, soles[0], &why) ||
      !resolveSoleFrame(model, contact.left_sole_frame, soles[1], &why)) {
    if (error) *error = "contact frames: " + why;
    return false;
  }
  if (model.frameIndex("imu") >= 0) resolveSoleFrame(model, "imu", imu, nullptr);
  else imu = SoleFrame{0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()};
  if (imu.body != 0) {
    if (error) *error = "the IMU frame must be on the base body";
    return false;
  }
  return true;
}

BaseStateObserver::BaseStateObserver(const Model& model, const ObserverConfig& config, double period,
                                       const std::array<SoleFrame, 2>& soles, const SoleFrame& imu)
    : model_(model),
      cfg_(config),
      period_(period),
      soles_(soles),
      imu_(imu),
      kin_(model),
      kin_state_(State::zero(model)),
      J_(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model.nv)),
      state_(State::zero(model)),
      q_prev_(Eigen::VectorXd::Zero(model.njoints)),
      dq_raw_(Eigen::VectorXd::Zero(model.njoints)),
      q0_(Eigen::VectorXd::Zero(model.njoints)) {
  const double fs = 1.0 / period;
  dq_filter_.configure(model.njoints, config.joint_velocity_cutoff_hz, fs);
  gyro_filter_.configure(3, config.gyro_cutoff_hz, fs);
  reset();
}

void BaseStateObserver::reset() {
  samples_ = 0;
  latched_ = false;
  leg_disagreement_ = 0.0;
  for (int i = 0; i < 2; ++i) {
    sole_pos_[static_cast<size_t>(i)].setZero();
    sole_rot_[static_cast<size_t>(i)].setIdentity();
  }
  state_.base_orientation.setIdentity();
  state_.base_position.setZero();
  state_.base_omega.setZero();
  state_.base_velocity.setZero();
  state_.base_domega.setZero();
  state_.base_acceleration.setZero();
  state_.q.setZero();
  state_.v.setZero();
  state_.a.setZero();
}

void BaseStateObserver::footKinematics() {
  kin_state_.q = state_.q;
  forwardKinematics(model_, kin_, kin_state_);
  for (size_t i = 0; i < 2; ++i) {
    const SoleFrame& s = soles_[i];
    sole_b_[i] = kin_.p[static_cast<size_t>(s.body)] + kin_.R[static_cast<size_t>(s.body)] * s.position;
    Rsole_b_[i] = kin_.R[static_cast<size_t>(s.body)] * s.rotation;
  }
}

void BaseStateObserver::update(const RobotStateSample& sample, int64_t ticks_since_last) {
  const bool first = samples_ == 0;
  const double dt = period_ * static_cast<double>(ticks_since_last < 1 ? 1 : ticks_since_last);
  updateOrientation(sample, first, dt);
  updateJoints(sample, first, dt);
  updateBaseFromSoles();
  ++samples_;
}

void BaseStateObserver::updateOrientation(const RobotStateSample& sample, bool first, double dt) {
  const Eigen::Quaterniond q_imu_base(imu_.rotation);  // base <- imu
  const Eigen::Quaterniond q_meas = (sample.imu_orientation.normalized() * q_imu_base.conjugate()).normalized();
  const Eigen::Vector3d gyro_b = imu_.rotation * sample.imu_gyro;
  if (first) {
    gyro_filter_.reset(gyro_b);
    gyro_base_ = gyro_b;
    quat_ = q_meas;
  } else {
    gyro_filter_.filter(gyro_b, gyro_base_);
    if (cfg_.orientation_time_constant > 0.0) {
      // Predict with the gyro (body-frame rate), correct a fraction of the way toward the IMU orientation.
      const Eigen::Vector3d dtheta = gyro_b * dt;
      const double angle = dtheta.norm();
      Eigen::Quaterniond q_pred = quat_;
      if (angle > 0.0) q_pred = quat_ * Eigen::Quaterniond(Eigen::AngleAxisd(angle, dtheta / angle));
      Eigen::Quaterniond q_err = q_pred.conjugate() * q_meas;
      if (q_err.w() < 0.0) q_err.coeffs() *= -1.0;
      const Eigen::AngleAxisd err(q_err);
      // Start-up: recursive mean of the IMU orientation over the latch window (alpha = 1/(n+1)), so the latched
      // sole poses do not inherit one sample's orientation noise; then the complementary time constant.
      const double alpha = std::max(dt / (cfg_.orientation_time_constant + dt),
                                    latched_ ? 0.0 : 1.0 / static_cast<double>(samples_ + 1));
      quat_ = (q_pred * Eigen::Quaterniond(Eigen::AngleAxisd(alpha * err.angle(), err.axis()))).normalized();
    } else {
      quat_ = q_meas;
    }
  }
  R_ = quat_.toRotationMatrix();
  state_.base_orientation = quat_;
  state_.base_omega = gyro_base_;
}

void BaseStateObserver::updateJoints(const RobotStateSample& sample, bool first, double dt) {
  state_.q = sample.q;
  if (first) {
    q0_ = sample.q;
    dq_raw_.setZero();
    dq_filter_.reset(dq_raw_);
    state_.v.setZero();
  } else {
    dq_raw_ = (sample.q - q_prev_) / dt;
    dq_filter_.filter(dq_raw_, state_.v);
  }
  q_prev_ = sample.q;
}

void BaseStateObserver::updateBaseFromSoles() {
  footKinematics();
  Eigen::Vector3d vb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < 2; ++i) {
    const SoleFrame& s = soles_[i];
    computePointJacobian(model_, kin_, s.body, s.position, J_);
    // Linear velocity of the sole with v_b = 0: J_lin [omega; 0; dq]; the v_b block of J_lin is identity.
    Eigen::Vector3d v_joints;
    v_joints.noalias() = J_.bottomRows<3>().rightCols(model_.njoints) * state_.v;
    vb -= J_.block<3, 3>(3, 0) * state_.base_omega + v_joints;
  }
  state_.base_velocity = 0.5 * vb;

  if (!latched_) {
    // Provisional world frame: base at (initial_base_xy, z) with the soles' mean height at ground_height. The
    // sole poses are latched at the end of the window, with the window-averaged orientation.
    const Eigen::Vector3d r0 = R_ * sole_b_[0], r1 = R_ * sole_b_[1];
    const double zb = cfg_.ground_height - 0.5 * (r0.z() + r1.z());
    const Eigen::Vector3d pb(cfg_.initial_base_xy.x(), cfg_.initial_base_xy.y(), zb);
    state_.base_position = pb;
    for (size_t i = 0; i < 2; ++i) {
      sole_pos_[i] = pb + R_ * sole_b_[i];
      sole_rot_[i] = R_ * Rsole_b_[i];
    }
    leg_disagreement_ = 0.0;
    latched_ = samples_ + 1 >= cfg_.latch_ticks;
  } else {
    const Eigen::Vector3d p0 = sole_pos_[0] - R_ * sole_b_[0];
    const Eigen::Vector3d p1 = sole_pos_[1] - R_ * sole_b_[1];
    state_.base_position = 0.5 * (p0 + p1);
    leg_disagreement_ = 0.5 * (p0 - p1).norm();
  }
}

}  // namespace exoid::controller
