// Safe fallback of BalanceController: bad inputs (NaN, out-of-order, stale, bad quaternion) and QP failures
// (infeasible, non-finite solution) hold the last safe command for fallback.hold_ticks, then damp the joints;
// the command is always finite, within limits, zero on the passive joints, and every event is counted.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "controller_test_util.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/proxqp_solver.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"

namespace exoid::controller {
namespace {

/// ProxQP with scripted failures (the solver interface makes the control law testable without a solver bug).
class ScriptedSolver final : public QpSolver {
 public:
  enum class Mode { Pass, Infeasible, NaN };
  explicit ScriptedSolver(const QpSolverSettings& s) : inner_(makeProxQpSolver(s)) {}
  bool setup(const QpDimensions& d) override { return inner_->setup(d); }
  void solve(const QpProblem& p, QpResult& r) override {
    inner_->solve(p, r);
    if (mode == Mode::Infeasible) r.status = QpStatus::Infeasible;
    if (mode == Mode::NaN) r.x[3] = std::numeric_limits<double>::quiet_NaN();  // "solved" but non-finite
  }
  void resetWarmStart() override { inner_->resetWarmStart(); }
  const char* name() const override { return "scripted"; }
  Mode mode = Mode::Pass;

 private:
  std::unique_ptr<QpSolver> inner_;
};

class FallbackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(testing::loadModel(model_, &err)) << err;
    ASSERT_TRUE(testing::loadConfig(cfg_, &err)) << err;
    // These tests are about what an applied estimate does: applied from the tick it names (the fixed lag has
    // its own test, EstimatesAreAppliedExactlyLagTicksAfterTheirTickInTickOrder).
    cfg_.estimate.lag_ticks = 0;
    make(cfg_);
  }
  void make(const ControllerConfig& cfg) {
    auto solver = std::make_unique<ScriptedSolver>(QpSolverSettings{cfg.solver.eps_abs, cfg.solver.max_iterations});
    solver_ = solver.get();
    ctrl_ = std::make_unique<BalanceController>(model_, cfg, 1, std::move(solver));
    ASSERT_TRUE(ctrl_->ok()) << ctrl_->error();
    ctrl_->sizeCommand(cmd_);
    sample_.q = Eigen::VectorXd::Zero(model_.njoints);  // standing pose of config/exo.urdf
    sample_.tau = Eigen::VectorXd::Zero(model_.njoints);
    sample_.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model_.njoints, true);
  }
  /// One tick with the standing sample at `tick`; checks the invariants every command must satisfy.
  void tick(int64_t tick) {
    sample_.tick = tick;
    sample_.utime = tick * 1000;
    ctrl_->tick(sample_, cmd_, st_);
    ASSERT_TRUE(cmd_.tau.allFinite());
    ASSERT_TRUE(cmd_.tau_ff.allFinite());
    EXPECT_EQ(cmd_.tick, tick + 1);
    for (int j = 0; j < model_.njoints; ++j) {
      EXPECT_LE(std::abs(cmd_.tau[j]), model_.effort_limit[j] * cfg_.torque.limit_scale + 1e-12);
      if (model_.effort_limit[j] == 0.0) {
        EXPECT_EQ(cmd_.tau[j], 0.0) << "passive joint " << j;
      }
    }
  }
  /// Runs good ticks until the controller is in torque mode past the start-up latch.
  int64_t settle(int64_t from = 0) {
    const int64_t end = from + cfg_.observer.latch_ticks + 50;
    for (int64_t k = from; k < end; ++k) tick(k);
    EXPECT_EQ(cmd_.mode, CommandMode::Torque);
    EXPECT_EQ(st_.fallbacks, 0);
    return end;
  }

  Model model_;
  ControllerConfig cfg_;
  ScriptedSolver* solver_ = nullptr;
  std::unique_ptr<BalanceController> ctrl_;
  RobotStateSample sample_;
  JointCommandSample cmd_;
  ControllerStatus st_;
};

