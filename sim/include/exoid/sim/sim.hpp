#pragma once
// The exoskeleton simulator as a flat pipeline (MuJoCo style): a constant SimModel built once by simLoad,
// a mutable SimData sized once by simMakeData, and simStep, which advances one 1 ms control tick and fills
// every sample of that tick. simStep and its stages never allocate and never throw.
//
// Timing of tick k (docs/sim.md): mj_step1 (kinematics, velocity-stage sensors at x_k) -> record q_k, v_k
// -> ctrl = command u_k -> mj_step2 (qacc_k, constraint forces, acceleration-stage sensors, then Euler to
// x_{k+1}) -> build the samples of tick k from step1/step2 results. utime = k * 1000 (simulated us).
//
// Conventions: world x forward, y left, z up; quaternions Hamilton w,x,y,z. Free joint: qvel[0:3] linear
// velocity of the base origin in WORLD, qvel[3:6] angular velocity in BODY coordinates. Joint arrays of the
// samples are in MJCF hinge order (= URDF / exoid::Model joint order for config/exo.xml).
#include <mujoco/mujoco.h>

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "exoid/model/wearer_mount.hpp"
#include "exoid/samples.hpp"
#include "exoid/sim/config.hpp"

namespace exoid::sim {

inline constexpr int kNumFeet = 2;  ///< index 0 right, 1 left (also the force plate index)
inline constexpr double kFallDrop = 0.25;  ///< m: the robot "fell" when its base dropped more than this
/// Scenario::harness: kg added to the pelvis (and kg m^2 to each of its principal moments), so that the legs'
/// reactions move it by ~1e-6 m and ~1e-6 rad: the legs see a fixed base to ~1e-4 of their torques. The harness
/// wrench (stageHarness) carries the whole weight at the system's CoM. A heavy base rather than a weld: MuJoCo's
/// equality constraints are soft, and their compliance would put base motion into the joint torques.
inline constexpr double kHarnessMass = 1e6;
/// Scenario::harness: the unactuated joints (the passive ankle in/eversion) are pinned by a spring-damper, as a
/// lab pins them for a calibration: free, a foot dangling on its ankle's long axis spins round (it turned 14 rad
/// in a 40 s swing). The pin's torque is not measured: those joints' rows of a held-base run are left out
/// (estimator::heldBaseRowMeasured).
inline constexpr double kHarnessPinStiffness = 20.0;  ///< N m/rad (a foot of ~0.005 kg m^2: ~10 Hz)
inline constexpr double kHarnessPinDamping = 0.6;     ///< N m s/rad (about critical)

/// Names the sim looks up in the MJCF (its contract with tools/model/gen_exo_model.py).
struct SimNames {
  std::string imu_site = "imu";
  std::array<std::string, kNumFeet> foot_geom = {"right_sole", "left_sole"};
  std::array<std::string, kNumFeet> plate_site = {"right_plate_sensor", "left_plate_sensor"};
};

struct SimOptions {
  double damping_gain = 5.0;  ///< N m s/rad: the drives' own damping in CommandMode::Damping (tau = -d v)
  SimNames names;
};

/// Owning, move-only handle of a MuJoCo object (mjModel, mjData): frees it with `Free`, converts to the raw
/// pointer for MuJoCo's C API. Lets the structs below use the compiler's moves instead of field lists.
template <class T, void (*Free)(T*)>
class MjOwned {
 public:
  MjOwned() = default;
  ~MjOwned() { reset(); }
  MjOwned(const MjOwned&) = delete;
  MjOwned& operator=(const MjOwned&) = delete;
  MjOwned(MjOwned&& o) noexcept : p_(o.p_) { o.p_ = nullptr; }
  MjOwned& operator=(MjOwned&& o) noexcept {
    if (this != &o) reset(), p_ = o.p_, o.p_ = nullptr;
    return *this;
  }
  MjOwned& operator=(T* p) noexcept {  ///< takes ownership
    reset();
    p_ = p;
    return *this;
  }
  operator T*() const { return p_; }
  T* operator->() const { return p_; }
  void reset() {
    if (p_) Free(p_);
    p_ = nullptr;
  }

