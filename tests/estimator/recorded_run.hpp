#pragma once
// Sensor samples of an in-process closed-loop run (MuJoCo robot, the balance controller doing CoM moves) for the
// online estimator's tests: what exo_sim would publish on EXO_STATE / EXO_PLATE_*, tick by tick.
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

#include "exoid/samples.hpp"
#include "exoid/sim/config.hpp"
#include "sim_closed_loop.hpp"

namespace exoid::estimator::testing {

struct RecordedRun {
  std::vector<RobotStateSample> states;
  std::vector<std::array<ForcePlateSample, 2>> plates;
  /// Of each state's tick, from the truth: the simulated robot's CoM (trunk, payloads and all) in the base frame,
  /// and the base orientation (world <- base).
  std::vector<Eigen::Vector3d> true_com_base;
  std::vector<Eigen::Quaterniond> true_orientation;
};

/// `moves` CoM moves of move seed `seed` on config/<scenario_file>; attach_at_s >= 0 moves every payload's
/// attachment to that time. Failures are test failures (the run is returned as far as it got).
inline RecordedRun recordRun(const Model& model, uint64_t seed, int moves, const char* scenario_file,
                             double attach_at_s = -1.0) {
  RecordedRun log;
  controller::ControllerConfig cfg;
  std::string err;
  EXPECT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  cfg.trajectory.moves = moves;
  sim::Scenario scenario;
  EXPECT_TRUE(sim::loadScenario(controller::testing::configPath(scenario_file), &scenario, &err)) << err;
  if (attach_at_s >= 0.0)
    for (auto& p : scenario.effects.payloads) p.attach_at_s = attach_at_s;
  const auto m = controller::testing::runScenarioClosedLoop(
      model, cfg, scenario, seed, &err,
      [&](long, const sim::SimModel&, const sim::SimData& sd, const controller::BalanceController&,
          const controller::ControllerStatus&) {
        log.states.push_back(sd.state);
        log.plates.push_back({sd.plates[0], sd.plates[1]});
        const Eigen::Quaterniond& q = sd.truth.base_orientation;
        log.true_com_base.push_back(q.conjugate() * (sd.truth.com - sd.truth.base_position));
        log.true_orientation.push_back(q);
      });
  EXPECT_TRUE(m.loaded) << err;
  EXPECT_FALSE(m.fell);
  return log;
}

}  // namespace exoid::estimator::testing
