/* exoid's message schema: every field of every message, once (docs/lcm.md "The schema").
 *
 * One X-macro table per message, in the spirit of MuJoCo's mjxmacro.h. Each row is
 *
 *     F(KIND, name, init, abi)
 *
 * KIND fixes the field's type in each shape (the plain C++ struct of exoid/samples.hpp, the plugin ABI's C
 * struct of exoid/controller_plugin.h, the LCM type of lcmtypes/<type>.lcm, same name there):
 *
 *   KIND        plain C++                          C ABI                          LCM
 *   I64         int64_t                            int64_t                        int64_t
 *   I32         int32_t                            int32_t                        int32_t
 *   F64         double                             double                         double
 *   BOOL        bool                               int32_t (0/1)                  boolean
 *   MODE        CommandMode                        int32_t (EXOID_MODE_*)         int8_t
 *   QP          QpStatus                           int32_t                        int8_t
 *   PLATE       int (0 right, 1 left)              int32_t                        string plate_name (by hand)
 *   V3, V6      Eigen::Vector3d, Vector6d          double[3], double[6]           double[3], double[6]
 *   QUAT        Eigen::Quaterniond                 double[4] (w x y z)            double[4] (w x y z)
 *   JOINTS      Eigen::VectorXd [njoints]          double[EXOID_PLUGIN_MAX_JOINTS] double[num_joints]
 *   JFLAGS      Eigen::Matrix<bool,-1,1> [njoints] uint8_t[EXOID_PLUGIN_MAX_JOINTS] boolean[num_joints]
 *   VECX        Eigen::VectorXd (sized at setup)   const double* (host-owned)     double[num_*]
 *   FEET3       std::array<Vector3d, 2> [right, left]  -                          name_right[3], name_left[3]
 *   ABI_I32     -                                  int32_t (count, padding, flag) -
 *
 * init: the plain struct's default of a scalar (`_`: by kind: zero vectors, identity quaternion, empty
 * arrays). abi: YES when the plugin ABI carries the field (the rows of a message with an ABI struct are in
 * that struct's layout order, frozen by EXOID_CONTROLLER_PLUGIN_ABI_VERSION), NO otherwise.
 *
 * Counts and names of the LCM arrays (num_joints, joint_names, ...) are not rows: the adapters take the
 * expected name lists and check them (lcmtypes/adapters). Adding a field: a row here, the field in the .lcm
 * file, and (ABI rows only) a new ABI version. C-compatible: controller_plugin.h includes it.
 */
#ifndef EXOID_INTERFACES_SCHEMA_H
#define EXOID_INTERFACES_SCHEMA_H

/* Robot sensors at one tick. RobotStateSample / exoid_plugin_state / exoid_lcm.robot_state_t (EXO_STATE).
 * Joint arrays follow the model's joint order. */
#define EXOID_SCHEMA_ROBOT_STATE(F)                                                                             \
  F(I64, utime, 0, YES)            /* sample time (simulated in lockstep, or wall), microseconds */             \
  F(I64, tick, 0, YES)             /* control tick the sample belongs to */                                     \
  F(ABI_I32, num_joints, _, YES)   /* ABI: = the config's num_joints */                                         \
  F(ABI_I32, reserved, _, YES)     /* ABI: padding, 0 */                                                        \
  F(JOINTS, q, _, YES)             /* joint encoders, rad */                                                    \
  F(JOINTS, tau, _, YES)           /* joint torque sensors, N m (0 where has_tau is false) */                   \
  F(JFLAGS, has_tau, _, YES)       /* the joint has a torque sensor */                                          \
  F(QUAT, imu_orientation, _, YES) /* world <- IMU unit quaternion, Hamilton, w x y z */                        \
  F(V3, imu_gyro, _, YES)          /* angular velocity, IMU coordinates, rad/s */                               \
  F(V3, imu_accel, _, YES)         /* specific force (a - g), IMU coordinates, m/s^2 */

/* One 6-axis force plate at one tick: what the plate's own sensor reports. ForcePlateSample /
 * exoid_plugin_force_plate / exoid_lcm.force_plate_t (EXO_PLATE_RIGHT, EXO_PLATE_LEFT). */
#define EXOID_SCHEMA_FORCE_PLATE(F)                                                                             \
  F(I64, utime, 0, YES)                                                                                         \
  F(I64, tick, 0, YES)                                                                                          \
  F(PLATE, plate, 0, YES)            /* 0 right, 1 left (LCM: plate_name "right" / "left") */                   \
  F(ABI_I32, reserved, _, YES)       /* ABI: padding, 0 */                                                      \
  F(V3, force, _, YES)               /* force applied ON the plate, plate frame, N */                           \
  F(V3, moment, _, YES)              /* moment ON the plate about the sensor origin, plate frame, N m */        \
  F(V3, cop, _, YES)                 /* centre of pressure on the top surface, plate frame, m */                \
  F(V3, plate_position, _, YES)      /* sensor origin in world, m */                                            \
  F(QUAT, plate_orientation, _, YES) /* world <- plate, w x y z */

