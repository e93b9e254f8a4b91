#pragma once
// Figures of merit of a closed-loop run, computed from its log (truth channel for what only the simulator
// knows, controller status for what the controller reports) and from what the run's supervisor knows
// beyond the log (the sim's own report, which processes failed). Every figure says what it is measured
// against; nothing is taken from a log that ended early as if the run had.
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/sim/loop_timing.hpp"

namespace exoid::tools {

/// Where the controller's world sits in the simulator's. The controller's observer (docs/controller.md,
/// BaseStateObserver) fixes its world at the start-up window's last state: the base at base_xy, the soles' mean
/// height at ground_height. A robot that settles during the window (a wearer's weight loading the joints: ~5 mm)
/// is then offset between the two worlds, and the truth is moved into the controller's before it is compared with
/// the controller's reference (the reference, its targets and the soles are all in the controller's world).
struct ControllerFrame {
  int64_t latch_tick = -1;  ///< the window's last tick (observer.latch_ticks - 1); -1: the simulator's world is taken
  Eigen::Vector2d base_xy = Eigen::Vector2d::Zero();  ///< observer.initial_base_xy
  double ground_height = 0.0;                         ///< observer.ground_height
  /// The soles where the controller latched them in its world (right, left; x-y), from replaying its base state
  /// observer over the logged states (controllerFrame). With them the two worlds are aligned by the soles,
  /// the points the controller's world is built on; without, by the base at the latch tick, which is off by the
  /// latch window's orientation error times the legs' length (0.2-0.6 mm with the realistic IMU, docs/wearer.md).
  bool has_soles = false;
  Eigen::Vector2d sole_xy[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
};

/// What `exoid experiment` knows about a run besides its log.
struct RunFacts {
  ControllerFrame controller_frame;  ///< the controller's world (from its configuration)
  int moves_planned = 0;
  int64_t ticks_planned = 0;        ///< planned run length (the sim's --duration in ticks)
  bool lockstep = true;             ///< the real-time factor target (>= 5x) applies to lockstep only
  bool estimate_feedback = false;   ///< the controller was given the online estimate
  bool sim_reported = false;        ///< the sim wrote its result; the sim_* fields are known
  std::string sim_outcome;          ///< completed | fell | controller_lost | interrupted | lcm_failure
  int64_t sim_ticks = 0;            ///< ticks the sim simulated and published
  int64_t sim_fall_tick = -1;
  int64_t sim_held_ticks = 0, sim_zero_ticks = 0, sim_timeouts = 0;  ///< the sim's own fallbacks
  double sim_realtime_factor = 0.0, sim_wall_s = 0.0;
  sim::LoopTiming sim_timing;       ///< the sim's loop timing (overruns, deadline misses, worst tick, plugin calls)
  std::vector<std::string> failures;  ///< what went wrong, one line each (a process died, the watchdog, ...)
  bool interrupted = false;           ///< SIGINT/SIGTERM stopped the run
  bool log_readable = true;           ///< false: the log could not be read at all (log_error says why)
  std::string log_error;
  /// The controller's model parameters [nparams] (its --controller-model; empty: the model's): what the
  /// joint-torque prediction error judges.
  Eigen::VectorXd controller_phi;
  double payload_attach_s = -1.0;  ///< a payload attached mid-run at this simulated time (-1: none)
  double payload_mass_kg = 0.0;    ///< its mass
};

struct ExperimentSummary {
  std::string outcome;             ///< completed | fell | failed | interrupted
  std::vector<std::string> failures;  ///< RunFacts::failures plus the log's own problems
  int moves_planned = 0;
  int moves_done = 0;              ///< CoM moves completed before a fall (or the end of the log)
  bool fell = false;               ///< the true base dropped > 0.25 m below its start
  int64_t fall_tick = -1;          ///< tick of the fall (the sim's report, else the first such tick in the log)
  double fall_time_s = -1.0;
  int fall_during_move = -1;       ///< 0-based move under way at the fall (-1: before the first move)
  /// The simulator's world minus the controller's (ControllerFrame) at the latch: subtracted from every true position
  /// compared with the reference below. Zero when the frame is unknown.
  Eigen::Vector3d frame_offset_m = Eigen::Vector3d::Zero();
  double com_rmse_m = 0.0;         ///< model CoM (the URDF model at the exact state) vs the CoM reference
  double com_max_error_m = 0.0;
  double true_com_rmse_m = 0.0;    ///< the simulated robot's CoM (undeclared payloads included) vs the reference
  double true_com_max_error_m = 0.0;
  double true_com_rmse_xy_m = 0.0; ///< its horizontal part
  /// The horizontal part over the move ticks from kSettleTicks on (10 s after the run's start, standing from its
  /// first tick): the window of issue 21's "within 10 s of the start of standing", which leaves out the online
  /// estimate's convergence. 0 (and settled_ticks 0) when the moves end before it.
  double true_com_rmse_xy_settled_m = 0.0;
  long settled_ticks = 0;
  static constexpr int64_t kSettleTicks = 10000;  ///< 10 s at the 1 kHz tick
  /// The same with the vertical error taken relative to its value at the first tick of the moves: the vertical
  /// targets are offsets from the start-up height (docs/controller.md), so this leaves out the constant height
  /// offset a model's CoM-height error puts between the true CoM and the reference (straight knees: no
  /// controller can remove it); the estimate's height changes during the run still count.
  double true_com_rmse_rel_m = 0.0;
  double max_foot_slip_m = 0.0;    ///< largest horizontal displacement of either sole centre from its start
  /// A wearer's trunk (truth `trunk_*`, docs/conventions.md "A wearer's trunk"), over the ticks of the moves: the
  /// lumbar hinges' mean angle and RMS about it (x, y, z, rad), and the upper body's CoM relative to the pelvis
  /// (pelvis frame: R^T (trunk_com - base_position)), RMS about its mean per axis (m): how far the body that no
  /// exo sensor measures moves on the base. Zero when has_trunk is false.
  bool has_trunk = false;
  Eigen::Vector3d trunk_angle_mean_rad = Eigen::Vector3d::Zero(), trunk_angle_rms_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d trunk_com_rms_m = Eigen::Vector3d::Zero();
  double qp_solve_us_p50 = 0.0, qp_solve_us_p99 = 0.0;
  double tick_us_p50 = 0.0, tick_us_p99 = 0.0, tick_us_max = 0.0;  ///< the controller's tick (its status)
  sim::LoopTiming timing;          ///< the sim's loop timing (docs/sim.md, "Loop timing"; valid when sim_reported)
  long controller_fallbacks = 0;   ///< controller ticks on a fallback command (its last status)
  long sim_held_ticks = 0, sim_zero_ticks = 0, sim_timeouts = 0;  ///< the sim's fallback ticks (-1: unknown)
  long controller_rejected = 0;    ///< input messages the controller rejected
  double realtime_factor = 0.0;    ///< the sim's simulated time / its wall time (0: unknown)
  bool lockstep = true;            ///< the >= 5x target applies
  bool estimate_feedback = false;  ///< the controller was given the online estimate (RunFacts)
  double sim_seconds = 0.0;        ///< simulated time (ticks_simulated / 1000)
  int64_t ticks_planned = 0;
  bool sim_reported = false;       ///< the sim wrote its result (else its figures are unknown)
  int64_t ticks_simulated = 0;     ///< the sim's count; the planned count when the sim did not report
  int64_t ticks_logged = 0;        ///< ticks in the log's truth channel
  long missing_ticks = 0;          ///< ticks of [0, ticks_simulated) absent from a sim channel, summed over the 4
  bool log_complete = false;       ///< every simulated tick on every sim channel, nothing damaged or rejected
  std::string log_damage;          ///< RunLog::damageReport()
  long log_rejected = 0;           ///< logged events that failed decoding or validation
  long log_corrupt_events = 0;     ///< damaged stretches of the log file
  double eom_residual_max_rel = -1.0;  ///< W phi_model - y, max relative (-1: not computed)
  /// The controller's joint-torque prediction error (docs/estimator.md, "Closing the loop"): RMS over the
  /// ticks of the moves (status move_index >= 0, a command for the tick) and the joints the controller drives of
  /// tau_applied - (K(q, v, a) phi_ctrl - sum J_c^T w_c + tau_ff_used)_joint, with q, v, a, the base motion, the
  /// contact wrenches and tau_applied the simulator's (truth channel: no sensor noise), phi_ctrl the controller's
  /// model and tau_ff_used the estimator's feedforward the command reports (blend weight included). -1: not
  /// computed. The second figure leaves tau_ff_used out (the controller's model alone, same ticks).
  double joint_torque_prediction_rmse_nm = -1.0;
  double joint_torque_model_rmse_nm = -1.0;
  long torque_prediction_ticks = 0;
  long estimate_messages = 0;          ///< EXO_ESTIMATE messages in the log
  long estimate_valid_messages = 0;    ///< of them flagged valid
  long estimate_in_use_ticks = 0;      ///< commands carrying a non-zero feedforward (estimate or disturbance observer)
  double payload_attach_s = -1.0;      ///< mid-run payload: attach time (-1: none)
  double payload_mass_kg = 0.0;
  /// Mid-run payload: seconds from the attachment until the estimated total mass (sum of the published link
  /// masses, by the estimate's tick) first reaches its value before (mean over the second before) plus 95 % of
  /// the payload's mass; -1: never within the log.
  double payload_mass_response_s = -1.0;
  double payload_mass_before_kg = 0.0, payload_mass_final_kg = 0.0;  ///< estimated total mass before, at the end
};

/// Summarises a run. Never fails: with an unreadable log (facts.log_readable false) only the facts and the
/// sim's report fill the summary, and the outcome is failed.
ExperimentSummary summarizeExperiment(const Model& model, const intake::RunLog& log, const RunFacts& facts);

/// summary.json (nlohmann/json; field names as in ExperimentSummary, docs/data-formats.md).
std::string summaryJson(const ExperimentSummary& s);
/// Readable table (also valid Markdown), then one line per failure.
std::string summaryTable(const ExperimentSummary& s);

}  // namespace exoid::tools
