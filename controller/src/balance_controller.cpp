#include "exoid/controller/balance_controller.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "exoid/controller/move_reach.hpp"
#include "exoid/controller/proxqp_solver.hpp"
#include "exoid/model/inertial.hpp"

namespace exoid::controller {

const char* toString(FallbackReason reason) {
  switch (reason) {
    case FallbackReason::None: return "none";
    case FallbackReason::InvalidInput: return "invalid input";
    case FallbackReason::OutOfOrder: return "tick not increasing";
    case FallbackReason::Stale: return "stale input";
    case FallbackReason::QpFailed: return "qp failed";
    case FallbackReason::NonFiniteTorque: return "non-finite torque";
    case FallbackReason::Recovering: return "recovering";
  }
  return "?";
}

const char* toString(EstimateRejection reason) {
  switch (reason) {
    case EstimateRejection::None: return "none";
    case EstimateRejection::Disabled: return "disabled";
    case EstimateRejection::WrongSize: return "wrong size";
    case EstimateRejection::NonFinite: return "non-finite";
    case EstimateRejection::NotValid: return "not valid";
    case EstimateRejection::Inconsistent: return "inconsistent";
    case EstimateRejection::Mass: return "total mass";
    case EstimateRejection::Count: break;
  }
  return "?";
}

void printEstimateUse(std::FILE* out, const char* who, const EstimateUse& u) {
  int refused = 0;
  for (const int32_t n : u.rejected) refused += n;
  std::fprintf(out, "%s: estimate: accepted %d, refused %d (", who, u.accepted, refused);
  bool first = true;
  for (size_t r = 1; r < u.rejected.size(); ++r) {
    if (u.rejected[r] == 0) continue;
    std::fprintf(out, "%s%s %d", first ? "" : ", ", toString(static_cast<EstimateRejection>(r)), u.rejected[r]);
    first = false;
  }
  std::fprintf(out, "), withdrawn %d (stale %d, refused %d), weight %.3f, mass %.3f kg",
               u.withdrawn_stale + u.withdrawn_refused, u.withdrawn_stale, u.withdrawn_refused, u.weight, u.mass);
  // Off the fixed lag's rule (0 in a reproducible run): said only when it happened.
  if (u.late + u.out_of_order + u.overflow > 0)
    std::fprintf(out, ", late %d, dropped %d (out of order %d, queue full %d)", u.late, u.out_of_order + u.overflow,
                 u.out_of_order, u.overflow);
  std::fputc('\n', out);
}

double plannedRunDuration(const ControllerConfig& c) {
  const TrajectoryConfig& t = c.trajectory;
  return c.observer.latch_ticks * c.loop.period + t.initial_hold + t.moves * (t.move_duration + t.hold_duration) +
         t.final_hold;
}

namespace {
double clampAbs(double v, double limit) { return std::max(-limit, std::min(limit, v)); }
}  // namespace

BalanceController::BalanceController(const Model& model, const ControllerConfig& config, uint64_t seed,
                                     std::unique_ptr<QpSolver> solver)
    : model_(model),
      cfg_(config),
      seed_(seed),
      trajectory_(config.trajectory.moves),
      momentum_(config.momentum),
      posture_(config.posture, model.njoints),
      contact_right_(config.contact, BaseStateObserver::kRight),
      contact_left_(config.contact, BaseStateObserver::kLeft),
      formulation_(model, config.contact, config.torque),
      disturbance_(config.disturbance, config.loop.period, model.nv),
      com_observer_(config.com_observer, config.loop.period, model.gravity.norm(),
                    config.com_observer.upper_body_momentum ? upperBodyLever(model) : Eigen::Vector2d::Zero()),
      solver_(std::move(solver)),
      dyn_(model) {
  std::string why;
  if (!model.floating_base) {
    error_ = "the balance controller needs a floating-base model";
    return;
  }
  if (!validateControllerConfig(cfg_, &why)) {
    error_ = "controller config: " + why;
    return;
  }
  if (!resolveObserverFrames(model, cfg_.contact, soles_, imu_, &why)) {
    error_ = why;
    return;
  }
  observer_ = std::make_unique<BaseStateObserver>(model, cfg_.observer, cfg_.loop.period, soles_, imu_);

  if (!solver_) solver_ = makeProxQpSolver({cfg_.solver.eps_abs, cfg_.solver.max_iterations});
  const QpDimensions dims = formulation_.dimensions();
  qp_.resize(dims);
  result_.resize(dims);
  if (!solver_->setup(dims)) {
    error_ = std::string("QP solver '") + solver_->name() + "' setup failed";
    return;
  }
  dnu_desired_ = Eigen::VectorXd::Zero(model.nv);
  dnu_weights_ = Eigen::VectorXd::Zero(model.nv);
  tau_gen_ = Eigen::VectorXd::Zero(model.nv);
  tau_cmd_ = Eigen::VectorXd::Zero(model.njoints);
  tau_last_safe_ = Eigen::VectorXd::Zero(model.njoints);
  tau_ff_joint_ = Eigen::VectorXd::Zero(model.njoints);
  wrench_residual_ = Eigen::VectorXd::Zero(model.nv);
  planned_tick_.fill(-1);
  ff_input_ = Eigen::VectorXd::Zero(model.nv);
  phi_hat_ = model.phi;
  for (PendingEstimate& p : pending_) {
    p.params = model.phi;
    p.ff = Eigen::VectorXd::Zero(model.nv);
  }
  joint_actuated_ = Eigen::VectorXi::Zero(model.njoints);
  joint_limit_ = Eigen::VectorXd::Zero(model.njoints);
  const auto& act = formulation_.actuatedRows();
  for (size_t k = 0; k < act.size(); ++k) {
    const int j = act[k] - 6;
    joint_actuated_[j] = 1;
    joint_limit_[j] = formulation_.torqueLimits()[static_cast<Eigen::Index>(k)];
  }
  ok_ = true;
}

BalanceController::~BalanceController() = default;

void BalanceController::sizeCommand(JointCommandSample& c) const {
  c.tau = Eigen::VectorXd::Zero(model_.njoints);
  c.tau_ff = Eigen::VectorXd::Zero(model_.njoints);
}

EstimateRejection BalanceController::judgeEstimate(const EstimatorOutputSample& e, double& mass) const {
  mass = 0.0;
  if (!cfg_.estimate.enabled) return EstimateRejection::Disabled;
  if (e.params.size() != model_.nparams() || e.tau_correction.size() != model_.nv) return EstimateRejection::WrongSize;
  if (e.tau_correction_stddev.size() != model_.nv) return EstimateRejection::WrongSize;
  if (!e.params.allFinite() || !e.tau_correction.allFinite() || !e.tau_correction_stddev.allFinite() ||
      !e.com_stddev.allFinite() || !std::isfinite(e.mass_stddev))
    return EstimateRejection::NonFinite;
  if (!e.valid) return EstimateRejection::NotValid;
  if (!e.consistent) return EstimateRejection::Inconsistent;
  for (int b = 0; b < model_.nbodies; ++b) {
    const Vector10d phi = e.params.segment<kParamsPerBody>(model_.bodyParamIndex(b));
    // The model may carry massless bodies (fixed frames); the estimator keeps them at the prior.
    if (model_.phi[model_.bodyParamIndex(b)] <= 0.0 && phi.isZero(0.0)) continue;
    if (!checkConsistency(phi).consistent) return EstimateRejection::Inconsistent;
    mass += phi[0];
  }
  double model_mass = 0.0;
  for (int b = 0; b < model_.nbodies; ++b) model_mass += model_.phi[model_.bodyParamIndex(b)];
  if (!(std::abs(mass - model_mass) <= cfg_.estimate.max_relative_mass_change * model_mass))
    return EstimateRejection::Mass;
  return EstimateRejection::None;
}

bool BalanceController::setEstimate(const EstimatorOutputSample& e) {
  if (has_applied_estimate_ && e.tick < applied_estimate_tick_) {  // would undo a newer one
    ++estimate_use_.out_of_order;
    return false;
  }
  double mass = 0.0;
  const EstimateRejection verdict = judgeEstimate(e, mass);
  // Its slot: a free one, or (queue full) the oldest pending one's, unless this estimate is older still.
  int at = pending_count_;  // position in the tick order
  while (at > 0 && pending_[static_cast<size_t>(pending_order_[static_cast<size_t>(at - 1)])].tick > e.tick) --at;
  int slot = pending_count_;
  if (pending_count_ == kEstimateQueue) {
    ++estimate_use_.overflow;
    if (at == 0) return false;
    slot = pending_order_[0];
    std::copy(pending_order_.begin() + 1, pending_order_.begin() + pending_count_, pending_order_.begin());
    --pending_count_;
    --at;
  } else {
    // Slots in use are exactly those named in pending_order_[0, count): take the first one not named.
    for (slot = 0; slot < kEstimateQueue; ++slot)
      if (std::find(pending_order_.begin(), pending_order_.begin() + pending_count_, slot) ==
          pending_order_.begin() + pending_count_)
        break;
  }
  PendingEstimate& p = pending_[static_cast<size_t>(slot)];
  p.tick = e.tick;
  p.verdict = verdict;
  p.late = has_last_tick_ && last_tick_ >= e.tick + cfg_.estimate.lag_ticks;
  p.mass = mass;
  if (verdict == EstimateRejection::None) {
    p.params = e.params;
    // Each entry of the correction as far as it stands out of its own uncertainty, then bounded.
    for (int r = 0; r < model_.nv; ++r)
      p.ff[r] = trustWeight(e.tau_correction[r], e.tau_correction_stddev[r], cfg_.estimate.trust_sigmas) *
                e.tau_correction[r];
    p.ff = p.ff.cwiseMax(-cfg_.estimate.max_abs).cwiseMin(cfg_.estimate.max_abs);
    p.com_stddev = e.com_stddev;
    p.mass_stddev = e.mass_stddev;
  }
  std::copy_backward(pending_order_.begin() + at, pending_order_.begin() + pending_count_,
                     pending_order_.begin() + pending_count_ + 1);
  pending_order_[static_cast<size_t>(at)] = slot;
  ++pending_count_;
  return verdict == EstimateRejection::None;
}

void BalanceController::applyDueEstimates(int64_t tick) {
  int n = 0;
  for (; n < pending_count_; ++n) {
    PendingEstimate& p = pending_[static_cast<size_t>(pending_order_[static_cast<size_t>(n)])];
    if (p.tick > tick - cfg_.estimate.lag_ticks) break;
    has_applied_estimate_ = true;
    applied_estimate_tick_ = p.tick;
    if (p.late) ++estimate_use_.late;
    if (p.verdict != EstimateRejection::None) {
      ++estimate_use_.rejected[static_cast<size_t>(p.verdict)];
      last_refusal_ = p.verdict;
      has_estimate_ = false;  // a newer estimate says no: stop using the older one (blended out from its values)
      continue;
    }
    phi_hat_.swap(p.params);  // the slot keeps the old vectors: no allocation
    ff_input_.swap(p.ff);
    com_stddev_ = p.com_stddev;
    mass_stddev_ = p.mass_stddev;
    estimate_tick_ = p.tick;
    has_estimate_ = true;
    ++estimate_use_.accepted;
    estimate_use_.mass = p.mass;
  }
  std::copy(pending_order_.begin() + n, pending_order_.begin() + pending_count_, pending_order_.begin());
  pending_count_ -= n;
}

void BalanceController::clearEstimate() {
  has_estimate_ = false;
  pending_count_ = 0;
}

void BalanceController::advanceEstimateBlend(int64_t tick) {
  // On while the last accepted estimate stands and is fresh; the ramp moves toward on/off at 1 / blend_time.
  const bool on = has_estimate_ && tick - estimate_tick_ <= cfg_.estimate.max_age_ticks;
  if (estimate_on_ && !on) {
    if (has_estimate_) ++estimate_use_.withdrawn_stale;
    else ++estimate_use_.withdrawn_refused;
  }
  estimate_on_ = on;
  const double step = cfg_.estimate.blend_time > 0.0
                          ? static_cast<double>(gap_) * cfg_.loop.period / cfg_.estimate.blend_time
                          : 1.0;
  blend_ramp_ = on ? std::min(1.0, blend_ramp_ + step) : std::max(0.0, blend_ramp_ - step);
  estimate_use_.active = on;
  estimate_use_.weight = blend_ramp_ * blend_ramp_ * (3.0 - 2.0 * blend_ramp_);  // smoothstep: no kick at the ends
}

void BalanceController::updateDynamics(const State& state) {
  computeRobotDynamics(model_, soles_, dyn_, state);
  angular_momentum_urdf_ = dyn_.momentum.tail<3>();
  const double w = estimate_use_.weight;
  vertical_shift_ = 0.0;
  vertical_shift_rate_ = 0.0;
  dyn_.tau_correction.setZero();
  if (w <= 0.0) return;
  if (cfg_.estimate.use_feedforward) dyn_.tau_correction = w * ff_input_;
  if (!cfg_.estimate.use_com) return;
  double mass;
  Eigen::Vector3d com, com_velocity;
  LinearAngular6d momentum;
  centroidalWorld(model_, phi_hat_, dyn_, mass, com, com_velocity, momentum);
  // Trust per world axis: the CoM's change from the model's against its uncertainty, the horizontal axes at their
  // own k (shipped 0: used whole), the height at 3 (the velocity and the momentum follow their axis's CoM: their
  // change comes from the same parameters). The height only when asked (use_com_height, the default;
  // docs/controller.md).
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i)
    t[i] = w * trustWeight(com[i] - dyn_.com[i], com_stddev_[i],
                           i < 2 ? cfg_.estimate.trust_sigmas_horizontal_com : cfg_.estimate.trust_sigmas);
  if (!cfg_.estimate.use_com_height) t.z() = 0.0;
  // A vertical CoM offset taken from the estimate moves the reference height with it: with straight knees the
  // stance, not the controller, sets the height, so only the horizontal CoM changes what is tracked.
  vertical_shift_ = t.z() * (com.z() - dyn_.com.z());
  vertical_shift_rate_ = t.z() * (com_velocity.z() - dyn_.com_velocity.z());
  dyn_.mass += w * trustWeight(mass - dyn_.mass, mass_stddev_, cfg_.estimate.trust_sigmas) * (mass - dyn_.mass);
  dyn_.com += t.cwiseProduct(com - dyn_.com);
  dyn_.com_velocity += t.cwiseProduct(com_velocity - dyn_.com_velocity);
  dyn_.momentum.head<3>() += t.cwiseProduct(momentum.head<3>() - dyn_.momentum.head<3>());
  dyn_.momentum.tail<3>() += t.cwiseProduct(momentum.tail<3>() - dyn_.momentum.tail<3>());
}