TEST_F(FallbackTest, NaNStateHoldsTheLastSafeCommandThenDampsThenRecovers) {
  int64_t k = settle();
  const Eigen::VectorXd safe = cmd_.tau;
  ASSERT_GT(safe.norm(), 1.0);  // standing needs torque (ankles, hips)
  const int hold = cfg_.fallback.hold_ticks, extra = 10;
  sample_.q[2] = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < hold + extra; ++i, ++k) {
    tick(k);
    EXPECT_EQ(st_.reason, FallbackReason::InvalidInput);
    if (i < hold) {
      EXPECT_EQ(cmd_.mode, CommandMode::HoldLastSafe) << i;
      EXPECT_EQ((cmd_.tau - safe).norm(), 0.0);
    } else {
      EXPECT_EQ(cmd_.mode, CommandMode::Damping) << i;
      // tau = -D v with the last joint velocity estimate (at rest: 0), bounded.
      EXPECT_LE(cmd_.tau.lpNorm<Eigen::Infinity>(), cfg_.fallback.damping_torque_limit);
    }
    EXPECT_EQ(cmd_.tau_ff.norm(), 0.0);
  }
  EXPECT_EQ(st_.rejected_inputs, hold + extra);
  EXPECT_EQ(st_.fallbacks, hold + extra);
  EXPECT_EQ(st_.hold_ticks, hold);
  EXPECT_EQ(st_.damping_ticks, extra);
  // Good samples again. The first is stale (its predecessor is hold + extra ticks back), then the controller
  // needs recovery_ticks consecutive good ticks before it leaves the damping mode.
  sample_.q[2] = 0.0;
  tick(k++);
  EXPECT_EQ(st_.reason, FallbackReason::Stale);
  EXPECT_EQ(st_.stale_inputs, hold + extra);
  EXPECT_EQ(cmd_.mode, CommandMode::Damping);
  for (int i = 0; i < cfg_.fallback.recovery_ticks - 1; ++i, ++k) {
    tick(k);
    EXPECT_EQ(cmd_.mode, CommandMode::Damping) << i;
    EXPECT_EQ(st_.reason, FallbackReason::Recovering);
  }
  tick(k++);
  EXPECT_EQ(cmd_.mode, CommandMode::Torque);
  EXPECT_EQ(st_.reason, FallbackReason::None);
  EXPECT_EQ(st_.fallbacks, hold + extra + cfg_.fallback.recovery_ticks);
}

TEST_F(FallbackTest, NaNBeforeAnyGoodTickDampsAtOnce) {
  sample_.imu_gyro = Eigen::Vector3d(0.0, std::numeric_limits<double>::infinity(), 0.0);
  tick(0);
  EXPECT_EQ(cmd_.mode, CommandMode::Damping);  // no safe command to hold yet
  EXPECT_EQ(cmd_.tau.norm(), 0.0);
  EXPECT_EQ(st_.rejected_inputs, 1);
  EXPECT_EQ(st_.qp_status, QpStatus::NotRun);
}

TEST_F(FallbackTest, OutOfOrderDuplicateAndBadQuaternionAreRejected) {
  int64_t k = settle();
  tick(k - 1);  // duplicate of the last accepted tick
  EXPECT_EQ(st_.reason, FallbackReason::OutOfOrder);
  tick(k - 5);  // older
  EXPECT_EQ(st_.reason, FallbackReason::OutOfOrder);
  sample_.imu_orientation.coeffs() *= 1.5;  // not a unit quaternion
  tick(k++);
  EXPECT_EQ(st_.reason, FallbackReason::InvalidInput);
  EXPECT_EQ(st_.rejected_inputs, 3);
  EXPECT_EQ(st_.fallbacks, 3);
  EXPECT_EQ(cmd_.mode, CommandMode::HoldLastSafe);
  sample_.imu_orientation = Eigen::Quaterniond::Identity();
  tick(k++);  // next tick after the rejected one: gap 2 from the last accepted, within max_missed_ticks
  EXPECT_EQ(cmd_.mode, CommandMode::Torque);
  EXPECT_EQ(st_.stale_inputs, 1);
}

