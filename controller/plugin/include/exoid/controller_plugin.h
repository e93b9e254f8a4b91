/* exoid controller plugin ABI, version 3 (docs/plugin.md; version 2 added the force plates, version 3 the
 * whole online estimate in place of the joint feedforward).
 *
 * A controller plugin is a shared library that exports one C function,
 *
 *     const exoid_controller_plugin_api* exoid_controller_plugin(void);
 *
 * returning a static table of function pointers. The host (exo_sim --controller-plugin PATH) dlopens the
 * library, checks abi_version and the four struct sizes against its own, then calls
 *
 *     create -> reset -> { [tick -> status] -> set_force_plates }*  (set_estimate at any time between
 *     ticks) -> destroy
 *
 * from ONE thread (the simulation loop), never concurrently. Only the plain C structs below cross the
 * boundary: no C++, LCM, MuJoCo or Eigen types, no ownership transfer, no exceptions (a C++ plugin catches
 * everything at its boundary). create and reset run before the loop (or between runs) and may allocate;
 * tick, status, set_estimate and set_force_plates run inside the 1 kHz loop and must not allocate, block
 * or throw.
 *
 * Timing: tick receives the sensor sample of physics tick k and fills the command for tick k + 1
 * (command->tick = k + 1, command->source_tick = k): one tick of transport delay, as in the process mode
 * (exo_controller over LCM). At a controller rate below the 1 kHz physics rate (every N-th tick) the host
 * holds each command until the next one. Units SI; frames and joint order as docs/conventions.md (the joint
 * order is the host's, given to create by name).
 *
 * Force plates: after the tick of physics tick k (or, between controller ticks, in its place) the host calls
 * set_force_plates with the two plate samples of tick k, every physics tick: the order in which the process
 * mode receives EXO_STATE then EXO_PLATE_RIGHT/LEFT of the same tick, so a plugin sees the plates of tick k
 * from its tick k + 1 on, exactly as exo_controller does.
 */
#ifndef EXOID_CONTROLLER_PLUGIN_H
#define EXOID_CONTROLLER_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped on any change of the structs or of the function table. */
#define EXOID_CONTROLLER_PLUGIN_ABI_VERSION 3u
/* Largest joint count a sample carries (the exoskeleton has 10). */
#define EXOID_PLUGIN_MAX_JOINTS 32
/* Force plates per set_force_plates call: 0 right, 1 left. */
#define EXOID_PLUGIN_NUM_PLATES 2
/* Name of the exported entry function. */
#define EXOID_CONTROLLER_PLUGIN_ENTRY "exoid_controller_plugin"

/* Command modes (exoid_lcm.joint_command_t.mode). The host applies tau in TORQUE mode; HOLD re-applies the
 * previous torque, DAMPING applies the drives' own damping, OFF zero torque. */
enum { EXOID_MODE_TORQUE = 0, EXOID_MODE_HOLD = 1, EXOID_MODE_DAMPING = 2, EXOID_MODE_OFF = 3 };

/* Return codes of reset/tick/status/set_estimate/set_force_plates. Anything but EXOID_PLUGIN_OK from tick makes the host
 * discard the command of that tick and apply its counted fallback (hold the last good command, then damping). */
enum { EXOID_PLUGIN_OK = 0, EXOID_PLUGIN_ERROR = 1 };

/* Sensors of one physics tick (exoid_lcm.robot_state_t). */
typedef struct exoid_plugin_state {
  int64_t utime;                                /* sample time, microseconds (simulated in lockstep) */
  int64_t tick;                                 /* physics tick k */
  int32_t num_joints;                           /* = config num_joints */
  int32_t reserved;
  double q[EXOID_PLUGIN_MAX_JOINTS];            /* joint encoders, rad */
  double tau[EXOID_PLUGIN_MAX_JOINTS];          /* joint torque sensors, N m (0 where has_tau is 0) */
  uint8_t has_tau[EXOID_PLUGIN_MAX_JOINTS];     /* 1: the joint has a torque sensor */
  double imu_orientation[4];                    /* world <- IMU unit quaternion, Hamilton, w x y z */
  double imu_gyro[3];                           /* angular velocity, IMU frame, rad/s */
  double imu_accel[3];                          /* specific force (a - g), IMU frame, m/s^2 */
} exoid_plugin_state;

