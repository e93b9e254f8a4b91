// Tests on the real robot (config/exo.xml + config/exo.urdf): plates under a standing robot, and the
// equations of motion of exoid's regressor against the simulator's contact wrenches and plate readings.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <dirent.h>

#include "exoid/controller/leg_swing.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "sim_test_util.hpp"

namespace exoid::sim::test {
namespace {

constexpr double kRobotMass = 41.05;  // kg, config/exo_true_parameters.csv (sum of the 11 links)
constexpr double kG = 9.81;

// Joint PD to q_ref from the simulator's current state (no transport delay: test only). Explicit damping on
// the light ankle link is unstable at 1 kHz once a foot unloads, so the ankle gains stay moderate except
// when standing still (stiff ankles damp the ~1.5 Hz sway mode within 1 s).
struct PdGains {
  double kp, kd, ankle_kp, ankle_kd;
};
constexpr PdGains kStandGains{1000.0, 150.0, 20000.0, 100.0};
constexpr PdGains kMoveGains{1000.0, 100.0, 2000.0, 50.0};
void pd(const SimModel& sm, const SimData& sd, const Eigen::VectorXd& q_ref, const PdGains& g,
        JointCommandSample& cmd) {
  for (int j = 0; j < sm.nj; ++j) {
    const bool ankle = sm.joint_names[j].find("ankle_pd") != std::string::npos;
    const double kp = ankle ? g.ankle_kp : g.kp, kd = ankle ? g.ankle_kd : g.kd;
    cmd.tau[j] = -kp * (sd.d->qpos[sm.qpos_adr[j]] - q_ref[j]) - kd * sd.d->qvel[sm.dof_adr[j]];
  }
}

class SimExo : public MujocoWarningsFail {
 protected:
  void SetUp() override {
    MujocoWarningsFail::SetUp();
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(configPath("exo.urdf"), true, model, &err)) << err;
  }
  void load(const Scenario& sc) {
    std::string err;
    ASSERT_TRUE(simLoad(configPath("exo.xml"), noiseOff(realisticSensors()), sc, sm, &err)) << err;
    ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
    ASSERT_EQ(sm.joint_names, model.joint_names);  // samples are in the Model's joint order
  }
  Model model;
  SimModel sm;
  SimData sd;
};

TEST_F(SimExo, MjcfAndUrdfDescribeTheSameRobot) {
  load(makeScenario(NoiseMode::Off));
  EXPECT_NEAR(model.totalMass(), kRobotMass, 1e-9);
  EXPECT_NEAR(sm.m->body_subtreemass[mj_name2id(sm.m, mjOBJ_BODY, "body")], kRobotMass, 1e-9);
  int sensed = 0;
  for (int j = 0; j < sm.nj; ++j) {
    const bool ie = sm.joint_names[j].find("ankle_ie") != std::string::npos;
    EXPECT_EQ(sd.state.has_tau[j], !ie) << sm.joint_names[j];  // in/eversion joints are passive
    sensed += sd.state.has_tau[j];
  }
  EXPECT_EQ(sensed, 8);
}

// (b) Standing still on the plates with a PD holding q = 0: once the sway has settled, the plates carry
// exactly the robot's weight (force ON the plates points down), and each CoP lies under its sole.
TEST_F(SimExo, PlatesCarryTheRobotWeightWhenStandingStill) {
  load(makeScenario(NoiseMode::Off));
  JointCommandSample cmd = simZeroCommand(sm);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sm.nj);
  const double W = kRobotMass * kG;
  double worst = 0.0;
  for (int k = 0; k < 2500; ++k) {
    cmd.tick = k;
    pd(sm, sd, zero, kStandGains, cmd);
    simStep(sm, sd, cmd);
    if (k < 1500) continue;  // the sway mode (about 1.5 Hz) decays below 1e-6 within ~1 s
    const double fz = sd.plates[0].force.z() + sd.plates[1].force.z();
    worst = std::max(worst, std::abs(fz + W) / W);
    for (int i = 0; i < kNumFeet; ++i) {
      const ForcePlateSample& p = sd.plates[i];
      ASSERT_LT(p.force.z(), -0.2 * W) << "both feet carry load";
      // CoP in world, then in the sole box's frame: inside its footprint (sole x axis points down).
      const Eigen::Vector3d cop_w = p.plate_position + p.plate_orientation.toRotationMatrix() * p.cop;
      const int g = sm.foot_geom[i];
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Rg(sd.d->geom_xmat + 9 * g);
      const Eigen::Vector3d local = Rg.transpose() * (cop_w - Eigen::Vector3d(sd.d->geom_xpos + 3 * g));
      const double* size = sm.m->geom_size + 3 * g;
      EXPECT_LT(std::abs(local.y()), size[1]) << "tick " << k;
      EXPECT_LT(std::abs(local.z()), size[2]) << "tick " << k;
      EXPECT_NEAR(cop_w.z(), 0.0, 1e-12);  // on the plate top
    }
  }
  std::printf("[ plates ] max |sum Fz_on_plates + m g| / m g over the last 1 s: %.3e\n", worst);
  RecordProperty("plate_weight_relative_error", std::to_string(worst));
  EXPECT_LT(worst, 1e-6);
  EXPECT_FALSE(simFell(sm, sd));
  // Standing still: the noise-free accelerometer reads +g up (specific force) in the base frame.
  const Eigen::Matrix3d R = sd.truth.base_orientation.toRotationMatrix();
  EXPECT_LT((sd.state.imu_accel - R.transpose() * Eigen::Vector3d(0, 0, kG)).norm(), 1e-4);
}

