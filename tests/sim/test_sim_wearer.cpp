// The wearer in the simulator (scenario key `wearer:`, docs/wearer.md): the MuJoCo model carries exo + wearer, its
// whole-system CoM is the anthropometric model's, the passive leg moments act on the exo's joints without reaching
// its torque sensors, the trunk sway has its RMS, reflex bursts come at their rate, the balance controller holds
// every shipped wearer for 2 s with the clinic's prior (exo URDF + the table wearer), and the whole 20-move protocol
// with the move reach: the heaviest shipped wearers and wearers drawn at random (issue 21 part 2).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "controller_test_util.hpp"
#include "sim_closed_loop.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/model/wearer_mount.hpp"
#include "exoid/sim/sim.hpp"
#include "exoid/tools/wearer_urdf.hpp"
#include "support/alloc_counter.hpp"
#include "support/paths.hpp"

namespace exoid::sim {
namespace {

using exoid::test::configPath;

Scenario scenario(const std::string& name) {
  Scenario sc;
  std::string err;
  EXPECT_TRUE(loadScenario(configPath("scenarios/" + name + ".yaml"), &sc, &err)) << err;
  return sc;
}

// The clinic's prior for the scenario's wearer: config/exo.urdf plus the table person at the typed mass, height and
// sex (the person's deviation from the table unknown), written to `file` in the test's temp dir and built.
Model clinicPrior(const Scenario& sc, const std::string& file) {
  const std::string path = ::testing::TempDir() + file;
  WearerSpec typed = sc.wearer.spec;
  typed.variation = 0.0;
  std::string err;
  Model prior;
  EXPECT_TRUE(tools::writeWearerPrior(configPath("exo.urdf"), typed, path, nullptr, &err)) << err;
  EXPECT_TRUE(buildModelFromUrdfFile(path, true, prior, &err)) << err;
  return prior;
}

void load(const Scenario& sc, SimModel& sm, SimData& sd) {
  SensorConfig realistic;
  std::string err;
  ASSERT_TRUE(loadSensorConfig(configPath("sensors.yaml"), &realistic, &err)) << err;
  ASSERT_TRUE(simLoad(configPath("exo.xml"), noiseOff(realistic), sc, sm, &err)) << err;
  ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
}

// The segments' world CoMs standing, from the placement rules (docs/wearer.md), with the pelvis origin at `base`
// (config/exo.urdf: hips 0.1 m below it at y = -+0.11, knees 0.43 m lower, ankle axes 0.42 m lower, soles 0.09 m).
Eigen::Vector3d handPlacedCom(const Wearer& w, const BodySegment& s, const Eigen::Vector3d& base) {
  const double y = s.side * 0.11, f = s.com_fraction, L = s.length;
  const double hip = -0.1, knee = hip - 0.43, ankle = knee - 0.42, sole = ankle - 0.09;
  switch (s.kind) {
    case SegmentKind::Thigh: return base + Eigen::Vector3d(0.0, y, hip - f * L);
    case SegmentKind::Shank: return base + Eigen::Vector3d(0.0, y, knee - f * L);
    case SegmentKind::Foot: return base + Eigen::Vector3d((f - 0.22) * L, y, 0.5 * (ankle + sole));
    default: return base + Eigen::Vector3d(0.0, 0.0, hip) + standingSegmentCom(w, s);
  }
}

TEST(SimWearer, ModelCarriesExoPlusWearerAndTheTruthCoMIsTheAnthropometricOne) {
  Model exo;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(configPath("exo.urdf"), true, exo, &err)) << err;
  DynamicsData dyn(exo);
  forwardKinematics(exo, dyn.kin, State::zero(exo));
  centroidal(exo, dyn);
  for (const char* name : {"wearer_light_passive", "wearer_heavy_sway_reflex"}) {
    const Scenario sc = scenario(name);
    SimModel sm;
    SimData sd;
    load(sc, sm, sd);
    ASSERT_TRUE(sm.wearer.enabled);
    EXPECT_EQ(sm.joint_names, exo.joint_names);  // the lumbar hinges are not exo joints
    double robot = 0.0;
    for (int b = 1; b < sm.m->nbody; ++b)
      if (sm.m->body_weldid[b] != 0) robot += sm.m->body_mass[b];  // moving bodies: not the plates
    EXPECT_NEAR(robot, exo.totalMass() + sc.wearer.spec.mass_kg, 1e-9) << name;
    EXPECT_NEAR(sm.m->body_subtreemass[sm.base_body], robot, 1e-9);

    Wearer w;
    ASSERT_TRUE(buildWearer(sc.wearer.spec, w, &err)) << err;
    const Eigen::Vector3d base(sd.d->qpos + sm.base_qpos);
    Eigen::Vector3d moment = exo.totalMass() * (base + dyn.com);
    for (const BodySegment& s : w.segments) moment += s.mass * handPlacedCom(w, s, base);
    const Eigen::Vector3d expected = moment / (exo.totalMass() + sc.wearer.spec.mass_kg);
    JointCommandSample zero = simZeroCommand(sm);
    simStep(sm, sd, zero);  // the truth of tick 0 is the state at reset
    EXPECT_LT((sd.truth.com - expected).norm(), 1e-9) << name << ": " << sd.truth.com.transpose() << " vs "
                                                      << expected.transpose();
  }
}

// The truth channel's trunk (schema.h `trunk_*`): the lumbar hinges' angles and rates as set, and the upper body's
// CoM where the hinges put it, recomputed here from the pelvis pose, the pivot and the lumped body's offset with
// intrinsic x-y-z rotations (MuJoCo's order of a body's joints): the convention written in docs/lcm.md. The system's
// CoM moves by the trunk's mass share of the trunk's move. The empty exoskeleton has no trunk: zeros.
TEST(SimWearer, TheTruthCarriesTheTrunksStateWhereTheLumbarHingesPutIt) {
  const Scenario sc = scenario("wearer_nominal_sway");
  SimModel sm;
  SimData sd;
  load(sc, sm, sd);
  const WearerSim& w = sm.wearer;
  const int pelvis = mj_name2id(sm.m, mjOBJ_BODY, exoPelvisLink());
  ASSERT_GE(pelvis, 0);
  const double M = sm.m->body_subtreemass[sm.base_body], mt = w.upper_body.mass;
  JointCommandSample zero = simZeroCommand(sm);
  simStep(sm, sd, zero);
  ASSERT_TRUE(sd.truth.has_trunk);
  const Eigen::Vector3d com0 = sd.truth.com, trunk0 = sd.truth.trunk_com;
  const Eigen::Vector3d angle(0.05, -0.12, 0.3), rate(0.2, -0.4, 0.7);
  simReset(sm, sd);
  for (size_t i = 0; i < 3; ++i) {
    sd.d->qpos[w.lumbar_qpos[i]] = angle[static_cast<Eigen::Index>(i)];
    sd.d->qvel[w.lumbar_dof[i]] = rate[static_cast<Eigen::Index>(i)];
  }
  simStep(sm, sd, zero);  // the truth of this tick is the state set above
  EXPECT_EQ(sd.truth.trunk_angle, angle);
  EXPECT_EQ(sd.truth.trunk_rate, rate);
  const Eigen::Vector3d p(sd.d->xpos + 3 * pelvis);
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sd.d->xmat + 9 * pelvis);
  const Eigen::Matrix3d lumbar = (Eigen::AngleAxisd(angle.x(), Eigen::Vector3d::UnitX()) *
                                  Eigen::AngleAxisd(angle.y(), Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(angle.z(), Eigen::Vector3d::UnitZ())).toRotationMatrix();
  const Eigen::Vector3d& pivot = w.mount.lumbar_pivot;
  const Eigen::Vector3d expected = p + R * (pivot + lumbar * (w.upper_body.com - pivot));
  EXPECT_LT((sd.truth.trunk_com - expected).norm(), 1e-12) << sd.truth.trunk_com.transpose() << " vs "
                                                           << expected.transpose();
  EXPECT_GT((sd.truth.trunk_com - trunk0).norm(), 0.03);  // the angles moved it by centimetres
  EXPECT_LT((sd.truth.com - (com0 + mt / M * (sd.truth.trunk_com - trunk0))).norm(), 1e-12);

  SimModel exo;
  SimData exo_data;
  load(scenario("ideal"), exo, exo_data);
  JointCommandSample exo_zero = simZeroCommand(exo);
  simStep(exo, exo_data, exo_zero);
  EXPECT_FALSE(exo_data.truth.has_trunk);
  EXPECT_EQ(exo_data.truth.trunk_angle, Eigen::Vector3d::Zero());
  EXPECT_EQ(exo_data.truth.trunk_com, Eigen::Vector3d::Zero());
}

// The passive moments are generalized forces on the exo's hip/knee/ankle dofs (qfrc_applied): the drives' torque
// sensors and the truth's applied torque carry the actuators only.
TEST(SimWearer, PassiveMomentsActOnTheJointsButNotOnTheTorqueSensors) {
  Scenario sc = scenario("wearer_nominal_passive");
  sc.initial.joints = {{"right_hip_fe", 0.2}, {"right_knee", 0.3}, {"left_ankle_pd", 0.1}};
  SimModel sm;
  SimData sd;
  load(sc, sm, sd);
  JointCommandSample zero = simZeroCommand(sm);
  simStep(sm, sd, zero);
  const char* legs[3] = {"hip_fe", "knee", "ankle_pd"};
  for (int s = 0; s < 2; ++s) {
    LegJoints q;
    for (int i = 0; i < 3; ++i) {
      const std::string jn = std::string(s == 0 ? "right_" : "left_") + legs[i];
      const auto it = std::find(sm.joint_names.begin(), sm.joint_names.end(), jn);
      q[i] = sd.truth.q[it - sm.joint_names.begin()];
    }
    const LegJoints expected = passiveElasticMoments(q);  // at rest: no damping term at tick 0
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(sd.d->qfrc_applied[sm.wearer.leg_dof[s][i]], expected[i], 1e-9) << s << " " << legs[i];
  }
  EXPECT_GT(sd.d->qfrc_applied[sm.wearer.leg_dof[1][1]], 5.0);  // the straight left knee is pulled into flexion
  for (int j = 0; j < sm.nj; ++j) {
    EXPECT_EQ(sd.state.tau[j], 0.0) << sm.joint_names[j];  // zero command, noise off
    EXPECT_EQ(sd.truth.tau_applied[j], 0.0) << sm.joint_names[j];
  }
}

// Sway: stationary RMS = sway_rms per axis (first-order low-pass noise); reflexes: Poisson onsets at rate_hz, each
// a half sine of the set amplitude on one leg joint; the same seed gives the same torques.
TEST(SimWearer, SwayRmsAndReflexRateAsConfigured) {
  const Scenario sc = scenario("wearer_heavy_sway_reflex");
  SimModel sm;
  SimData sd;
  load(sc, sm, sd);
  const long n = 400000;  // 400 s of stageWearer alone (the state stays at rest: only the torques are drawn)
  Eigen::Vector3d ss = Eigen::Vector3d::Zero();
  double peak = 0.0;
  for (long k = 0; k < n; ++k, ++sd.tick) {
    stageWearer(sm, sd);
    ss += sd.wearer.sway.cwiseAbs2();
    for (const LegJoints& r : sd.wearer.reflex) peak = std::max(peak, r.cwiseAbs().maxCoeff());
  }
  const Eigen::Vector3d rms = (ss / static_cast<double>(n)).cwiseSqrt();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(rms[i], sc.wearer.trunk.sway_rms, 0.1 * sc.wearer.trunk.sway_rms) << i;
  const double expected = sc.wearer.reflex.rate_hz * 400.0;  // 80 onsets (less the ~6 % spent inside bursts)
  EXPECT_GT(sd.wearer.reflexes, 0.7 * expected);
  EXPECT_LT(sd.wearer.reflexes, 1.2 * expected);
  EXPECT_LE(peak, sc.wearer.reflex.amplitude + 1e-12);
  EXPECT_GT(peak, 0.99 * sc.wearer.reflex.amplitude);
  SimData again;
  std::string err;
  ASSERT_TRUE(simMakeData(sm, again, &err)) << err;
  simReset(sm, sd);
  for (int k = 0; k < 1000; ++k, ++sd.tick, ++again.tick) {
    stageWearer(sm, sd);
    stageWearer(sm, again);
    ASSERT_EQ(sd.wearer.sway, again.wearer.sway);
  }
}

// The wearer's stage runs in the 1 kHz loop: a step with passive moments, sway and reflexes allocates nothing.
TEST(SimWearer, StepWithAWearerDoesNotAllocate) {
  Scenario sc = scenario("wearer_heavy_sway_reflex");
  sc.wearer.reflex.rate_hz = 10.0;  // bursts within the 1000 ticks
  SimModel sm;
  SimData sd;
  load(sc, sm, sd);
  JointCommandSample cmd = simZeroCommand(sm);
  exoid::test::AllocationCounter counter;
  for (int k = 0; k < 1000; ++k) simStep(sm, sd, cmd);
  counter.stop();
  EXPECT_EQ(counter.news(), 0);
  EXPECT_EQ(counter.mallocs(), 0);
  EXPECT_GT(sd.wearer.reflexes, 0);
}

TEST(SimWearer, RefusesABadWearer) {
  const std::string path = ::testing::TempDir() + "bad_wearer.yaml";
  for (const char* body : {"wearer: {mass_kg: 75, height_m: 1.78, sex: x, trunk: {stiffness: [1,1,1], damping: [1,1,1]}}",
                           "wearer: {mass_kg: 75, height_m: 3.0, sex: m, trunk: {stiffness: [1,1,1], damping: [1,1,1]}}",
                           "wearer: {mass_kg: 75, height_m: 1.78, sex: m}",
                           "wearer: {mass_kg: 75, height_m: 1.78, sex: m, trunk: {stiffness: [1,1,-1], damping: [1,1,1]}}",
                           "wearer: {mass_kg: 75, height_m: 1.78, sex: m, colour: red, trunk: {stiffness: [1,1,1], damping: [1,1,1]}}"}) {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fprintf(f, "name: bad\nseed: 1\nnoise: off\n%s\n", body);
    std::fclose(f);
    Scenario sc;
    std::string err;
    EXPECT_FALSE(loadScenario(path, &sc, &err)) << body;
    EXPECT_NE(err.find("wearer"), std::string::npos) << err;
  }
}

// The balance controller with the clinic's prior (config/exo.urdf + the table wearer at the typed mass and height)
// holds every shipped wearer for the first 2 s of the move protocol (the first move starts at ~1.2 s; the 20 moves
// with a wearer are issue 21 part 2): no fall, the true CoM within 20 mm of the controller's reference.
TEST(SimWearer, BalanceControllerHoldsEveryShippedWearerForTwoSeconds) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  for (const char* name : {"wearer_light_passive", "wearer_nominal_passive", "wearer_nominal_sway", "wearer_heavy_passive",
                           "wearer_heavy_sway_reflex", "wearer_short_reflex", "wearer_tall_light_sway"}) {
    const Scenario sc = scenario(name);
    const Model prior = clinicPrior(sc, "wearer_prior.urdf");
    ASSERT_GT(prior.nv, 0) << name;
    SimModel sm;
    SimData sd;
    load(sc, sm, sd);
    controller::BalanceController ctrl(prior, cfg, 1);
    ASSERT_TRUE(ctrl.ok()) << ctrl.error();
    JointCommandSample cmd = simZeroCommand(sm);
    controller::ControllerStatus st;
    double max_error = 0.0;
    bool fell = false;
    controller::testing::ControllerFrameOffset frame;
    for (int k = 0; k < 2000 && !fell; ++k) {
      simStep(sm, sd, cmd);
      ctrl.tick(sd.state, cmd, st);
      for (const ForcePlateSample& p : sd.plates) ctrl.setForcePlate(p);
      frame.update(ctrl, sd.truth);
      max_error = std::max(max_error, (sd.truth.com - frame.offset - st.com_ref).head<2>().norm());
      fell = simFell(sm, sd);
    }
    std::printf("%-26s 2 s: fell %s, horizontal true CoM - reference max %.2f mm, lumbar (%.4f, %.4f, %.4f) rad, "
                "qp failures %d\n",
                name, fell ? "yes" : "no", 1e3 * max_error, sd.d->qpos[sm.wearer.lumbar_qpos[0]],
                sd.d->qpos[sm.wearer.lumbar_qpos[1]], sd.d->qpos[sm.wearer.lumbar_qpos[2]], st.qp_failures);
    EXPECT_FALSE(fell) << name;
    EXPECT_LT(max_error, 0.02) << name;
  }
}