TEST_F(FallbackTest, GapBeyondTheLimitIsStale) {
  int64_t k = settle();
  const int gap = cfg_.fallback.max_missed_ticks + 2;
  tick(k + gap - 1);
  EXPECT_EQ(st_.reason, FallbackReason::Stale);
  EXPECT_EQ(cmd_.mode, CommandMode::HoldLastSafe);
  EXPECT_EQ(st_.stale_inputs, gap - 1);
  tick(k + gap);
  EXPECT_EQ(cmd_.mode, CommandMode::Torque);  // hold, not damping: back to torque at once
}

TEST_F(FallbackTest, QpFailureHoldsThenDamps) {
  int64_t k = settle();
  const Eigen::VectorXd safe = cmd_.tau;
  solver_->mode = ScriptedSolver::Mode::Infeasible;
  for (int i = 0; i < cfg_.fallback.hold_ticks + 5; ++i, ++k) {
    tick(k);
    EXPECT_EQ(st_.reason, FallbackReason::QpFailed);
    EXPECT_EQ(st_.qp_status, QpStatus::Infeasible);
    EXPECT_EQ(cmd_.mode, i < cfg_.fallback.hold_ticks ? CommandMode::HoldLastSafe : CommandMode::Damping);
    if (i < cfg_.fallback.hold_ticks) {
      EXPECT_EQ((cmd_.tau - safe).norm(), 0.0);
    }
  }
  EXPECT_EQ(st_.qp_failures, cfg_.fallback.hold_ticks + 5);
  EXPECT_EQ(st_.fallbacks, cfg_.fallback.hold_ticks + 5);
  EXPECT_EQ(st_.rejected_inputs, 0);
}

TEST_F(FallbackTest, NonFiniteSolutionNeverReachesTheCommand) {
  int64_t k = settle();
  solver_->mode = ScriptedSolver::Mode::NaN;
  tick(k++);
  EXPECT_EQ(st_.reason, FallbackReason::QpFailed);
  EXPECT_EQ(cmd_.mode, CommandMode::HoldLastSafe);
  EXPECT_EQ(st_.qp_failures, 1);
  solver_->mode = ScriptedSolver::Mode::Pass;
  tick(k++);
  EXPECT_EQ(cmd_.mode, CommandMode::Torque);
}

TEST_F(FallbackTest, InfeasibleProblemFromTheConfigFallsBack) {
  // Each foot must push 5 kN (ten times the weight): the real ProxQP reports it infeasible every tick.
  ControllerConfig cfg = cfg_;
  cfg.contact.min_normal_force = 5000.0;
  make(cfg);
  for (int64_t k = 0; k < 50; ++k) {
    tick(k);
    EXPECT_NE(st_.qp_status, QpStatus::Solved);
    EXPECT_EQ(cmd_.mode, CommandMode::Damping);
  }
  EXPECT_EQ(st_.qp_failures, 50);
  EXPECT_EQ(st_.fallbacks, 50);
}

EstimatorOutputSample modelEstimate(const Model& model, int64_t tick) {
  EstimatorOutputSample e;
  e.tick = tick;
  e.valid = e.consistent = true;
  e.params = model.phi;
  e.tau_correction = Eigen::VectorXd::Zero(model.nv);
  e.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  return e;
}

