// The controller plugin ABI, host and plugins (docs/plugin.md), in-process (no LCM):
//  - loading: a missing library, a library without the entry, another ABI version, other struct sizes and a
//    failing create give one-line errors naming the library;
//  - the balance plugin computes bit for bit what BalanceController computes from the same states and force
//    plates (given as exo_controller gets them: over LCM, after the state), differs from a controller never
//    given the plates, and its tick and set_force_plates allocate nothing through the ABI (counted with
//    tests/support/alloc_counter);
//  - the example joint PD plugin answers tau = KP (q0 - q) - KD dq, clamped (recomputed here), and holds the
//    exoskeleton standing in MuJoCo;
//  - the host gives the plates of tick k after the tick, counts refusals, and nothing without the entry;
//  - faults (error code, NaN torque, wrong tick, over budget): the host holds the last good torque for
//    hold_ticks, then damps, counted per kind, and returns to the plugin's torque when it answers well again.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/controller_plugin.hpp"
#include "exoid/sim/runner.hpp"
#include "exoid/sim/sim.hpp"
#include "support/alloc_counter.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

std::string pluginLib(const std::string& name) { return std::string(EXOID_PLUGIN_DIR) + "/lib" + name + ".so"; }

/// The exoskeleton on its plates (nominal scenario: realistic noise).
struct Exo {
  sim::SimModel model;
  sim::SimData data;
  explicit Exo(const std::string& scenario = "scenarios/nominal.yaml") {
    std::string err;
    sim::Scenario sc;
    sim::SensorConfig realistic, noise;
    EXPECT_TRUE(sim::loadScenario(test::configPath(scenario), &sc, &err)) << err;
    EXPECT_TRUE(sim::loadSensorConfig(test::configPath("sensors.yaml"), &realistic, &err)) << err;
    EXPECT_TRUE(sim::resolveSensorConfig(sc, realistic, &noise, &err)) << err;
    EXPECT_TRUE(sim::simLoad(test::configPath("exo.xml"), noise, sc, model, &err)) << err;
    EXPECT_TRUE(sim::simMakeData(model, data, &err)) << err;
  }
};

sim::PluginOptions balanceOptions() {
  sim::PluginOptions o;
  o.path = pluginLib("exoid_controller_plugin");
  o.model_path = test::configPath("exo.urdf");
  o.config_path = test::configPath("controller.yaml");
  o.seed = 3;
  o.moves = 2;
  return o;
}

std::unique_ptr<sim::ControllerPlugin> load(const sim::PluginOptions& o, const Exo& exo, std::string* err) {
  return sim::ControllerPlugin::load(o, exo.model.joint_names, exo.model.m->opt.timestep, err);
}

sim::PluginOptions faultOptions(const std::string& script, int hold_ticks = 3) {
  sim::PluginOptions o;
  o.path = pluginLib("exoid_fault_plugin");
  o.config_path = script;
  o.hold_ticks = hold_ticks;
  return o;
}

TEST(PluginLoad, ErrorsNameTheLibraryAndTheProblem) {
  Exo exo;
  std::string err;
  sim::PluginOptions o = balanceOptions();
  o.path = "/nonexistent/libnothing.so";
  EXPECT_EQ(load(o, exo, &err), nullptr);
  EXPECT_NE(err.find("/nonexistent/libnothing.so: cannot load"), std::string::npos) << err;

  o.path = pluginLib("exoid_not_a_plugin");  // a shared library without the entry function
  EXPECT_EQ(load(o, exo, &err), nullptr);
  EXPECT_NE(err.find("not a controller plugin: no symbol 'exoid_controller_plugin'"), std::string::npos) << err;

  EXPECT_NE(load(faultOptions("ok 0 0"), exo, &err), nullptr) << err;
  sim::PluginOptions wrong = faultOptions("ok 0 0");
  wrong.path = pluginLib("exoid_fault_plugin_abi1");
  EXPECT_EQ(load(wrong, exo, &err), nullptr);
  EXPECT_NE(err.find("ABI version 1, this exo_sim needs 4"), std::string::npos) << err;
  wrong.path = pluginLib("exoid_fault_plugin_size");
  EXPECT_EQ(load(wrong, exo, &err), nullptr);
  EXPECT_NE(err.find("struct sizes (state " + std::to_string(sizeof(exoid_plugin_state) + 8)), std::string::npos) << err;

  EXPECT_EQ(load(faultOptions("create_fail 0 0"), exo, &err), nullptr);
  EXPECT_NE(err.find("create failed: fault plugin: script 'create_fail 0 0' says fail"), std::string::npos) << err;

  // The balance plugin refuses what it cannot do, naming the file or the value.
  o = balanceOptions();
  o.config_path = "/nonexistent/controller.yaml";
  EXPECT_EQ(load(o, exo, &err), nullptr);
  EXPECT_NE(err.find("create failed:"), std::string::npos) << err;
  EXPECT_NE(err.find("/nonexistent/controller.yaml"), std::string::npos) << err;
  o = balanceOptions();
  o.divisor = 10;  // a state 10 ticks after the previous one is stale for the balance controller
  EXPECT_EQ(load(o, exo, &err), nullptr);
  EXPECT_NE(err.find("tick divisor 10"), std::string::npos) << err;
}