 private:
  T* p_ = nullptr;
};

/// Scenario::wearer in the MuJoCo model (docs/wearer.md "In the simulation"): the wearer's segments are bodies welded
/// to the exo links they ride on, its upper body sits on three lumbar hinges ("wearer_lumbar_x/y/z", not exo joints:
/// left out of the samples' joint arrays), and stageWearer applies the passive leg moments, the sway and the reflexes.
struct WearerSim {
  bool enabled = false;
  Wearer wearer;                       ///< the simulated person (de Leva + variation)
  WearerMount mount;                   ///< its segments on the exo links (pelvis-frame lumbar pivot)
  MountedSegment upper_body;           ///< the lumped body on the lumbar joint
  std::array<int, 3> lumbar_qpos{}, lumbar_dof{};  ///< x, y, z hinges
  int upper_body_id = -1;              ///< its MuJoCo body id (the truth's trunk_com)
  std::array<std::array<int, 3>, 2> leg_qpos{}, leg_dof{};  ///< [right, left][hip_fe, knee, ankle_pd]
  double sway_decay = 0.0;             ///< exp(-2 pi fc h): first-order low-pass of the sway torque per tick
};

/// Constant description: the MuJoCo model with the scenario's effects applied, and every id the pipeline
/// needs. Owns m (RAII); movable, not copyable.
struct SimModel {
  MjOwned<mjModel, mj_deleteModel> m;
  std::string mjcf_path;
  SimOptions options;
  Scenario scenario;
  SensorConfig noise;  ///< effective noise (already resolved from the scenario)

  int nj = 0;                            ///< hinge joints
  std::vector<std::string> joint_names;  ///< [nj] MJCF hinge order
  std::vector<int> joint_id;             ///< [nj] MuJoCo joint id
  std::vector<int> qpos_adr;             ///< [nj]
  std::vector<int> dof_adr;              ///< [nj]
  std::vector<int> actuator;             ///< [nj] motor driving the joint, -1 if unactuated
  std::vector<double> gear;              ///< [nj] joint torque per unit ctrl (0 if unactuated)
  std::vector<int> torque_sensor_adr;    ///< [nj] sensordata address of its actuatorfrc sensor, -1 if none
  std::vector<double> torque_gain;       ///< [nj] torque sensor error: measured = gain * true + offset
  std::vector<double> torque_offset;     ///< [nj] N m

  int base_body = -1, base_qpos = -1, base_dof = -1;  ///< free joint of the root body
  int imu_site = -1, imu_quat_adr = -1, imu_gyro_adr = -1, imu_accel_adr = -1;
  std::array<int, kNumFeet> foot_geom{};        ///< [2] sole geoms (right, left; all [2] arrays below too)
  std::array<int, kNumFeet> plate_site{};       ///< sensor sites (plate frame = site frame)
  std::array<int, kNumFeet> plate_force_adr{};  ///< sensordata address of the <force> sensor
  std::array<int, kNumFeet> plate_torque_adr{}; ///< sensordata address of the <torque> sensor
  std::array<Eigen::Vector3d, kNumFeet> plate_tare_force;   ///< raw reading of the unloaded plate, site frame
  std::array<Eigen::Vector3d, kNumFeet> plate_tare_torque;  ///< raw reading of the unloaded plate, site frame

  std::vector<double> qpos_init;  ///< [nq] initial configuration (MJCF qpos0 + scenario initial_state)
  double harness_mass = 0.0;      ///< kg added to the base by Scenario::harness (kHarnessMass, else 0)
  WearerSim wearer;               ///< Scenario::wearer (enabled = false: none)

  /// Payloads attached mid-run (effects.payload attach_at_s > 0): simStep composes each into its link at the
  /// start of its tick, changing the mjModel in place (the one part of SimModel a run changes); simReset
  /// restores the inertial arrays saved here (the model before any timed payload).
  struct TimedPayload {
    int body = -1;
    int64_t tick = 0;  ///< first tick simulated with it: round(attach_at_s / timestep)
    Payload payload;
  };
  std::vector<TimedPayload> timed_payloads;
  std::vector<double> body_mass0, body_ipos0, body_iquat0, body_inertia0, body_subtreemass0;
};

/// Counters of one run.
struct SimStats {
  int64_t ticks = 0;               ///< simStep calls since reset
  int64_t rejected_commands = 0;   ///< commands refused by simStep (wrong size, non-finite): previous ctrl held
  int64_t clamped_commands = 0;    ///< commands with at least one torque clamped to the actuator range
  int64_t mujoco_warnings = 0;     ///< MuJoCo warnings raised (e.g. bad qacc: MuJoCo then resets the state)
  int payloads_attached = 0;       ///< timed payloads attached so far (SimModel::timed_payloads)
};

/// Mutable state: mjData, the noise generator, and the samples of the last tick (sized once).
struct SimData {
  MjOwned<mjData, mj_deleteData> d;
  std::mt19937_64 rng;          ///< noise source, seeded from Scenario::seed on reset
  bool has_spare_normal = false;
  double spare_normal = 0.0;    ///< second output of the last Box-Muller draw

  int64_t tick = 0;             ///< tick that the next simStep simulates
  RobotStateSample state;       ///< samples of the last simulated tick
  std::array<ForcePlateSample, kNumFeet> plates;  ///< [2] right, left
  GroundTruthSample truth;
  std::vector<double> ctrl_prev;  ///< [nu] ctrl applied at the previous tick (held on a refused command)
  std::array<int, mjNWARNING> warnings_seen{};  ///< [mjNWARNING] MuJoCo warning counts already accounted for
  double initial_base_height = 0.0;  ///< m, base height at reset
  SimStats stats;