/* One force plate's load cell at one physics tick (exoid_lcm.force_plate_t). */
typedef struct exoid_plugin_force_plate {
  int64_t utime;                                /* sample time, microseconds */
  int64_t tick;                                 /* physics tick k */
  int32_t plate;                                /* 0 right, 1 left (= its index in the call's array) */
  int32_t reserved;
  double force[3];                              /* force ON the plate, plate frame, N */
  double moment[3];                             /* moment ON the plate about the sensor origin, plate frame, N m */
  double cop[3];                                /* centre of pressure on the top surface, plate frame, m */
  double plate_position[3];                     /* sensor origin, world, m */
  double plate_orientation[4];                  /* world <- plate unit quaternion, Hamilton, w x y z */
} exoid_plugin_force_plate;

/* The online estimator's output (exoid_lcm.estimator_output_t, channel EXO_ESTIMATE), as far as a controller
 * uses it. Arrays are owned by the host and live only during the call (copy what you keep). Orders are the
 * model's (the URDF given to create as model_path; the host checks EXO_ESTIMATE's parameter and coordinate
 * names against it): params = [10 per body (m, m c, inertia about the body origin xx xy xz yy yz zz), 2 per
 * joint (viscous, Coulomb)], tau_ff rows = [6 base (angular; linear, base coordinates); the joints]. */
typedef struct exoid_plugin_estimate {
  int64_t utime;                                /* estimate time, microseconds */
  int64_t tick;                                 /* last physics tick folded into it (tau_ff evaluated there) */
  int32_t valid;                                /* 1: finite, physically consistent, excited (the estimator's verdict) */
  int32_t consistent;                           /* 1: every body's pseudo-inertia positive definite */
  int32_t num_params;                           /* entries of params */
  int32_t num_coords;                           /* entries of tau_ff (nv = 6 + joints) */
  const double* params;                         /* [num_params] estimated standard parameters */
  const double* tau_ff;                         /* [num_coords] generalized-force correction K (phi_hat - phi_model), N / N m */
  double excitation;                            /* excited fraction of the information, [0, 1] */
} exoid_plugin_estimate;

/* Command for one tick (exoid_lcm.joint_command_t). The host pre-fills num_joints; tau must be finite. */
typedef struct exoid_plugin_command {
  int64_t utime;                                /* utime of the source state */
  int64_t tick;                                 /* tick at which to apply it: source_tick + 1 */
  int64_t source_tick;                          /* tick of the state it answers */
  int32_t mode;                                 /* EXOID_MODE_* */
  int32_t num_joints;
  double tau[EXOID_PLUGIN_MAX_JOINTS];          /* total joint torque, N m (entries of passive joints ignored) */
  double tau_ff[EXOID_PLUGIN_MAX_JOINTS];       /* feedforward part of tau (0 if none), N m */
} exoid_plugin_command;

/* Diagnostics after a tick (exoid_lcm.controller_status_t; fields a controller does not have stay 0, with
 * qp_status 3 "not run" and move_index -1). */
typedef struct exoid_plugin_status {
  int64_t utime;
  int64_t tick;                                 /* tick of the last state */
  int32_t qp_status;                            /* 0 solved, 1 max iterations, 2 infeasible, 3 not run */
  int32_t qp_iterations;
  double qp_solve_us;                           /* microseconds */
  double tick_us;                               /* the controller's own tick time, microseconds */
  int32_t move_index;                           /* current CoM move (0-based), -1 before the first */
  int32_t moves_done;
  double com_ref[3], com[3];                    /* CoM reference / estimate, world, m */
  double com_vel_ref[3], com_vel[3];            /* world, m/s */
  double momentum_rate_ref[6];                  /* [N; N m], world, about the CoM */
  double momentum[6];                           /* [kg m/s; kg m^2/s], world, about the CoM */
  double wrench_right[6], wrench_left[6];       /* contact wrenches [force; moment about the sole origin], world */
  int32_t fallbacks;                            /* ticks on the controller's own fallback so far */
  int32_t rejected_inputs;                      /* states it rejected so far */
  int32_t stale_inputs;                         /* ticks without a fresh state so far */
  int32_t finished;                             /* 1 once the controller's task is over (balance: moves + final hold) */
} exoid_plugin_status;