double BalanceController::trustWeight(double change, double stddev, double k) {
  const double a = std::abs(change);
  if (k <= 0.0) return 1.0;
  if (!(a > k * stddev)) return 0.0;  // within k sigma of the model (and 0 = 0): the model stands
  const double r = k * stddev / a;
  return 1.0 - r * r;
}

bool BalanceController::setForcePlate(const ForcePlateSample& p) {
  if (p.plate < 0 || p.plate > 1 || !p.force.allFinite() || !p.moment.allFinite() ||
      !p.plate_position.allFinite() || !p.plate_orientation.coeffs().allFinite())
    return false;
  // Each plate is placed where its latched sole is (the sole's centre on the plate's reported origin, the
  // identification's convention), its moment taken about the controller's world origin: the plate residual below and
  // the CoM observer work in the controller's world, whatever the lab's origin (`plate_position` is in the lab's
  // frame, which may be metres from this world). Before the latch that world is not fixed yet: the sample is valid
  // but not used.
  if (!observer_->latched()) return true;
  const size_t i = static_cast<size_t>(p.plate);
  const Eigen::Matrix3d R = p.plate_orientation.normalized().toRotationMatrix();
  const Eigen::Vector3d F_plate = R * p.force;
  plate_force_[i] = -F_plate;  // ON the foot
  const Eigen::Vector3d& origin = observer_->solePosition(p.plate);
  plate_moment_[i] = -(R * p.moment + origin.cross(F_plate));
  plate_tick_[i] = p.tick;
  return true;
}

