#pragma once
// BalanceController: the 1 kHz centroidal balance controller (Vallinas et al., ICORR 2023, as used in the seed
// thesis section IV-A, without the torso stabilisation task). One tick:
//   input checks -> BaseStateObserver -> computeRobotDynamics (rnea, crba, sole Jacobians/drifts, centroidal)
//   -> MomentumTask / PostureRegularization / ContactSixD -> BalanceFormulation -> QpSolver -> joint torques,
// with a safe fallback (hold the last safe command, then joint damping). tick() never allocates, never throws
// and never blocks. Timing convention: the command answers state tick k with command.tick = k + 1.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "exoid/controller/base_state_observer.hpp"
#include "exoid/controller/com_observer.hpp"
#include "exoid/controller/com_trajectory.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/controller/disturbance_observer.hpp"
#include "exoid/controller/formulation.hpp"
#include "exoid/controller/qp_solver.hpp"
#include "exoid/controller/robot_dynamics.hpp"
#include "exoid/controller/tasks.hpp"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::controller {

/// Why a tick did not produce a QP torque command.
enum class FallbackReason : int8_t { None = 0, InvalidInput, OutOfOrder, Stale, QpFailed, NonFiniteTorque, Recovering };
const char* toString(FallbackReason reason);

/// Why an estimate was refused (setEstimate) or withdrawn (tick).
enum class EstimateRejection : int8_t {
  None = 0,
  Disabled,      ///< estimate.enabled is false
  WrongSize,     ///< params not [nparams] or tau_correction not [nv]
  NonFinite,     ///< a parameter or a feedforward component is NaN/Inf
  NotValid,      ///< the estimator flags it not valid (not excited, not converged)
  Inconsistent,  ///< flagged inconsistent, or a body's pseudo-inertia is not positive definite here
  Mass,          ///< total mass off the model's by more than estimate.max_relative_mass_change
  Count
};
const char* toString(EstimateRejection reason);

/// What the controller did with the online estimate (counters since construction).
struct EstimateUse {
  double weight = 0.0;   ///< blend weight in [0, 1] this tick (0: the model alone, 1: the estimate)
  bool active = false;   ///< the latest estimate is fresh and accepted (the weight moves toward 1)
  int32_t accepted = 0;  ///< estimates accepted by setEstimate
  std::array<int32_t, static_cast<size_t>(EstimateRejection::Count)> rejected{};  ///< refused, by reason
  int32_t withdrawn_stale = 0;    ///< switched off because the latest estimate grew older than max_age_ticks
  int32_t withdrawn_refused = 0;  ///< switched off because a newer estimate was refused
  double mass = 0.0;              ///< kg, total mass of the latest accepted estimate
  // The fixed lag (estimate.lag_ticks): what did not go by the rule. All 0 in a reproducible run.
  int32_t late = 0;          ///< applied after its tick + lag_ticks (it arrived after that tick had been ticked)
  int32_t out_of_order = 0;  ///< dropped: older than the estimate applied last
  int32_t overflow = 0;      ///< dropped: the queue was full (the oldest pending one goes)
};

/// One line "<who>: estimate: accepted N, refused N (reason N, ...), withdrawn N (stale N, refused N), weight W,
/// mass M kg" (the summaries of exo_controller and exo_sim's plugin line). Not real-time.
void printEstimateUse(std::FILE* out, const char* who, const EstimateUse& use);