/* Given to create. Strings are owned by the host and valid only during create (copy what you keep). */
typedef struct exoid_plugin_config {
  uint32_t abi_version;                         /* the host's EXOID_CONTROLLER_PLUGIN_ABI_VERSION */
  int32_t num_joints;                           /* joints of the samples, <= EXOID_PLUGIN_MAX_JOINTS */
  const char* const* joint_names;               /* [num_joints], the order of q, tau and command tau */
  const char* model_path;                       /* robot URDF ("" if none) */
  const char* config_path;                      /* the controller's own configuration file ("" if none) */
  uint64_t seed;                                /* experiment seed (balance: the CoM move sequence) */
  int32_t moves;                                /* balance: number of CoM moves, 0 = the configuration's */
  int32_t tick_divisor;                         /* tick is called every tick_divisor physics ticks (>= 1) */
  double physics_period_s;                      /* 0.001 */
} exoid_plugin_config;

typedef struct exoid_controller_plugin_api {
  uint32_t abi_version;                         /* EXOID_CONTROLLER_PLUGIN_ABI_VERSION the plugin was built with */
  uint32_t state_size;                          /* sizeof(exoid_plugin_state) */
  uint32_t command_size;                        /* sizeof(exoid_plugin_command) */
  uint32_t status_size;                         /* sizeof(exoid_plugin_status) */
  const char* name;                             /* short human-readable name */

  /* Builds an instance (may allocate). On failure returns NULL and writes a one-line reason into
   * error[error_size] (NUL-terminated). */
  void* (*create)(const exoid_plugin_config* config, char* error, size_t error_size);
  /* Back to the state right after create (the next tick is treated as the first). May allocate. */
  int (*reset)(void* self);
  /* One control tick: state of tick k in, command for tick k + 1 out. */
  int (*tick)(void* self, const exoid_plugin_state* state, exoid_plugin_command* command);
  /* Diagnostics of the last tick. */
  int (*status)(const void* self, exoid_plugin_status* status);
  /* Optional (may be NULL): the online estimate, every one the host receives (valid or not: the plugin
   * decides). Returns EXOID_PLUGIN_ERROR when it does not use this one (wrong size, non-finite, not valid,
   * inconsistent, ...); the host counts it. Version 3 (version 2 had set_feedforward: joint torques only). */
  int (*set_estimate)(void* self, const exoid_plugin_estimate* estimate);
  void (*destroy)(void* self);

  /* Version 2 (appended, so a table written in positional order for version 1 still lines up). */
  uint32_t force_plate_size;                    /* sizeof(exoid_plugin_force_plate) */
  /* Optional (may be NULL: the host then keeps the plates to itself): the EXOID_PLUGIN_NUM_PLATES plate
   * samples of physics tick k, plates[0] right, plates[1] left, called every physics tick after tick (see
   * "Force plates" above). The array lives only during the call. Returns EXOID_PLUGIN_ERROR (and ignores
   * the samples) on a wrong count or non-finite values; the host counts it. */
  int (*set_force_plates)(void* self, const exoid_plugin_force_plate* plates, int32_t num_plates);

  /* Version 3. */
  uint32_t estimate_size;                       /* sizeof(exoid_plugin_estimate) */
} exoid_controller_plugin_api;

typedef const exoid_controller_plugin_api* (*exoid_controller_plugin_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* EXOID_CONTROLLER_PLUGIN_H */
