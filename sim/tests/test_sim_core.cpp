// Pipeline tests on a tiny inline biped: conventions (finite differences), IMU, command handling,
// allocation-free stepping, determinism, model-contract errors, and the command arbiter.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <new>

#include "exoid/sim/command.hpp"
#include "sim_test_util.hpp"
#include "support/alloc_counter.hpp"

namespace exoid::sim::test {
namespace {

constexpr double kDt = 0.001;

class SimCore : public MujocoWarningsFail {
 protected:
  // Loads the tiny biped with `scenario` and `noise` into sm/sd.
  void load(const Scenario& scenario, const SensorConfig& noise) {
    std::string err;
    ASSERT_TRUE(simLoad(tinyBipedPath(), noise, scenario, sm, &err)) << err;
    ASSERT_TRUE(simMakeData(sm, sd, &err)) << err;
  }
  SimModel sm;
  SimData sd;
};

TEST_F(SimCore, LoadsTheContractOfTheTinyBiped) {
  load(makeScenario(NoiseMode::Off), SensorConfig());
  ASSERT_EQ(sm.nj, 4);
  EXPECT_EQ(sm.joint_names, (std::vector<std::string>{"right_hip", "right_ankle", "left_hip", "left_ankle"}));
  EXPECT_EQ(sm.actuator[3], -1);  // left ankle unactuated
  EXPECT_DOUBLE_EQ(sm.gear[0], 2.0);
  EXPECT_TRUE(sd.state.has_tau[0] && sd.state.has_tau[1] && sd.state.has_tau[2]);
  EXPECT_FALSE(sd.state.has_tau[3]);
  // Tare = the unloaded plate's support: its own weight, upward, at the sensor site (5 kg plates).
  for (int i = 0; i < kNumFeet; ++i) {
    EXPECT_NEAR(sm.plate_tare_force[i].z(), 5.0 * 9.81, 1e-9);
    EXPECT_NEAR(sm.plate_tare_force[i].head<2>().norm(), 0.0, 1e-12);
  }
}

// (a) GroundTruth base fields against finite differences of qpos/qvel over one step. MuJoCo's Euler is
// semi-implicit (v+ = v + h a; then q+ = q (+) h v+, the quaternion turned by h * v+ in the BODY frame),
// so the differences are exact up to rounding and pin down every frame convention.
TEST_F(SimCore, GroundTruthMatchesFiniteDifferencesOfQpos) {
  Scenario sc = makeScenario(NoiseMode::Off);
  sc.initial.base_height_offset = 2.0;  // in the air: no contact during the test
  load(sc, SensorConfig());
  mjData* d = sd.d;
  // A tilted, spinning, flying base with moving joints.
  const Eigen::Quaterniond q0 = Eigen::Quaterniond(0.8, 0.3, -0.4, 0.2).normalized();
  d->qpos[sm.base_qpos + 3] = q0.w();
  d->qpos[sm.base_qpos + 4] = q0.x();
  d->qpos[sm.base_qpos + 5] = q0.y();
  d->qpos[sm.base_qpos + 6] = q0.z();
  const double v0[10] = {0.4, -0.3, 0.5, 1.2, -0.7, 2.1, 0.8, -1.1, 0.6, 0.9};
  for (int i = 0; i < sm.m->nv; ++i) d->qvel[i] = v0[i];
  JointCommandSample cmd = simZeroCommand(sm);
  cmd.tau << 6.0, -4.0, 5.0, 0.0;

  simStep(sm, sd, cmd);
  const GroundTruthSample t0 = sd.truth;
  const RobotStateSample s0 = sd.state;
  cmd.tick = 1;
  simStep(sm, sd, cmd);
  const GroundTruthSample t1 = sd.truth;
  ASSERT_EQ(d->ncon, 0);

  const Eigen::Matrix3d R0 = t0.base_orientation.toRotationMatrix();
  const Eigen::Matrix3d R1 = t1.base_orientation.toRotationMatrix();
  // Orientation stored w,x,y,z from qpos (world <- base).
  EXPECT_LT((R0 - q0.toRotationMatrix()).norm(), 1e-12);
  // Linear velocity of the origin: base coordinates (R^T of the world-frame qvel).
  const Eigen::Vector3d dp = (t1.base_position - t0.base_position) / kDt;
  EXPECT_LT((R1 * t1.base_velocity - dp).norm(), 1e-9);
  EXPECT_GT((t1.base_velocity - dp).norm(), 0.1);  // the frames really differ in this test
  // Classical linear acceleration of the origin, base coordinates, gravity excluded (free fall: R^T g).
  const Eigen::Vector3d dv = (R1 * t1.base_velocity - R0 * t0.base_velocity) / kDt;
  EXPECT_LT((R0 * t0.base_acceleration - dv).norm(), 1e-8);
  // Angular velocity in BODY coordinates: q1 = q0 * exp(h omega1 / 2).
  const Eigen::AngleAxisd turn(t0.base_orientation.conjugate() * t1.base_orientation);
  EXPECT_LT((turn.angle() * turn.axis() / kDt - t1.base_omega).norm(), 1e-8);
  EXPECT_LT((t0.base_domega - (t1.base_omega - t0.base_omega) / kDt).norm(), 1e-8);
  EXPECT_GT(t0.base_domega.norm(), 0.1);
  // Joints.
  for (int j = 0; j < sm.nj; ++j) {
    EXPECT_NEAR((t1.q[j] - t0.q[j]) / kDt, t1.v[j], 1e-9) << j;
    EXPECT_NEAR((t1.v[j] - t0.v[j]) / kDt, t0.a[j], 1e-8) << j;
  }
  // Applied torque = gear * clamped ctrl; the unactuated joint gets none.
  EXPECT_NEAR(t0.tau_applied[0], 6.0, 1e-12);
  EXPECT_NEAR(t0.tau_applied[1], -4.0, 1e-12);
  EXPECT_NEAR(t0.tau_applied[2], 5.0, 1e-12);
  EXPECT_EQ(t0.tau_applied[3], 0.0);
  // Noise-free IMU at the base origin, aligned with the base: orientation, gyro = omega (both at x_0),
  // accelerometer = specific force R^T (a - g) with g = (0, 0, -9.81).
  EXPECT_LT(s0.imu_orientation.angularDistance(t0.base_orientation), 1e-12);
  EXPECT_LT((s0.imu_gyro - t0.base_omega).norm(), 1e-12);
  EXPECT_LT((s0.imu_accel - (t0.base_acceleration - R0.transpose() * Eigen::Vector3d(0, 0, -9.81))).norm(), 1e-9);
  // Encoders and torque sensors without noise.
  EXPECT_EQ(s0.q, t0.q);
  EXPECT_NEAR(s0.tau[0], 6.0, 1e-12);
  EXPECT_EQ(s0.tau[3], 0.0);
  // Stamps: tick k, utime = k * 1000.
  EXPECT_EQ(t0.tick, 0);
  EXPECT_EQ(t1.tick, 1);
  EXPECT_EQ(t1.utime, 1000);
  EXPECT_EQ(sd.plates[0].utime, 1000);
}

// The plate reading must equal the load the foot puts on it: minus MuJoCo's contact wrench on the foot.
TEST_F(SimCore, PlateWrenchIsMinusTheFootContactWrench) {
  load(makeScenario(NoiseMode::Off), SensorConfig());
  JointCommandSample cmd = simZeroCommand(sm);
  double max_fz = 0.0;
  for (int k = 0; k < 300; ++k) {
    cmd.tick = k;
    for (int j = 0; j < 3; ++j) cmd.tau[j] = -50.0 * sd.d->qpos[sm.qpos_adr[j]] - 2.0 * sd.d->qvel[sm.dof_adr[j]];
    simStep(sm, sd, cmd);
    for (int i = 0; i < kNumFeet; ++i) {
      const ForcePlateSample& p = sd.plates[i];
      const Eigen::Matrix3d Rp = p.plate_orientation.toRotationMatrix();
      const Eigen::Vector3d f_on_plate = Rp * p.force;
      const Eigen::Vector3d n_origin = Rp * p.moment + p.plate_position.cross(f_on_plate);  // about world origin
      const double scale = 1.0 + sd.truth.foot_force[i].norm();
      EXPECT_LT((f_on_plate + sd.truth.foot_force[i]).norm(), 1e-9 * scale) << "tick " << k;
      EXPECT_LT((n_origin + sd.truth.foot_moment[i]).norm(), 1e-9 * scale) << "tick " << k;
      max_fz = std::max(max_fz, sd.truth.foot_force[i].z());
    }
  }
  EXPECT_GT(max_fz, 10.0);  // the feet did load the plates
}

TEST_F(SimCore, CommandsAreValidatedClampedAndModesApplied) {
  load(makeScenario(NoiseMode::Off), SensorConfig());
  JointCommandSample cmd = simZeroCommand(sm);
  cmd.tau << 10.0, 1.0, -3.0, 99.0;  // unactuated entry ignored
  EXPECT_TRUE(simStep(sm, sd, cmd));
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[0], 10.0);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[3], 0.0);