// effects.foot_placement moves each plate by minus the sole's offset on it: the robot, its contacts and the wrenches
// they put on the plates stay where they were (to rounding: 5e-17 m, 7e-11 N after 1.5 s), and each plate
// reports its own moved origin, so the sole stands at +offset from it. Standing still under a PD, 1.5 s.
TEST_F(SimExo, AFootPlacementMovesThePlateNotTheRobot) {
  const Eigen::Vector2d d[2] = {Eigen::Vector2d(0.02, -0.01), Eigen::Vector2d(-0.015, 0.005)};
  SimModel sm0;
  SimData sd0;
  std::string err;
  ASSERT_TRUE(simLoad(configPath("exo.xml"), noiseOff(realisticSensors()), makeScenario(NoiseMode::Off), sm0, &err)) << err;
  ASSERT_TRUE(simMakeData(sm0, sd0, &err)) << err;
  Scenario moved = makeScenario(NoiseMode::Off);
  moved.effects.foot_placement = {d[0], d[1]};
  load(moved);
  JointCommandSample cmd = simZeroCommand(sm), cmd0 = simZeroCommand(sm0);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sm.nj);
  for (int k = 0; k < 1500; ++k) {
    cmd.tick = cmd0.tick = k;
    pd(sm, sd, zero, kStandGains, cmd);
    pd(sm0, sd0, zero, kStandGains, cmd0);
    simStep(sm, sd, cmd);
    simStep(sm0, sd0, cmd0);
  }
  EXPECT_LT((sd.truth.base_position - sd0.truth.base_position).norm(), 1e-12);
  for (int i = 0; i < kNumFeet; ++i) {
    const ForcePlateSample &p = sd.plates[i], &p0 = sd0.plates[i];
    const Eigen::Vector3d shift = p.plate_position - p0.plate_position;
    EXPECT_NEAR(shift.x(), -d[i].x(), 1e-15) << i;
    EXPECT_NEAR(shift.y(), -d[i].y(), 1e-15) << i;
    EXPECT_EQ(shift.z(), 0.0) << i;
    EXPECT_LT((p.force - p0.force).norm(), 1e-8) << i;  // of ~200 N
    // The same wrench about the world origin; about the moved origin its moment differs by (origin shift) x force.
    const Eigen::Matrix3d R = p.plate_orientation.toRotationMatrix();
    EXPECT_LT((R * p.moment + p.plate_position.cross(R * p.force) -
               (R * p0.moment + p0.plate_position.cross(R * p0.force))).norm(), 1e-9) << i;
    // The sole's centre (its geom) now stands at +d from the plate's reported origin.
    const Eigen::Vector3d sole(sd.d->geom_xpos + 3 * sm.foot_geom[i]);
    const Eigen::Vector3d sole0(sd0.d->geom_xpos + 3 * sm0.foot_geom[i]);
    EXPECT_LT((((sole - p.plate_position) - (sole0 - p0.plate_position)).head<2>() - d[i]).norm(), 1e-12) << i;
  }
}