// The plates' reported origins are in the lab's frame, whose origin a lab chooses (a room corner, metres from the
// robot); the controller places each plate where its sole is (BalanceController::setForcePlate), so where the lab's
// origin lies changes nothing it commands: the same 4 s of a wearer run (the CoM observer and the plate residual of
// the disturbance observer on, both anchors) with the plates reported 3 m and -2 m away gives the same commands, bit
// for bit. Before 2026-12-07 the plate moments were taken about the lab's origin, and the residual's moments would
// have been off by that offset times the load (~1.7 kN m per foot here).
TEST(SimWearer, WhereTheLabPutsItsOriginChangesNoCommand) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  ASSERT_TRUE(cfg.com_observer.enabled);
  ASSERT_TRUE(cfg.disturbance.enabled && cfg.disturbance.force_plates);
  const Scenario sc = scenario("wearer_nominal_sway");
  const Model prior = clinicPrior(sc, "lab_origin_prior.urdf");
  ASSERT_GT(prior.nv, 0);
  for (const auto anchor : {controller::ComObserverConfig::Anchor::kModel, controller::ComObserverConfig::Anchor::kPlates}) {
    controller::ControllerConfig c = cfg;
    c.com_observer.anchor = anchor;
    SimModel sm;
    SimData sd;
    load(sc, sm, sd);
    controller::BalanceController here(prior, c, 1), away(prior, c, 1);
    ASSERT_TRUE(here.ok() && away.ok());
    JointCommandSample cmd = simZeroCommand(sm), cmd_away = cmd;
    controller::ControllerStatus st, st_away;
    const Eigen::Vector3d shift(3.0, -2.0, 0.0);
    int differing = 0;
    for (int k = 0; k < 4000; ++k) {
      simStep(sm, sd, cmd);
      here.tick(sd.state, cmd, st);
      away.tick(sd.state, cmd_away, st_away);
      for (ForcePlateSample p : sd.plates) {
        ASSERT_TRUE(here.setForcePlate(p));
        p.plate_position += shift;  // the same plate, its position in another lab frame; its own wrench unchanged
        ASSERT_TRUE(away.setForcePlate(p));
      }
      differing += (cmd.tau - cmd_away.tau).cwiseAbs().maxCoeff() > 0.0 ? 1 : 0;
    }
    EXPECT_TRUE(st.trajectory_ready);
    EXPECT_GT(st.moves_done, 0);  // the moves had begun: the observer and the residual were at work
    EXPECT_EQ(differing, 0) << (anchor == controller::ComObserverConfig::Anchor::kModel ? "model" : "plates");
    EXPECT_FALSE(simFell(sm, sd));
  }
}