  // Non-finite: refused, previous ctrl held, counted.
  JointCommandSample bad = cmd;
  bad.tau[1] = std::nan("");
  EXPECT_FALSE(simStep(sm, sd, bad));
  EXPECT_EQ(sd.stats.rejected_commands, 1);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[1], 1.0);
  // Wrong size: refused.
  JointCommandSample small;
  small.tau.setZero(2);
  EXPECT_FALSE(simStep(sm, sd, small));
  EXPECT_EQ(sd.stats.rejected_commands, 2);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[0], 10.0);

  // Clamped to ctrlrange (right hip: gear 2, ctrl +-20 -> +-40 N m; left hip +-40).
  cmd.tau << 100.0, -100.0, 100.0, 0.0;
  EXPECT_TRUE(simStep(sm, sd, cmd));
  EXPECT_EQ(sd.stats.clamped_commands, 1);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[0], 40.0);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[1], -30.0);
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[2], 40.0);

  // Hold: the previous ctrl again; Off: zero; Damping: -d v with the drive's gain.
  cmd.mode = CommandMode::HoldLastSafe;
  cmd.tau.setConstant(std::nan(""));  // ignored in this mode
  EXPECT_TRUE(simStep(sm, sd, cmd));
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied[0], 40.0);
  cmd.mode = CommandMode::Off;
  EXPECT_TRUE(simStep(sm, sd, cmd));
  EXPECT_DOUBLE_EQ(sd.truth.tau_applied.norm(), 0.0);
  cmd.mode = CommandMode::Damping;
  EXPECT_TRUE(simStep(sm, sd, cmd));
  for (int j = 0; j < 3; ++j)
    EXPECT_NEAR(sd.truth.tau_applied[j], -sm.options.damping_gain * sd.truth.v[j], 1e-12) << j;
}