// Residuals of K(q, v, a) phi = y, with y built from external wrenches on the feet (about the world
// origin, world coordinates) by the estimator's one implementation (thesis eq. 4). Returns max |K phi - y|
// and max |y|.
struct EomResidual {
  double err = 0.0, scale = 0.0;
};
EomResidual eomResidual(const Model& model, Data& kin, const GroundTruthSample& t,
                        const std::array<Eigen::Vector3d, 2>& F, const std::array<Eigen::Vector3d, 2>& N) {
  const State st = estimator::stateFromTruth(model, t);
  computeJointTorqueRegressor(model, kin, st);  // also forward kinematics: kin.p, kin.axis in base coords
  ExternalWrench w[2];
  const int foot_body[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  for (int i = 0; i < 2; ++i) w[i].body = foot_body[i], w[i].force = F[i], w[i].moment_world_origin = N[i];
  Eigen::VectorXd y(model.nv);
  generalizedForceFromMeasurements(model, kin, st, t.tau_applied, w, 2, y);
  return {(kin.K * model.phi - y).cwiseAbs().maxCoeff(), y.cwiseAbs().maxCoeff()};
}

struct EomRun {
  double truth = 0.0, plates = 0.0;  // max over ticks of max|K phi - y| / max|y|
  double min_load = 1e300;           // smallest vertical load on one foot (N)
};

// A squat: bends smoothly to a = 0.1 rad over 1 s (hip and ankle flexion a, knee 2a: trunk stays upright),
// then oscillates a by +-0.05 rad at 2 Hz (joint speeds up to ~1 rad/s).
// The CoM the truth should report at its own state, from exoid's kinematics of the URDF (world): the model's, and with
// a rigid payload at payload.com on `body` (body < 0: none), the two combined. An independent computation of
// GroundTruthSample::com.
struct ExpectedCom {
  Eigen::Vector3d model, with_payload;
};
ExpectedCom expectedCom(const Model& model, const GroundTruthSample& truth, int body = -1, const Payload& payload = {}) {
  State s = State::zero(model);
  s.base_position = truth.base_position;
  s.base_orientation = truth.base_orientation;
  s.q = truth.q;
  DynamicsData dyn(model);
  forwardKinematics(model, dyn.kin, s);
  centroidal(model, dyn);
  const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
  ExpectedCom c;
  c.model = c.with_payload = s.base_position + R * dyn.com;
  if (body >= 0) {
    const Eigen::Vector3d c_payload = s.base_position + R * (dyn.kin.p[body] + dyn.kin.R[body] * payload.com);
    c.with_payload = (dyn.mass * c.model + payload.mass * c_payload) / (dyn.mass + payload.mass);
  }
  return c;
}

EomRun runEom(const Model& model, const SimModel& sm, SimData& sd, int ticks) {
  Data kin(model);
  JointCommandSample cmd = simZeroCommand(sm);
  Eigen::VectorXd q_ref = Eigen::VectorXd::Zero(sm.nj);
  EomRun r;
  for (int k = 0; k < ticks; ++k) {
    const double s = std::min(1.0, k / 1000.0);
    const double a = 0.1 * s * s * (3.0 - 2.0 * s) + (k < 1000 ? 0.0 : 0.05 * std::sin(4.0 * M_PI * (k - 1000) * 1e-3));
    for (int j = 0; j < sm.nj; ++j) {
      const std::string& n = sm.joint_names[j];
      q_ref[j] = n.find("hip_fe") != std::string::npos || n.find("ankle_pd") != std::string::npos ? a
                 : n.find("knee") != std::string::npos                                             ? 2.0 * a
                                                                                                   : 0.0;
    }
    cmd.tick = k;
    pd(sm, sd, q_ref, kMoveGains, cmd);
    simStep(sm, sd, cmd);
    if (k < 10) continue;  // first contact transient (y ~ 0 while the robot settles onto the plates)
    const GroundTruthSample& tr = sd.truth;
    const EomResidual rt = eomResidual(model, kin, tr, tr.foot_force, tr.foot_moment);
    // Plate measurement -> wrench on the foot (negated, moved to the world origin).
    std::array<Eigen::Vector3d, 2> F, N;
    for (int i = 0; i < 2; ++i) estimator::footWrenchFromPlate(sd.plates[i], F[i], N[i]);
    const EomResidual rp = eomResidual(model, kin, tr, F, N);
    r.truth = std::max(r.truth, rt.err / rt.scale);
    r.plates = std::max(r.plates, rp.err / rp.scale);
    r.min_load = std::min({r.min_load, tr.foot_force[0].z(), tr.foot_force[1].z()});
  }
  return r;
}

// (c) In-process EoM consistency: noise off, no effect -> the sim is exactly the URDF's rigid-body model.
TEST_F(SimExo, RegressorEquationsOfMotionHoldOnTruthAndPlates) {
  load(makeScenario(NoiseMode::Off));
  const EomRun r = runEom(model, sm, sd, 2500);
  std::printf("[ eom ] max rel residual: truth contacts %.3e, plates %.3e (min load on a foot %.1f N)\n", r.truth,
              r.plates, r.min_load);
  RecordProperty("eom_residual_truth", std::to_string(r.truth));
  RecordProperty("eom_residual_plates", std::to_string(r.plates));
  EXPECT_LE(r.truth, 1e-8);
  EXPECT_LE(r.plates, 1e-8);
  EXPECT_GT(r.min_load, 0.25 * kRobotMass * kG);  // both feet stayed loaded while squatting
  EXPECT_FALSE(simFell(sm, sd));
}

// The harness (calibration runs): the heavy, held pelvis stays put, the feet stay off the plates, the passive ankles
// stay pinned, and the legs obey the fixed-base equations of motion: the URDF's joint rows with the base at rest
// (K phi on the exact q, v, qacc) equal the applied torques of every actuated joint, here over 8 s of the
// calibration swing (the sines fade in at 3-6 s; torques up to 23 N m).
TEST_F(SimExo, HarnessHoldsThePelvisSoTheLegsSeeAFixedBase) {
  Scenario sc = makeScenario(NoiseMode::Off);
  sc.harness.enabled = true;
  load(sc);
  Eigen::VectorXd q0(sm.nj);
  for (int j = 0; j < sm.nj; ++j) q0[j] = sd.d->qpos[sm.qpos_adr[j]];
  controller::LegSwingTrajectory traj;
  std::string err;
  ASSERT_TRUE(controller::makeLegSwingTrajectory(model, q0, controller::LegSwingOptions(), traj, &err)) << err;
  controller::LegSwingData swing(model);
  JointCommandSample cmd = simZeroCommand(sm);
  Data kin(model);
  State st = State::zero(model);
  const Eigen::Vector3d p0(sd.d->qpos + sm.base_qpos);
  double worst = 0.0, largest = 0.0, drift = 0.0, plate = 0.0, pinned = 0.0;
  Eigen::VectorXd q = q0, v = Eigen::VectorXd::Zero(sm.nj);
  for (int k = 0; k < 8000; ++k) {
    controller::legSwingTorque(model, traj, swing, k * 1e-3, q, v, cmd.tau);
    cmd.tick = k;
    simStep(sm, sd, cmd);
    const GroundTruthSample& tr = sd.truth;
    q = tr.q, v = tr.v;
    st.q = tr.q, st.v = tr.v, st.a = tr.a;
    st.base_orientation = tr.base_orientation;  // at rest: omega, domega, acceleration 0
    computeJointTorqueRegressor(model, kin, st);
    for (int j = 0; j < sm.nj; ++j) {
      if (sm.actuator[j] < 0) {
        pinned = std::max(pinned, std::abs(tr.q[j]));
        continue;
      }
      const int r = model.jointRow(j);
      worst = std::max(worst, std::abs(kin.K.row(r).dot(model.phi) - tr.tau_applied[j]));
      largest = std::max(largest, std::abs(tr.tau_applied[j]));
    }
    drift = std::max(drift, (Eigen::Vector3d(sd.d->qpos + sm.base_qpos) - p0).norm());
    for (const ForcePlateSample& pl : sd.plates) plate = std::max(plate, pl.force.norm());
  }
  std::printf("[ harness ] fixed-base joint rows: max |K phi - tau| %.2e N m of |tau| up to %.1f N m; pelvis drift "
              "%.2e m; plates %.2e N; pinned ankles %.2e rad\n", worst, largest, drift, plate, pinned);
  EXPECT_GT(largest, 20.0);      // the legs really swing against gravity
  EXPECT_LT(worst, 2e-5 * largest);  // measured 2.1e-6 of the torques: the heavy base barely moves
  EXPECT_LT(drift, 1e-4);
  EXPECT_LT(plate, 1e-6);        // noise off: the feet never touch
  EXPECT_LT(pinned, 0.02);
  // The truth's CoM is the robot's (the URDF's at the exact state, exoid's kinematics), not the harness mass's.
  const Eigen::Vector3d c_model = expectedCom(model, sd.truth).model;
  EXPECT_LE((sd.truth.com - c_model).norm(), 1e-6) << sd.truth.com.transpose() << " vs " << c_model.transpose();
}

// ...and every undeclared effect breaks it (the residual is what an estimator would have to explain).
TEST_F(SimExo, UndeclaredEffectsBreakTheEquationsOfMotion) {
  struct Case {
    const char* name;
    void (*edit)(Effects&);
  };
  const Case cases[] = {
      {"joint_damping", [](Effects& e) { e.joint_damping = {{"all", 1.0}}; }},
      {"joint_frictionloss", [](Effects& e) { e.joint_frictionloss = {{"all", 1.5}}; }},
      {"armature", [](Effects& e) { e.armature = {{"all", 0.05}}; }},
      {"payload", [](Effects& e) {
         Payload p;
         p.link = "body";
         p.mass = 3.0;
         p.com = Eigen::Vector3d(-0.12, 0.0, 0.35);
         e.payloads = {p};
       }},
  };
  for (const Case& c : cases) {
    Scenario sc = makeScenario(NoiseMode::Off);
    c.edit(sc.effects);
    SimModel m;
    SimData d;
    std::string err;
    ASSERT_TRUE(simLoad(configPath("exo.xml"), SensorConfig(), sc, m, &err)) << err;
    ASSERT_TRUE(simMakeData(m, d, &err)) << err;
    const EomRun r = runEom(model, m, d, 2500);
    std::printf("[ eom ] undeclared %-18s residual: truth %.3e, plates %.3e\n", c.name, r.truth, r.plates);
    EXPECT_GT(r.truth, 1e-3) << c.name;
    EXPECT_GT(r.plates, 1e-3) << c.name;
  }
}

// The truth's CoM is the simulated robot's, payloads included: the URDF model's CoM at the exact state plus the
// payload at its place on the link (an independent computation with exoid's kinematics).
TEST_F(SimExo, TruthCoMIncludesUndeclaredPayloads) {
  Scenario sc = makeScenario(NoiseMode::Off);
  Payload p;
  p.link = "right_thigh";
  p.mass = 3.0;
  p.com = Eigen::Vector3d(0.10, 0.05, -0.08);
  p.inertia << 0.005, 0.005, 0.005, 0.0, 0.0, 0.0;
  sc.effects.payloads = {p};
  sc.initial.joints = {{"right_hip_fe", 0.3}, {"right_knee", 0.5}, {"left_hip_aa", -0.1}};
  load(sc);
  JointCommandSample cmd = simZeroCommand(sm);
  for (int k = 0; k < 50; ++k) simStep(sm, sd, cmd);  // moving: the truth's CoM must belong to its own tick
  const int b = model.bodyIndex("right_thigh");
  ASSERT_GE(b, 0);
  const ExpectedCom c = expectedCom(model, sd.truth, b, p);
  EXPECT_LE((sd.truth.com - c.with_payload).norm(), 1e-9) << sd.truth.com.transpose() << " vs " << c.with_payload.transpose();
  EXPECT_GT((sd.truth.com - c.model).norm(), 5e-3);  // the payload moved it
}

// A payload attached mid-run (effects.payload attach_at_s): before its tick the run is bit-identical to one
// without it; from its tick on the truth CoM is the URDF model's combined with the payload (computed here
// from the kinematics, not from MuJoCo's subtree CoM), the robot's mass grew by the payload's, the plates
// carry the new weight once the robot stands still again, and simReset takes it off.
TEST_F(SimExo, PayloadAttachedMidRunIsAbsentBeforeAndComposedAfter) {
  Payload p;
  p.link = "body";
  p.mass = 3.0;
  p.com = Eigen::Vector3d(-0.12, 0.0, 0.35);
  p.inertia << 0.045, 0.025, 0.025, 0.0, 0.0, 0.0;
  p.attach_at_s = 0.5;
  const int attach = 500, ticks = 2500;
  // Reference: the same run without the payload.
  load(makeScenario(NoiseMode::Off));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sm.nj);
  std::vector<Eigen::Vector3d> com_ref;
  std::vector<double> fz_ref;
  std::vector<Eigen::VectorXd> q_ref;
  JointCommandSample cmd = simZeroCommand(sm);
  for (int k = 0; k < attach + 1; ++k) {
    cmd.tick = k;
    pd(sm, sd, zero, kStandGains, cmd);
    simStep(sm, sd, cmd);
    com_ref.push_back(sd.truth.com);
    q_ref.push_back(sd.truth.q);
    fz_ref.push_back(sd.plates[0].force.z() + sd.plates[1].force.z());
  }
  const double mass0 = sm.m->body_subtreemass[sm.base_body];

  Scenario sc = makeScenario(NoiseMode::Off);
  sc.effects.payloads = {p};
  load(sc);
  ASSERT_EQ(sm.timed_payloads.size(), 1u);
  EXPECT_EQ(sm.timed_payloads[0].tick, attach);
  const int b = model.bodyIndex("body");
  ASSERT_GE(b, 0);
  double worst = 0.0;
  for (int round = 0; round < 2; ++round) {  // the second round after simReset: the payload comes off first
    simReset(sm, sd);
    EXPECT_EQ(sm.m->body_subtreemass[sm.base_body], mass0);
    cmd = simZeroCommand(sm);
    for (int k = 0; k < ticks; ++k) {
      cmd.tick = k;
      pd(sm, sd, zero, kStandGains, cmd);
      simStep(sm, sd, cmd);
      if (k < attach) {
        ASSERT_EQ(sd.truth.com, com_ref[static_cast<size_t>(k)]) << "tick " << k;
        ASSERT_EQ(sd.truth.q, q_ref[static_cast<size_t>(k)]) << "tick " << k;
        ASSERT_EQ(sd.plates[0].force.z() + sd.plates[1].force.z(), fz_ref[static_cast<size_t>(k)]) << "tick " << k;
        continue;
      }
      if (k == attach) {
        EXPECT_EQ(sd.stats.payloads_attached, 1);
        EXPECT_NEAR(sm.m->body_subtreemass[sm.base_body], mass0 + p.mass, 1e-12);
        EXPECT_EQ(sd.truth.q, q_ref[static_cast<size_t>(k)]);  // the positions of its tick are not yet affected
      }
      if (k == attach || k == ticks - 1) {
        const ExpectedCom c = expectedCom(model, sd.truth, b, p);
        EXPECT_LE((sd.truth.com - c.with_payload).norm(), 1e-9) << "tick " << k;
        EXPECT_GT((sd.truth.com - c.model).norm(), 0.02);  // 3 kg 0.37 m from the base: ~ 2.6 cm
      }
      if (k >= ticks - 500) {  // standing still again: the plates carry the new weight
        const double W = (kRobotMass + p.mass) * kG;
        worst = std::max(worst, std::abs(sd.plates[0].force.z() + sd.plates[1].force.z() + W) / W);
      }
    }
  }
  EXPECT_LT(worst, 1e-4);
}