TEST_F(FallbackTest, EstimateFeedforwardIsAppliedReportedAndAgesOut) {
  // Not a fallback, but the same standing fixture: the estimate's feedforward on an actuated joint enters
  // the dynamics, so the commanded torque moves by exactly that amount; command.tau_ff reports it; a stale
  // estimate (older than estimate.max_age_ticks) is withdrawn (no blending here: blend_time 0).
  ControllerConfig cfg = cfg_;
  cfg.estimate.blend_time = 0.0;
  make(cfg);
  int64_t k = settle();
  tick(k++);
  const Eigen::VectorXd tau0 = cmd_.tau;
  const int knee = model_.jointIndex("left_knee");
  EstimatorOutputSample e = modelEstimate(model_, k);
  e.tau_correction[model_.jointRow(knee)] = 2.5;
  ASSERT_TRUE(ctrl_->setEstimate(e));
  tick(k++);
  // command.tau_ff: everything fed forward, the estimate's correction plus the disturbance observer's estimate.
  const int row = model_.jointRow(knee);
  EXPECT_NEAR(cmd_.tau_ff[knee], 2.5 + ctrl_->disturbanceObserver().estimate()[row], 1e-12);
  EXPECT_NEAR(cmd_.tau[knee] - tau0[knee], 2.5, 0.05);  // the state barely changed in one tick
  EXPECT_EQ(st_.estimate.weight, 1.0);
  for (int i = 0; i < cfg.estimate.max_age_ticks + 1; ++i) tick(k++);
  // The estimate withdrawn: on every actuated joint tau_ff is the disturbance observer's estimate alone, exactly.
  for (int j = 0; j < model_.njoints; ++j) {
    const double observer = ctrl_->disturbanceObserver().estimate()[model_.jointRow(j)];
    EXPECT_EQ(cmd_.tau_ff[j], model_.effort_limit[j] > 0.0 ? observer : 0.0) << j;
  }
  EXPECT_NEAR(cmd_.tau[knee], tau0[knee], 0.05);
  EXPECT_EQ(st_.estimate.withdrawn_stale, 1);
  EXPECT_EQ(st_.estimate.withdrawn_refused, 0);
  EXPECT_FALSE(st_.estimate.active);
}