// The whole move protocol (cfg.trajectory.moves) with the scenario's wearer, the controller on the clinic's prior
// (the table person at the typed mass, height and sex), without the estimator; realistic sensor noise off.
struct ProtocolRun {
  bool fell = false;
  double fell_at_s = 0.0;
  int moves_done = 0;
  bool done = false;
  double max_slip = 0.0;   ///< m, horizontal, either sole
  double rmse_xy = 0.0;    ///< m, horizontal true CoM - reference over the moves
  controller::MoveReach reach;
  double model_mass = 0.0; ///< kg, the prior's
  double peak_carrying = 0.0;  ///< max over the run of |tau| / limit of the joints that carry the moves' moment
  double hip_fe_jitter = 0.0;  ///< N m, RMS of the hip flexions' tick-to-tick command change after the start-up window
  double com_belief_rms = 0.0;  ///< m, RMS about its mean of the true - the controller's horizontal CoM over the moves
  Eigen::Vector2d com_belief_mean = Eigen::Vector2d::Zero();  ///< m, its mean (the worlds aligned by the soles)
};
ProtocolRun runProtocol(const Scenario& sc, const controller::ControllerConfig& cfg) {
  ProtocolRun r;
  const Model prior = clinicPrior(sc, "protocol_wearer_prior.urdf");
  r.model_mass = prior.totalMass();
  SimModel sm;
  SimData sd;
  load(sc, sm, sd);
  controller::BalanceController ctrl(prior, cfg, 1);
  EXPECT_TRUE(ctrl.ok()) << ctrl.error();
  if (!ctrl.ok() || !sd.d) return r;
  JointCommandSample cmd = simZeroCommand(sm);
  controller::ControllerStatus st;
  Eigen::Vector2d sole0[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  double track2 = 0.0;
  long n = 0;
  controller::testing::ControllerFrameOffset frame;
  const long ticks = std::lround(controller::plannedRunDuration(cfg) / cfg.loop.period);
  // The joints that carry the moves' static moment and their limits (config/exo.urdf): hip_aa sideways, ankle_pd
  // forward (docs/controller.md "Move reach").
  std::vector<std::pair<int, double>> carrying;
  std::vector<int> hip_fe;  // and the hip flexions, whose ringing a compliant trunk sets off
  for (size_t j = 0; j < sm.joint_names.size(); ++j) {
    const std::string& name = sm.joint_names[j];
    const int i = static_cast<int>(j);
    if (name.find("hip_aa") != std::string::npos) carrying.emplace_back(i, 150.0);
    if (name.find("ankle_pd") != std::string::npos) carrying.emplace_back(i, 100.0);
    if (name.find("hip_fe") != std::string::npos) hip_fe.push_back(i);
  }
  EXPECT_EQ(carrying.size(), 4u);
  EXPECT_EQ(hip_fe.size(), 2u);
  std::vector<double> hip_prev(hip_fe.size(), 0.0);
  double jitter2 = 0.0;
  long jitter_n = 0;
  Eigen::Vector2d belief_sum = Eigen::Vector2d::Zero();
  double belief2 = 0.0;
  for (long k = 0; !r.fell && !st.trajectory_done && k < ticks; ++k) {
    simStep(sm, sd, cmd);
    ctrl.tick(sd.state, cmd, st);
    for (const ForcePlateSample& p : sd.plates) ctrl.setForcePlate(p);
    frame.update(ctrl, sd.truth);
    if (st.move_index >= 0)
      for (const auto& [j, limit] : carrying) r.peak_carrying = std::max(r.peak_carrying, std::abs(cmd.tau[j]) / limit);
    for (size_t i = 0; i < hip_fe.size(); ++i) {
      if (k > cfg.observer.latch_ticks) {
        jitter2 += (cmd.tau[hip_fe[i]] - hip_prev[i]) * (cmd.tau[hip_fe[i]] - hip_prev[i]);
        ++jitter_n;
      }
      hip_prev[i] = cmd.tau[hip_fe[i]];
    }
    for (int f = 0; f < 2; ++f) {  // the soles' world positions (MuJoCo's geoms)
      const Eigen::Vector2d p(sd.d->geom_xpos[3 * sm.foot_geom[f]], sd.d->geom_xpos[3 * sm.foot_geom[f] + 1]);
      if (k == 0) sole0[f] = p;
      r.max_slip = std::max(r.max_slip, (p - sole0[f]).norm());
    }
    if (st.move_index >= 0) {
      track2 += (sd.truth.com - frame.offset - st.com_ref).head<2>().squaredNorm();
      const Eigen::Vector2d belief = (sd.truth.com - frame.offset - st.com).head<2>();
      belief_sum += belief;
      belief2 += belief.squaredNorm();
      ++n;
    }
    r.fell = simFell(sm, sd);
  }
  r.fell_at_s = sd.d->time;
  r.moves_done = st.moves_done;
  r.done = st.trajectory_done;
  r.rmse_xy = std::sqrt(track2 / std::max(n, 1L));
  const double nn = static_cast<double>(std::max(n, 1L));
  r.com_belief_rms = std::sqrt(std::max(0.0, belief2 / nn - (belief_sum / nn).squaredNorm()));
  r.com_belief_mean = belief_sum / nn;
  r.hip_fe_jitter = std::sqrt(jitter2 / std::max(jitter_n, 1L));
  r.reach = ctrl.moveReach();
  return r;
}

void print(const char* what, const WearerConfig& w, const ProtocolRun& r) {
  std::printf("%s: %.1f kg, %.2f m, %s, sway %.1f N m, reflexes %s: fell %s (%.2f s), moves %d, max slip %.3f mm, "
              "horizontal true CoM - reference RMSE %.2f mm, reach %.3f / %.3f m, peak carrying torque %.2f of its "
              "limit, hip flexion jitter %.2f N m, true - controller's CoM %.2f mm RMS about its mean (%.2f, %.2f)\n",
              what, w.spec.mass_kg, w.spec.height_m, w.spec.sex == Sex::Male ? "m" : "f", w.trunk.sway_rms,
              w.reflex.rate_hz > 0.0 ? "yes" : "no", r.fell ? "yes" : "no", r.fell_at_s, r.moves_done,
              1e3 * r.max_slip, 1e3 * r.rmse_xy, r.reach.half.x(), r.reach.half.y(), r.peak_carrying,
              r.hip_fe_jitter, 1e3 * r.com_belief_rms, 1e3 * r.com_belief_mean.x(), 1e3 * r.com_belief_mean.y());
}

// Issue 21 part 2: the shipped 110 kg, 1.95 m wearers (151 kg in all) complete the 20 moves with the move reach
// (trajectory.torque_budget, docs/controller.md "Move reach"), which keeps the static moment of every target within
// the budget's share of the carrying joints' limits. With the empty exoskeleton's amplitudes (no reach) the passive
// wearer's moves ask 0.57 of the limit (0.35 with the reach); at the earlier CoM gains (kp 100, kd 20) that run fell
// in its 16th move (the hip abduction, then an ankle and both hip flexions saturated).
TEST(SimWearer, TheMoveReachKeepsTheHeaviestShippedWearersStanding) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  ASSERT_EQ(cfg.trajectory.moves, 20);
  ASSERT_GT(cfg.trajectory.torque_budget, 0.0);
  for (const char* name : {"wearer_heavy_passive", "wearer_heavy_sway_reflex"}) {
    const Scenario sc = scenario(name);
    const ProtocolRun r = runProtocol(sc, cfg);
    print(name, sc.wearer, r);
    EXPECT_FALSE(r.fell) << name;
    EXPECT_TRUE(r.done) << name;
    EXPECT_EQ(r.moves_done, 20) << name;
    EXPECT_LE(r.max_slip, 1e-3) << name;
    // Without reflexes (the other's 20 N m bursts saturate a joint for a moment whatever the moves), the moves'
    // torque stays near the budget: the static share plus the moves' dynamics.
    if (sc.wearer.reflex.rate_hz == 0.0) {
      EXPECT_LT(r.peak_carrying, cfg.trajectory.torque_budget + 0.1) << name;
    }
    // The rule's reach for this system (the prior's mass): hip_aa 150 N m sideways, ankle_pd 100 N m forward.
    EXPECT_NEAR(r.reach.half.y(), cfg.trajectory.torque_budget * 150.0 / (r.model_mass * 9.81), 1e-12) << name;
    EXPECT_NEAR(r.reach.half.x(), cfg.trajectory.torque_budget * 100.0 / (r.model_mass * 9.81), 1e-12) << name;
  }
  controller::ControllerConfig unbounded = cfg;
  unbounded.trajectory.torque_budget = 0.0;
  const Scenario sc = scenario("wearer_heavy_passive");
  const ProtocolRun r = runProtocol(sc, unbounded);
  print("wearer_heavy_passive, no reach", sc.wearer, r);
  EXPECT_GT(r.peak_carrying, cfg.trajectory.torque_budget + 0.1)
      << "without the reach the heavy wearer's moves should ask more of the joints (else the test above shows nothing)";
}