// (e) simStep, the stages and the arbiter never allocate (noise on: the RNG path is exercised too).
TEST_F(SimCore, StepDoesNotAllocate) {
  load(makeScenario(NoiseMode::Realistic), realisticSensors());
  CommandArbiter arb;
  arbiterInit(arb, sm, 5);
  JointCommandSample cmd = simZeroCommand(sm);
  exoid::test::AllocationCounter counter;
  for (int k = 0; k < 1000; ++k) {
    cmd.tick = k;
    cmd.tau[0] = 0.5 * std::sin(0.01 * k);
    if (k % 3 != 0) arbiterOffer(arb, cmd);
    simStep(sm, sd, arbiterSelect(arb, k));
  }
  counter.stop();
  EXPECT_EQ(counter.news(), 0);
  EXPECT_EQ(counter.mallocs(), 0);
  EXPECT_GT(sd.d->ncon, 0);  // the contact path ran too
  // The counters work: operator new and Eigen's malloc are both seen.
  exoid::test::AllocationCounter probe_counter;
  auto* boxed = new double(1.0);
  Eigen::VectorXd probe(100);
  probe_counter.stop();
  delete boxed;
  EXPECT_GE(probe_counter.news(), 1);
  EXPECT_GE(probe_counter.mallocs(), 2);
  EXPECT_EQ(probe.size(), 100);
}