  /// Scenario::wearer's state: its own generator (seeded from the wearer's seed, so that the sensor noise is the
  /// same draw with or without a wearer), the sway torque's filter state, the current reflex burst, and the
  /// passive, sway and reflex torques applied at the last tick (qfrc_applied; not measured by the torque sensors).
  struct WearerState {
    std::mt19937_64 rng;
    Eigen::Vector3d sway = Eigen::Vector3d::Zero();   ///< N m about the lumbar x, y, z hinges
    int reflex_joint = -1;                            ///< 0..5: [right, left] x [hip, knee, ankle]; -1 none
    int64_t reflex_start = 0, reflex_ticks = 0;
    double reflex_sign = 1.0;
    int reflexes = 0;                                 ///< bursts started since reset
    std::array<LegJoints, 2> passive{LegJoints::Zero(), LegJoints::Zero()};  ///< [right, left] N m
    std::array<LegJoints, 2> reflex{LegJoints::Zero(), LegJoints::Zero()};
  } wearer;
};

/// Loads and compiles the MJCF, checks the sim's contract (one free joint on the root body, hinge joints,
/// joint motors, the IMU and plate sensors, sole geoms, static plates), applies the scenario's effects to
/// the MuJoCo model and tares the plates. `noise` is the effective sensor config (see resolveSensorConfig).
/// With Scenario::wearer the MJCF is recompiled with the wearer's bodies and lumbar hinges (WearerSim).
/// On failure: false and one line in *err naming the file and field.
bool simLoad(const std::string& mjcf_path, const SensorConfig& noise, const Scenario& scenario, SimModel& out,
             std::string* err, const SimOptions& options = SimOptions());

/// Allocates mjData and the samples for `model`, then simReset. False (and *err) if MuJoCo cannot allocate.
bool simMakeData(const SimModel& model, SimData& data, std::string* err);

/// Initial state of the scenario (velocities 0), tick 0, counters 0, RNG reseeded. With a harness the pelvis
/// starts Harness::lift above its standing height.
void simReset(const SimModel& model, SimData& data);

/// A zero-torque command sized for the model (for tick 0 and fallbacks). Allocates: call on setup.
JointCommandSample simZeroCommand(const SimModel& model);

/// Simulates tick data.tick with `command` and fills data.state, data.plates, data.truth for that tick,
/// then increments data.tick. A command with the wrong size or a non-finite torque is refused (counted; the
/// previous tick's ctrl is held); torques are clamped to the actuator ranges (counted). Modes: Torque
/// applies tau, HoldLastSafe holds the previous ctrl, Damping applies -damping_gain * v, Off applies 0.
/// Returns false if the command was refused. Allocation-free.
bool simStep(const SimModel& model, SimData& data, const JointCommandSample& command);

/// True if the base dropped more than kFallDrop below its initial height.
bool simFell(const SimModel& model, const SimData& data);

// --- stages, in the order simStep runs them (exposed for tests) -----------------------------------------
/// After mj_step1: ground truth q_k, v_k and the base pose/velocity (conventions above).
void stageRecordState(const SimModel& model, SimData& data);
/// After mj_step1, Scenario::harness only: the harness wrench on the base, -(subtree mass) g through the system's
/// CoM (xfrc_applied), so that the held robot neither falls nor turns. No-op without a harness.
void stageHarness(const SimModel& model, SimData& data);
/// After mj_step1, Scenario::wearer only: qfrc_applied on the exo's hip flexion, knee and ankle dorsiflexion dofs =
/// the wearer's passive moments (Riener & Edrich + damping) plus any reflex burst; on the lumbar hinges the active
/// sway torque. No-op without a wearer. Allocation-free.
void stageWearer(const SimModel& model, SimData& data);
/// Validates/clamps the command into d->ctrl. Returns false if refused.
bool stageControl(const SimModel& model, SimData& data, const JointCommandSample& command);
/// After mj_step2: qacc_k, applied torques, per-foot contact wrenches from MuJoCo's contacts.
void stageTruth(const SimModel& model, SimData& data);
/// Encoders, joint torque sensors (with sensor errors), IMU; noise added.
void stageRobotSensors(const SimModel& model, SimData& data);
/// Plate load cells: tared, as force/moment ON the plate about the sensor origin, plate frame; noise; CoP.
void stagePlates(const SimModel& model, SimData& data);

/// One standard normal draw from data's generator (Box-Muller on mt19937_64: identical on every platform).
double simGaussian(SimData& data);

}  // namespace exoid::sim