// Runs the sim in closed loop with the plugin stage: command for tick k+1 from the state of tick k.
template <class PerTick>
void closedLoop(Exo& exo, sim::ControllerPlugin& plugin, int ticks, PerTick per_tick) {
  JointCommandSample cmd = sim::simZeroCommand(exo.model);
  for (int k = 0; k < ticks; ++k) {
    sim::simStep(exo.model, exo.data, cmd);
    per_tick(k, exo.data.state);
    cmd = plugin.command();
  }
}

TEST(BalancePlugin, SameCommandsAsTheControllerBitForBitWithoutAllocating) {
  Exo exo;
  std::string err;
  auto plugin = load(balanceOptions(), exo, &err);
  ASSERT_TRUE(plugin) << err;
  // The reference: BalanceController itself, fed the same states.
  Model model;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  controller::ControllerConfig cfg;
  ASSERT_TRUE(controller::loadControllerConfig(test::configPath("controller.yaml"), cfg, &err)) << err;
  cfg.trajectory.moves = 2;
  controller::BalanceController ref(model, cfg, 3);
  ASSERT_TRUE(ref.ok()) << ref.error();
  JointCommandSample ref_cmd;
  ref.sizeCommand(ref_cmd);
  controller::ControllerStatus ref_status;

  // The same controller never given the plates: the observer (disturbance.force_plates) must make a
  // difference, else this test could not tell whether the plates reach the plugin.
  ASSERT_TRUE(cfg.disturbance.enabled && cfg.disturbance.force_plates);
  controller::BalanceController blind(model, cfg, 3);
  JointCommandSample blind_cmd;
  blind.sizeCommand(blind_cmd);
  controller::ControllerStatus blind_status;
  exoid_lcm::force_plate_t plate_msg;
  ForcePlateSample plate;
  // An online estimate at 100 Hz from tick 300 (the model plus 2 kg on the base link, a small correction):
  // the plugin through set_estimate, the reference as exo_controller gets it (over LCM, every one decoded).
  EstimatorOutputSample est, est_rx;
  est.valid = est.consistent = true;
  est.params = model.phi;
  est.params.segment<kParamsPerBody>(model.bodyParamIndex(0)) += paramsFromInertial(
      2.0, Eigen::Vector3d(-0.1, 0.03, 0.3), Eigen::Matrix3d::Identity(), 0.01 * Eigen::Matrix3d::Identity());
  est.param_stddev = Eigen::VectorXd::Zero(model.nparams());
  est.tau_correction = Eigen::VectorXd::LinSpaced(model.nv, -0.3, 0.4);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  est.residual_rms = Eigen::VectorXd::Zero(model.nv);
  exoid_lcm::estimator_output_t est_msg;
  const std::vector<std::string> param_names = model.paramNames(), coord_names = model.coordinateNames();

  long mismatches = 0, allocations = 0, torque_ticks = 0, blind_differ = 0;
  const int ticks = 2500;  // start-up latch (200), initial hold, into the first move
  closedLoop(exo, *plugin, ticks, [&](int k, const RobotStateSample& s) {
    const bool send = k >= 300 && k % 10 == 0;
    if (send) {
      est.tick = k - 1;
      est.utime = 1000 * est.tick;
      toLcm(est, param_names, coord_names, est_msg);
      ASSERT_TRUE(fromLcm(est_msg, param_names, kAnyNumBase, coord_names, est_rx, &err)) << err;
      ASSERT_TRUE(ref.setEstimate(est_rx));
      ASSERT_TRUE(blind.setEstimate(est_rx));
    }
    test::AllocationCounter count;
    if (send) { ASSERT_TRUE(plugin->setEstimate(est_rx)); }
    ASSERT_TRUE(plugin->step(s));
    const bool plates_taken = plugin->setForcePlates(exo.data.plates.data(), sim::kNumFeet);
    count.stop();
    ASSERT_TRUE(plates_taken) << k;
    if (k >= 10) allocations += count.mallocs() + count.news();  // the first ticks warm the solver up
    ref.tick(s, ref_cmd, ref_status);
    // exo_controller's path for the plates of tick k: over LCM (toLcm, fromLcm), after the state of tick k.
    for (int i = 0; i < sim::kNumFeet; ++i) {
      toLcm(exo.data.plates[static_cast<size_t>(i)], plate_msg);
      ASSERT_TRUE(fromLcm(plate_msg, i, plate, &err)) << err;
      ASSERT_TRUE(ref.setForcePlate(plate));
    }
    blind.tick(s, blind_cmd, blind_status);
    blind_differ += blind_cmd.tau == plugin->command().tau ? 0 : 1;
    const JointCommandSample& c = plugin->command();
    bool same = c.tick == ref_cmd.tick && c.source_tick == ref_cmd.source_tick && c.mode == ref_cmd.mode;
    for (int j = 0; j < model.njoints; ++j)
      same = same && std::memcmp(&c.tau[j], &ref_cmd.tau[j], sizeof(double)) == 0 &&
             std::memcmp(&c.tau_ff[j], &ref_cmd.tau_ff[j], sizeof(double)) == 0;
    mismatches += same ? 0 : 1;
    torque_ticks += c.mode == CommandMode::Torque ? 1 : 0;
    EXPECT_EQ(plugin->status().moves_done, ref_status.moves_done);
    EXPECT_EQ(plugin->status().move_index, ref_status.move_index);
    EXPECT_EQ(plugin->status().com.x(), ref_status.com.x());
    EXPECT_EQ(plugin->status().qp_iterations, ref_status.qp_iterations);
  });
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(ref_status.estimate.weight, 1.0);  // the estimate was in use, fully, by the end
  EXPECT_EQ(plugin->stats().estimates_accepted, (ticks - 300) / 10);
  EXPECT_EQ(torque_ticks, ticks);  // the controller balanced every tick (no fallback)
  EXPECT_EQ(plugin->stats().calls, ticks);
  EXPECT_EQ(plugin->stats().good, ticks);
  EXPECT_EQ(plugin->stats().fallbackTicks(), 0);
  EXPECT_EQ(plugin->stats().plates_accepted, ticks);
  EXPECT_EQ(plugin->stats().plates_rejected, 0);
  EXPECT_GT(blind_differ, ticks / 2) << "the plates made no difference to the commands";
  EXPECT_TRUE(plugin->statusValid());
  EXPECT_GE(plugin->status().move_index, 0);  // the moves started
  EXPECT_FALSE(sim::simFell(exo.model, exo.data));

  // reset: the next tick is the first again, and the plugin computes what a fresh controller computes. It
  // rebuilds the controller inside the plugin: the counter sees that heap use (so it would see the tick's).
  test::AllocationCounter reset_count;
  ASSERT_TRUE(plugin->reset(&err)) << err;
  reset_count.stop();
  EXPECT_GT(reset_count.news(), 10);
  EXPECT_GT(reset_count.mallocs(), 10);
  sim::simReset(exo.model, exo.data);
  controller::BalanceController fresh(model, cfg, 3);
  mismatches = 0;
  closedLoop(exo, *plugin, 300, [&](int, const RobotStateSample& s) {
    plugin->step(s);
    fresh.tick(s, ref_cmd, ref_status);
    mismatches += plugin->command().tau == ref_cmd.tau ? 0 : 1;
  });
  EXPECT_EQ(mismatches, 0);
}

