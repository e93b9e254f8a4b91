#pragma once
// The controller against the simulator library in-process (exoid_sim: the MuJoCo robot of config/exo.xml with
// a scenario's sensor noise and undeclared effects), with exo_sim's timing: tick 0 runs the zero command, the
// state of tick k is answered with the command applied at tick k + 1. No LCM, no processes: the cheap way to
// run the 20-move protocol under many scenarios. Metrics as in `exoid experiment`'s summary.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "controller_test_util.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::controller::testing {

/// The simulator's world minus the controller's. The controller's observer fixes its world at the start-up latch
/// (docs/controller.md, BaseStateObserver: the base at initial_base_xy, the soles at ground_height); a robot that
/// settles during the window is offset between the two (a wearer: ~5 mm). The worlds are aligned by the soles, the
/// points the controller's world is built on: the true soles (the controller's model at the true state) minus
/// where the observer latched them, mean of the two (the summary of `exoid experiment` does the same from the log,
/// tools::ControllerFrame). Zero until the latch.
struct ControllerFrameOffset {
  bool set = false;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  /// After ctrl.tick on the state of the tick `truth` describes.
  void update(const BalanceController& ctrl, const GroundTruthSample& truth) {
    if (set || !ctrl.observer().latched()) return;
    const Model& model = ctrl.model();
    Data kin(model);
    State st = State::zero(model);
    st.q = truth.q;
    st.base_orientation = truth.base_orientation;
    st.base_position = truth.base_position;
    forwardKinematics(model, kin, st);
    offset.setZero();
    for (int side = 0; side < 2; ++side) {
      const SoleFrame& f = ctrl.soles()[static_cast<size_t>(side)];
      const Eigen::Vector3d p = truth.base_position + truth.base_orientation * (kin.p[f.body] + kin.R[f.body] * f.position);
      offset += 0.5 * (p - ctrl.observer().solePosition(side));
    }
    set = true;
  }
};

struct ScenarioRunMetrics {
  bool loaded = false;
  bool fell = false;
  double fell_at_s = 0.0;       ///< simulated time of the fall
  int moves_done = 0;
  double model_com_rmse = 0.0;  ///< m, controller's (model) CoM vs its reference, during the moves
  double model_com_max = 0.0;   ///< m
  double true_com_rmse = 0.0;   ///< m, MuJoCo's CoM (with undeclared payloads) vs the reference
  double true_com_max = 0.0;    ///< m
  double true_com_rmse_xy = 0.0;  ///< m, the same, horizontal only
  double slip = 0.0;            ///< m, largest horizontal sole displacement since tick 0
  int fallbacks = 0;
  int qp_failures = 0;
  double duration_s = 0.0;      ///< simulated
};

inline const char* yesNo(bool b) { return b ? "yes" : "no"; }

inline void printMetrics(const char* label, const ScenarioRunMetrics& m) {
  std::printf("%s: fell %s%s moves %d, model-CoM RMSE %.2f mm (max %.2f), true-CoM RMSE %.2f mm (max %.2f), "
              "slip %.3f mm, fallbacks %d, qp failures %d\n",
              label, yesNo(m.fell), m.fell ? (" at " + std::to_string(m.fell_at_s) + " s,").c_str() : ",",
              m.moves_done, 1e3 * m.model_com_rmse, 1e3 * m.model_com_max, 1e3 * m.true_com_rmse,
              1e3 * m.true_com_max, 1e3 * m.slip, m.fallbacks, m.qp_failures);
}