// Issue 21 part 2: a wearer the shipped scenarios did not have. The heavy swaying wearer with reflexes drawn with
// variation seed 100 fell at 2.4 s at the earlier CoM gains (kp 100, kd 20): from a reflex burst at 0.75 s the hip
// flexions rang at ~18 Hz between the torque limits, the QP turned infeasible and the fallback let the robot fall.
// The model's CoM velocity carries the trunk as if rigid on the pelvis, which it is not above its lumbar mode; the
// CoM gains at 7 rad/s (config/controller.yaml) keep that loop calm (docs/wearer.md "Unseen wearers and the CoM
// gains"). The earlier gains are run too, for the first three moves: their ringing is what the test would
// otherwise not see.
TEST(SimWearer, AHeavyWearerWhoseReflexRangTheHipsCompletesTheProtocol) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  Scenario sc = scenario("wearer_heavy_sway_reflex");
  sc.wearer.spec.seed = 100;
  const ProtocolRun r = runProtocol(sc, cfg);
  print("heavy_sway_reflex, person 100", sc.wearer, r);
  EXPECT_FALSE(r.fell);
  EXPECT_TRUE(r.done);
  EXPECT_EQ(r.moves_done, 20);
  EXPECT_LE(r.max_slip, 1e-3);
  controller::ControllerConfig earlier = cfg;
  earlier.momentum.kp_com.setConstant(100.0);
  earlier.momentum.kd_com.setConstant(20.0);
  earlier.trajectory.moves = 3;
  const ProtocolRun e = runProtocol(sc, earlier);
  print("heavy_sway_reflex, person 100, kp 100 / kd 20", sc.wearer, e);
  // Tick-to-tick hip flexion command change, RMS: 1.15 N m at 7 rad/s over the 20 moves (the shipped heavy wearers
  // 0.06-0.48), 26.6 N m at 10 rad/s until the fall (2026-12-04).
  EXPECT_LT(r.hip_fe_jitter, 4.0);
  EXPECT_GT(e.hip_fe_jitter, 10.0);
}