TEST(BalancePlugin, RunsAtADivisorOfThePhysicsRateHoldingTheCommand) {
  Exo exo;
  std::string err;
  sim::PluginOptions o = balanceOptions();
  o.divisor = 2;  // 500 Hz
  auto plugin = load(o, exo, &err);
  ASSERT_TRUE(plugin) << err;
  Eigen::VectorXd held;
  closedLoop(exo, *plugin, 2000, [&](int k, const RobotStateSample& s) {
    const bool ran = plugin->step(s);
    ASSERT_EQ(ran, k % 2 == 0) << k;
    EXPECT_EQ(plugin->command().tick, k + 1);  // always the command for the next tick
    if (ran) held = plugin->command().tau;
    else EXPECT_TRUE(plugin->command().tau == held) << k;
  });
  EXPECT_EQ(plugin->stats().calls, 1000);
  EXPECT_EQ(plugin->stats().fallbackTicks(), 0);
  EXPECT_EQ(plugin->status().fallbacks, 0);
  EXPECT_EQ(plugin->status().stale_inputs, 999);  // the controller sees every other tick
  EXPECT_FALSE(sim::simFell(exo.model, exo.data));
}

TEST(EstimateThroughTheAbi, EntersTheBalanceControllerBitForBitAndIsRefusedWhenUnusable) {
  Exo exo;
  std::string err;
  auto plugin = load(balanceOptions(), exo, &err);
  ASSERT_TRUE(plugin) << err;
  Model model;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  controller::ControllerConfig cfg;
  ASSERT_TRUE(controller::loadControllerConfig(test::configPath("controller.yaml"), cfg, &err)) << err;
  cfg.trajectory.moves = 2;
  controller::BalanceController ref(model, cfg, 3);
  JointCommandSample ref_cmd;
  ref.sizeCommand(ref_cmd);
  controller::ControllerStatus ref_status;
  // The model plus 2 kg on the base link, and a feedforward on an actuated joint.
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = model.phi;
  est.params.segment<kParamsPerBody>(model.bodyParamIndex(0)) += paramsFromInertial(
      2.0, Eigen::Vector3d(0.0, 0.05, 0.1), Eigen::Matrix3d::Identity(), 0.01 * Eigen::Matrix3d::Identity());
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction[model.jointRow(2)] = 1.5;  // N m on an actuated joint
  long differ = 0, with_ff = 0;
  double max_ff = 0.0;
  closedLoop(exo, *plugin, 500, [&](int k, const RobotStateSample& s) {
    if (k == 250) {
      est.tick = k;
      EstimatorOutputSample bad = est;
      bad.params[3] = std::nan("");
      EXPECT_FALSE(plugin->setEstimate(bad));  // refused by the controller
      EXPECT_FALSE(ref.setEstimate(bad));
      bad = est;
      bad.tau_correction.resize(3);
      EXPECT_FALSE(plugin->setEstimate(bad));  // wrong size: refused at the boundary
      EXPECT_TRUE(plugin->setEstimate(est));
      EXPECT_TRUE(ref.setEstimate(est));
    }
    plugin->step(s);
    ref.tick(s, ref_cmd, ref_status);
    differ += plugin->command().tau == ref_cmd.tau && plugin->command().tau_ff == ref_cmd.tau_ff ? 0 : 1;
    // Reported as part of the command's feedforward (with the disturbance observer's estimate), blended in from
    // tick 250 + lag_ticks while fresh (until 250 + max_age_ticks), then out.
    const double from_estimate =
        plugin->command().tau_ff[2] - ref.disturbanceObserver().estimate()[model.jointRow(2)];
    if (std::abs(from_estimate) > 1e-12) ++with_ff;
    max_ff = std::max(max_ff, from_estimate);
  });
  EXPECT_EQ(differ, 0);
  EXPECT_GT(with_ff, cfg.estimate.max_age_ticks - cfg.estimate.lag_ticks);
  EXPECT_GT(max_ff, 0.0);
  EXPECT_LT(max_ff, 1.5);  // blended (blend_time 1 s): never the full value within 81 ticks
  // Withdrawn and blended out by tick 500: the disturbance observer's estimate alone, exactly.
  EXPECT_EQ(plugin->command().tau_ff[2], ref.disturbanceObserver().estimate()[model.jointRow(2)]);
  EXPECT_EQ(ref_status.estimate.withdrawn_stale, 1);
  EXPECT_EQ(plugin->stats().estimates_accepted, 1);
  EXPECT_EQ(plugin->stats().estimates_rejected, 2);
}