/* Controller -> robot. JointCommandSample / exoid_plugin_command / exoid_lcm.joint_command_t (EXO_COMMAND). */
#define EXOID_SCHEMA_JOINT_COMMAND(F)                                                                           \
  F(I64, utime, 0, YES)            /* utime of the source state */                                              \
  F(I64, tick, 0, YES)             /* tick at which the command is to be applied */                             \
  F(I64, source_tick, 0, YES)      /* tick of the state it was computed from */                                 \
  F(MODE, mode, CommandMode::Torque, YES) /* 0 torque, 1 hold last safe, 2 damping, 3 off */                    \
  F(ABI_I32, num_joints, _, YES)   /* ABI: pre-filled by the host */                                            \
  F(JOINTS, tau, _, YES)           /* total joint torque command, N m (0 on unactuated joints) */               \
  F(JOINTS, tau_ff, _, YES)        /* per-joint feedforward part of tau: all the controller added to its model (estimate, disturbance observer), N m */

/* Exact simulator state at one tick, for validation only (never used by controller or estimator).
 * GroundTruthSample / exoid_lcm.ground_truth_t (EXO_TRUTH). Base quantities refer to the base-link origin. */
#define EXOID_SCHEMA_GROUND_TRUTH(F)                                                                            \
  F(I64, utime, 0, NO)                                                                                          \
  F(I64, tick, 0, NO)                                                                                           \
  F(V3, base_position, _, NO)      /* world, m */                                                               \
  F(QUAT, base_orientation, _, NO) /* world <- base, w x y z */                                                 \
  F(V3, base_omega, _, NO)         /* angular velocity, base coordinates */                                     \
  F(V3, base_velocity, _, NO)      /* linear velocity of the origin, base coordinates */                        \
  F(V3, base_domega, _, NO)        /* angular acceleration, base coordinates */                                 \
  F(V3, base_acceleration, _, NO)  /* classical acceleration of the origin, base coordinates, gravity excluded */ \
  F(JOINTS, q, _, NO)                                                                                           \
  F(JOINTS, v, _, NO)                                                                                           \
  F(JOINTS, a, _, NO)                                                                                           \
  F(JOINTS, tau_applied, _, NO)    /* actuator torque applied this tick, N m */                                 \
  F(FEET3, foot_force, _, NO)      /* [right, left] contact force ON the foot, world, N */                      \
  F(FEET3, foot_moment, _, NO)     /* [right, left] its moment about the world origin, world, N m */            \
  F(V3, com, _, NO)                /* whole-robot CoM, world, m (the simulated robot: payloads included) */     \
  F(BOOL, has_trunk, false, NO)    /* a wearer's upper body rides on lumbar hinges (trunk_* valid; else 0) */   \
  F(V3, trunk_angle, _, NO)        /* lumbar hinges x, y, z: upper body on the pelvis, intrinsic x-y-z, rad */  \
  F(V3, trunk_rate, _, NO)         /* their rates, rad/s */                                                     \
  F(V3, trunk_com, _, NO)          /* the upper body's CoM, world, m (also inside com) */

/* Controller diagnostics at one tick. ControllerStatusSample / exoid_plugin_status /
 * exoid_lcm.controller_status_t (EXO_CONTROLLER_STATUS). */
#define EXOID_SCHEMA_CONTROLLER_STATUS(F)                                                                       \
  F(I64, utime, 0, YES)                                                                                         \
  F(I64, tick, 0, YES)                                                                                          \
  F(QP, qp_status, QpStatus::NotRun, YES) /* 0 solved, 1 max iterations, 2 infeasible, 3 not run */             \
  F(I32, qp_iterations, 0, YES)                                                                                 \
  F(F64, qp_solve_us, 0.0, YES)     /* QP solve time, microseconds */                                           \
  F(F64, tick_us, 0.0, YES)         /* whole control tick (dynamics + QP), microseconds */                      \
  F(I32, move_index, -1, YES)       /* current CoM move (0-based), -1 before the first, = count when done */    \
  F(I32, moves_done, 0, YES)                                                                                    \
  F(V3, com_ref, _, YES)            /* CoM reference, world, m */                                               \
  F(V3, com, _, YES)                /* CoM estimate, world, m */                                                \
  F(V3, com_vel_ref, _, YES)        /* world, m/s */                                                            \
  F(V3, com_vel, _, YES)            /* world, m/s */                                                            \
  F(V6, momentum_rate_ref, _, YES)  /* desired centroidal momentum rate [N; N m], world, about the CoM */       \
  F(V6, momentum, _, YES)           /* centroidal momentum [kg m/s; kg m^2/s], world, about the CoM */          \
  F(V6, wrench_right, _, YES)       /* QP contact wrench on the right foot [force; moment about the sole origin], world */ \
  F(V6, wrench_left, _, YES)        /* same, left foot */                                                       \
  F(I32, fallbacks, 0, YES)         /* ticks on a fallback command so far */                                    \
  F(I32, rejected_inputs, 0, YES)   /* rejected input messages so far (NaN, out of order, duplicate, size) */   \
  F(I32, stale_inputs, 0, YES)      /* ticks without a fresh state so far */                                    \
  F(ABI_I32, finished, _, YES)      /* ABI: 1 once the controller's task is over (balance: moves + final hold) */

