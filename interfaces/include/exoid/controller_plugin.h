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

#include "exoid/interfaces/schema.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped on any change of the structs or of the function table. */
#define EXOID_CONTROLLER_PLUGIN_ABI_VERSION 4u
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
  EXOID_SCHEMA_ROBOT_STATE(EXOID_ABI_MEMBER)  /* the rows of exoid/interfaces/schema.h */
} exoid_plugin_state;

/* One force plate's load cell at one physics tick (exoid_lcm.force_plate_t). */
typedef struct exoid_plugin_force_plate {
  EXOID_SCHEMA_FORCE_PLATE(EXOID_ABI_MEMBER)  /* the rows of exoid/interfaces/schema.h */
} exoid_plugin_force_plate;

/* The online estimator's output (exoid_lcm.estimator_output_t, channel EXO_ESTIMATE), as far as a controller
 * uses it. Arrays are owned by the host and live only during the call (copy what you keep). Orders are the
 * model's (the URDF given to create as model_path; the host checks EXO_ESTIMATE's parameter and coordinate
 * names against it): params = [10 per body (m, m c, inertia about the body origin xx xy xz yy yz zz), 2 per
 * joint (viscous, Coulomb)], tau_correction rows = [6 base (angular; linear, base coordinates); the joints]. */
typedef struct exoid_plugin_estimate {
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_ABI_MEMBER)  /* the rows of exoid/interfaces/schema.h */
} exoid_plugin_estimate;

/* Command for one tick (exoid_lcm.joint_command_t). The host pre-fills num_joints; tau must be finite. */
typedef struct exoid_plugin_command {
  EXOID_SCHEMA_JOINT_COMMAND(EXOID_ABI_MEMBER)  /* the rows of exoid/interfaces/schema.h */
} exoid_plugin_command;

/* Diagnostics after a tick (exoid_lcm.controller_status_t; fields a controller does not have stay 0, with
 * qp_status 3 "not run" and move_index -1). */
typedef struct exoid_plugin_status {
  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_ABI_MEMBER)  /* the rows of exoid/interfaces/schema.h */
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