bool BalanceController::platePairFresh() const {
  return plate_tick_[0] >= 0 && plate_tick_[0] == plate_tick_[1] &&
         last_tick_ - plate_tick_[0] <= cfg_.disturbance.max_plate_age_ticks;
}

void BalanceController::applyComObserver() {
  const Eigen::Vector3d force = plate_force_[0] + plate_force_[1];
  const Eigen::Vector3d moment = plate_moment_[0] + plate_moment_[1];
  const bool plates = platePairFresh();
  const Eigen::Matrix3d R = observer_->state().base_orientation.toRotationMatrix();  // the pelvis is the base
  com_observer_.setHeading(std::atan2(R(1, 0), R(0, 0)));
  com_observer_.update(dyn_.com, dyn_.com_velocity, angular_momentum_urdf_, plates ? &force : nullptr,
                       plates ? &moment : nullptr, dyn_.mass, gap_);
  if (!com_observer_.applies()) return;
  dyn_.com += com_observer_.correction();
  dyn_.com_velocity += com_observer_.velocityCorrection();
  dyn_.momentum.head<3>() += dyn_.mass * com_observer_.velocityCorrection();
}

bool BalanceController::plateResidual() {
  // Both plates of the same tick j, recent, and the wrench planned for the command applied at tick j.
  if (!platePairFresh()) return false;
  const size_t slot = static_cast<size_t>(plate_tick_[0] % kPlanRing);
  if (planned_tick_[slot] != plate_tick_[0]) return false;
  wrench_residual_.setZero();
  for (size_t i = 0; i < 2; ++i) {
    LinearAngular6d f;  // measured, the formulation's convention: world, moment about the sole origin
    f.head<3>() = plate_force_[i];
    f.tail<3>() = plate_moment_[i] - dyn_.foot_position[i].cross(plate_force_[i]);
    f -= planned_wrench_[slot].segment<6>(6 * static_cast<Eigen::Index>(i));
    wrench_residual_.noalias() += dyn_.Jc[i].transpose() * f;
  }
  return true;
}