// (f) Same seed: bit-identical samples; another seed: different noise.
TEST_F(SimCore, SameSeedGivesBitIdenticalSamples) {
  const SensorConfig noise = realisticSensors();
  const std::string path = tinyBipedPath();
  auto run = [&](uint64_t seed, std::vector<double>* out) {
    SimModel m;
    SimData d;
    std::string err;
    ASSERT_TRUE(simLoad(path, noise, makeScenario(NoiseMode::Realistic, seed), m, &err)) << err;
    ASSERT_TRUE(simMakeData(m, d, &err)) << err;
    JointCommandSample cmd = simZeroCommand(m);
    for (int k = 0; k < 300; ++k) {
      cmd.tick = k;
      for (int j = 0; j < 3; ++j) cmd.tau[j] = -40.0 * d.state.q[j] - 1.0 * d.truth.v[j];
      simStep(m, d, cmd);
      auto put = [&](const double* p, Eigen::Index n) { out->insert(out->end(), p, p + n); };
      put(d.state.q.data(), d.state.q.size());
      put(d.state.tau.data(), d.state.tau.size());
      put(d.state.imu_orientation.coeffs().data(), 4);
      put(d.state.imu_gyro.data(), 3);
      put(d.state.imu_accel.data(), 3);
      for (const ForcePlateSample& p : d.plates) {
        put(p.force.data(), 3);
        put(p.moment.data(), 3);
        put(p.cop.data(), 3);
      }
      put(d.truth.base_position.data(), 3);
      put(d.truth.a.data(), d.truth.a.size());
    }
  };
  std::vector<double> a, b, c;
  run(7, &a);
  run(7, &b);
  run(8, &c);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
  EXPECT_NE(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)), 0);
}

// The noise actually applied has the configured sigma (encoders: 9e-6 rad) and zero mean.
TEST_F(SimCore, NoiseHasTheConfiguredSigma) {
  SensorConfig noise = realisticSensors();
  load(makeScenario(NoiseMode::Realistic, 3), noise);
  JointCommandSample cmd = simZeroCommand(sm);
  double sum = 0.0, sum2 = 0.0, gsum2 = 0.0, fsum2 = 0.0;
  long n = 0, ng = 0;
  for (int k = 0; k < 4000; ++k) {
    cmd.tick = k;
    simStep(sm, sd, cmd);
    for (int j = 0; j < sm.nj; ++j, ++n) {
      const double e = sd.state.q[j] - sd.truth.q[j];
      sum += e;
      sum2 += e * e;
    }
    const Eigen::Vector3d eg = sd.state.imu_gyro - sd.truth.base_omega;
    gsum2 += eg.squaredNorm();
    const ForcePlateSample& p = sd.plates[0];
    fsum2 += std::pow(p.force.z() - (-(p.plate_orientation.toRotationMatrix().transpose() *
                                         sd.truth.foot_force[0]).z()), 2);
    ng += 1;
  }
  const double sigma = std::sqrt(sum2 / n);
  EXPECT_NEAR(sigma, noise.encoder_sigma, 0.03 * noise.encoder_sigma);  // 16000 samples: ~0.6 % std error
  EXPECT_NEAR(sum / n, 0.0, 4.0 * noise.encoder_sigma / std::sqrt(double(n)));
  EXPECT_NEAR(std::sqrt(gsum2 / (3.0 * ng)), noise.gyro_sigma, 0.05 * noise.gyro_sigma);
  EXPECT_NEAR(std::sqrt(fsum2 / ng), noise.plate_force_sigma.z(), 0.05 * noise.plate_force_sigma.z());
}

