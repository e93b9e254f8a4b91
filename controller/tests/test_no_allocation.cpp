// Proof that BalanceController::tick() does not allocate, in a realistic closed loop against MuJoCo (start-up
// latch and trajectory generation, QP solves with warm start, a NaN input with hold and damping, a stale gap,
// a QP failure with the warm-start reset and preconditioner recomputation, recovery, feedforward updates).
// The controller is the shipped library (exoid_controller, as built), checked by two independent detectors around
// every tick (tests/support/alloc_counter, shared by every no-allocation test):
//   1. a replaced global operator new / new[] (all variants) counting calls;
//   2. glibc malloc / calloc / realloc / memalign / posix_memalign / aligned_alloc interposed and counted, which
//      sees every Eigen heap allocation (Eigen allocates through malloc: positive control below), the header-only
//      ProxQP's, exoid_model's and any C code's.
// Eigen's own run-time check (EIGEN_RUNTIME_NO_MALLOC) is not used: it would need the controller compiled a second
// time into this test, detector 2 sees every allocation it would, and this way the test checks the code that ships.
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <limits>
#include <new>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/controller/proxqp_solver.hpp"
#include "mujoco_exo.hpp"
#include "support/alloc_counter.hpp"

namespace exoid::controller {
namespace {

using NoAllocationScope = exoid::test::AllocationCounter;

TEST(NoAllocationDetectors, CountersSeeOperatorNewMallocAndEigensHeap) {
  NoAllocationScope scope;
  int* volatile p = new int(3);
  void* volatile m = std::malloc(16);
  scope.stop();
  EXPECT_GE(scope.news(), 1);
  EXPECT_GE(scope.mallocs(), 2);  // the malloc, and operator new's own malloc
  delete p;
  std::free(m);
  // An Eigen heap temporary (what an allocating expression in the tick would make) is seen by the malloc counter.
  NoAllocationScope eigen;
  Eigen::VectorXd v(1000);
  v.setZero();
  eigen.stop();
  EXPECT_EQ(eigen.news(), 0);
  EXPECT_GE(eigen.mallocs(), 1);
  EXPECT_EQ(v.sum(), 0.0);
}

/// ProxQP that can be told to report a failure (exercises the fallback and the warm-start reset path).
class FailableSolver final : public QpSolver {
 public:
  explicit FailableSolver(const QpSolverSettings& s) : inner_(s) {}
  bool setup(const QpDimensions& d) override { return inner_.setup(d); }
  void solve(const QpProblem& p, QpResult& r) override {
    inner_.solve(p, r);
    if (fail) {
      r.status = QpStatus::Infeasible;
      inner_.resetWarmStart();
    }
  }
  void resetWarmStart() override { inner_.resetWarmStart(); }
  const char* name() const override { return "failable-proxqp"; }
  bool fail = false;