bool BalanceController::inputValid(const RobotStateSample& in) const {
  if (in.q.size() != model_.njoints || !in.q.allFinite()) return false;
  if (!in.imu_gyro.allFinite() || !in.imu_orientation.coeffs().allFinite()) return false;
  const double n = in.imu_orientation.coeffs().norm();
  return std::abs(n - 1.0) <= cfg_.fallback.max_quaternion_norm_error;
}

void BalanceController::startTrajectory(int64_t tick) {
  // Posture and contact references from the start-up estimate; support polygon of the latched soles.
  posture_.setReference(observer_->initialPosture());
  contact_right_.setReference(observer_->solePosition(0), observer_->soleRotation(0));
  contact_left_.setReference(observer_->solePosition(1), observer_->soleRotation(1));
  updateDynamics(observer_->state());
  com_observer_.reset();  // its anchor to the model was in the world before the latch
  const auto yaw = [](const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); };
  const SupportPolygon polygon = SupportPolygon::fromSoles(
      observer_->solePosition(0).head<2>(), yaw(observer_->soleRotation(0)), observer_->solePosition(1).head<2>(),
      yaw(observer_->soleRotation(1)), cfg_.contact.sole_half_length, cfg_.contact.sole_half_width);
  const Eigen::Vector3d start = dyn_.com - Eigen::Vector3d(0.0, 0.0, vertical_shift_);
  move_reach_ = staticMomentReach(model_, dyn_.dyn.kin, dyn_.R, dyn_.base_position, soles_, cfg_.trajectory.torque_budget);
  trajectory_.generate(cfg_.trajectory, seed_, start, polygon, move_reach_);  // not ready() on failure: holds the start
  trajectory_start_tick_ = tick;
}

