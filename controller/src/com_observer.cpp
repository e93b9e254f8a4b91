#include "exoid/controller/com_observer.hpp"

#include <algorithm>
#include <cmath>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/wearer_mount.hpp"

namespace exoid::controller {

Eigen::Vector2d upperBodyLever(const Model& model) {
  MountedSegment body;
  Eigen::Vector3d pivot;
  if (!model.floating_base || !upperBodyFromModel(model, body, pivot)) return Eigen::Vector2d::Zero();
  const double h = body.com.z() - pivot.z();
  if (!(h > 1e-3)) return Eigen::Vector2d::Zero();  // a body not above its pivot is no upright trunk
  DynamicsData dyn(model);
  forwardKinematics(model, dyn.kin, State::zero(model));
  centroidal(model, dyn);
  const int pelvis = model.bodyIndex(exoPelvisLink());
  const Eigen::Vector3d com_world =
      dyn.kin.p[static_cast<size_t>(pelvis)] + dyn.kin.R[static_cast<size_t>(pelvis)] * body.com;
  const double d = com_world.z() - dyn.com.z();
  return Eigen::Vector2d(body.inertia_com(1, 1) / (body.mass * h) + d, body.inertia_com(0, 0) / (body.mass * h) + d);
}

ComObserver::ComObserver(const ComObserverConfig& config, double period, double gravity,
                         const Eigen::Vector2d& upper_body_lever)
    : cfg_(config), period_(period), gravity_(gravity), lever_(upper_body_lever) {
  const double w = 2.0 * M_PI * cfg_.crossover_hz;
  // 4th-order Butterworth: (s^2 + 2 sin(pi/8) w s + w^2)(s^2 + 2 cos(pi/8) w s + w^2).
  const double p = 2.0 * std::sin(M_PI / 8.0), q = 2.0 * std::cos(M_PI / 8.0);
  a3_ = (p + q) * w;
  a2_ = (2.0 + p * q) * w * w;
  a1_ = (p + q) * w * w * w;
  a0_ = w * w * w * w;
}

void ComObserver::update(const Eigen::Vector3d& com_model, const Eigen::Vector3d& com_velocity_model,
                         const Eigen::Vector3d& angular_momentum_urdf, const Eigen::Vector3d* force,
                         const Eigen::Vector3d* moment, double mass, int64_t ticks_since_last) {
  const bool plates_anchor = cfg_.anchor == ComObserverConfig::Anchor::kPlates;
  fusing_ = false;
  delta_.setZero();
  delta_velocity_.setZero();
  weight_ = 0.0;
  // With the plates' anchor the last correction stands in until the plates are back (header; zero until it fused).
  if (cfg_.enabled && plates_anchor) delta_.head<2>() = held_;
  if (!cfg_.enabled || force == nullptr || moment == nullptr || !(mass > 0.0) || !force->allFinite() ||
      !moment->allFinite() || !(force->z() > kMinLoadFraction * mass * gravity_) || ticks_since_last < 1) {
    started_ = false;
    return;
  }
  const double dt = static_cast<double>(ticks_since_last) * period_;
  const Eigen::Vector3d& F = *force;
  const Eigen::Vector3d& M = *moment;
  if (started_) {
    const double k = std::min(1.0, dt / kAngularMomentumRateTimeConstant);
    momentum_rate_ += k * ((angular_momentum_urdf - previous_momentum_) / dt - momentum_rate_);
    com_acceleration_ += k * ((com_velocity_model - previous_com_velocity_) / dt - com_acceleration_);
    force_low_passed_ += k * (F - force_low_passed_);
  } else {
    momentum_rate_.setZero();
    force_low_passed_ = F;
    com_acceleration_ = F / mass;  // no missing force at the start (only x and y are used)
  }
  previous_momentum_ = angular_momentum_urdf;
  previous_com_velocity_ = com_velocity_model;
  // What the model's dL/dt lacks: the upper body's turning, from the force its CoM acceleration lacks (header).
  // K = R_z diag(lever) R_z^T (world axes): (dL_y, -dL_x) gain K dF.
  const Eigen::Vector3d missing_force = force_low_passed_ - mass * com_acceleration_;
  const double c = heading_cos_, s = heading_sin_;
  const double kxx = lever_.x() * c * c + lever_.y() * s * s, kyy = lever_.x() * s * s + lever_.y() * c * c,
               kxy = (lever_.x() - lever_.y()) * s * c;
  const double dLy = momentum_rate_.y() + (kxx * missing_force.x() + kxy * missing_force.y());
  const double dLx = momentum_rate_.x() - (kxy * missing_force.x() + kyy * missing_force.y());
  const double cz = com_model.z();
  balance_com_ << (cz * F.x() - M.y() + dLy) / F.z(), (M.x() + cz * F.y() - dLx) / F.z(), cz;
  plates_com_.z() = cz;
  if (!started_) {  // the pair's steady state for a CoM at c_P moving at the model's velocity, no acceleration
    for (int i = 0; i < 2; ++i) {
      x_(0, i) = plates_com_[i] = balance_com_[i];
      x_(1, i) = a3_ * balance_com_[i] + com_velocity_model[i];
      x_(2, i) = a3_ * com_velocity_model[i];
      x_(3, i) = 0.0;
      anchor_[i] = balance_com_[i] - com_model[i];  // anchor `model` only
    }
    restart_hold_ = held_;
    fused_time_ = 0.0;
    started_ = true;
    return;
  }
  fused_time_ += dt;
  const double r = std::clamp((fused_time_ - cfg_.settle_time) / cfg_.settle_time, 0.0, 1.0);
  weight_ = r * r * (3.0 - 2.0 * r);  // smoothstep: no kick at either end
  const double k = std::min(1.0, dt / cfg_.anchor_time_constant);
  for (int i = 0; i < 2; ++i) {
    const double u = balance_com_[i], a = F[i] / mass;
    const double x1 = x_(0, i), x2 = x_(1, i), x3 = x_(2, i), x4 = x_(3, i);
    x_(0, i) = x1 + dt * (-a3_ * x1 + x2);
    x_(1, i) = x2 + dt * (-a2_ * x1 + x3 + a2_ * u + a);
    x_(2, i) = x3 + dt * (-a1_ * x1 + x4 + a1_ * u + a3_ * a);
    x_(3, i) = x4 + dt * (-a0_ * x1 + a0_ * u);
    plates_com_[i] = x_(0, i);
    const double d = x_(0, i) - com_model[i];  // c_P - c_model
    const double d_rate = -a3_ * x_(0, i) + x_(1, i) - com_velocity_model[i];
    if (plates_anchor) {
      delta_[i] = weight_ * d + (1.0 - weight_) * restart_hold_[i];
      delta_velocity_[i] = weight_ * d_rate;
      held_[i] = delta_[i];
    } else {
      anchor_[i] += k * (d - anchor_[i]);
      delta_[i] = weight_ * (d - anchor_[i]);
      delta_velocity_[i] = weight_ * (d_rate - (d - anchor_[i]) / cfg_.anchor_time_constant);
    }
  }
  fusing_ = true;
}

}  // namespace exoid::controller