/// Everything of controller_status_t plus controller-internal counters (the base part goes on LCM as is).
struct ControllerStatus : ControllerStatusSample {
  CommandMode mode = CommandMode::Torque;
  FallbackReason reason = FallbackReason::None;
  int32_t qp_failures = 0;    ///< ticks whose QP gave no usable solution (status or non-finite)
  int32_t hold_ticks = 0;     ///< ticks spent holding the last safe command
  int32_t damping_ticks = 0;  ///< ticks spent in joint damping
  int32_t dropped_contact_directions = 0;  ///< contact directions removed by the range projection this tick
  double leg_disagreement = 0.0;  ///< m, half the disagreement of the legs about the base position
  double trajectory_time = 0.0;   ///< s since the trajectory start (start-up latch complete)
  bool trajectory_ready = false;  ///< the move sequence has been generated
  bool trajectory_failed = false; ///< the feet are latched but no move sequence fits (the CoM start is held)
  bool trajectory_done = false;   ///< every move and hold finished
  EstimateUse estimate;           ///< the online estimate in the control law
};

/// Seconds from the first state to the end of the final hold, known upfront from the configuration:
/// start-up latch (observer.latch_ticks) + initial hold + moves * (move + hold) + final hold.
double plannedRunDuration(const ControllerConfig& config);