bool BalanceController::runQp() {
  momentum_.compute(ref_, dyn_, rate_desired_);
  posture_.compute(observer_->state(), dnu_desired_, dnu_weights_);
  formulation_.build(dyn_, rate_desired_, momentum_.weights(), dnu_desired_, dnu_weights_, contact_right_,
                     contact_left_, qp_);
  solver_->solve(qp_, result_);
  return result_.status == QpStatus::Solved && result_.x.allFinite();
}

void BalanceController::fallbackTorque(JointCommandSample& out) {
  if (has_last_safe_ && !damping_latched_ && bad_streak_ <= cfg_.fallback.hold_ticks) {
    out.mode = CommandMode::HoldLastSafe;
    tau_cmd_ = tau_last_safe_;
    ++hold_ticks_;
    return;
  }
  damping_latched_ = true;
  out.mode = CommandMode::Damping;
  for (Eigen::Index j = 0; j < tau_cmd_.size(); ++j) {
    const double vj = observer_ && std::isfinite(observer_->state().v[j]) ? observer_->state().v[j] : 0.0;
    tau_cmd_[j] = clampAbs(-cfg_.fallback.damping * vj, cfg_.fallback.damping_torque_limit);
  }
  ++damping_ticks_;
}

FallbackReason BalanceController::acceptState(const RobotStateSample& in, bool& fresh) {
  fresh = false;
  if (!ok_) return FallbackReason::InvalidInput;
  if (!inputValid(in)) {
    ++rejected_;
    return FallbackReason::InvalidInput;
  }
  if (has_last_tick_ && in.tick <= last_tick_) {
    ++rejected_;
    return FallbackReason::OutOfOrder;
  }
  const int64_t gap = has_last_tick_ ? in.tick - last_tick_ : 1;
  gap_ = gap;
  if (gap > 1) stale_ += static_cast<int32_t>(gap - 1);
  const bool was_latched = observer_->latched();
  observer_->update(in, gap);
  has_last_tick_ = true;
  last_tick_ = in.tick;
  fresh = true;
  const FallbackReason reason = gap - 1 > cfg_.fallback.max_missed_ticks ? FallbackReason::Stale : FallbackReason::None;
  applyDueEstimates(in.tick);
  advanceEstimateBlend(in.tick);
  if (observer_->latched() && !was_latched) startTrajectory(in.tick);
  return reason;
}

