#pragma once
// Sim inputs read from YAML: the sensor noise model (config/sensors.yaml) and a scenario
// (config/scenarios/*.yaml). Loaders run once at startup; they report the first problem as one line
// "<file>: <key>: <what>" and never throw. Formats: docs/sim.md.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/model/anthropometry.hpp"
#include "exoid/model/passive_joint_moments.hpp"

namespace exoid::sim {

/// One-sigma Gaussian white noise of every sensor, per sample (1 kHz). Zero switches a sensor's noise off.
struct SensorConfig {
  double encoder_sigma = 0.0;                                 ///< rad
  double torque_sigma = 0.0;                                  ///< N m, joint torque sensors
  Eigen::Vector3d imu_orientation_sigma = Eigen::Vector3d::Zero();  ///< rad, rotation about world x, y, z
  double gyro_sigma = 0.0;                                    ///< rad/s, per axis
  double accel_sigma = 0.0;                                   ///< m/s^2, per axis
  Eigen::Vector3d plate_force_sigma = Eigen::Vector3d::Zero();   ///< N, plate x, y, z
  Eigen::Vector3d plate_moment_sigma = Eigen::Vector3d::Zero();  ///< N m, plate x, y, z
  double cop_min_force = 20.0;  ///< N: CoP is reported only while the normal load exceeds this (else 0)
  std::string source;           ///< file it was read from ("" = built in)
};

/// Reads a sensors file (every key required, unknown keys refused, sigmas finite and >= 0).
bool loadSensorConfig(const std::string& path, SensorConfig* out, std::string* err);
/// The same config with every sigma zero (cop_min_force kept).
SensorConfig noiseOff(const SensorConfig& config);

/// A per-joint value; name is a joint name or "all" (applied first; named joints override it).
struct JointValue {
  std::string joint;
  double value = 0.0;
};

/// A rigid mass added to a link (undeclared payload).
struct Payload {
  std::string link;
  double mass = 0.0;                                 ///< kg, > 0
  Eigen::Vector3d com = Eigen::Vector3d::Zero();     ///< its centre of mass, link frame, m
  Eigen::Matrix<double, 6, 1> inertia = Eigen::Matrix<double, 6, 1>::Zero();  ///< about its com, link frame:
                                                     ///< ixx iyy izz ixy ixz iyz (MJCF fullinertia order)
  double attach_at_s = 0.0;  ///< s of simulated time at which it is attached (0: from the start; docs/sim.md)
};

/// Torque sensor error: measured = gain * true + offset (before noise).
struct TorqueSensorError {
  std::string joint;  ///< joint name or "all"
  double offset = 0.0;  ///< N m
  double gain = 1.0;
};

/// effects.foot_placement: the largest offset per axis (m) that keeps a sole on its 60 x 20 cm plate.
inline constexpr double kMaxFootPlacement = 0.05;

/// Physics and sensor effects that the URDF (hence controller and estimator) does not know about.
/// Applied to the MuJoCo model / the sim's sensor model only.
struct Effects {
  std::vector<JointValue> joint_damping;       ///< N m s/rad (MuJoCo dof_damping), >= 0
  std::vector<JointValue> joint_frictionloss;  ///< N m (MuJoCo dof_frictionloss: dry friction), >= 0
  std::vector<JointValue> armature;            ///< kg m^2 (MuJoCo dof_armature: reflected rotor inertia), >= 0
  std::vector<Payload> payloads;
  std::vector<TorqueSensorError> torque_sensor;
  /// The drives close their torque loop on their (miscalibrated) torque sensors: they apply tau such that
  /// gain * tau + offset = the command, so the sensor errors become actuation errors. false: the drives apply
  /// the command exactly and the errors stay in the measurements.
  bool drive_loop_on_sensor = false;
  /// Where each sole's centre stands relative to its plate's sensor origin, lab x and y, m ([0] right, [1] left):
  /// a placement the lab did not measure (exoid assumes each sole centred on its plate unless told, e.g. `exoid
  /// identify --sole-on-plate`). The plate is moved by minus it, so the robot and the world stay where they were and
  /// the plate reports its own (moved) origin. |x|, |y| <= kMaxFootPlacement: the sole stays on its plate.
  std::array<Eigen::Vector2d, 2> foot_placement{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  bool any() const {
    return !joint_damping.empty() || !joint_frictionloss.empty() || !armature.empty() || !payloads.empty() ||
           !torque_sensor.empty() || !foot_placement[0].isZero() || !foot_placement[1].isZero();
  }
};

enum class NoiseMode { Realistic, Off, File };

struct InitialState {
  double base_height_offset = 0.0;  ///< m, added to the MJCF base height (standing: 0)
  std::vector<JointValue> joints;   ///< rad, initial joint angles (others 0); "all" not allowed
};

/// The pelvis held still in the air by a rigid harness, the feet hanging free above the plates: the set-up of a
/// calibration run (`exoid calibrate`, docs/sim.md "Harness"). Balancing data cannot tell a constant torque-sensor
/// offset from a first-moment shift of the links around its joint; legs swinging through large angles can.
struct Harness {
  bool enabled = false;
  double lift = 0.2;  ///< m the pelvis is raised above its standing height, so that the swinging feet clear the plates
};

/// The wearer's upper body (head, trunk above the navel, arms) on a 3-hinge lumbar joint on the pelvis
/// (docs/wearer.md).
struct WearerTrunk {
  Eigen::Vector3d stiffness = Eigen::Vector3d::Zero();  ///< N m/rad about the pelvis's x (roll), y (pitch), z (yaw)
  Eigen::Vector3d damping = Eigen::Vector3d::Zero();    ///< N m s/rad, same axes
  double sway_rms = 0.0;        ///< N m per axis: active sway torque, low-pass filtered Gaussian noise (0: passive)
  double sway_cutoff_hz = 0.5;  ///< its first-order low-pass corner
};

/// Spasm / reflex torque bursts on the wearer's leg joints (hip flexion, knee, ankle dorsiflexion, either leg).
struct WearerReflex {
  double rate_hz = 0.0;     ///< mean bursts per second (Poisson onsets; 0: none)
  double amplitude = 0.0;   ///< N m, peak of the half-sine burst, random sign
  double duration_s = 0.3;  ///< of one burst
};

/// YAML `wearer:` (docs/wearer.md): a person strapped into the exoskeleton, unknown to the URDF.
struct WearerConfig {
  bool enabled = false;
  WearerSpec spec;                 ///< mass_kg, height_m, sex, seed, variation
  WearerTrunk trunk;
  bool passive_moments = true;     ///< Riener & Edrich 1999 elastic + damping on hip/knee/ankle (sagittal)
  PassiveJointDamping joint_damping;  ///< N m s/rad (hip, knee, ankle)
  WearerReflex reflex;
};

struct Scenario {
  std::string name = "default";
  std::string description;
  uint64_t seed = 1;                  ///< noise RNG seed
  NoiseMode noise = NoiseMode::Realistic;
  std::string noise_file;             ///< NoiseMode::File: sensors file (resolved against the scenario's dir)
  Effects effects;
  InitialState initial;
  Harness harness;                    ///< YAML `harness: {lift: 0.2}` (present: enabled)
  WearerConfig wearer;                ///< YAML `wearer: {...}` (present: enabled)
  std::string source;                 ///< file it was read from ("" = built-in default)
};

/// Reads a scenario file. Joint/link names are checked later, by simLoad (it knows the model).
bool loadScenario(const std::string& path, Scenario* out, std::string* err);

/// The noise a scenario asks for: Realistic -> `realistic`, Off -> noiseOff(realistic), File -> that file.
bool resolveSensorConfig(const Scenario& scenario, const SensorConfig& realistic, SensorConfig* out,
                         std::string* err);

}  // namespace exoid::sim