class BalanceController {
 public:
  /// Setup (allocates). `solver` defaults to ProxQP with config.solver. Check ok()/error() afterwards.
  BalanceController(const Model& model, const ControllerConfig& config, uint64_t seed,
                    std::unique_ptr<QpSolver> solver = nullptr);
  ~BalanceController();

  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }

  /// Sizes a command sample for this model (setup).
  void sizeCommand(JointCommandSample& command) const;
  /// The online estimator's output (EXO_ESTIMATE as a plain sample; base_params etc. are not read). Judged
  /// here: accepted when config.estimate.enabled, params [nparams] and tau_correction [nv] finite, flagged valid
  /// and consistent, every body's parameters consistent (model/inertial.hpp) and the total mass within
  /// max_relative_mass_change of the model's; false when refused (or dropped: older than the one applied last,
  /// EstimateUse::out_of_order). Only queued: the tick of state k applies, in tick order, every queued estimate
  /// whose tick e <= k - estimate.lag_ticks (a fixed lag, so that what the controller uses does not depend on
  /// when the estimate arrived; docs/controller.md "The fixed lag"). An applied refusal withdraws the current
  /// estimate (counted by reason); an applied accepted one, while younger than estimate.max_age_ticks (from its
  /// tick), gives tau_correction (bounded by max_abs) to the QP's dynamics and params to the momentum task's CoM
  /// and momentum, blended in and out over estimate.blend_time. Allocation-free.
  bool setEstimate(const EstimatorOutputSample& estimate);
  /// Withdraws the estimate (blended out) and empties the queue, e.g. when the estimator is known to have stopped.
  void clearEstimate();
  /// Estimates queued, not yet due.
  int pendingEstimates() const { return pending_count_; }
  /// A force plate sample (plate 0 right, 1 left: the load cell's wrench ON the plate about its sensor origin,
  /// plate frame, with the plate's world pose). The disturbance observer compares it with the wrench the QP
  /// planned for the same tick when config.disturbance.force_plates. False (ignored) on a wrong plate index or
  /// non-finite values. Allocation-free.
  bool setForcePlate(const ForcePlateSample& plate);

  /// One control tick for the state of tick k: fills `out` (tick k+1) and `status`. Allocation-free.
  void tick(const RobotStateSample& in, JointCommandSample& out, ControllerStatus& status);

  // --- inspection (tests, the app, benchmarks) ---
  const Model& model() const { return model_; }
  const ControllerConfig& config() const { return cfg_; }
  const CoMTrajectory& trajectory() const { return trajectory_; }
  /// Where the moves' targets may go (staticMomentReach), set when the feet are latched.
  const MoveReach& moveReach() const { return move_reach_; }
  const BaseStateObserver& observer() const { return *observer_; }
  const RobotDynamicsData& dynamics() const { return dyn_; }
  const BalanceFormulation& formulation() const { return formulation_; }
  const QpProblem& problem() const { return qp_; }
  const QpResult& result() const { return result_; }
  const CoMReference& reference() const { return ref_; }
  const LinearAngular6d& desiredMomentumRate() const { return rate_desired_; }
  const DisturbanceObserver& disturbanceObserver() const { return disturbance_; }
  const ComObserver& comObserver() const { return com_observer_; }
  /// Trajectory duration (s), known once the trajectory is generated (at the end of the start-up latch).
  double trajectoryDuration() const { return trajectory_.ready() ? trajectory_.duration() : 0.0; }
  const std::array<SoleFrame, 2>& soles() const { return soles_; }

 private:
  bool inputValid(const RobotStateSample& in) const;
  void startTrajectory(int64_t tick);
  bool runQp();
  void updateDynamics(const State& state);  // model dynamics, then the blend toward the estimate
  /// Weight of an estimated change from the model with one-sigma `stddev`: max(0, 1 - (k stddev / |change|)^2),
  /// k = estimate.trust_sigmas or trust_sigmas_horizontal_com (1 when k is 0). Zero within k sigma; -> 1 as the
  /// change stands out.
  static double trustWeight(double change, double stddev, double k);
  void advanceEstimateBlend(int64_t tick);
  // The estimate's fixed lag (setEstimate queues, the tick applies):
  /// The verdict on an estimate (None: usable) and its total mass; the checks of setEstimate.
  EstimateRejection judgeEstimate(const EstimatorOutputSample& e, double& mass) const;
  /// Applies, in tick order, every queued estimate whose tick e <= tick - estimate.lag_ticks.
  void applyDueEstimates(int64_t tick);
  void fallbackTorque(JointCommandSample& out);
  // The stages of tick(), in order:
  /// Validates the state sample and feeds the observer; `fresh` when it was taken. Returns why the tick
  /// falls back so far (None, InvalidInput, OutOfOrder, Stale).
  FallbackReason acceptState(const RobotStateSample& in, bool& fresh);
  /// The CoM reference of the tick: the trajectory once the feet are latched, else the current CoM held.
  void updateReference(int64_t tick, ControllerStatus& status);
  /// Disturbance estimate, the QP, and tau_cmd_ from its solution; false (reason set) when the QP failed.
  bool computeTorque(FallbackReason& reason, ControllerStatus& status);
  /// Reference, momentum, the QP's contact wrenches and the trajectory's progress into the status.
  void reportTaskState(bool qp_ok, ControllerStatus& status) const;
  /// Torque mode (the solution becomes the last safe command) or the fallback (Recovering while a latched
  /// damping waits for recovery_ticks good ticks).
  void selectMode(FallbackReason& reason, JointCommandSample& out);

  const Model& model_;
  ControllerConfig cfg_;
  uint64_t seed_;
  bool ok_ = false;
  std::string error_;

  std::array<SoleFrame, 2> soles_{};
  SoleFrame imu_{};
  std::unique_ptr<BaseStateObserver> observer_;
  CoMTrajectory trajectory_;
  MoveReach move_reach_;  ///< where the moves' targets may go (set at the last trajectory start)
  MomentumTask momentum_;
  PostureRegularization posture_;
  ContactSixD contact_right_, contact_left_;
  BalanceFormulation formulation_;
  DisturbanceObserver disturbance_;
  ComObserver com_observer_;
  std::unique_ptr<QpSolver> solver_;
  RobotDynamicsData dyn_;
  QpProblem qp_;
  QpResult result_;

  CoMReference ref_;
  LinearAngular6d rate_desired_ = LinearAngular6d::Zero();
  Eigen::VectorXd dnu_desired_, dnu_weights_;
  Eigen::VectorXd tau_gen_;      // [nv] generalized force of the solution
  Eigen::VectorXd tau_cmd_;      // [njoints] command being built
  Eigen::VectorXd tau_last_safe_;  // [njoints]
  Eigen::VectorXd tau_ff_joint_;   // [njoints] feedforward reported in the command
  Eigen::VectorXd ff_input_;       // [nv] feedforward of the last accepted estimate (bounded)
  Eigen::VectorXd phi_hat_;        // [nparams] parameters of the last accepted estimate
  Eigen::Vector3d com_stddev_ = Eigen::Vector3d::Zero();  // m, world axes: its CoM's uncertainty
  double mass_stddev_ = 0.0;       // kg: its total mass's uncertainty
  Eigen::VectorXi joint_actuated_;  // [njoints] 1 if actuated
  Eigen::VectorXd joint_limit_;     // [njoints] torque bound (0 on unactuated joints)

  bool has_last_tick_ = false;
  int64_t last_tick_ = 0;
  int64_t gap_ = 1;  // ticks since the previous good state
  // Force plates: latest wrench ON each foot (world force, moment about the world origin) and its tick; the
  // contact wrenches the QP planned, by the tick their command is applied at (ring buffer).
  std::array<Eigen::Vector3d, 2> plate_force_{}, plate_moment_{};
  std::array<int64_t, 2> plate_tick_{{-1, -1}};
  static constexpr int kPlanRing = 16;
  std::array<Eigen::Matrix<double, 12, 1>, kPlanRing> planned_wrench_{};
  std::array<int64_t, kPlanRing> planned_tick_{};
  Eigen::VectorXd wrench_residual_;  // [nv]
  bool plateResidual();              // fills wrench_residual_; false if no usable pair
  bool platePairFresh() const;       // both plates of the same tick, at most max_plate_age_ticks old
  /// Folds this tick's CoM (after the estimate's blend) and plates into the CoM observer (once per tick), then adds
  /// its correction to dyn_'s CoM, CoM velocity and linear momentum.
  void applyComObserver();
  Eigen::Vector3d angular_momentum_urdf_ = Eigen::Vector3d::Zero();  // world, about the CoM: the URDF model's
  int64_t trajectory_start_tick_ = 0;
  bool has_last_safe_ = false;
  // Online estimate: the last accepted one (kept for blending out after a withdrawal), its tick, whether it
  // still stands (no refusal since), the blend ramp in [0, 1] (weight = smoothstep of it).
  bool has_estimate_ = false;
  bool estimate_on_ = false;
  int64_t estimate_tick_ = 0;
  double blend_ramp_ = 0.0;
  EstimateRejection last_refusal_ = EstimateRejection::None;
  EstimateUse estimate_use_;
  // The queue of judged estimates not yet due (fixed capacity, sized in the constructor): slots, and their
  // indices sorted by tick (arrival order among equal ticks).
  struct PendingEstimate {
    int64_t tick = 0;
    EstimateRejection verdict = EstimateRejection::None;  // None: accepted
    bool late = false;      // its due tick had already been ticked when it arrived
    double mass = 0.0;      // kg, accepted only
    Eigen::VectorXd params;  // [nparams], accepted only
    Eigen::VectorXd ff;      // [nv] tau_correction as far as trusted, bounded by max_abs, accepted only
    Eigen::Vector3d com_stddev = Eigen::Vector3d::Zero();  // m, world axes: its CoM's uncertainty
    double mass_stddev = 0.0;  // kg
  };
  static constexpr int kEstimateQueue = 16;
  std::array<PendingEstimate, kEstimateQueue> pending_;
  std::array<int, kEstimateQueue> pending_order_{};
  int pending_count_ = 0;
  bool has_applied_estimate_ = false;
  int64_t applied_estimate_tick_ = 0;  // tick of the estimate applied last (accepted or refused)
  double vertical_shift_ = 0.0, vertical_shift_rate_ = 0.0;  // m, m/s: reference height follows the estimate
  int bad_streak_ = 0;
  int good_streak_ = 0;
  bool damping_latched_ = false;
  // counters (mirrored into the status every tick)
  int32_t fallbacks_ = 0, rejected_ = 0, stale_ = 0, qp_failures_ = 0, hold_ticks_ = 0, damping_ticks_ = 0;
};

}  // namespace exoid::controller
