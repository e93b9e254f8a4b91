#pragma once
// Floating-base state from the robot's own sensors only (no simulator ground truth):
//  - base orientation: complementary filter of the gyro (integrated) and the IMU orientation,
//    R <- R Exp(omega dt), then R <- R Exp(alpha Log(R^T R_imu)), alpha = dt / (tau + dt) (tau = 0: raw IMU);
//  - base angular velocity: the gyro (optionally 2nd-order low-pass), rotated into the base frame;
//  - joint velocities: backward difference of the encoders through a 2nd-order Butterworth low-pass;
//  - base position and linear velocity: leg kinematics with both soles stationary. The sole poses are
//    latched in the world at start-up, after latch_ticks samples during which the orientation estimate is the
//    running mean of the IMU orientation (world x-y origin chosen so the base is at
//    ObserverConfig::initial_base_xy, height so the soles are at ground_height), then
//      p_b = mean_i (p_i^latched - R p_i^b),   v_b = mean_i -(omega x p_i^b + J_i,q dq)   (base coordinates).
// Output: exoid::State (conventions of model.hpp: base velocities in base coordinates).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <string>

#include "exoid/controller/config.hpp"
#include "exoid/signal/filters.hpp"
#include "exoid/model/model.hpp"
#include "exoid/samples.hpp"

namespace exoid::controller {

/// A sole frame resolved on the model: body and placement of the frame in body coordinates.
struct SoleFrame {
  int body = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< frame origin, body coordinates
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< body <- frame
};

/// Resolves a URDF frame by name (a fixed-joint link lumped into a body, or a body itself).
bool resolveSoleFrame(const Model& model, const std::string& name, SoleFrame& out, std::string* error);

/// The frames the balance controller gives its observer: the soles of `contact` (right, left) and the IMU ("imu" if
/// the model has that frame, the base frame otherwise; it must be on the base body). False with *error otherwise.
bool resolveObserverFrames(const Model& model, const ContactConfig& contact, std::array<SoleFrame, 2>& soles,
                           SoleFrame& imu, std::string* error);

class BaseStateObserver {
 public:
  static constexpr int kRight = 0;
  static constexpr int kLeft = 1;

  /// Setup (allocates). `imu_frame` names the URDF frame of the IMU ("" = the base frame itself).
  BaseStateObserver(const Model& model, const ObserverConfig& config, double period,
                     const std::array<SoleFrame, 2>& soles, const SoleFrame& imu);

  /// Forget everything (next update() starts over, re-latching the feet).
  void reset();

  /// Folds in one sample that passed the input checks. `ticks_since_last` >= 1 is the number of control
  /// periods since the previous update (ignored on the first). Allocation-free.
  void update(const RobotStateSample& sample, int64_t ticks_since_last);

  bool initialized() const { return samples_ > 0; }
  /// True once the sole poses are latched (after ObserverConfig::latch_ticks samples).
  bool latched() const { return latched_; }
  const State& state() const { return state_; }
  /// Rotation world <- base.
  const Eigen::Matrix3d& baseRotation() const { return R_; }
  /// Latched (or, before latching, provisional) sole poses in the world.
  const Eigen::Vector3d& solePosition(int foot) const { return sole_pos_[static_cast<size_t>(foot)]; }
  const Eigen::Matrix3d& soleRotation(int foot) const { return sole_rot_[static_cast<size_t>(foot)]; }
  /// Start-up posture (joint encoders of the first sample).
  const Eigen::VectorXd& initialPosture() const { return q0_; }
  /// Half the disagreement of the two legs about the base position (m): a slip / model-error indicator.
  double legDisagreement() const { return leg_disagreement_; }

 private:
  void footKinematics();  // fills sole_b_, Rsole_b_, J_ for the current q
  // The stages of update(), in order:
  /// Orientation (gyro prediction corrected toward the IMU's, complementary) and angular velocity, base frame.
  void updateOrientation(const RobotStateSample& sample, bool first, double dt);
  /// Joint positions, and velocities by filtered differences over dt.
  void updateJoints(const RobotStateSample& sample, bool first, double dt);
  /// Base position and linear velocity from the stationary soles (latched at the end of the start-up window).
  void updateBaseFromSoles();

  const Model& model_;
  ObserverConfig cfg_;
  double period_;
  std::array<SoleFrame, 2> soles_;
  SoleFrame imu_;

  LowPassFilter dq_filter_, gyro_filter_;
  Data kin_;
  State kin_state_;  // q only (velocities/accelerations zero) for the kinematics
  Eigen::Matrix<double, 6, Eigen::Dynamic> J_;
  std::array<Eigen::Vector3d, 2> sole_b_{};  // sole origin, base coordinates
  std::array<Eigen::Matrix3d, 2> Rsole_b_{};  // base <- sole

  State state_;
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Quaterniond quat_ = Eigen::Quaterniond::Identity();
  Eigen::VectorXd q_prev_, dq_raw_, q0_;
  Eigen::Vector3d gyro_base_ = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, 2> sole_pos_{};
  std::array<Eigen::Matrix3d, 2> sole_rot_{};
  int64_t samples_ = 0;
  bool latched_ = false;
  double leg_disagreement_ = 0.0;
};

}  // namespace exoid::controller