TEST(JointPdPlugin, AnswersThePdLawAndHoldsTheRobotStanding) {
  Exo exo;
  std::string err;
  sim::PluginOptions o;
  o.path = pluginLib("exoid_joint_pd_plugin");
  auto plugin = load(o, exo, &err);
  ASSERT_TRUE(plugin) << err;
  EXPECT_STREQ(plugin->name(), "joint PD holding the standing pose");
  const double kp = 1000.0, kd = 60.0, tau_max = 100.0;  // docs/plugin.md
  Eigen::VectorXd q0, q_prev;
  double max_err = 0.0;
  long allocations = 0;
  Eigen::Vector3d p0;
  closedLoop(exo, *plugin, 3000, [&](int k, const RobotStateSample& s) {
    if (k == 0) p0 = exo.data.truth.base_position;
    test::AllocationCounter count;
    plugin->step(s);
    count.stop();
    allocations += count.mallocs() + count.news();
    if (k == 0) q0 = q_prev = s.q;
    const Eigen::VectorXd dq = (s.q - q_prev) / 1e-3;
    for (Eigen::Index j = 0; j < s.q.size(); ++j) {
      const double expected = std::clamp(kp * (q0[j] - s.q[j]) - kd * dq[j], -tau_max, tau_max);
      max_err = std::max(max_err, std::abs(plugin->command().tau[j] - expected));
    }
    q_prev = s.q;
  });
  EXPECT_LE(max_err, 1e-9);
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(plugin->stats().good, 3000);
  // No set_force_plates (NULL in its table): the host keeps the plates, counts nothing.
  EXPECT_FALSE(plugin->setForcePlates(exo.data.plates.data(), sim::kNumFeet));
  EXPECT_EQ(plugin->stats().plates_accepted + plugin->stats().plates_rejected, 0);
  EXPECT_FALSE(sim::simFell(exo.model, exo.data));
  // Standing: a stiff joint PD leaves a static sag (gravity torque / KP) and a slow sway of ~1-2 cm; the base
  // stays at its height (no collapse) and comes to rest.
  const Eigen::Vector3d d = exo.data.truth.base_position - p0;
  std::printf("joint PD plugin after 3 s: base moved %.2f mm horizontally, %.3f mm vertically, speed %.1f mm/s\n",
              1e3 * d.head<2>().norm(), 1e3 * d.z(), 1e3 * exo.data.truth.base_velocity.norm());
  EXPECT_LT(d.head<2>().norm(), 0.03);
  EXPECT_LT(std::abs(d.z()), 1e-3);
  EXPECT_LT(exo.data.truth.base_velocity.norm(), 0.02);
}