TEST_F(FallbackTest, TrustUsesOnlyWhatStandsOutOfTheEstimatesUncertainty) {
  // Issue 20: each quantity the estimate changes enters with weight max(0, 1 - (k sigma / |change|)^2), k =
  // estimate.trust_sigmas (3) for every tau_correction entry, the mass and the CoM height, and
  // estimate.trust_sigmas_horizontal_com (0: used whole) for the CoM's horizontal axes; sigma the estimate's own
  // one-sigma. A hand-made estimate: the model plus 2 kg on the base link (the CoM moves on every axis), two joint
  // corrections; sigmas chosen to put each quantity on a known side of the threshold. Expected values computed here
  // from the parameters (centroidalWorld).
  ControllerConfig cfg = cfg_;
  cfg.estimate.blend_time = 0.0;
  ASSERT_EQ(cfg.estimate.trust_sigmas, 3.0);                 // the shipped configuration
  ASSERT_EQ(cfg.estimate.trust_sigmas_horizontal_com, 0.0);
  const int knee = model_.jointIndex("left_knee"), hip = model_.jointIndex("right_hip_fe");
  ASSERT_GE(knee, 0);
  ASSERT_GE(hip, 0);
  // One run: the controller at its settled state, this estimate with CoM sigmas (change / ratio) per axis (ratio
  // 0: sigma 0); returns the CoM change used, the full change, and the controller's dynamics.
  struct Used {
    Eigen::Vector3d used, full;
    double mass = 0.0, mass_model = 0.0, mass_estimate = 0.0;
    Eigen::VectorXd tau_correction;  // [nv]
  };
  const auto run = [&](const ControllerConfig& c, const Eigen::Vector3d& ratio) {
    make(c);
    int64_t k = settle();
    tick(k++);
    EstimatorOutputSample e = modelEstimate(model_, k);
    e.params.segment<kParamsPerBody>(model_.bodyParamIndex(0)) += paramsFromInertial(
        2.0, Eigen::Vector3d(0.08, 0.05, 0.1), Eigen::Matrix3d::Identity(), 0.01 * Eigen::Matrix3d::Identity());
    e.tau_correction[model_.jointRow(knee)] = 2.5;  // 2.5 sigma: not used at k = 3
    e.tau_correction_stddev[model_.jointRow(knee)] = 1.0;
    e.tau_correction[model_.jointRow(hip)] = 5.0;   // 5 sigma: weight 1 - (3/5)^2 = 0.64
    e.tau_correction_stddev[model_.jointRow(hip)] = 1.0;
    // The CoM change at the current state (the state barely moves in one tick: recomputed after it below).
    controller::RobotDynamicsData d = ctrl_->dynamics();
    double m0, m1;
    Eigen::Vector3d c0, c1, v;
    LinearAngular6d h;
    controller::centroidalWorld(model_, model_.phi, d, m0, c0, v, h);
    controller::centroidalWorld(model_, e.params, d, m1, c1, v, h);
    const Eigen::Vector3d change = c1 - c0;
    EXPECT_GT(change.cwiseAbs().minCoeff(), 1e-4);
    for (int a = 0; a < 3; ++a) e.com_stddev[a] = ratio[a] > 0.0 ? std::abs(change[a]) / ratio[a] : 0.0;
    e.mass_stddev = 2.0;  // 1 sigma: the mass change is not used at k = 3
    EXPECT_TRUE(ctrl_->setEstimate(e));
    tick(k++);
    d = ctrl_->dynamics();
    controller::RobotDynamicsData scratch = d;
    controller::centroidalWorld(model_, model_.phi, scratch, m0, c0, v, h);
    controller::centroidalWorld(model_, e.params, scratch, m1, c1, v, h);
    Used u;
    u.used = d.com - c0;
    u.mass = d.mass;
    u.tau_correction = d.tau_correction;
    u.full = c1 - c0;
    u.mass_model = m0;
    u.mass_estimate = m1;
    return u;
  };
  const auto ff = [&](const Used& u, int joint) {
    return u.tau_correction[model_.jointRow(joint)] -
           ctrl_->disturbanceObserver().estimate()[model_.jointRow(joint)];
  };
  // Shipped: x at 10 sigma, y and z at 2 sigma: x and y used whole (k = 0), z not (k = 3).
  Used u = run(cfg, Eigen::Vector3d(10.0, 2.0, 2.0));
  EXPECT_NEAR(u.used.x(), u.full.x(), 1e-9);
  EXPECT_NEAR(u.used.y(), u.full.y(), 1e-9);
  EXPECT_NEAR(u.used.z(), 0.0, 1e-12);
  EXPECT_NEAR(u.mass, u.mass_model, 1e-9);  // within 1 sigma: the model's mass
  EXPECT_NEAR(ff(u, knee), 0.0, 1e-12);
  EXPECT_NEAR(ff(u, hip), 0.64 * 5.0, 1e-12);
  // The horizontal axes at k = 1 (the James-Stein weight, shipped 2026-12-06 to stop 47): 10 sigma 1 - 1/100, 2 sigma
  // 1 - 1/4; the height still at k = 3.
  ControllerConfig one = cfg;
  one.estimate.trust_sigmas_horizontal_com = 1.0;
  u = run(one, Eigen::Vector3d(10.0, 2.0, 2.0));
  EXPECT_NEAR(u.used.x(), 0.99 * u.full.x(), 1e-9);
  EXPECT_NEAR(u.used.y(), 0.75 * u.full.y(), 1e-9);
  EXPECT_NEAR(u.used.z(), 0.0, 1e-12);
  // The horizontal axes at k = 3 too (the rule before 2026-12-06): 10 sigma 0.91, 2 sigma not used; a zero sigma
  // (exact) is used whole.
  ControllerConfig three = cfg;
  three.estimate.trust_sigmas_horizontal_com = 3.0;
  u = run(three, Eigen::Vector3d(10.0, 2.0, 0.0));
  EXPECT_NEAR(u.used.x(), 0.91 * u.full.x(), 1e-9);
  EXPECT_NEAR(u.used.y(), 0.0, 1e-12);
  EXPECT_NEAR(u.used.z(), u.full.z(), 1e-9);
  // trust_sigmas 0 for both: everything as it is (the mass and the joint corrections too).
  ControllerConfig none = cfg;
  none.estimate.trust_sigmas = 0.0;
  none.estimate.trust_sigmas_horizontal_com = 0.0;
  u = run(none, Eigen::Vector3d(10.0, 2.0, 2.0));
  EXPECT_NEAR((u.used - u.full).norm(), 0.0, 1e-9);
  EXPECT_NEAR(u.mass, u.mass_estimate, 1e-9);
  EXPECT_NEAR(ff(u, knee), 2.5, 1e-12);
  EXPECT_NEAR(ff(u, hip), 5.0, 1e-12);
}
TEST_F(FallbackTest, UnusableEstimatesAreRefusedByReasonAndWithdrawTheCurrentOne) {
  int64_t k = settle();
  const auto refused = [&](EstimateRejection r) { return st_.estimate.rejected[static_cast<size_t>(r)]; };
  EstimatorOutputSample good = modelEstimate(model_, k);
  ASSERT_TRUE(ctrl_->setEstimate(good));
  tick(k++);
  EXPECT_TRUE(st_.estimate.active);
  EXPECT_GT(st_.estimate.weight, 0.0);
  const double model_mass = st_.estimate.mass;

  EstimatorOutputSample e = good;
  e.params.resize(3);
  EXPECT_FALSE(ctrl_->setEstimate(e));
  e = good;
  e.tau_correction[7] = std::nan("");
  EXPECT_FALSE(ctrl_->setEstimate(e));
  e = good;
  e.valid = false;
  EXPECT_FALSE(ctrl_->setEstimate(e));
  e = good;
  e.consistent = false;
  EXPECT_FALSE(ctrl_->setEstimate(e));
  // Flagged consistent but not: a negative principal moment on a thigh (checked here, model/inertial.hpp).
  e = good;
  const int thigh = model_.bodyParamIndex(model_.bodyIndex("right_thigh"));
  e.params[thigh + 4] = -0.5;  // I_xx about the link origin
  EXPECT_FALSE(ctrl_->setEstimate(e));
  // Consistent body by body, but twice the robot's mass.
  e = good;
  for (int b = 0; b < model_.nbodies; ++b) e.params.segment<kParamsPerBody>(model_.bodyParamIndex(b)) *= 2.0;
  EXPECT_FALSE(ctrl_->setEstimate(e));
  tick(k++);
  EXPECT_EQ(refused(EstimateRejection::WrongSize), 1);
  EXPECT_EQ(refused(EstimateRejection::NonFinite), 1);
  EXPECT_EQ(refused(EstimateRejection::NotValid), 1);
  EXPECT_EQ(refused(EstimateRejection::Inconsistent), 2);
  EXPECT_EQ(refused(EstimateRejection::Mass), 1);
  EXPECT_EQ(st_.estimate.accepted, 1);
  EXPECT_EQ(st_.estimate.withdrawn_refused, 1);  // one switch-off, however many refusals
  EXPECT_FALSE(st_.estimate.active);
  EXPECT_EQ(st_.estimate.mass, model_mass);  // the last accepted one's

  ControllerConfig off = cfg_;
  off.estimate.enabled = false;
  make(off);
  EXPECT_FALSE(ctrl_->setEstimate(good));
}