// drive_torque_loop: sensor turns the torque-sensor errors into actuation errors: the drive applies
// (command - offset) / gain, which its sensor reads as the command; ideal applies the command.
TEST_F(SimExo, DriveTorqueLoopOnTheSensorAppliesTheSensorsError) {
  for (const bool on_sensor : {false, true}) {
    Scenario sc = makeScenario(NoiseMode::Off);
    sc.effects.torque_sensor = {{"all", 0.7, 1.08}, {"left_knee", -0.9, 0.93}};
    sc.effects.drive_loop_on_sensor = on_sensor;
    load(sc);
    JointCommandSample cmd = simZeroCommand(sm);
    for (int j = 0; j < sm.nj; ++j) cmd.tau[j] = 2.0 + 0.5 * j;
    simStep(sm, sd, cmd);
    for (int j = 0; j < sm.nj; ++j) {
      if (sm.actuator[static_cast<size_t>(j)] < 0) continue;
      const double gain = sm.torque_gain[static_cast<size_t>(j)], offset = sm.torque_offset[static_cast<size_t>(j)];
      const double applied = on_sensor ? (cmd.tau[j] - offset) / gain : cmd.tau[j];
      EXPECT_NEAR(sd.truth.tau_applied[j], applied, 1e-12) << sm.joint_names[j];
      EXPECT_NEAR(sd.state.tau[j], gain * applied + offset, 1e-9) << sm.joint_names[j];
    }
    EXPECT_DOUBLE_EQ(sm.torque_offset[static_cast<size_t>(model.jointIndex("left_knee"))], -0.9);
  }
}