TEST_F(SimCore, ScenarioInitialStateIsApplied) {
  Scenario sc = makeScenario(NoiseMode::Off);
  sc.initial.base_height_offset = 0.1;
  sc.initial.joints = {{"right_hip", 0.2}, {"left_ankle", -0.1}};
  load(sc, SensorConfig());
  JointCommandSample cmd = simZeroCommand(sm);
  simStep(sm, sd, cmd);
  EXPECT_NEAR(sd.truth.base_position.z(), 0.6, 1e-12);
  EXPECT_NEAR(sd.truth.q[0], 0.2, 1e-12);
  EXPECT_NEAR(sd.truth.q[3], -0.1, 1e-12);
  EXPECT_NEAR(sd.initial_base_height, 0.6, 1e-12);
  EXPECT_FALSE(simFell(sm, sd));
}

// (d) Model contract: a broken or incomplete MJCF gives one line naming the file and what is wrong.
TEST_F(SimCore, MalformedOrIncompleteMjcfIsRefusedWithAClearError) {
  struct Case {
    std::string name, from, to, expect;
  };
  const std::string base = kTinyBiped;
  const std::vector<Case> cases = {
      {"unclosed", "</mujoco>", "", "MuJoCo cannot load the model"},
      {"no_gyro", "<gyro site=\"imu\"/>", "", "missing <gyro> at site 'imu'"},
      {"no_sole", "name=\"left_sole\"", "name=\"left_shoe\"", "geom name=\"left_sole\""},
      {"timestep", "timestep=\"0.001\"", "timestep=\"0.002\"", "timestep"},
      {"no_plate_force", "<force site=\"right_plate_sensor\"/>", "", "right_plate_sensor"},
      {"slide", "<joint name=\"left_ankle\" type=\"hinge\"", "<joint name=\"left_ankle\" type=\"slide\"",
       "joint 'left_ankle'"},
      {"no_free", "<freejoint name=\"base\"/>", "", "<freejoint>"},
  };
  for (const Case& c : cases) {
    std::string xml = base;
    const size_t at = xml.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.name;
    xml.replace(at, c.from.size(), c.to);
    const std::string path = writeTemp("bad_" + c.name + ".xml", xml);
    SimModel m;
    std::string err;
    EXPECT_FALSE(simLoad(path, SensorConfig(), makeScenario(NoiseMode::Off), m, &err)) << c.name;
    EXPECT_NE(err.find(path), std::string::npos) << c.name << ": " << err;
    EXPECT_NE(err.find(c.expect), std::string::npos) << c.name << ": " << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << c.name << ": one line: " << err;
    EXPECT_EQ(m.m, nullptr);
  }
  SimOptions renamed;
  renamed.names.imu_site = "chest";
  {
    SimModel m;
    std::string err;
    EXPECT_FALSE(simLoad(tinyBipedPath(), SensorConfig(), makeScenario(NoiseMode::Off), m, &err, renamed));
    EXPECT_NE(err.find("<site name=\"chest\">: missing"), std::string::npos) << err;
  }
  SimModel m;
  std::string err;
  EXPECT_FALSE(simLoad("/nonexistent/robot.xml", SensorConfig(), makeScenario(NoiseMode::Off), m, &err));
  EXPECT_NE(err.find("/nonexistent/robot.xml"), std::string::npos) << err;
}

