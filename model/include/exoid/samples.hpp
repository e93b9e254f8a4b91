#pragma once
// Plain, transport-free samples exchanged between sim, controller and estimator. LCM appears only in the
// adapters (lcmtypes/adapters); algorithms take and return these. Units SI; conventions docs/conventions.md.
// Vectors are sized once (resize on setup), so filling a sample in a loop does not allocate.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

namespace exoid {

/// Robot sensors at one tick (exoid_lcm.robot_state_t). Joint arrays follow Model joint order.
struct RobotStateSample {
  int64_t utime = 0;  ///< simulated (or wall) time of the sample, microseconds
  int64_t tick = 0;   ///< control tick the sample belongs to
  Eigen::VectorXd q;         ///< [njoints] joint encoders, rad
  Eigen::VectorXd tau;       ///< [njoints] joint torque sensors, N m (0 where has_tau is false)
  Eigen::Matrix<bool, Eigen::Dynamic, 1> has_tau;  ///< [njoints] joint has a torque sensor
  Eigen::Quaterniond imu_orientation = Eigen::Quaterniond::Identity();  ///< world <- IMU, Hamilton
  Eigen::Vector3d imu_gyro = Eigen::Vector3d::Zero();   ///< angular velocity, IMU coordinates, rad/s
  Eigen::Vector3d imu_accel = Eigen::Vector3d::Zero();  ///< specific force (a - g), IMU coordinates, m/s^2
};

/// One 6-axis force plate at one tick (exoid_lcm.force_plate_t): what the plate's own sensor reports.
struct ForcePlateSample {
  int64_t utime = 0;
  int64_t tick = 0;
  int plate = 0;  ///< 0 right, 1 left
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< force applied ON the plate, plate frame, N
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< moment ON the plate about the sensor origin, plate frame
  Eigen::Vector3d cop = Eigen::Vector3d::Zero();     ///< centre of pressure on the top surface, plate frame
  Eigen::Vector3d plate_position = Eigen::Vector3d::Zero();  ///< sensor origin in world
  Eigen::Quaterniond plate_orientation = Eigen::Quaterniond::Identity();  ///< world <- plate
};

/// Controller -> robot (exoid_lcm.joint_command_t).
enum class CommandMode : int8_t { Torque = 0, HoldLastSafe = 1, Damping = 2, Off = 3 };
struct JointCommandSample {
  int64_t utime = 0;
  int64_t tick = 0;          ///< tick at which the command is to be applied
  int64_t source_tick = 0;   ///< tick of the state it was computed from
  CommandMode mode = CommandMode::Torque;
  Eigen::VectorXd tau;       ///< [njoints] total joint torque command, N m (0 on unactuated joints)
  Eigen::VectorXd tau_ff;    ///< [njoints] feedforward part (from the estimated model), N m
};

/// Exact simulator state at one tick, for validation only (exoid_lcm.ground_truth_t).
struct GroundTruthSample {
  int64_t utime = 0;
  int64_t tick = 0;
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();        ///< world
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< world <- base
  Eigen::Vector3d base_omega = Eigen::Vector3d::Zero();           ///< base coordinates
  Eigen::Vector3d base_velocity = Eigen::Vector3d::Zero();        ///< base origin, base coordinates
  Eigen::Vector3d base_domega = Eigen::Vector3d::Zero();          ///< base coordinates
  Eigen::Vector3d base_acceleration = Eigen::Vector3d::Zero();    ///< classical, base coords, gravity excluded
  Eigen::VectorXd q, v, a;       ///< [njoints]
  Eigen::VectorXd tau_applied;   ///< [njoints] actuator torque applied this tick, N m
  std::array<Eigen::Vector3d, 2> foot_force;   ///< [right, left] contact force ON the foot, world
  std::array<Eigen::Vector3d, 2> foot_moment;  ///< [right, left] its moment about the world origin, world
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  ///< whole-robot CoM, world (the simulated robot: with payloads)
};

}  // namespace exoid