// Issue 21 part 2: the controller's CoM observer (docs/controller.md "The CoM observer") gives the CoM task the
// swaying trunk the model holds rigid. Over the moves the controller's horizontal CoM follows the true one's motion
// (RMS about the mean, which is the prior's bias and the estimate's job) several times closer with the observer
// than without, and the true CoM follows the reference closer. Taking the upper body's turning from the force the
// model lacks (`upper_body_momentum`, its lever from the prior's lumbar pivot) brings the controller's CoM closer
// still. With the plates' anchor (`anchor: plates`, each plate placed by the controller's latched sole) the mean goes
// too: the table person's bias is measured. Prior alone, in-process, 8 moves.
TEST(SimWearer, TheCoMObserverGivesTheControllerTheSwayingTrunk) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  ASSERT_TRUE(cfg.com_observer.enabled);
  cfg.trajectory.moves = 8;
  ASSERT_TRUE(cfg.com_observer.upper_body_momentum);
  ASSERT_EQ(cfg.com_observer.anchor, controller::ComObserverConfig::Anchor::kModel);
  controller::ControllerConfig off = cfg, rigid = cfg, plates = cfg;
  off.com_observer.enabled = false;
  rigid.com_observer.upper_body_momentum = false;
  plates.com_observer.anchor = controller::ComObserverConfig::Anchor::kPlates;
  const Scenario sc = scenario("wearer_nominal_sway");
  const ProtocolRun on = runProtocol(sc, cfg);
  print("nominal_sway, CoM observer", sc.wearer, on);
  const ProtocolRun without = runProtocol(sc, off);
  print("nominal_sway, no CoM observer", sc.wearer, without);
  const ProtocolRun no_turning = runProtocol(sc, rigid);
  print("nominal_sway, CoM observer without the upper body's turning", sc.wearer, no_turning);
  const ProtocolRun measured = runProtocol(sc, plates);
  print("nominal_sway, CoM observer with the plates' anchor", sc.wearer, measured);
  for (const ProtocolRun* r : {&on, &without, &no_turning, &measured}) {
    EXPECT_FALSE(r->fell);
    EXPECT_EQ(r->moves_done, 8);
    EXPECT_LE(r->max_slip, 1e-3);
  }
  EXPECT_LT(on.com_belief_rms, 0.5 * without.com_belief_rms);
  EXPECT_LT(on.rmse_xy, 0.85 * without.rmse_xy);
  EXPECT_LT(on.com_belief_rms, 0.92 * no_turning.com_belief_rms);
  // The model's anchor keeps the table person's bias (the estimate's job: 1.48 mm here); the plates' anchor measures
  // it once its weight is in (3-6 s after the latch: over these 25 s of moves the mean keeps ~a fifth of the bias,
  // 0.33 mm), and the true CoM follows the reference closer (1.07 against 1.78 mm; the RMS about the mean is not
  // compared: the bias going at the ramp is part of it).
  EXPECT_GT(on.com_belief_mean.norm(), 1e-3);
  EXPECT_LT(measured.com_belief_mean.norm(), 0.3 * on.com_belief_mean.norm());
  EXPECT_LT(measured.rmse_xy, 0.7 * on.rmse_xy);
}

