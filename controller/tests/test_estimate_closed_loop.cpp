// The online estimate closing the loop, in-process against the simulator library (no estimator process: the
// estimate is made here, the way an exact estimator would publish it): an undeclared payload scenario's TRUE
// parameters (the URDF's plus the payloads, model/inertial.hpp) as a constant valid estimate at 100 Hz, with
// tau_correction = K(q, v, 0)(phi_true - phi_model) at the controller's own state estimate. Issue 8's controller-side
// target: the true CoM tracks the reference at least 2x better than without the estimate, the controller's
// CoM tracking is no worse, nothing falls or slips.
//
// EXOID_ESTIMATE_ALL=1 runs every shipped payload scenario with the configuration's 20 moves and prints the
// table quoted in docs/controller.md ("Using the estimate: measured").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/tools/perturb_inertials.hpp"
#include "sim_closed_loop.hpp"

namespace exoid::controller {
namespace {

/// The simulated robot's standard parameters in the URDF model's order: each payload (link frame, inertia about
/// its CoM in the MJCF fullinertia order) added to its link's parameters, those attached by time t (s).
/// Independent of the controller.
bool truePhi(const Model& model, const sim::Scenario& scenario, double t, Eigen::VectorXd& phi, std::string* err) {
  phi = model.phi;
  for (const sim::Payload& p : scenario.effects.payloads) {
    if (p.attach_at_s > t) continue;
    const int b = model.bodyIndex(p.link);
    if (b < 0) return *err = "no link " + p.link + " in the URDF", false;
    Eigen::Matrix3d I;
    I << p.inertia[0], p.inertia[3], p.inertia[4], p.inertia[3], p.inertia[1], p.inertia[5], p.inertia[4],
        p.inertia[5], p.inertia[2];
    phi.segment<kParamsPerBody>(model.bodyParamIndex(b)) +=
        paramsFromInertial(p.mass, p.com, Eigen::Matrix3d::Identity(), I);
  }
  return true;
}

struct Runs {
  testing::ScenarioRunMetrics without, with;
  EstimateUse use;
};

/// `model`: the controller's (the URDF, or a wrong prior); `robot`: the URDF the simulated robot is built from
/// (its parameters plus the scenario's payloads are the truth the estimate carries).
Runs runBoth(const Model& model, const Model& robot, const ControllerConfig& cfg, const std::string& file,
             uint64_t seed, std::string* err) {
  Runs r;
  sim::Scenario scenario;
  if (!sim::loadScenario(testing::configPath("scenarios/" + file), &scenario, err)) return r;
  Eigen::VectorXd phi, phi_final;
  if (!truePhi(robot, scenario, 0.0, phi, err) || !truePhi(robot, scenario, 1e9, phi_final, err)) return r;
  double attach_s = 1e9;  // a payload attached mid-run: the estimate switches to it 0.5 s later
  for (const sim::Payload& p : scenario.effects.payloads)
    if (p.attach_at_s > 0.0) attach_s = std::min(attach_s, p.attach_at_s);
  ControllerConfig off = cfg;
  off.estimate.enabled = false;
  r.without = testing::runScenarioClosedLoop(model, off, scenario, seed, err);
  if (!r.without.loaded) return r;

  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = phi;
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  DynamicsData with_phi(model), with_model(model);
  ControllerStatus last;
  r.with = testing::runScenarioClosedLoop(
      model, cfg, scenario, seed, err,
      [&](long, const sim::SimModel&, const sim::SimData&, const BalanceController&, const ControllerStatus& st) {
        last = st;
      },
      [&](long k, const sim::SimModel&, const sim::SimData&, BalanceController& ctrl) {
        if (k == 0 || k % 10 != 0) return;  // 100 Hz, from the first state on
        if (static_cast<double>(k) * 1e-3 >= attach_s + 0.5) phi = phi_final;
        const State& s = ctrl.observer().state();  // the state of the previous tick, accelerations zero
        est.params = phi;
        rnea(model, phi, with_phi, s);
        rnea(model, model.phi, with_model, s);
        est.tau_correction = with_phi.tau - with_model.tau;
        est.tick = k - 1;
        ctrl.setEstimate(est);
      });
  r.use = last.estimate;
  return r;
}

void print(const char* name, const Runs& r) {
  std::printf("%-28s true-CoM RMSE %6.2f -> %6.2f mm (max %6.2f -> %6.2f; horizontal %6.2f -> %6.2f), "
              "controller CoM RMSE %.2f -> %.2f mm, "
              "slip %.3f -> %.3f mm, fell %s/%s, moves %d/%d, fallbacks %d/%d, estimate weight %.3f\n",
              name, 1e3 * r.without.true_com_rmse, 1e3 * r.with.true_com_rmse, 1e3 * r.without.true_com_max,
              1e3 * r.with.true_com_max, 1e3 * r.without.true_com_rmse_xy, 1e3 * r.with.true_com_rmse_xy,
              1e3 * r.without.model_com_rmse, 1e3 * r.with.model_com_rmse,
              1e3 * r.without.slip, 1e3 * r.with.slip, testing::yesNo(r.without.fell), testing::yesNo(r.with.fell),
              r.without.moves_done, r.with.moves_done, r.without.fallbacks, r.with.fallbacks, r.use.weight);
}

TEST(EstimateClosedLoop, TrueComTracksTheReferenceTwiceAsWellUnderAnUndeclaredPayload) {
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  ControllerConfig cfg;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  ASSERT_TRUE(cfg.estimate.enabled && cfg.estimate.use_feedforward && cfg.estimate.use_com);
  cfg.estimate.use_com_height = true;  // the hand-made estimate is exact, its CoM height too
  cfg.trajectory.moves = 3;
  for (const char* file : {"undeclared_payload.yaml", "payload_two_legs.yaml"}) {
    const Runs r = runBoth(model, model, cfg, file, 3, &err);
    ASSERT_TRUE(r.with.loaded) << err;
    print(file, r);
    EXPECT_FALSE(r.with.fell) << file;
    EXPECT_EQ(r.with.moves_done, cfg.trajectory.moves) << file;
    EXPECT_LE(r.with.slip, 1e-3) << file;
    EXPECT_EQ(r.use.weight, 1.0) << file;
    EXPECT_EQ(r.use.withdrawn_stale + r.use.withdrawn_refused, 0) << file;
    EXPECT_LE(r.with.true_com_rmse, 0.5 * r.without.true_com_rmse) << file;
    EXPECT_LE(r.with.true_com_rmse_xy, 0.5 * r.without.true_com_rmse_xy) << file;
    // The controller's own CoM (now the estimate's) tracks its reference no worse (0.1 mm of noise allowed).
    EXPECT_LE(r.with.model_com_rmse, r.without.model_com_rmse + 1e-4) << file;
  }
}

// Issue 8's fault on the controller side: the estimator dies mid-run (its estimates stop) and restarts later.
// The controller withdraws the estimate exactly max_age_ticks after the last one, blends it out over
// blend_time, keeps balancing on the model (plus the disturbance observer), and takes the estimate back when
// the estimates return (estimate.lag_ticks after the first one's tick).
TEST(EstimateClosedLoop, EstimatorKilledMidRunIsWithdrawnInTimeAndTheRobotKeepsBalancing) {
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  ControllerConfig cfg;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  cfg.trajectory.moves = 3;
  sim::Scenario scenario;
  ASSERT_TRUE(sim::loadScenario(testing::configPath("scenarios/undeclared_payload.yaml"), &scenario, &err)) << err;
  Eigen::VectorXd phi;
  ASSERT_TRUE(truePhi(model, scenario, 0.0, phi, &err)) << err;
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = phi;
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  DynamicsData with_phi(model), with_model(model);
  const long kill = 4000, restart = 7000;  // ticks: dead from 4 s to 7 s
  long last_sent = -1, first_drop = -1, first_zero = -1, back_to_one = -1;
  int withdrawn = 0;
  const testing::ScenarioRunMetrics m = testing::runScenarioClosedLoop(
      model, cfg, scenario, 1, &err,
      [&](long k, const sim::SimModel&, const sim::SimData&, const BalanceController&, const ControllerStatus& st) {
        if (k > kill && first_drop < 0 && st.estimate.weight < 1.0) first_drop = k;
        if (k > kill && first_zero < 0 && st.estimate.weight == 0.0) first_zero = k;
        if (k > restart && back_to_one < 0 && st.estimate.weight == 1.0) back_to_one = k;
        withdrawn = st.estimate.withdrawn_stale;
      },
      [&](long k, const sim::SimModel&, const sim::SimData&, BalanceController& ctrl) {
        if (k == 0 || k % 10 != 0 || (k > kill && k < restart)) return;
        const State& s = ctrl.observer().state();
        rnea(model, phi, with_phi, s);
        rnea(model, model.phi, with_model, s);
        est.tau_correction = with_phi.tau - with_model.tau;
        est.tick = k - 1;
        ctrl.setEstimate(est);
        if (k <= kill) last_sent = est.tick;
      });
  ASSERT_TRUE(m.loaded) << err;
  testing::printMetrics("estimator killed 4-7 s", m);
  // The state of tick k is ticked at loop index k: the last estimate (tick last_sent) is stale once
  // k - last_sent > max_age_ticks, and that tick already blends out.
  EXPECT_EQ(first_drop, last_sent + cfg.estimate.max_age_ticks + 1);
  const long blend = static_cast<long>(std::lround(cfg.estimate.blend_time / cfg.loop.period));
  EXPECT_NEAR(static_cast<double>(first_zero - first_drop), static_cast<double>(blend), 2.0);
  EXPECT_EQ(withdrawn, 1);
  EXPECT_GT(back_to_one, restart);
  EXPECT_LT(back_to_one, restart + cfg.estimate.lag_ticks + blend + 20);  // the first one acts lag_ticks after its tick
  EXPECT_FALSE(m.fell);
  EXPECT_EQ(m.moves_done, cfg.trajectory.moves);
  EXPECT_LE(m.slip, 1e-3);
  EXPECT_EQ(m.fallbacks, 0);
}

TEST(EstimateClosedLoop, EveryPayloadScenarioTwentyMoves) {
  const char* all = std::getenv("EXOID_ESTIMATE_ALL");
  if (!all || std::string(all) != "1") GTEST_SKIP() << "EXOID_ESTIMATE_ALL=1 runs the 20-move table";
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  ControllerConfig cfg;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  cfg.estimate.use_com_height = true;  // the hand-made estimate is exact, its CoM height too
  for (const char* file : {"undeclared_payload.yaml", "payload_body_lateral.yaml", "payload_left_shank.yaml",
                           "payload_right_foot.yaml", "payload_right_thigh.yaml", "payload_two_legs.yaml",
                           "combined_payload_friction.yaml", "combined_worst.yaml", "payload_mid_run.yaml"}) {
    const Runs r = runBoth(model, model, cfg, file, 1, &err);
    ASSERT_TRUE(r.with.loaded) << err;
    print(file, r);
  }
  // The controller on a +-25 % prior (exoid model perturb --relative 0.25 --seed S), the estimate = the truth.
  for (const uint64_t s : {1, 2}) {
    Model prior = model;
    ASSERT_TRUE(tools::perturbInertials(model, 0.25, s, prior.phi, &err)) << err;
    for (const char* file : {"nominal.yaml", "undeclared_payload.yaml"}) {
      const Runs r = runBoth(prior, model, cfg, file, 1, &err);
      ASSERT_TRUE(r.with.loaded) << err;
      print((std::string("prior seed ") + std::to_string(s) + ", " + file).c_str(), r);
    }
  }
}

}  // namespace
}  // namespace exoid::controller