 private:
  ProxQpSolver inner_;
};

TEST(NoAllocation, ControllerTickInClosedLoop) {
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  ControllerConfig cfg;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  testing::MujocoExo sim;
  ASSERT_TRUE(sim.load(model, &err)) << err;
  auto solver = std::make_unique<FailableSolver>(QpSolverSettings{cfg.solver.eps_abs, cfg.solver.max_iterations});
  FailableSolver* failable = solver.get();
  BalanceController ctrl(model, cfg, 3, std::move(solver));
  ASSERT_TRUE(ctrl.ok()) << ctrl.error();

  RobotStateSample state;
  sim.sizeState(state);
  JointCommandSample cmd, pending;
  ctrl.sizeCommand(cmd);
  ctrl.sizeCommand(pending);
  ControllerStatus st;
  // The online estimate at 100 Hz (its CoM moves), a small generalized
  // correction (the model plus 1 kg on the base link), a non-finite one now and then (refused: withdrawn, blended out) and a pause (stale).
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = model.phi;
  est.params.segment<kParamsPerBody>(model.bodyParamIndex(0)) +=
      paramsFromInertial(1.0, Eigen::Vector3d(0.02, 0.05, 0.0), Eigen::Matrix3d::Identity(),
                         0.001 * Eigen::Matrix3d::Identity());
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Force plates for the disturbance observer: the wrench the controller planned last tick, as a plate under each
  // sole reads it (this loop's MuJoCo has no plates), stamped with the tick its command is applied at.
  std::array<ForcePlateSample, 2> plates;
  for (int i = 0; i < 2; ++i) plates[static_cast<size_t>(i)].plate = i;
  ASSERT_TRUE(cfg.disturbance.enabled && cfg.disturbance.force_plates);

  const long latch = cfg.observer.latch_ticks;
  // Start-up latch, initial hold and three moves with their holds (~10 s, ~10^4 ticks).
  const long total = latch + static_cast<long>((cfg.trajectory.initial_hold +
                                                3 * (cfg.trajectory.move_duration + cfg.trajectory.hold_duration)) /
                                               cfg.loop.period);
  const long nan_at = latch + 300, gap_at = latch + 600, qp_fail_at = latch + 900;
  long tick_news = 0, tick_mallocs = 0, ticks = 0, max_news_tick = -1;
  int64_t tick_id = 0;
  bool saw_hold = false, saw_damping = false, saw_torque_after = false;
  for (long k = 0; k < total; ++k) {
    sim.step1();
    sim.sample(state, tick_id, testing::realisticNoise());
    if (k >= nan_at && k < nan_at + cfg.fallback.hold_ticks + 5) state.q[1] = std::numeric_limits<double>::quiet_NaN();
    if (k == gap_at) tick_id += cfg.fallback.max_missed_ticks + 3, state.tick = tick_id;  // stale gap
    failable->fail = k >= qp_fail_at && k < qp_fail_at + 3;
    sim.apply(pending);
    est.tau_correction.setConstant(0.01 * static_cast<double>(k % 7));
    est.tau_correction[0] = k % 1500 == 700 ? nan : 0.0;
    est.tick = tick_id;
    {
      NoAllocationScope scope;
      if (k % 10 == 0 && !(k % 3000 > 2000 && k % 3000 < 2200)) ctrl.setEstimate(est);
      for (int i = 0; i < 2; ++i) {
        const Vector6d& w = i == 0 ? st.wrench_right : st.wrench_left;
        const Eigen::Vector3d& p = ctrl.dynamics().foot_position[static_cast<size_t>(i)];
        ForcePlateSample& plate = plates[static_cast<size_t>(i)];
        plate.tick = tick_id;
        plate.plate_position = p;  // each sole on its plate's origin (BalanceController::setForcePlate)
        plate.force = -w.head<3>();
        plate.moment = -w.tail<3>();  // about the plate's origin, the sole's
        ctrl.setForcePlate(plate);
      }
      ctrl.tick(state, cmd, st);
      scope.stop();
      tick_news += scope.news();
      tick_mallocs += scope.mallocs();
      if (scope.news() + scope.mallocs() > 0 && max_news_tick < 0) max_news_tick = k;
    }
    ++ticks;
    saw_hold = saw_hold || cmd.mode == CommandMode::HoldLastSafe;
    saw_damping = saw_damping || cmd.mode == CommandMode::Damping;
    saw_torque_after = saw_torque_after || (k > qp_fail_at + 200 && cmd.mode == CommandMode::Torque);
    std::swap(pending, cmd);
    sim.step2();
    ++tick_id;
  }
  EXPECT_EQ(tick_news, 0) << "operator new calls inside tick(), first at loop index " << max_news_tick;
  EXPECT_EQ(tick_mallocs, 0) << "malloc-family calls inside tick(), first at loop index " << max_news_tick;
  // The run really went through the paths that could allocate.
  EXPECT_TRUE(st.trajectory_ready);
  EXPECT_GE(st.qp_failures, 3);
  EXPECT_GE(st.rejected_inputs, cfg.fallback.hold_ticks + 5);
  EXPECT_GT(st.stale_inputs, cfg.fallback.max_missed_ticks);
  EXPECT_TRUE(saw_hold);
  EXPECT_TRUE(saw_damping);
  EXPECT_TRUE(saw_torque_after);
  EXPECT_GT(st.estimate.accepted, 0);
  EXPECT_GT(st.estimate.rejected[static_cast<size_t>(EstimateRejection::NonFinite)], 0);
  EXPECT_GT(st.estimate.withdrawn_stale, 0);
  EXPECT_GT(st.estimate.withdrawn_refused, 0);
  EXPECT_EQ(st.estimate.weight, 1.0);
  EXPECT_GT(sim.baseHeight(), 1.0);  // and the robot is still standing
  EXPECT_EQ(ticks, total);
}

}  // namespace
}  // namespace exoid::controller