// The plates of tick k go to the plugin after its tick, in order right, left; a refusal is counted and
// changes nothing else.
TEST(PluginPlates, HostHandsThemOverInOrderAndCountsRefusals) {
  Exo exo;
  std::string err;
  auto plugin = load(faultOptions("plates 100 110"), exo, &err);
  ASSERT_TRUE(plugin) << err;
  closedLoop(exo, *plugin, 130, [&](int k, const RobotStateSample& s) {
    plugin->step(s);
    EXPECT_EQ(exo.data.plates[0].tick, k);
    EXPECT_EQ(plugin->setForcePlates(exo.data.plates.data(), sim::kNumFeet), k < 100 || k >= 110) << k;
    EXPECT_EQ(plugin->command().mode, CommandMode::Torque) << k;
  });
  EXPECT_EQ(plugin->stats().plates_accepted, 120);
  EXPECT_EQ(plugin->stats().plates_rejected, 10);
  EXPECT_EQ(plugin->stats().fallbackTicks(), 0);
  EXPECT_FALSE(plugin->setForcePlates(exo.data.plates.data(), 1));  // the ABI carries both plates
  EXPECT_NE(plugin->formatStats().find("plates accepted 120 rejected 11"), std::string::npos) << plugin->formatStats();
}

struct FaultCase {
  const char* script;
  int64_t sim::PluginStats::*counter;
};

class PluginFaults : public ::testing::TestWithParam<FaultCase> {};

