#pragma once
// Horizontal CoM observer: the CoM the force plates measure, fused with the model's (docs/wearer.md, "The CoM from
// the plates"; docs/controller.md, "The CoM observer").
//
// The model's CoM moves only with the measured joints: a body it holds rigid that is not (a wearer's trunk on its
// lumbar joint) is missing from it, at 0.05-2 Hz. Two feet on plates measure the whole system's CoM:
//  1. the moment balance about the CoM, per horizontal axis (world; F, M the total contact force and moment ON the
//     robot, M about the world origin; L the angular momentum about the CoM, from the model):
//        c_x = (c_z F_x - M_y + dL_y/dt) / F_z,   c_y = (M_x + c_z F_y - dL_x/dt) / F_z,
//     exact at every frequency but for the part of dL/dt the model lacks (the trunk's own rotation), which grows
//     with the frequency squared; c_z, a 1 cm error of which moves c by F_x / F_z cm, is the model's. That part
//     is what the model's CoM acceleration lacks of the plates' force, times a lever (upperBodyLever):
//        dL_y/dt += kappa_x (F_x - m c''_model,x),   dL_x/dt -= kappa_y (F_y - m c''_model,y),
//     both sides through the same 20 ms low-pass as dL/dt;
//  2. Newton, c'' = F_xy / m: exact at high frequency, useless at low (an offset integrates twice; in 1. a force
//     offset is a constant, c_z offset / F_z).
// They are fused by a 4th-order complementary pair (D the Butterworth polynomial at w = 2 pi crossover_hz):
//        c_P = L(s) c_1 + H(s) (F / m) / s^2,   L = (a2 s^2 + a1 s + a0) / D,   H = 1 - L = s^3 (s + a3) / D,
// in observable canonical form, forward Euler at the control period:
//        x1' = -a3 x1 + x2,   x2' = -a2 x1 + x3 + a2 u + a,   x3' = -a1 x1 + x4 + a1 u + a3 a,   x4' = -a0 x1 + a0 u,
//        c_P = x1,  c_P' = -a3 x1 + x2.
// F and M are in the controller's world: BalanceController places each plate where its sole is (the sole's centre on
// the plate's reported origin, the identification's convention: docs/identification.md "Input pipelines"), so c_P is
// in that world. What the controller's CoM takes of it (`anchor`):
//  - model (the default): the model's CoM below 1 / (2 pi anchor_time_constant), c_P above (the model's bias stays,
//    for the online estimate to correct):  c = c_model + w HP(c_P - c_model),   HP = tau s / (tau s + 1);
//  - plates: all of it, right at every frequency, the model's error and a body it holds rigid (a wearer's trunk, its
//    slow lean included) with it:  c = c_model + w (c_P - c_model).
// c_model is the controller's (the URDF's, or blended toward the estimate's), w a smoothstep from 0 at settle_time to
// 1 at twice that, counted from the start of fusing (the pair's start-up transient decays first). Fusing needs both
// plates fresh and loaded (F_z above half the weight); otherwise it restarts. With `plates` the last correction is
// then held (it is mostly the model's static error, still right without the plates) and the restarted pair's blends
// in from it; with `model` the correction drops to 0 (its HP part has no static share).
// Allocation-free per tick.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>

#include "exoid/controller/config.hpp"
#include "exoid/model/model.hpp"

namespace exoid::controller {

/// The lever [2] (m, world x and y) of a body that the model holds rigid on the pelvis link but that turns on it
/// (a wearer's upper body on the lumbar joint: the model's frames "wearer_<segment>" above it and "wearer_lumbar",
/// model/wearer_mount.hpp upperBodyFromModel). A body of mass m, inertia I about its CoM, its CoM h above the
/// pivot and d above the system's CoM, turning by a small theta about the pivot's y axis, moves its CoM by h theta
/// along x: the model lacks the force dF_x = m h theta'' and, about the system's CoM, the angular momentum
/// dL_y = (I_yy + m d h) theta' (L = sum I_i w_i + m_i (c_i - c) x c_i'), so dL_y/dt = kappa_x dF_x with
///        kappa_x = I_yy / (m h) + d,   and about x:  dL_x/dt = -kappa_y dF_y,  kappa_y = I_xx / (m h) + d.
/// In the standing pose (the model's zero state: pelvis level), along the pelvis's x and y (ComObserver::setHeading
/// turns them into the world's). Zero where the model has no such body (the empty exoskeleton), so the observer is
/// then unchanged.
Eigen::Vector2d upperBodyLever(const Model& model);

class ComObserver {
 public:
  /// period: s, the control period; gravity: m/s^2, the model's (its norm), for the plates' load check.
  /// upper_body_lever [2] m: upperBodyLever of the controller's model where `upper_body_momentum` is set, else 0.
  ComObserver(const ComObserverConfig& config, double period, double gravity,
              const Eigen::Vector2d& upper_body_lever = Eigen::Vector2d::Zero());