// The fixed lag (estimate.lag_ticks = L): the estimate of tick e is applied at the state of tick e + L exactly,
// whenever and in whatever order it was offered; none before its tick; a refusal withdraws at its tick too. An
// estimate older than the one applied last is dropped, one that arrives after its tick is applied at the next
// tick and counted late, a full queue drops its oldest.
TEST_F(FallbackTest, EstimatesAreAppliedExactlyLagTicksAfterTheirTickInTickOrder) {
  ControllerConfig cfg = cfg_;
  cfg.estimate.lag_ticks = 20;
  cfg.estimate.max_age_ticks = 200;
  cfg.estimate.blend_time = 0.0;  // the weight switches at once: tau_ff shows which estimate is applied
  make(cfg);
  const int64_t k0 = settle();
  const int L = cfg.estimate.lag_ticks;
  const int knee = model_.jointIndex("left_knee");
  // command.tau_ff holds the disturbance observer's estimate too: the estimate's part is what is left.
  const auto fromEstimate = [&] {
    return cmd_.tau_ff[knee] - ctrl_->disturbanceObserver().estimate()[model_.jointRow(knee)];
  };
  const auto offer = [&](int64_t tick, double ff, bool valid) {
    EstimatorOutputSample e = modelEstimate(model_, tick);
    e.tau_correction[model_.jointRow(knee)] = ff;
    e.valid = valid;
    return ctrl_->setEstimate(e);
  };
  // Offered early and out of order, before tick k0: 1.0 at k0 + 5, 2.0 at k0 + 2, a refusal at k0 + 12, 4.0 at
  // k0 + 15.
  EXPECT_TRUE(offer(k0 + 5, 1.0, true));
  EXPECT_TRUE(offer(k0 + 2, 2.0, true));
  EXPECT_FALSE(offer(k0 + 12, 3.0, false));
  EXPECT_TRUE(offer(k0 + 15, 4.0, true));
  EXPECT_EQ(ctrl_->pendingEstimates(), 4);
  const auto expected = [&](int64_t k) {  // tau_ff of the command answering state k
    if (k < k0 + 2 + L) return 0.0;
    if (k < k0 + 5 + L) return 2.0;
    if (k < k0 + 12 + L) return 1.0;
    if (k < k0 + 15 + L) return 0.0;  // withdrawn by the refusal
    return 4.0;
  };
  int64_t k = k0;
  for (; k < k0 + 15 + L + 5; ++k) {
    tick(k);
    ASSERT_NEAR(fromEstimate(), expected(k), 1e-12) << "tick " << k - k0 << " after the offers";
    ASSERT_EQ(st_.estimate.accepted, (k >= k0 + 2 + L) + (k >= k0 + 5 + L) + (k >= k0 + 15 + L)) << k - k0;
    ASSERT_EQ(st_.estimate.rejected[static_cast<size_t>(EstimateRejection::NotValid)], k >= k0 + 12 + L ? 1 : 0);
  }
  EXPECT_EQ(ctrl_->pendingEstimates(), 0);
  EXPECT_EQ(st_.estimate.withdrawn_refused, 1);
  EXPECT_EQ(st_.estimate.late + st_.estimate.out_of_order + st_.estimate.overflow, 0);
  // Older than the one applied last (k0 + 15): dropped, whatever it says.
  EXPECT_FALSE(offer(k0 + 14, 5.0, true));
  EXPECT_EQ(ctrl_->pendingEstimates(), 0);
  tick(k++);
  EXPECT_EQ(st_.estimate.out_of_order, 1);
  EXPECT_NEAR(fromEstimate(), 4.0, 1e-12);
  // Arrived after its tick + L had been ticked: applied at the next tick, counted late.
  EXPECT_TRUE(offer(k - L - 3, 6.0, true));
  tick(k++);
  EXPECT_NEAR(fromEstimate(), 6.0, 1e-12);
  EXPECT_EQ(st_.estimate.late, 1);
  // A full queue drops its oldest: 17 estimates ahead, the first (tick k + 1) never applied.
  for (int i = 1; i <= 17; ++i) offer(k + i, 10.0 + i, true);
  EXPECT_EQ(ctrl_->pendingEstimates(), 16);
  for (int i = 0; i <= L + 2; ++i) tick(k++);  // up to the state of tick (first k) + 2 + L
  EXPECT_EQ(st_.estimate.overflow, 1);
  EXPECT_NEAR(fromEstimate(), 12.0, 1e-12);  // tick k + 2's (k + 1's was dropped)
}