TEST_F(SimCore, ScenarioNamesUnknownToTheModelAreRefused) {
  struct Case {
    const char* name;
    void (*edit)(Scenario&);
    const char* expect;
  };
  const Case cases[] = {
      {"damping", [](Scenario& s) { s.effects.joint_damping = {{"right_knee", 1.0}}; },
       "effects.joint_damping.right_knee: unknown joint"},
      {"payload", [](Scenario& s) { s.effects.payloads = {Payload{"torso", 1.0, {}, {}}}; },
       "effects.payload.link: unknown robot link 'torso'"},
      {"payload_plate", [](Scenario& s) { s.effects.payloads = {Payload{"right_plate", 1.0, {}, {}}}; },
       "unknown robot link 'right_plate'"},
      {"sensorless", [](Scenario& s) { s.effects.torque_sensor = {{"left_ankle", 0.1, 1.0}}; },
       "effects.torque_sensor.left_ankle: joint has no torque sensor"},
      {"init", [](Scenario& s) { s.initial.joints = {{"knee", 0.1}}; }, "initial_state.joints.knee"},
  };
  for (const Case& c : cases) {
    Scenario sc = makeScenario(NoiseMode::Off);
    c.edit(sc);
    SimModel m;
    std::string err;
    EXPECT_FALSE(simLoad(tinyBipedPath(), SensorConfig(), sc, m, &err)) << c.name;
    EXPECT_NE(err.find("test-scenario: "), std::string::npos) << c.name << ": " << err;
    EXPECT_NE(err.find(c.expect), std::string::npos) << c.name << ": " << err;
  }
}

TEST_F(SimCore, EffectsReachTheMujocoModel) {
  Scenario sc = makeScenario(NoiseMode::Off);
  sc.effects.joint_damping = {{"all", 0.5}, {"left_hip", 2.0}};
  sc.effects.joint_frictionloss = {{"right_ankle", 0.7}};
  sc.effects.armature = {{"all", 0.01}};
  sc.effects.torque_sensor = {{"all", 0.2, 1.1}, {"right_ankle", -0.3, 0.9}};
  load(sc, SensorConfig());
  const double damping[4] = {0.5, 0.5, 2.0, 0.5};
  for (int j = 0; j < 4; ++j) {
    EXPECT_DOUBLE_EQ(sm.m->dof_damping[sm.dof_adr[j]], damping[j]) << j;
    EXPECT_DOUBLE_EQ(sm.m->dof_frictionloss[sm.dof_adr[j]], j == 1 ? 0.7 : 0.0) << j;
    EXPECT_DOUBLE_EQ(sm.m->dof_armature[sm.dof_adr[j]], 0.01) << j;
  }
  for (int i = 0; i < 6; ++i) EXPECT_EQ(sm.m->dof_damping[sm.base_dof + i], 0.0);  // base untouched
  // Torque sensors: measured = gain * applied + offset.
  JointCommandSample cmd = simZeroCommand(sm);
  cmd.tau << 10.0, 5.0, -8.0, 0.0;
  simStep(sm, sd, cmd);
  EXPECT_NEAR(sd.state.tau[0], 1.1 * 10.0 + 0.2, 1e-12);
  EXPECT_NEAR(sd.state.tau[1], 0.9 * 5.0 - 0.3, 1e-12);
  EXPECT_NEAR(sd.state.tau[2], 1.1 * -8.0 + 0.2, 1e-12);
  EXPECT_EQ(sd.state.tau[3], 0.0);
}