  /// Forget the state and the correction: the next update restarts (e.g. the controller's world was just fixed).
  void reset() {
    started_ = fusing_ = false;
    delta_.setZero();
    delta_velocity_.setZero();
    held_.setZero();
    restart_hold_.setZero();
    weight_ = 0.0;
  }
  /// One tick. com_model, com_velocity_model [3] world: the controller's CoM and its velocity (the URDF's or blended
  /// with the estimate's); angular_momentum_urdf [3] world: the URDF model's angular momentum about its CoM;
  /// force, moment [3] world: the total contact force ON the robot and its moment about the world origin, as the
  /// plates measured them (nullptr: no usable plate pair this tick);
  /// mass kg; ticks_since_last >= 1.
  void update(const Eigen::Vector3d& com_model, const Eigen::Vector3d& com_velocity_model,
              const Eigen::Vector3d& angular_momentum_urdf, const Eigen::Vector3d* force,
              const Eigen::Vector3d* moment, double mass, int64_t ticks_since_last);
  /// m and m/s, world [3]: what to add to the controller's CoM and CoM velocity (z always 0; zero unless applies()).
  const Eigen::Vector3d& correction() const { return delta_; }
  const Eigen::Vector3d& velocityCorrection() const { return delta_velocity_; }
  /// rad: the pelvis's heading in the world (yaw about z), which turns the lever's axes into the world's:
  /// K = R_z diag(kappa_x, kappa_y) R_z^T on the missing force (0 until set).
  void setHeading(double yaw) {
    heading_cos_ = std::cos(yaw);
    heading_sin_ = std::sin(yaw);
  }
  /// m [2]: the lever in use, pelvis axes (zero: no upper body, or `upper_body_momentum` off).
  const Eigen::Vector2d& upperBodyLever() const { return lever_; }
  /// The moment balance's CoM c_1 and the fused plates' CoM c_P [3] (lab frame; z: the model's), the weight w of
  /// the last update.
  const Eigen::Vector3d& balanceCom() const { return balance_com_; }
  const Eigen::Vector3d& platesCom() const { return plates_com_; }
  double weight() const { return weight_; }
  /// Whether the last update fused the plates (false: disabled, no plates, or restarting).
  bool fusing() const { return fusing_; }
  /// Whether correction() is to be applied: fusing, or (anchor `plates`) holding the last correction.
  bool applies() const {
    return fusing_ || (cfg_.enabled && cfg_.anchor == ComObserverConfig::Anchor::kPlates && !held_.isZero());
  }

  /// s, time constant of the low-pass on the model's dL/dt and CoM acceleration (differences of the encoders'
  /// velocities) and on the plates' force beside the latter.
  static constexpr double kAngularMomentumRateTimeConstant = 0.02;
  /// Fusing needs the plates' vertical force above this fraction of the weight (feet on the plates).
  static constexpr double kMinLoadFraction = 0.5;

 private:
  ComObserverConfig cfg_;
  double period_, gravity_;
  double a0_ = 0.0, a1_ = 0.0, a2_ = 0.0, a3_ = 0.0;  // D(s) coefficients
  Eigen::Matrix<double, 4, 2> x_ = Eigen::Matrix<double, 4, 2>::Zero();  // the pair's states (rows) per axis x, y
  Eigen::Vector2d anchor_ = Eigen::Vector2d::Zero();      // m: anchor `model`: the low-passed c_P - c_model
  Eigen::Vector2d held_ = Eigen::Vector2d::Zero();        // m: anchor `plates`: the last correction applied
  Eigen::Vector2d restart_hold_ = Eigen::Vector2d::Zero();  // m: held_ when the pair last restarted
  Eigen::Vector2d lever_;                                 // m: upperBodyLever, or zero (pelvis axes)
  double heading_cos_ = 1.0, heading_sin_ = 0.0;           // the pelvis's heading (setHeading)
  Eigen::Vector3d previous_momentum_ = Eigen::Vector3d::Zero(), momentum_rate_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d previous_com_velocity_ = Eigen::Vector3d::Zero(), com_acceleration_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_low_passed_ = Eigen::Vector3d::Zero();  // N: the plates' force through the same low-pass
  Eigen::Vector3d balance_com_ = Eigen::Vector3d::Zero(), plates_com_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d delta_ = Eigen::Vector3d::Zero(), delta_velocity_ = Eigen::Vector3d::Zero();
  double fused_time_ = 0.0, weight_ = 0.0;
  bool started_ = false, fusing_ = false;
};

}  // namespace exoid::controller