TEST_F(FallbackTest, EstimatedComBlendsInWithoutAKickAndIsTracked) {
  // An estimate with 3 kg more on the base link, 10 cm to the side: the controller's CoM moves to the
  // estimate's (centroidal with its parameters, independent of the controller) over blend_time, smoothly.
  // With use_com_height (below, without: the estimate's horizontal CoM at the model's height).
  ControllerConfig cfg = cfg_;
  cfg.estimate.blend_time = 0.3;
  cfg.estimate.use_feedforward = false;  // the CoM alone
  cfg.estimate.use_com_height = true;
  make(cfg);
  int64_t k = settle();
  EstimatorOutputSample e = modelEstimate(model_, k);
  e.params.segment<kParamsPerBody>(model_.bodyParamIndex(0)) += paramsFromInertial(
      3.0, Eigen::Vector3d(0.0, 0.1, 0.0), Eigen::Matrix3d::Identity(), 0.01 * Eigen::Matrix3d::Identity());
  Eigen::Vector3d prev = st_.com;
  double max_step = 0.0;
  const int n = static_cast<int>(cfg.estimate.blend_time / cfg.loop.period);
  for (int i = 0; i < n + 20; ++i) {
    e.tick = k;
    ASSERT_TRUE(ctrl_->setEstimate(e));
    tick(k++);
    max_step = std::max(max_step, (st_.com - prev).norm());
    prev = st_.com;
  }
  EXPECT_EQ(st_.estimate.weight, 1.0);
  DynamicsData dd(model_);
  State s = ctrl_->observer().state();
  forwardKinematics(model_, dd.kin, s);
  centroidal(model_, e.params, dd);
  const Eigen::Vector3d com_est = s.base_position + s.base_orientation.toRotationMatrix() * dd.com;
  EXPECT_LT((st_.com - com_est).norm(), 1e-9);
  // The estimate moves the CoM ~7 mm sideways; no tick jumps by more than 1.5 x the mean step of a smoothstep.
  const double shift = 3.0 * 0.1 / (st_.estimate.mass);
  EXPECT_GT(shift, 0.005);
  EXPECT_LT(max_step, 1.5 * 1.5 * shift / n + 2e-5);
  // The reference height moved with the estimate's height (horizontal reference unchanged).
  EXPECT_NEAR(st_.com_ref.z() - st_.com.z(), 0.0, 2e-3);

  // use_com_height off (the default is on): the estimate's horizontal CoM, the model's height; the reference
  // height stays.
  ASSERT_TRUE(cfg_.estimate.use_com_height);
  cfg.estimate.use_com_height = false;
  make(cfg);
  k = settle();
  const double ref_z = st_.com_ref.z();
  for (int i = 0; i < n + 20; ++i) {
    e.tick = k;
    ASSERT_TRUE(ctrl_->setEstimate(e));
    tick(k++);
  }
  EXPECT_EQ(st_.estimate.weight, 1.0);
  s = ctrl_->observer().state();
  forwardKinematics(model_, dd.kin, s);
  centroidal(model_, e.params, dd);
  const Eigen::Vector3d est = s.base_position + s.base_orientation.toRotationMatrix() * dd.com;
  centroidal(model_, model_.phi, dd);
  const Eigen::Vector3d mod = s.base_position + s.base_orientation.toRotationMatrix() * dd.com;
  EXPECT_GT(std::abs(est.z() - mod.z()), 1e-3);  // the estimate does move the height: it is left out
  EXPECT_LT((st_.com.head<2>() - est.head<2>()).norm(), 1e-9);
  EXPECT_NEAR(st_.com.z(), mod.z(), 1e-9);
  EXPECT_NEAR(st_.com_ref.z(), ref_z, 1e-3);
}

TEST_F(FallbackTest, ImpossibleTrajectoryIsReportedAndTheStartIsHeld) {
  ControllerConfig cfg = cfg_;
  cfg.trajectory.polygon_margin = 0.3;  // no point of the support polygon is 0.3 m inside it
  cfg.trajectory.max_sampling_attempts = 100;
  make(cfg);
  settle();
  EXPECT_TRUE(st_.trajectory_failed);
  EXPECT_FALSE(st_.trajectory_ready);
  EXPECT_EQ(cmd_.mode, CommandMode::Torque);  // still balancing, on the start-up CoM
  EXPECT_NEAR((st_.com_ref - st_.com).norm(), 0.0, 1e-3);
  EXPECT_EQ(st_.move_index, -1);
}

}  // namespace
}  // namespace exoid::controller