// Every shipped scenario loads against the real model, and the realistic sensors file is complete.
TEST_F(SimExo, ShippedScenariosLoad) {
  const SensorConfig realistic = realisticSensors();
  EXPECT_DOUBLE_EQ(realistic.encoder_sigma, 9e-6);
  const std::string dir = configPath("scenarios");
  DIR* dp = opendir(dir.c_str());
  ASSERT_NE(dp, nullptr) << dir;
  std::vector<std::string> names;
  while (dirent* e = readdir(dp)) {
    const std::string f = e->d_name;
    if (f.size() > 5 && f.substr(f.size() - 5) == ".yaml") names.push_back(f);
  }
  closedir(dp);
  for (const char* required : {"nominal.yaml", "ideal.yaml", "undeclared_friction.yaml", "undeclared_armature.yaml",
                               "undeclared_payload.yaml", "torque_sensor_bias.yaml"})
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
  for (const std::string& f : names) {
    Scenario sc;
    SensorConfig noise;
    SimModel m;
    SimData d;
    std::string err;
    ASSERT_TRUE(loadScenario(dir + "/" + f, &sc, &err)) << err;
    ASSERT_TRUE(resolveSensorConfig(sc, realistic, &noise, &err)) << err;
    ASSERT_TRUE(simLoad(configPath("exo.xml"), noise, sc, m, &err)) << err;
    ASSERT_TRUE(simMakeData(m, d, &err)) << err;
    EXPECT_EQ(sc.name + ".yaml", f);
    if (f == "nominal.yaml" || f == "ideal.yaml") {
      EXPECT_FALSE(sc.effects.any()) << f;
    }
    if (f == "ideal.yaml") {
      EXPECT_EQ(noise.encoder_sigma, 0.0);
    }
    if (f == "nominal.yaml") {
      EXPECT_EQ(noise.encoder_sigma, 9e-6);
    }
  }
}

}  // namespace
}  // namespace exoid::sim::test