void BalanceController::updateReference(int64_t tick, ControllerStatus& st) {
  if (observer_->latched()) {
    const double t = static_cast<double>(tick - trajectory_start_tick_) * cfg_.loop.period;
    trajectory_.sample(t, ref_);
    if (!trajectory_.ready()) ref_.position = trajectory_.start();
    ref_.position.z() += vertical_shift_;
    ref_.velocity.z() += vertical_shift_rate_;
    st.trajectory_time = t;
  } else {
    ref_ = CoMReference{};
    ref_.position = dyn_.com;
    contact_right_.setReference(observer_->solePosition(0), observer_->soleRotation(0));
    contact_left_.setReference(observer_->solePosition(1), observer_->soleRotation(1));
    posture_.setReference(observer_->initialPosture());
  }
}

bool BalanceController::computeTorque(FallbackReason& reason, ControllerStatus& st) {
  // The disturbance observer's estimate of what the model (and the estimate) still misses is added.
  if (cfg_.disturbance.enabled) {
    const bool plates = cfg_.disturbance.force_plates && plateResidual();
    disturbance_.update(dyn_.dyn.M, dyn_.nu, gap_, plates ? &wrench_residual_ : nullptr);
    dyn_.tau_correction += disturbance_.estimate();
  }
  const bool qp_ok = runQp();
  st.qp_status = result_.status;
  st.qp_iterations = result_.iterations;
  st.qp_solve_us = result_.solve_us;
  if (!qp_ok) {
    ++qp_failures_;
    if (reason == FallbackReason::None) reason = FallbackReason::QpFailed;
    return false;
  }
  formulation_.generalizedForce(dyn_, result_.x, tau_gen_);
  for (Eigen::Index j = 0; j < tau_cmd_.size(); ++j)
    tau_cmd_[j] = joint_actuated_[j] ? clampAbs(tau_gen_[6 + j], joint_limit_[j]) : 0.0;
  if (!tau_cmd_.allFinite() && reason == FallbackReason::None) reason = FallbackReason::NonFiniteTorque;
  // command.tau_ff reports everything fed forward on the joints: what the controller added to its model's
  // dynamics (the estimate's trusted, blended correction and the disturbance observer's estimate).
  for (Eigen::Index j = 0; j < tau_ff_joint_.size(); ++j)
    tau_ff_joint_[j] = joint_actuated_[j] ? dyn_.tau_correction[6 + j] : 0.0;
  return true;
}