// Issue 21 part 2: wearers nobody chose complete the protocol: no fall, no slip beyond 1 mm, every move done.
// Drawn from a fixed seed: mass 50-110 kg, height 1.50-1.95 m, either sex, +-15 % per segment, the trunk's
// stiffness and damping scaled from the shipped 75 kg, 1.78 m wearer's as the shipped scenarios are (with m H and
// m H^1.5), active sway 0-8 N m RMS in half the draws, reflex bursts (0.2 per s, 20 N m) in half.
TEST(SimWearer, RandomWearersCompleteTheProtocolWithoutAFallOrSlip) {
  controller::ControllerConfig cfg;
  std::string err;
  ASSERT_TRUE(controller::testing::loadConfig(cfg, &err)) << err;
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 3; ++i) {
    Scenario sc = scenario("wearer_nominal_passive");
    WearerConfig& w = sc.wearer;
    w.spec.mass_kg = 50.0 + 60.0 * u(rng);
    w.spec.height_m = 1.50 + 0.45 * u(rng);
    w.spec.sex = u(rng) < 0.5 ? Sex::Male : Sex::Female;
    w.spec.seed = 100 + static_cast<uint64_t>(i);
    w.spec.variation = 0.15;
    const double size = w.spec.mass_kg / 75.0 * w.spec.height_m / 1.78;
    w.trunk.stiffness = Eigen::Vector3d(850.0, 350.0, 280.0) * size;
    w.trunk.damping = Eigen::Vector3d(35.0, 20.0, 15.0) * size * std::sqrt(w.spec.height_m / 1.78);
    w.trunk.sway_rms = u(rng) < 0.5 ? 8.0 * u(rng) : 0.0;
    if (u(rng) < 0.5) w.reflex = WearerReflex{0.2, 20.0, 0.3};
    const ProtocolRun r = runProtocol(sc, cfg);
    print(("random wearer " + std::to_string(i)).c_str(), w, r);
    EXPECT_FALSE(r.fell) << i;
    EXPECT_TRUE(r.done) << i;
    EXPECT_EQ(r.moves_done, 20) << i;
    EXPECT_LE(r.max_slip, 1e-3) << i;
  }
}

}  // namespace
}  // namespace exoid::sim