// Ticks 100..109 misbehave: 3 ticks hold the last good torque (the one answered for tick 100), 7 damp, then
// the plugin's answers are applied again. The simulator keeps running (the robot is fixed-ish: tiny torques).
TEST_P(PluginFaults, HoldThenDampingThenRecover) {
  Exo exo;
  std::string err;
  sim::PluginOptions o = faultOptions(GetParam().script, 3);
  // Generous budget: a well-behaved call (< 1 us) never reaches it, even on a loaded machine.
  if (std::string(GetParam().script).rfind("slow", 0) == 0) o.budget_us = 20000.0;
  auto plugin = load(o, exo, &err);
  ASSERT_TRUE(plugin) << err;
  RobotStateSample s = exo.data.state;
  for (int64_t k = 0; k < 130; ++k) {
    s.tick = k;
    plugin->step(s);
    const JointCommandSample& c = plugin->command();
    ASSERT_EQ(c.tick, k + 1);
    const double good_tau0 = 1.0 + static_cast<double>(k) * 1e-3;  // the fault plugin's answer
    if (k < 100 || k >= 110) {
      EXPECT_EQ(c.mode, CommandMode::Torque) << k;
      EXPECT_EQ(c.tau[0], good_tau0) << k;
    } else if (k < 103) {
      EXPECT_EQ(c.mode, CommandMode::HoldLastSafe) << k;
      EXPECT_EQ(c.tau[0], 1.0 + 99 * 1e-3) << k;  // the last good one, tick 99's answer
    } else {
      EXPECT_EQ(c.mode, CommandMode::Damping) << k;
    }
    EXPECT_TRUE(c.tau.allFinite());
  }
  const sim::PluginStats& st = plugin->stats();
  EXPECT_EQ(st.*(GetParam().counter), 10);
  EXPECT_EQ(st.calls, 130);
  EXPECT_EQ(st.good, 120);
  EXPECT_EQ(st.hold_ticks, 3);
  EXPECT_EQ(st.damping_ticks, 7);
  EXPECT_EQ(st.failed + st.non_finite + st.bad_output + st.overruns, 10);
  EXPECT_EQ(plugin->status().fallbacks, 10);  // the host's fallback ticks appear in the published status
  EXPECT_NE(plugin->formatStats().find("fallback ticks 10 (held 3, damping 7)"), std::string::npos)
      << plugin->formatStats();
}

INSTANTIATE_TEST_SUITE_P(Kinds, PluginFaults,
                         ::testing::Values(FaultCase{"error 100 110", &sim::PluginStats::failed},
                                           FaultCase{"nan 100 110", &sim::PluginStats::non_finite},
                                           FaultCase{"bad_tick 100 110", &sim::PluginStats::bad_output},
                                           FaultCase{"slow 100 110 50000", &sim::PluginStats::overruns}));

TEST(PluginFaultsInTheLoop, NanTorqueNeverReachesMujoco) {
  Exo exo;
  std::string err;
  auto plugin = load(faultOptions("nan 50 2000", 20), exo, &err);
  ASSERT_TRUE(plugin) << err;
  closedLoop(exo, *plugin, 500, [&](int, const RobotStateSample& s) { plugin->step(s); });
  EXPECT_EQ(exo.data.stats.rejected_commands, 0);  // the sim never saw a non-finite command
  EXPECT_EQ(plugin->stats().non_finite, 450);
  EXPECT_EQ(plugin->stats().hold_ticks, 20);
  EXPECT_EQ(plugin->stats().damping_ticks, 430);
  EXPECT_TRUE(std::isfinite(exo.data.truth.base_position.z()));
}