/* The online estimator's output. EstimatorOutputSample / exoid_plugin_estimate (the part a controller uses) /
 * exoid_lcm.estimator_output_t (EXO_ESTIMATE). Orders: params = the model's parameter order (10 per body, 2 per
 * joint), nbase base parameters, coordinates = [6 base (angular; linear, base coordinates); the joints]. */
#define EXOID_SCHEMA_ESTIMATOR_OUTPUT(F)                                                                        \
  F(I64, utime, 0, YES)                                                                                         \
  F(I64, tick, 0, YES)              /* last tick folded into the estimate (tau_correction is evaluated at its state) */ \
  F(BOOL, valid, false, YES)        /* finite, physically consistent and excited: the controller may use it */  \
  F(BOOL, consistent, false, YES)   /* every link's pseudo-inertia positive definite (model/inertial.hpp) */    \
  F(ABI_I32, num_params, _, YES)    /* ABI: entries of params */                                                \
  F(ABI_I32, num_coords, _, YES)    /* ABI: entries of tau_correction (nv) */                                   \
  F(VECX, params, _, YES)           /* [nparams] estimated standard parameters (base parameters mapped back) */ \
  F(VECX, tau_correction, _, YES)   /* [nv] generalized-force correction K(q, v, dnu)(phi_hat - phi_model), N / N m */ \
  F(F64, excitation, 0.0, YES)      /* excited fraction of the base-parameter information, [0, 1] */           \
  F(I64, samples_used, 0, NO)       /* accepted samples */                                                      \
  F(I32, samples_rejected, 0, NO)   /* rejected_nonfinite + rejected_out_of_order + rejected_duplicate */       \
  F(I32, rejected_nonfinite, 0, NO)                                                                             \
  F(I32, rejected_out_of_order, 0, NO)                                                                          \
  F(I32, rejected_duplicate, 0, NO)                                                                             \
  F(I64, samples_missing, 0, NO)    /* ticks skipped between accepted samples */                                \
  F(F64, effective_samples, 0.0, NO) /* memory length sum lambda^(N-k) */                                       \
  F(VECX, param_stddev, _, NO)      /* [nparams] one-sigma uncertainty of each (>= 0) */                        \
  F(VECX, base_params, _, NO)       /* [nbase] estimated base parameters */                                     \
  F(VECX, base_stddev, _, NO)       /* [nbase] one-sigma uncertainty of each (>= 0) */                          \
  F(VECX, residual_rms, _, NO)      /* [nv] per-coordinate residual RMS over the estimate's memory (>= 0) */    \
  /* The uncertainty of what a controller uses (ABI v4; docs/estimator.md "Trust"), residual correlation included: */ \
  F(V3, com_stddev, _, YES)         /* one sigma of the CoM of params at `tick`'s state, per world axis, m */   \
  F(F64, mass_stddev, 0.0, YES)     /* one sigma of the total mass of params, kg */                            \
  F(VECX, tau_correction_stddev, _, YES) /* [nv] one sigma of tau_correction's entries, N / N m */

/* ---- the C ABI expansion (controller_plugin.h): one member per row with abi YES ---------------------- */
#define EXOID_ABI_MEMBER(KIND, name, init, abi) EXOID_ABI_MEMBER_##abi(KIND, name)
#define EXOID_ABI_MEMBER_NO(KIND, name)
#define EXOID_ABI_MEMBER_YES(KIND, name) EXOID_ABI_MEMBER_##KIND(name)
#define EXOID_ABI_MEMBER_I64(name) int64_t name;
#define EXOID_ABI_MEMBER_I32(name) int32_t name;
#define EXOID_ABI_MEMBER_F64(name) double name;
#define EXOID_ABI_MEMBER_BOOL(name) int32_t name;
#define EXOID_ABI_MEMBER_MODE(name) int32_t name;
#define EXOID_ABI_MEMBER_QP(name) int32_t name;
#define EXOID_ABI_MEMBER_PLATE(name) int32_t name;
#define EXOID_ABI_MEMBER_V3(name) double name[3];
#define EXOID_ABI_MEMBER_V6(name) double name[6];
#define EXOID_ABI_MEMBER_QUAT(name) double name[4];
#define EXOID_ABI_MEMBER_JOINTS(name) double name[EXOID_PLUGIN_MAX_JOINTS];
#define EXOID_ABI_MEMBER_JFLAGS(name) uint8_t name[EXOID_PLUGIN_MAX_JOINTS];
#define EXOID_ABI_MEMBER_VECX(name) const double* name;
#define EXOID_ABI_MEMBER_ABI_I32(name) int32_t name;

#endif /* EXOID_INTERFACES_SCHEMA_H */