/// Runs `cfg`'s protocol (plus 0.5 s) with move seed `seed` on the simulator loaded with `scenario`
/// (its noise resolved against config/sensors.yaml). Stops at a fall. *error set if something failed to load.
/// `observe(k, sim_model, sim_data, controller, status)` is called after every tick (tests' traces);
/// `feed(k, sim_model, sim_data, controller)` before every tick (e.g. an online estimate, as over LCM).
template <class Observer, class Feed>
ScenarioRunMetrics runScenarioClosedLoop(const Model& model, const ControllerConfig& cfg, const sim::Scenario& scenario,
                                         uint64_t seed, std::string* error, Observer&& observe, Feed&& feed) {
  ScenarioRunMetrics m;
  sim::SensorConfig realistic, noise;
  sim::SimModel sm;
  sim::SimData sd;
  if (!sim::loadSensorConfig(configPath("sensors.yaml"), &realistic, error) ||
      !sim::resolveSensorConfig(scenario, realistic, &noise, error) ||
      !sim::simLoad(configPath("exo.xml"), noise, scenario, sm, error) || !sim::simMakeData(sm, sd, error))
    return m;
  BalanceController ctrl(model, cfg, seed);
  if (!ctrl.ok()) {
    *error = ctrl.error();
    return m;
  }
  m.loaded = true;
  int sole_geom[2] = {sm.foot_geom[0], sm.foot_geom[1]};
  JointCommandSample cmd = sim::simZeroCommand(sm);
  ControllerStatus st;
  Eigen::Vector3d sole0[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  double se_model = 0.0, se_true = 0.0, se_true_xy = 0.0;
  long n = 0;
  ControllerFrameOffset frame;
  const long ticks = static_cast<long>((plannedRunDuration(cfg) + 0.5) / cfg.loop.period);
  for (long k = 0; k < ticks; ++k) {
    sim::simStep(sm, sd, cmd);
    feed(k, sm, sd, ctrl);
    ctrl.tick(sd.state, cmd, st);
    // As over LCM: the plates of tick k reach the controller after its answer to the state of tick k.
    for (const ForcePlateSample& p : sd.plates) ctrl.setForcePlate(p);
    observe(k, sm, sd, ctrl, st);
    frame.update(ctrl, sd.truth);
    const mjData* d = sd.d;
    for (int i = 0; i < 2; ++i) {
      const Eigen::Vector3d p(d->geom_xpos + 3 * sole_geom[i]);
      if (k == 0) sole0[i] = p;
      m.slip = std::max(m.slip, (p - sole0[i]).head<2>().norm());
    }
    if (st.move_index >= 0 && st.trajectory_ready && !st.trajectory_done) {
      const Eigen::Vector3d true_com = Eigen::Vector3d(d->subtree_com + 3 * sm.base_body) - frame.offset;
      const double em = (st.com - st.com_ref).norm(), et = (true_com - st.com_ref).norm();
      se_model += em * em;
      se_true += et * et;
      se_true_xy += (true_com - st.com_ref).head<2>().squaredNorm();
      m.model_com_max = std::max(m.model_com_max, em);
      m.true_com_max = std::max(m.true_com_max, et);
      ++n;
    }
    if (sim::simFell(sm, sd)) {
      m.fell = true;
      m.fell_at_s = static_cast<double>(k) * 1e-3;
      break;
    }
  }
  if (n > 0) {
    m.model_com_rmse = std::sqrt(se_model / static_cast<double>(n));
    m.true_com_rmse = std::sqrt(se_true / static_cast<double>(n));
    m.true_com_rmse_xy = std::sqrt(se_true_xy / static_cast<double>(n));
  }
  m.moves_done = st.moves_done;
  m.fallbacks = st.fallbacks;
  m.qp_failures = st.qp_failures;
  m.duration_s = static_cast<double>(n) * cfg.loop.period;
  return m;
}

template <class Observer>
ScenarioRunMetrics runScenarioClosedLoop(const Model& model, const ControllerConfig& cfg, const sim::Scenario& scenario,
                                         uint64_t seed, std::string* error, Observer&& observe) {
  return runScenarioClosedLoop(model, cfg, scenario, seed, error, observe,
                               [](long, const sim::SimModel&, const sim::SimData&, BalanceController&) {});
}

inline ScenarioRunMetrics runScenarioClosedLoop(const Model& model, const ControllerConfig& cfg,
                                                const sim::Scenario& scenario, uint64_t seed, std::string* error) {
  return runScenarioClosedLoop(model, cfg, scenario, seed, error,
                               [](long, const sim::SimModel&, const sim::SimData&, const BalanceController&,
                                  const ControllerStatus&) {});
}

}  // namespace exoid::controller::testing