void BalanceController::reportTaskState(bool qp_ok, ControllerStatus& st) const {
  st.com_ref = ref_.position;
  st.com_vel_ref = ref_.velocity;
  st.com = dyn_.com;
  st.com_vel = dyn_.com_velocity;
  st.momentum_rate_ref = rate_desired_;
  st.momentum = dyn_.momentum;
  if (qp_ok) {
    st.wrench_right = result_.x.segment<6>(model_.nv);
    st.wrench_left = result_.x.segment<6>(model_.nv + 6);
  }
  st.move_index = ref_.move_index;
  st.moves_done = ref_.moves_done;
  st.trajectory_ready = trajectory_.ready();
  st.trajectory_failed = observer_->latched() && !trajectory_.ready();
  st.trajectory_done = ref_.done;
  st.leg_disagreement = observer_->legDisagreement();
  st.dropped_contact_directions = formulation_.droppedContactDirections();
}

void BalanceController::selectMode(FallbackReason& reason, JointCommandSample& out) {
  bool good = reason == FallbackReason::None;
  if (good && damping_latched_) {
    ++good_streak_;
    if (good_streak_ < cfg_.fallback.recovery_ticks) {
      good = false;
      reason = FallbackReason::Recovering;
    }
  }
  if (good) {
    out.mode = CommandMode::Torque;
    disturbance_.setPlanned(result_.x.head(model_.nv));
    const size_t slot = static_cast<size_t>(out.tick % kPlanRing);
    planned_wrench_[slot] = result_.x.segment<12>(model_.nv);
    planned_tick_[slot] = out.tick;
    tau_last_safe_ = tau_cmd_;
    has_last_safe_ = true;
    bad_streak_ = 0;
    damping_latched_ = false;
    return;
  }
  if (reason != FallbackReason::Recovering) {
    ++bad_streak_;
    good_streak_ = 0;
  }
  ++fallbacks_;
  disturbance_.clearPlanned();
  planned_tick_[static_cast<size_t>(out.tick % kPlanRing)] = -1;
  fallbackTorque(out);
  tau_ff_joint_.setZero();
}

void BalanceController::tick(const RobotStateSample& in, JointCommandSample& out, ControllerStatus& st) {
  const auto t0 = std::chrono::steady_clock::now();
  if (out.tau.size() != model_.njoints || out.tau_ff.size() != model_.njoints) sizeCommand(out);  // misuse only
  out.tick = in.tick + 1;
  out.source_tick = in.tick;
  out.utime = in.utime + static_cast<int64_t>(std::llround(cfg_.loop.period * 1e6));
  st.utime = in.utime;
  st.tick = in.tick;

  bool fresh = false;  // the estimator took this sample
  FallbackReason reason = acceptState(in, fresh);
  st.qp_status = QpStatus::NotRun;
  st.qp_iterations = 0;
  st.qp_solve_us = 0.0;
  if (fresh) {
    // Dynamics with the estimate blended in: tau_correction (estimator) in h + tau_correction, the controller's CoM.
    updateDynamics(observer_->state());
    applyComObserver();  // what the model holds rigid and the plates see (com_observer.hpp)
    // Reference: the trajectory once the feet are latched (its height moved with the estimate's vertical CoM
    // offset); before that, hold the current CoM.
    updateReference(in.tick, st);
    const bool qp_ok = computeTorque(reason, st);
    reportTaskState(qp_ok, st);
  }
  selectMode(reason, out);
  // Last line of defence: finite, within limits, zero on unactuated joints.
  for (Eigen::Index j = 0; j < tau_cmd_.size(); ++j) {
    const double v = std::isfinite(tau_cmd_[j]) ? tau_cmd_[j] : 0.0;
    out.tau[j] = joint_actuated_[j] ? clampAbs(v, joint_limit_[j]) : 0.0;
    out.tau_ff[j] = std::isfinite(tau_ff_joint_[j]) ? tau_ff_joint_[j] : 0.0;
  }

  st.mode = out.mode;
  st.reason = reason;
  st.fallbacks = fallbacks_;
  st.rejected_inputs = rejected_;
  st.stale_inputs = stale_;
  st.qp_failures = qp_failures_;
  st.hold_ticks = hold_ticks_;
  st.damping_ticks = damping_ticks_;
  st.estimate = estimate_use_;
  st.tick_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace exoid::controller
