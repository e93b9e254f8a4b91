#pragma once
// Configuration of the balance controller (config/controller.yaml, documented there and in docs/controller.md).
// Plain data: no defaults that matter live here — every value the controller uses is read from the YAML file
// (loadControllerConfig fails, naming the field, when one is missing). The in-class initialisers only make a
// default-constructed struct well defined for tests that fill it field by field.
#include <Eigen/Core>
#include <string>

namespace exoid::controller {

/// Timing of the control loop.
struct LoopConfig {
  double period = 0.0;  ///< s, control tick period (1 kHz -> 0.001)
};

/// CoM move protocol (seed thesis section IV-A): straight-line moves inside the support polygon.
struct TrajectoryConfig {
  int moves = 0;                  ///< number of moves
  double move_duration = 0.0;     ///< s, duration of one move (cubic time law)
  double hold_duration = 0.0;     ///< s, rest at each target after a move
  double initial_hold = 0.0;      ///< s, rest at the start-up CoM before the first move
  double final_hold = 0.0;        ///< s, rest after the last move before exo_controller exits
  double polygon_margin = 0.0;    ///< m, inward offset of the support polygon edges for the targets
  double min_move_distance = 0.0; ///< m, minimum horizontal distance between consecutive targets
  double max_move_distance = 0.0; ///< m, maximum horizontal distance between consecutive targets
  /// Fraction of the carrying joints' effort limits a target's static moment may ask (move_reach.hpp); 0: none
  double torque_budget = 0.0;
  double vertical_min = 0.0;      ///< m, lower bound of the target height offset from the start-up CoM
  double vertical_max = 0.0;      ///< m, upper bound of the target height offset from the start-up CoM
  int max_sampling_attempts = 0;  ///< rejection-sampling attempts per target before giving up
};

/// Base state estimation from IMU + encoders + stationary-feet kinematics.
struct ObserverConfig {
  double joint_velocity_cutoff_hz = 0.0;  ///< Hz, 2nd-order Butterworth on the encoder backward difference
  double gyro_cutoff_hz = 0.0;            ///< Hz, 2nd-order Butterworth on the gyro (0: unfiltered)
  double orientation_time_constant = 0.0; ///< s, complementary filter gyro/IMU orientation (0: raw IMU)
  Eigen::Vector2d initial_base_xy = Eigen::Vector2d::Zero();  ///< m, world x, y of the base at start-up
  double ground_height = 0.0;             ///< m, world z of the soles at start-up
  int latch_ticks = 0;                    ///< ticks averaged to latch the foot poses at start-up (>= 1)
};

/// Centroidal momentum task: CoM PD + angular momentum damping.
struct MomentumTaskConfig {
  Eigen::Vector3d kp_com = Eigen::Vector3d::Zero();  ///< 1/s^2, CoM position gain (world x, y, z)
  Eigen::Vector3d kd_com = Eigen::Vector3d::Zero();  ///< 1/s, CoM velocity gain
  Eigen::Vector3d kd_angular = Eigen::Vector3d::Zero();  ///< 1/s, angular momentum damping K_L
  Eigen::Vector3d weight_linear = Eigen::Vector3d::Zero();   ///< 1/N^2, weight of the linear rate error
  Eigen::Vector3d weight_angular = Eigen::Vector3d::Zero();  ///< 1/(N m)^2, weight of the angular rate error
};

/// Posture regularisation on dnu.
struct PostureConfig {
  double weight_joint = 0.0;  ///< weight of the joint acceleration error, 1/(rad/s^2)^2
  double weight_base = 0.0;   ///< weight of the base acceleration (toward zero), SI^-2
  double kp = 0.0;            ///< 1/s^2, pull of the joints toward the start-up posture
  double kd = 0.0;            ///< 1/s, joint velocity damping
};

/// Rigid stationary foot contacts (both feet).
struct ContactConfig {
  std::string right_sole_frame;   ///< URDF frame at the right sole centre
  std::string left_sole_frame;    ///< URDF frame at the left sole centre
  double friction_coefficient = 0.0;  ///< pyramid coefficient (|f_t| <= mu f_n per tangent axis)
  double sole_half_length = 0.0;  ///< m, half length of the sole rectangle along the sole x axis
  double sole_half_width = 0.0;   ///< m, half width along the sole y axis
  double cop_margin = 0.0;        ///< m, the CoP is kept this far inside the sole rectangle
  double min_normal_force = 0.0;  ///< N, lower bound of each foot's normal force
  double yaw_moment_coefficient = 0.0;  ///< m, |m_z| <= coef * f_n (torsional friction bound)
  double kp = 0.0;                ///< 1/s^2, foot pose error feedback in the acceleration constraint
  double kd = 0.0;                ///< 1/s, foot velocity error feedback
  double force_weight = 0.0;      ///< weight of the contact wrench regularisation, 1/N^2 (and 1/(N m)^2)
  double range_tolerance = 0.0;   ///< singular values of the stacked foot Jacobian below this are treated as 0
};

/// Actuator limits.
struct TorqueConfig {
  double limit_scale = 0.0;  ///< fraction of the URDF effort limits used as the QP's torque bounds
};

/// QP solver settings.
struct SolverConfig {
  double eps_abs = 0.0;    ///< absolute primal/dual residual tolerance
  int max_iterations = 0;  ///< iteration cap (bounds the solve time)
};

/// Input checking and the safe fallback.
struct FallbackConfig {
  int hold_ticks = 0;             ///< ticks the last safe command is held before switching to damping
  double damping = 0.0;           ///< N m s/rad, joint damping gain D of the damping mode (tau = -D v)
  double damping_torque_limit = 0.0;  ///< N m, bound of each damping torque
  int recovery_ticks = 0;         ///< consecutive good ticks needed to leave the damping mode
  int max_missed_ticks = 0;       ///< a gap of more ticks than this since the last good input is stale
  double max_quaternion_norm_error = 0.0;  ///< | |q| - 1 | above this rejects the IMU orientation
};

/// The online estimator's output (EXO_ESTIMATE) in the control law (docs/controller.md, "Using the estimate").
struct EstimateConfig {
  bool enabled = false;          ///< accept estimates at all (setEstimate refuses every one otherwise)
  bool use_feedforward = false;  ///< its tau_correction [nv] enters the QP's dynamics (h + tau_correction), base rows too
  bool use_com = false;          ///< its parameters give the CoM and centroidal momentum of the momentum task
  /// with use_com: also the CoM height (and its rate), which then moves the reference height; off: the model's
  /// height, the estimate's horizontal CoM (docs/controller.md, "Using the online estimate")
  bool use_com_height = true;
  double max_abs = 0.0;          ///< N, N m: bound of each feedforward component
  int max_age_ticks = 0;         ///< an estimate older than this many ticks is withdrawn
  /// The estimate of tick e is applied at the state of tick e + lag_ticks (the newest one with e <= k - lag_ticks
  /// at tick k), whenever it arrived before: runs do not depend on scheduling (docs/controller.md "The fixed lag").
  int lag_ticks = 0;
  double blend_time = 0.0;       ///< s, switching in and out blends over this time (0: at once)
  double max_relative_mass_change = 0.0;  ///< refuse an estimate whose total mass differs more from the model's
  /// Each quantity the estimate changes (every tau_correction entry, the mass, the CoM height; the horizontal CoM
  /// with trust_sigmas_horizontal_com) is
  /// used only as far as its change from the model stands out of the estimate's own one-sigma uncertainty:
  /// weight max(0, 1 - (k sigma / |change|)^2) with k = trust_sigmas; 0: everything used as it is
  /// (docs/controller.md, "Trust").
  double trust_sigmas = 0.0;
  /// k of the same rule for the CoM's horizontal axes (x, y and their velocity and momentum), which set the
  /// balance: 0 (shipped) uses the estimate's horizontal CoM as it is; k = 1 is the positive-part James-Stein weight
  /// (docs/controller.md, "Trust").
  double trust_sigmas_horizontal_com = 0.0;
};

/// Disturbance observer: the generalized force the model misses (docs/controller.md, "Model error").
struct DisturbanceConfig {
  bool enabled = false;        ///< add the estimate to the dynamics of the QP (h + d)
  double time_constant = 0.0;  ///< s, time constant of the estimate's convergence
  double max_abs = 0.0;        ///< N, N m: bound of each component of the estimate
  bool force_plates = false;   ///< also compare the measured contact wrenches (force plates) with the planned
  int max_plate_age_ticks = 0; ///< a plate sample older than this many ticks is not used
};

/// Horizontal CoM observer: the CoM the force plates measure, fused with the model's (com_observer.hpp;
/// docs/controller.md, "The CoM observer").
struct ComObserverConfig {
  /// What the controller's CoM follows at low frequency (com_observer.hpp).
  enum class Anchor {
    kPlates,  ///< the plates' CoM at every frequency, placed in the controller's world by its latched soles
    kModel,   ///< the model's CoM below 1 / (2 pi anchor_time_constant), the plates' above
  };
  bool enabled = false;               ///< the controller's horizontal CoM takes the plates' correction
  Anchor anchor = Anchor::kModel;
  bool upper_body_momentum = false;   ///< the moment balance takes the upper body's turning (upperBodyLever)
  double crossover_hz = 0.0;          ///< Hz: the plates' moment balance below, their acceleration above
  double anchor_time_constant = 0.0;  ///< s: with Anchor::kModel, the model's CoM below 1 / (2 pi this)
  double settle_time = 0.0;           ///< s of fusing before the correction enters (in fully at twice this)
};

struct ControllerConfig {
  LoopConfig loop;
  TrajectoryConfig trajectory;
  ObserverConfig observer;  ///< base state observer (config section observer:)
  MomentumTaskConfig momentum;
  PostureConfig posture;
  ContactConfig contact;
  TorqueConfig torque;
  SolverConfig solver;
  FallbackConfig fallback;
  EstimateConfig estimate;
  DisturbanceConfig disturbance;
  ComObserverConfig com_observer;
};

/// Reads and validates a controller configuration file. Returns false with a one-line message naming the
/// offending field (e.g. "config/controller.yaml: momentum.kp_com: expected 3 numbers") in *error.
/// Unknown keys are errors (typos must not silently fall back to something). Setup-time only (allocates).
bool loadControllerConfig(const std::string& path, ControllerConfig& config, std::string* error);
/// Same, from YAML text; `source` names it in messages.
bool parseControllerConfig(const std::string& yaml, const std::string& source, ControllerConfig& config,
                           std::string* error);
/// Range checks of an already filled configuration (also run by the loaders).
bool validateControllerConfig(const ControllerConfig& config, std::string* error);
/// Whether the controller reads the force plates: the disturbance observer with force_plates, or the CoM observer.
inline bool usesForcePlates(const ControllerConfig& c) {
  return (c.disturbance.enabled && c.disturbance.force_plates) || c.com_observer.enabled;
}

}  // namespace exoid::controller