// The loop with the plugin, on memq://: every tick it publishes the plugin's command (tick k + 1, the exact
// torque then applied at tick k + 1, as the truth shows) and status; an EXO_ESTIMATE reaches the plugin.
TEST(PluginInTheLoop, PublishesCommandAndStatusAndTakesTheEstimate) {
  Exo exo;
  std::string err;
  sim::PluginOptions o = balanceOptions();
  auto plugin = load(o, exo, &err);
  ASSERT_TRUE(plugin) << err;
  Model model;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  LcmEndpoint ep("memq://");
  constexpr int kTicks = 400;
  std::vector<Eigen::VectorXd> commanded(kTicks + 1), applied(kTicks);
  int commands = 0, statuses = 0, wrong_stamp = 0;
  ep.subscribe<exoid_lcm::joint_command_t>(channels::kCommand, [&](const char*, const exoid_lcm::joint_command_t& c) {
    ++commands;
    wrong_stamp += c.tick == c.source_tick + 1 && c.tick == commands ? 0 : 1;
    if (c.tick <= kTicks) commanded[static_cast<size_t>(c.tick)] = Eigen::Map<const Eigen::VectorXd>(c.tau.data(), c.num_joints);
  });
  ep.subscribe<exoid_lcm::controller_status_t>(channels::kControllerStatus,
                                               [&](const char*, const exoid_lcm::controller_status_t&) { ++statuses; });
  ep.subscribe<exoid_lcm::ground_truth_t>(channels::kTruth, [&](const char*, const exoid_lcm::ground_truth_t& t) {
    applied[static_cast<size_t>(t.tick)] = Eigen::Map<const Eigen::VectorXd>(t.tau_applied.data(), t.num_joints);
  });
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = model.phi;
  est.param_stddev = Eigen::VectorXd::Zero(model.nparams());
  est.tau_correction = Eigen::VectorXd::Zero(model.nv);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  est.residual_rms = Eigen::VectorXd::Zero(model.nv);
  exoid_lcm::estimator_output_t est_msg;
  ep.subscribe<exoid_lcm::robot_state_t>(channels::kState, [&](const char*, const exoid_lcm::robot_state_t& s) {
    if (s.tick != 300 && s.tick != 301) return;
    est.tick = s.tick;
    est.tau_correction[model.jointRow(2)] = s.tick == 300 ? 0.5 : NAN;  // the second one is rejected by the gate
    toLcm(est, model.paramNames(), model.coordinateNames(), est_msg);
    ep.publish(channels::kEstimate, est_msg);
  });
  sim::RunOptions opt;
  opt.duration_s = kTicks * 1e-3;
  opt.quiet = true;
  opt.plugin = plugin.get();
  sim::RunSummary sum;
  ASSERT_TRUE(sim::runSim(exo.model, exo.data, ep, opt, &sum, &err)) << err;
  ep.handleAvailable();
  EXPECT_EQ(sum.ticks, kTicks);
  EXPECT_EQ(commands, kTicks);
  EXPECT_EQ(statuses, kTicks);
  EXPECT_EQ(wrong_stamp, 0);
  EXPECT_EQ(sum.fresh_ticks, kTicks - 1);  // tick 0 applies the initial zero command
  EXPECT_EQ(sum.fallbackTicks(), 0);
  // Torque applied at tick k = the command published for tick k (actuated joints; motors have gear 1).
  double max_diff = 0.0;
  for (int k = 1; k < kTicks; ++k)
    for (int j = 0; j < model.njoints; ++j)
      if (model.joint_names[static_cast<size_t>(j)].find("_ie") == std::string::npos)
        max_diff = std::max(max_diff, std::abs(applied[static_cast<size_t>(k)][j] - commanded[static_cast<size_t>(k)][j]));
  EXPECT_LE(max_diff, 1e-12);
  EXPECT_EQ(plugin->stats().estimates_accepted, 1);
  EXPECT_EQ(plugin->stats().calls, kTicks);
}

// exo_sim's command line with a plugin: one-line errors with exit code 2, the options in --help.
TEST(PluginCli, BadPluginsExitTwoWithOneLineAndHelpListsTheOptions) {
  test::TempDir dir("plugin_cli");
  const std::string sim = std::string(EXOID_BIN_DIR) + "/exo_sim --quiet --duration 0.01 --lcm-url memq:// ";
  struct Case {
    std::string args, expect;
  } cases[] = {
      {"--controller-plugin /nonexistent/lib.so", "--controller-plugin /nonexistent/lib.so: cannot load"},
      {"--controller-plugin " + pluginLib("exoid_fault_plugin_abi1"), "ABI version 1, this exo_sim needs 4"},
      {"--controller-plugin " + pluginLib("exoid_not_a_plugin"), "not a controller plugin"},
      {"--controller-plugin " + pluginLib("exoid_controller_plugin") + " --controller-config /nonexistent.yaml",
       "/nonexistent.yaml"},
      {"--controller-plugin " + pluginLib("exoid_joint_pd_plugin") + " --controller-rate-hz 300",
       "--controller-rate-hz: not a divisor of 1000"},
  };
  for (const Case& c : cases) {
    const auto r = test::runCommand(sim + c.args, dir.path);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  // A working plugin: the run completes and the plugin's line follows the summary.
  auto r = test::runCommand(sim + "--controller-plugin " + pluginLib("exoid_joint_pd_plugin"), dir.path);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("plugin 'joint PD holding the standing pose': calls 10, good 10"), std::string::npos) << r.out;
  r = test::runCommand(std::string(EXOID_BIN_DIR) + "/exo_sim --help", dir.path);
  for (const char* o : {"--controller-plugin", "--controller-model", "--controller-config", "--controller-seed",
                        "--controller-moves", "--controller-rate-hz", "--plugin-budget-us", "--plugin-hold-ticks",
                        "--no-estimate", "--rt-priority", "EXO_ESTIMATE"})
    EXPECT_NE(r.out.find(o), std::string::npos) << o;
}

}  // namespace
}  // namespace exoid