// A payload changes mass, com and inertia exactly as rigid-body composition says (inertia compared about
// the link origin, computed here from MuJoCo's stored principal form).
TEST_F(SimCore, PayloadIsComposedIntoTheLink) {
  Payload p;
  p.link = "body";
  p.mass = 3.0;
  p.com = Eigen::Vector3d(-0.1, 0.05, 0.3);
  p.inertia << 0.04, 0.03, 0.02, 0.001, -0.002, 0.003;
  auto originInertia = [](const mjModel* m, int b) {
    const Eigen::Quaterniond q(m->body_iquat[4 * b], m->body_iquat[4 * b + 1], m->body_iquat[4 * b + 2],
                               m->body_iquat[4 * b + 3]);
    const Eigen::Matrix3d R = q.toRotationMatrix();
    const Eigen::Vector3d c(m->body_ipos + 3 * b);
    return Eigen::Matrix3d(R * Eigen::Vector3d(m->body_inertia + 3 * b).asDiagonal() * R.transpose() +
                           m->body_mass[b] * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose()));
  };
  SimModel plain;
  std::string err;
  ASSERT_TRUE(simLoad(tinyBipedPath(), SensorConfig(), makeScenario(NoiseMode::Off), plain, &err)) << err;
  Scenario sc = makeScenario(NoiseMode::Off);
  sc.effects.payloads = {p};
  load(sc, SensorConfig());
  const int b = mj_name2id(sm.m, mjOBJ_BODY, "body");
  EXPECT_NEAR(sm.m->body_mass[b], 8.0, 1e-12);
  const Eigen::Vector3d c_expect = (5.0 * Eigen::Vector3d(0.01, 0.005, 0.1) + 3.0 * p.com) / 8.0;
  EXPECT_LT((Eigen::Vector3d(sm.m->body_ipos + 3 * b) - c_expect).norm(), 1e-12);
  Eigen::Matrix3d Ip;
  Ip << 0.04, 0.001, -0.002, 0.001, 0.03, 0.003, -0.002, 0.003, 0.02;
  const Eigen::Matrix3d expect = originInertia(plain.m, b) + Ip +
                                 p.mass * (p.com.squaredNorm() * Eigen::Matrix3d::Identity() - p.com * p.com.transpose());
  EXPECT_LT((originInertia(sm.m, b) - expect).norm(), 1e-12);
  EXPECT_NEAR(sm.m->body_subtreemass[b], 13.0, 1e-12);  // mj_setConst refreshed the derived fields
}

// Fallback policy: fresh commands pass; missing ones hold the last valid command for hold_ticks, then zero.
TEST_F(SimCore, ArbiterHoldsThenZeroes) {
  load(makeScenario(NoiseMode::Off), SensorConfig());
  CommandArbiter arb;
  arbiterInit(arb, sm, 3);
  EXPECT_EQ(&arbiterSelect(arb, 0), &arb.zero);  // tick 0: the initial command, not a fallback
  EXPECT_EQ(arb.fallbackTicks(), 0);
  EXPECT_EQ(&arbiterSelect(arb, 1), &arb.zero);  // nothing received yet: zero torque
  EXPECT_EQ(arb.zero_ticks, 1);
  JointCommandSample c = simZeroCommand(sm);
  c.tick = 2;
  c.tau.setConstant(1.5);
  arbiterOffer(arb, c);
  EXPECT_TRUE(arbiterHasFresh(arb, 2));
  EXPECT_FALSE(arbiterHasFresh(arb, 3));
  EXPECT_DOUBLE_EQ(arbiterSelect(arb, 2).tau[0], 1.5);
  EXPECT_EQ(arb.fresh_ticks, 1);
  for (int64_t k = 3; k <= 5; ++k) EXPECT_DOUBLE_EQ(arbiterSelect(arb, k).tau[0], 1.5) << k;  // held
  EXPECT_EQ(arb.held_ticks, 3);
  EXPECT_DOUBLE_EQ(arbiterSelect(arb, 6).tau[0], 0.0);  // then zero
  EXPECT_EQ(arb.zero_ticks, 2);
  c.tick = 7;
  arbiterOffer(arb, c);
  EXPECT_DOUBLE_EQ(arbiterSelect(arb, 7).tau[0], 1.5);  // recovers, stale run reset
  EXPECT_DOUBLE_EQ(arbiterSelect(arb, 8).tau[0], 1.5);
  EXPECT_EQ(arb.stale_run, 1);
  EXPECT_EQ(arb.fallbackTicks(), 6);
}

TEST_F(SimCore, GaussianIsStandardNormal) {
  load(makeScenario(NoiseMode::Off, 11), SensorConfig());
  double s = 0, s2 = 0, s4 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double x = simGaussian(sd);
    s += x;
    s2 += x * x;
    s4 += x * x * x * x;
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.01);
  EXPECT_NEAR(s4 / n, 3.0, 0.05);  // kurtosis of a normal
}

}  // namespace
}  // namespace exoid::sim::test