namespace exoid {
namespace {
// Without --duration the plugin's own "finished" status ends the run: the balance plugin with one move stops
// at the end of its planned task (latch, initial hold, one move and hold, final hold), exit 0.
TEST(PluginCli, WithoutDurationTheRunEndsWhenThePluginFinishes) {
  test::TempDir dir("plugin_finished");
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::loadControllerConfig(std::string(EXOID_CONFIG_DIR) + "/controller.yaml", cfg, &err)) << err;
  cfg.trajectory.moves = 1;
  const long planned = std::lround(controller::plannedRunDuration(cfg) * 1000.0);
  const std::string result = dir.file("result.json");
  const auto r = test::runCommand(std::string(EXOID_BIN_DIR) + "/exo_sim --quiet --lcm-url memq:// --no-estimate " +
                                      "--controller-plugin " + pluginLib("exoid_controller_plugin") +
                                      " --controller-moves 1 --result " + result,
                                  dir.path);
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("ended by the plugin (task finished)"), std::string::npos) << r.out;
  sim::RunSummary s;
  ASSERT_TRUE(sim::parseRunSummaryJson(test::slurp(result), &s, &err)) << err;
  EXPECT_TRUE(s.plugin_finished);
  EXPECT_EQ(s.outcome, sim::RunOutcome::Completed);
  EXPECT_FALSE(s.fell);
  // The task ends within a controller tick or two of the planned duration (the latch tick is counted once).
  EXPECT_NEAR(static_cast<double>(s.ticks), static_cast<double>(planned), 2.0) << "planned " << planned;
  EXPECT_LT(s.ticks, s.ticks_planned);  // the 3600 s cap was not what ended it
  // The plugin's calls in the loop timing (docs/sim.md, "Loop timing"): one per tick at 1 kHz, no budget in lockstep.
  EXPECT_EQ(s.timing.plugin_calls, s.ticks);
  EXPECT_GT(s.timing.plugin_call_us_mean, 0.0);
  EXPECT_GE(s.timing.plugin_call_us_max, s.timing.plugin_call_us_mean);
  EXPECT_GT(s.timing.plugin_call_cpu_us_max, 0.0);
  EXPECT_EQ(s.timing.plugin_budget_overruns, 0);
  EXPECT_EQ(s.timing.plugin_fallback_ticks, 0);
  EXPECT_EQ(s.timing.deadline_misses, -1);
}
// Lockstep waiting for the estimate (exo_sim --estimate-lag-ticks L) with no estimator: before the plugin's tick L
// the loop waits for the first estimate (--start-timeout-s), gives up once, says the run is no longer
// reproducible, and completes without waiting again.
TEST(PluginCli, AnEstimateThatNeverComesEndsTheWaitOnceAndIsReported) {
  test::TempDir dir("plugin_estimate_wait");
  const std::string result = dir.file("result.json");
  const auto r = test::runCommand(std::string(EXOID_BIN_DIR) + "/exo_sim --quiet --lcm-url memq:// --duration 0.1 " +
                                      "--controller-plugin " + pluginLib("exoid_controller_plugin") +
                                      " --estimate-lag-ticks 5 --start-timeout-s 0.2 --result " + result,
                                  dir.path);
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("no EXO_ESTIMATE with tick >= 0 within 0.200 s at tick 5 (none received yet)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("estimate waits 1 ("), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("timeouts 1: not reproducible"), std::string::npos) << r.out;
  sim::RunSummary s;
  std::string err;
  ASSERT_TRUE(sim::parseRunSummaryJson(test::slurp(result), &s, &err)) << err;
  EXPECT_EQ(s.ticks, 100);
  EXPECT_EQ(s.estimate_waits, 1);
  EXPECT_EQ(s.estimate_timeouts, 1);
  EXPECT_EQ(s.estimate_wait_stopped_tick, 5);
  EXPECT_GE(s.estimate_wait_s, 0.2);
}
}  // namespace
}  // namespace exoid
