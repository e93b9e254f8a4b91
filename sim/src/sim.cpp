// Simulator pipeline: load + checks + effects (startup, may allocate) and the per-tick stages (no allocation,
// no exceptions). See exoid/sim/sim.hpp and docs/sim.md.
#include "exoid/sim/sim.hpp"

#include "mjcf_check.hpp"
#include "wearer.hpp"
#include "exoid/common/fail.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

namespace exoid::sim {
namespace {

// MuJoCo 2.2's <force>/<torque> sensor reports cfrc_int of the site's body: the wrench its PARENT (here the
// world, through the plate's load cell) exerts ON the plate, in the site frame. With the plate tared, that
// support wrench is minus the load applied on the plate top, hence the sign. Checked by the sim tests
// (plate force vs MuJoCo's contact forces and vs the robot's weight).
constexpr double kPlateSensorSign = -1.0;

using common::fail;

int findSensor(const mjModel* m, int type, int objtype, int objid) {
  for (int i = 0; i < m->nsensor; ++i)
    if (m->sensor_type[i] == type && m->sensor_objtype[i] == objtype && m->sensor_objid[i] == objid) return i;
  return -1;
}

Eigen::Matrix3d quatToMat(const mjtNum* q) {
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
}

// body_mass/ipos/iquat/inertia of `body` with a rigid payload added (all in the body frame).
void addPayload(mjModel* m, int body, const Payload& p) {
  const double m0 = m->body_mass[body];
  const Eigen::Vector3d c0(m->body_ipos + 3 * body);
  const Eigen::Matrix3d R0 = quatToMat(m->body_iquat + 4 * body);
  const Eigen::Matrix3d I0 = R0 * Eigen::Vector3d(m->body_inertia + 3 * body).asDiagonal() * R0.transpose();
  Eigen::Matrix3d I1;
  I1 << p.inertia[0], p.inertia[3], p.inertia[4], p.inertia[3], p.inertia[1], p.inertia[5], p.inertia[4],
      p.inertia[5], p.inertia[2];
  const double M = m0 + p.mass;
  const Eigen::Vector3d c = (m0 * c0 + p.mass * p.com) / M;
  // Parallel-axis theorem: both inertias moved to the combined centre of mass.
  auto shift = [](double mass, const Eigen::Vector3d& d) {
    return Eigen::Matrix3d(mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
  };
  const Eigen::Matrix3d I = I0 + shift(m0, c0 - c) + I1 + shift(p.mass, p.com - c);
  // MuJoCo stores principal moments and the principal frame (a proper rotation).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I);
  Eigen::Matrix3d V = es.eigenvectors();
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  const Eigen::Quaterniond q(V);
  m->body_mass[body] = M;
  for (int i = 0; i < 3; ++i) {
    m->body_ipos[3 * body + i] = c[i];
    m->body_inertia[3 * body + i] = es.eigenvalues()[i];
  }
  m->body_iquat[4 * body + 0] = q.w();
  m->body_iquat[4 * body + 1] = q.x();
  m->body_iquat[4 * body + 2] = q.y();
  m->body_iquat[4 * body + 3] = q.z();
}

// Resolves a per-joint map ("all" first, then named joints) into `values` [nj].
bool resolveJointValues(const SimModel& sm, const std::vector<JointValue>& in, const std::string& key,
                        std::vector<double>* values, std::string* err) {
  for (const JointValue& jv : in)
    if (jv.joint == "all") std::fill(values->begin(), values->end(), jv.value);
  for (const JointValue& jv : in) {
    if (jv.joint == "all") continue;
    const auto it = std::find(sm.joint_names.begin(), sm.joint_names.end(), jv.joint);
    if (it == sm.joint_names.end())
      return fail(err, sm.scenario.source + ": " + key + "." + jv.joint + ": unknown joint '" + jv.joint + "'");
    (*values)[static_cast<size_t>(it - sm.joint_names.begin())] = jv.value;
  }
  return true;
}

double gaussian(SimData& sd) {
  if (sd.has_spare_normal) {
    sd.has_spare_normal = false;
    return sd.spare_normal;
  }
  // Box-Muller; u1 in (0, 1] so that log(u1) is finite. 53 random bits per uniform.
  constexpr double k = 1.0 / 9007199254740992.0;  // 2^-53
  const double u1 = (static_cast<double>(sd.rng() >> 11) + 1.0) * k;
  const double u2 = static_cast<double>(sd.rng() >> 11) * k;
  const double r = std::sqrt(-2.0 * std::log(u1));
  const double a = 2.0 * M_PI * u2;
  sd.spare_normal = r * std::sin(a);
  sd.has_spare_normal = true;
  return r * std::cos(a);
}

Eigen::Vector3d gaussian3(SimData& sd, const Eigen::Vector3d& sigma) {
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = sigma[i] > 0.0 ? sigma[i] * gaussian(sd) : 0.0;
  return v;
}

// ---- simLoad's stages: each checks what it reads and returns false with a one-line *err -----------------

// The MJCF parsed (its numbers checked first: MuJoCo 2.2 accepts "nan" and "inf"), at 1 ms a step.
bool loadMjcf(SimModel& sm, std::string* err) {
  const std::string& f = sm.mjcf_path;
  if (!checkMjcfNumbers(f, err)) return false;
  char mjerr[1000] = "";
  sm.m = mj_loadXML(f.c_str(), nullptr, mjerr, sizeof(mjerr));
  if (!sm.m) {
    std::string e(mjerr);
    std::replace(e.begin(), e.end(), '\n', ' ');  // MuJoCo's messages span lines; ours are one line
    return fail(err, f + ": MuJoCo cannot load the model: " + e);
  }
  // One control tick is one MuJoCo step of 1 ms (utime = tick * 1000).
  if (std::abs(sm.m->opt.timestep - 0.001) > 1e-12)
    return fail(err, f + ": <option timestep>: must be 0.001 (one 1 kHz control tick per step), found " +
                         std::to_string(sm.m->opt.timestep));
  return !sm.scenario.wearer.enabled || loadWearer(sm, err);  // recompiled with the wearer's bodies
}

// Joints: exactly one free joint (the base, on a child of the world), every other joint a hinge (named); the
// per-joint arrays sized [nj].
bool findJoints(SimModel& sm, std::string* err) {
  const mjModel* m = sm.m;
  const std::string& f = sm.mjcf_path;
  for (int j = 0; j < m->njnt; ++j) {
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    const std::string jn = name ? name : "#" + std::to_string(j);
    if (m->jnt_type[j] == mjJNT_FREE) {
      if (sm.base_body >= 0) return fail(err, f + ": joint '" + jn + "': more than one free joint");
      sm.base_body = m->jnt_bodyid[j];
      if (m->body_parentid[sm.base_body] != 0)
        return fail(err, f + ": joint '" + jn + "': the free joint must be on a child of <worldbody>");
      sm.base_qpos = m->jnt_qposadr[j];
      sm.base_dof = m->jnt_dofadr[j];
    } else if (m->jnt_type[j] == mjJNT_HINGE) {
      if (!name) return fail(err, f + ": hinge joint #" + std::to_string(j) + " has no name");
      if (sm.wearer.enabled && jn.rfind(kWearerPrefix, 0) == 0) continue;  // the wearer's lumbar: not an exo joint
      sm.joint_names.push_back(jn);
      sm.joint_id.push_back(j);
      sm.qpos_adr.push_back(m->jnt_qposadr[j]);
      sm.dof_adr.push_back(m->jnt_dofadr[j]);
    } else {
      return fail(err, f + ": joint '" + jn + "': only one free joint and hinge joints are supported");
    }
  }
  if (sm.base_body < 0) return fail(err, f + ": <freejoint>: missing (the robot needs a floating base)");
  sm.nj = static_cast<int>(sm.joint_names.size());
  const size_t nj = static_cast<size_t>(sm.nj);
  sm.actuator.assign(nj, -1);
  sm.gear.assign(nj, 0.0);
  sm.torque_sensor_adr.assign(nj, -1);
  sm.torque_gain.assign(nj, 1.0);
  sm.torque_offset.assign(nj, 0.0);
  return true;
}

// Actuators: direct-drive motors on hinge joints (torque = gear * ctrl), at most one per joint, each with
// its torque sensor when the MJCF has one (<actuatorfrc>).
bool findActuators(SimModel& sm, std::string* err) {
  const mjModel* m = sm.m;
  const std::string& f = sm.mjcf_path;
  for (int a = 0; a < m->nu; ++a) {
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, a);
    const std::string an = name ? name : "#" + std::to_string(a);
    if (m->actuator_trntype[a] != mjTRN_JOINT || m->actuator_dyntype[a] != mjDYN_NONE ||
        m->actuator_gaintype[a] != mjGAIN_FIXED || m->actuator_biastype[a] != mjBIAS_NONE ||
        m->actuator_gainprm[a * mjNGAIN] != 1.0)
      return fail(err, f + ": actuator '" + an + "': only <motor> on a joint is supported");
    const auto it = std::find(sm.joint_id.begin(), sm.joint_id.end(), m->actuator_trnid[2 * a]);
    if (it == sm.joint_id.end()) return fail(err, f + ": actuator '" + an + "': must drive a hinge joint");
    const size_t j = static_cast<size_t>(it - sm.joint_id.begin());
    if (sm.actuator[j] >= 0)
      return fail(err, f + ": actuator '" + an + "': joint '" + sm.joint_names[j] + "' already has a motor");
    sm.actuator[j] = a;
    sm.gear[j] = m->actuator_gear[6 * a];
    const int s = findSensor(m, mjSENS_ACTUATORFRC, mjOBJ_ACTUATOR, a);
    if (s >= 0) sm.torque_sensor_adr[j] = m->sensor_adr[s];
  }
  return true;
}

// IMU: orientation, gyro and accelerometer at one site.
bool findImu(SimModel& sm, std::string* err) {
  const mjModel* m = sm.m;
  const std::string& f = sm.mjcf_path;
  const std::string& site = sm.options.names.imu_site;
  sm.imu_site = mj_name2id(m, mjOBJ_SITE, site.c_str());
  if (sm.imu_site < 0) return fail(err, f + ": <site name=\"" + site + "\">: missing (IMU)");
  struct Need {
    int type;
    const char* what;
    int* adr;
  };
  for (const Need& n : {Need{mjSENS_FRAMEQUAT, "framequat", &sm.imu_quat_adr},
                        Need{mjSENS_GYRO, "gyro", &sm.imu_gyro_adr},
                        Need{mjSENS_ACCELEROMETER, "accelerometer", &sm.imu_accel_adr}}) {
    const int s = findSensor(m, n.type, mjOBJ_SITE, sm.imu_site);
    if (s < 0) return fail(err, f + ": <sensor>: missing <" + n.what + "> at site '" + site + "'");
    *n.adr = m->sensor_adr[s];
  }
  return true;
}

// Feet (sole geoms) and force plates: a site on a static plate body with <force> and <torque> sensors.
bool findFeetAndPlates(SimModel& sm, std::string* err) {
  const mjModel* m = sm.m;
  const std::string& f = sm.mjcf_path;
  for (int i = 0; i < kNumFeet; ++i) {
    const std::string& g = sm.options.names.foot_geom[static_cast<size_t>(i)];
    sm.foot_geom[i] = mj_name2id(m, mjOBJ_GEOM, g.c_str());
    if (sm.foot_geom[i] < 0) return fail(err, f + ": <geom name=\"" + g + "\">: missing (sole)");
    const std::string& ps = sm.options.names.plate_site[static_cast<size_t>(i)];
    sm.plate_site[i] = mj_name2id(m, mjOBJ_SITE, ps.c_str());
    if (sm.plate_site[i] < 0) return fail(err, f + ": <site name=\"" + ps + "\">: missing (force plate)");
    const int pb = m->site_bodyid[sm.plate_site[i]];
    if (pb == 0 || m->body_weldid[pb] != 0)
      return fail(err, f + ": site '" + ps + "': must be on a static plate body (welded to the world)");
    const int sf = findSensor(m, mjSENS_FORCE, mjOBJ_SITE, sm.plate_site[i]);
    const int st = findSensor(m, mjSENS_TORQUE, mjOBJ_SITE, sm.plate_site[i]);
    if (sf < 0 || st < 0) return fail(err, f + ": <sensor>: missing <force>/<torque> at site '" + ps + "'");
    sm.plate_force_adr[i] = m->sensor_adr[sf];
    sm.plate_torque_adr[i] = m->sensor_adr[st];
  }
  return true;
}

// effects.joint_damping / joint_frictionloss / armature: the MJCF's per-dof values overridden by joint.
bool applyDofEffects(SimModel& sm, const Effects& e, std::string* err) {
  mjModel* m = sm.m;
  const size_t nj = static_cast<size_t>(sm.nj);
  std::vector<double> v(nj, 0.0);
  struct DofEffect {
    const std::vector<JointValue>* values;
    const char* key;
    mjtNum* field;
  };
  for (const DofEffect& de : {DofEffect{&e.joint_damping, "effects.joint_damping", m->dof_damping},
                              DofEffect{&e.joint_frictionloss, "effects.joint_frictionloss", m->dof_frictionloss},
                              DofEffect{&e.armature, "effects.armature", m->dof_armature}}) {
    if (de.values->empty()) continue;
    for (size_t j = 0; j < nj; ++j) v[j] = de.field[sm.dof_adr[j]];
    if (!resolveJointValues(sm, *de.values, de.key, &v, err)) return false;
    for (size_t j = 0; j < nj; ++j) de.field[sm.dof_adr[j]] = v[j];
  }
  return true;
}

// effects.payload: rigid masses added to robot links now, or at attach_at_s (timed_payloads, applied by the loop).
bool applyPayloads(SimModel& sm, const Effects& e, std::string* err) {
  mjModel* m = sm.m;
  const std::string& src = sm.scenario.source;
  for (size_t i = 0; i < e.payloads.size(); ++i) {
    const Payload& p = e.payloads[i];
    const std::string key = e.payloads.size() > 1 ? "effects.payload[" + std::to_string(i) + "]" : "effects.payload";
    const int b = mj_name2id(m, mjOBJ_BODY, p.link.c_str());
    if (b <= 0 || m->body_weldid[b] == 0)
      return fail(err, src + ": " + key + ".link: unknown robot link '" + p.link + "'");
    if (!(p.mass > 0.0)) return fail(err, src + ": " + key + ".mass: must be > 0");
    if (p.attach_at_s > 0.0)
      sm.timed_payloads.push_back({b, static_cast<int64_t>(std::llround(p.attach_at_s / m->opt.timestep)), p});
    else
      addPayload(m, b, p);
  }
  return true;
}

// effects.torque_sensor: offset and gain per sensed joint (offsets and gains share the "all first, then named
// joints" rule; a named joint must have a sensor).
bool applyTorqueSensorErrors(SimModel& sm, const Effects& e, std::string* err) {
  if (e.torque_sensor.empty()) return true;
  const size_t nj = static_cast<size_t>(sm.nj);
  std::vector<JointValue> off, gain;
  for (const TorqueSensorError& t : e.torque_sensor) {
    off.push_back({t.joint, t.offset});
    gain.push_back({t.joint, t.gain});
  }
  std::vector<double> o(nj, 0.0), g(nj, 1.0);
  if (!resolveJointValues(sm, off, "effects.torque_sensor", &o, err) ||
      !resolveJointValues(sm, gain, "effects.torque_sensor", &g, err))
    return false;
  for (const TorqueSensorError& t : e.torque_sensor) {
    if (t.joint == "all") continue;
    const size_t j = static_cast<size_t>(
        std::find(sm.joint_names.begin(), sm.joint_names.end(), t.joint) - sm.joint_names.begin());
    if (sm.torque_sensor_adr[j] < 0)
      return fail(err, sm.scenario.source + ": effects.torque_sensor." + t.joint + ": joint has no torque sensor");
  }
  for (size_t j = 0; j < nj; ++j) {
    if (sm.torque_sensor_adr[j] < 0) continue;  // "all" covers the sensed joints only
    sm.torque_offset[j] = o[j];
    sm.torque_gain[j] = g[j];
  }
  return true;
}

// The harness: a heavy, held pelvis (kHarnessMass; isotropic inertia keeps body_iquat valid), the passive
// joints pinned by a spring.
void applyHarness(SimModel& sm) {
  mjModel* m = sm.m;
  sm.harness_mass = kHarnessMass;
  m->body_mass[sm.base_body] += kHarnessMass;
  for (int i = 0; i < 3; ++i) m->body_inertia[3 * sm.base_body + i] += kHarnessMass;
  for (size_t j = 0; j < static_cast<size_t>(sm.nj); ++j)
    if (sm.actuator[j] < 0) {
      m->jnt_stiffness[sm.joint_id[j]] = kHarnessPinStiffness;
      m->dof_damping[sm.dof_adr[j]] += kHarnessPinDamping;
    }
}

// qpos_init: the MJCF's qpos0, the base raised by the scenario's offset (and the harness lift), named joints set.
bool setInitialConfiguration(SimModel& sm, const Scenario& scenario, std::string* err) {
  const mjModel* m = sm.m;
  sm.qpos_init.assign(m->qpos0, m->qpos0 + m->nq);
  sm.qpos_init[static_cast<size_t>(sm.base_qpos) + 2] +=
      scenario.initial.base_height_offset + (scenario.harness.enabled ? scenario.harness.lift : 0.0);
  for (const JointValue& jv : scenario.initial.joints) {
    const auto it = std::find(sm.joint_names.begin(), sm.joint_names.end(), jv.joint);
    if (it == sm.joint_names.end())
      return fail(err, sm.scenario.source + ": initial_state.joints." + jv.joint + ": unknown joint '" + jv.joint +
                           "'");
    sm.qpos_init[static_cast<size_t>(sm.qpos_adr[static_cast<size_t>(it - sm.joint_names.begin())])] = jv.value;
  }
  return true;
}

// effects.foot_placement: each plate moved by minus the sole's offset on it, so the robot and the world stay put and
// the sole stands at +offset from the plate's sensor origin, which the plate reports (site_xpos, stagePlates).
void applyFootPlacement(SimModel& sm, const Effects& e) {
  for (int i = 0; i < kNumFeet; ++i) {
    const int pb = sm.m->site_bodyid[sm.plate_site[i]];
    sm.m->body_pos[3 * pb + 0] -= e.foot_placement[static_cast<size_t>(i)].x();
    sm.m->body_pos[3 * pb + 1] -= e.foot_placement[static_cast<size_t>(i)].y();
  }
}

// Derived constants (subtree masses, invweight0...) after the effects, the body inertials before any timed
// payload, then the plate tare: the raw reading with nothing on the plates (contacts disabled), as a lab plate
// is zeroed before a trial.
bool setConstantsAndTare(SimModel& sm, std::string* err) {
  mjModel* m = sm.m;
  mjData* d = mj_makeData(m);
  if (!d) return fail(err, sm.mjcf_path + ": MuJoCo cannot allocate mjData");
  mj_setConst(m, d);
  if (!sm.timed_payloads.empty()) {
    const auto save = [](const mjtNum* a, int n) { return std::vector<double>(a, a + n); };
    sm.body_mass0 = save(m->body_mass, m->nbody);
    sm.body_ipos0 = save(m->body_ipos, 3 * m->nbody);
    sm.body_iquat0 = save(m->body_iquat, 4 * m->nbody);
    sm.body_inertia0 = save(m->body_inertia, 3 * m->nbody);
    sm.body_subtreemass0 = save(m->body_subtreemass, m->nbody);
  }
  std::copy(sm.qpos_init.begin(), sm.qpos_init.end(), d->qpos);
  const int flags = m->opt.disableflags;
  m->opt.disableflags |= mjDSBL_CONTACT;
  mj_forward(m, d);
  m->opt.disableflags = flags;
  for (int i = 0; i < kNumFeet; ++i) {
    sm.plate_tare_force[i] = Eigen::Vector3d(d->sensordata + sm.plate_force_adr[i]);
    sm.plate_tare_torque[i] = Eigen::Vector3d(d->sensordata + sm.plate_torque_adr[i]);
  }
  mj_deleteData(d);
  return true;
}

}  // namespace

bool simLoad(const std::string& mjcf_path, const SensorConfig& noise, const Scenario& scenario, SimModel& out,
             std::string* err, const SimOptions& options) {
  SimModel sm;
  sm.mjcf_path = mjcf_path;
  sm.options = options;
  sm.scenario = scenario;
  sm.noise = noise;
  if (!loadMjcf(sm, err) || !findJoints(sm, err) || !findWearerJoints(sm, err) || !findActuators(sm, err) ||
      !findImu(sm, err) || !findFeetAndPlates(sm, err))
    return false;
  // Scenario effects (MuJoCo model and sensor model only: the URDF does not see them).
  sm.scenario.source = scenario.source.empty() ? std::string("scenario") : scenario.source;
  if (!applyDofEffects(sm, scenario.effects, err) || !applyPayloads(sm, scenario.effects, err) ||
      !applyTorqueSensorErrors(sm, scenario.effects, err))
    return false;
  if (scenario.harness.enabled) applyHarness(sm);
  applyFootPlacement(sm, scenario.effects);
  if (!setInitialConfiguration(sm, scenario, err) || !setConstantsAndTare(sm, err)) return false;
  out = std::move(sm);
  return true;
}

bool simMakeData(const SimModel& sm, SimData& sd, std::string* err) {
  sd.d = mj_makeData(sm.m);
  if (!sd.d) return fail(err, sm.mjcf_path + ": MuJoCo cannot allocate mjData");
  const Eigen::Index nj = sm.nj;
  sd.state.q.setZero(nj);
  sd.state.tau.setZero(nj);
  sd.state.has_tau.resize(nj);
  for (int j = 0; j < sm.nj; ++j) sd.state.has_tau[j] = sm.torque_sensor_adr[static_cast<size_t>(j)] >= 0;
  sd.truth.q.setZero(nj);
  sd.truth.v.setZero(nj);
  sd.truth.a.setZero(nj);
  sd.truth.tau_applied.setZero(nj);
  for (int i = 0; i < kNumFeet; ++i) sd.plates[static_cast<size_t>(i)].plate = i;
  sd.ctrl_prev.assign(static_cast<size_t>(sm.m->nu), 0.0);
  simReset(sm, sd);
  return true;
}

void simReset(const SimModel& sm, SimData& sd) {
  if (!sm.timed_payloads.empty()) {  // back to the model before the timed payloads
    mjModel* mm = sm.m;
    std::copy(sm.body_mass0.begin(), sm.body_mass0.end(), mm->body_mass);
    std::copy(sm.body_ipos0.begin(), sm.body_ipos0.end(), mm->body_ipos);
    std::copy(sm.body_iquat0.begin(), sm.body_iquat0.end(), mm->body_iquat);
    std::copy(sm.body_inertia0.begin(), sm.body_inertia0.end(), mm->body_inertia);
    std::copy(sm.body_subtreemass0.begin(), sm.body_subtreemass0.end(), mm->body_subtreemass);
  }
  const mjModel* m = sm.m;
  mjData* d = sd.d;
  mj_resetData(m, d);
  std::copy(sm.qpos_init.begin(), sm.qpos_init.end(), d->qpos);
  mj_forward(m, d);
  sd.rng.seed(sm.scenario.seed);
  sd.has_spare_normal = false;
  sd.spare_normal = 0.0;
  sd.tick = 0;
  std::fill(sd.ctrl_prev.begin(), sd.ctrl_prev.end(), 0.0);
  for (int w = 0; w < mjNWARNING; ++w) sd.warnings_seen[static_cast<size_t>(w)] = d->warning[w].number;
  sd.initial_base_height = d->qpos[sm.base_qpos + 2];
  sd.stats = SimStats();
  resetWearerState(sm, sd);
}

JointCommandSample simZeroCommand(const SimModel& sm) {
  JointCommandSample c;
  c.mode = CommandMode::Torque;
  c.tau.setZero(sm.nj);
  c.tau_ff.setZero(sm.nj);
  return c;
}

double simGaussian(SimData& sd) { return gaussian(sd); }

bool simFell(const SimModel& sm, const SimData& sd) {
  return sd.d->qpos[sm.base_qpos + 2] < sd.initial_base_height - kFallDrop;
}

void stageRecordState(const SimModel& sm, SimData& sd) {
  const mjData* d = sd.d;
  GroundTruthSample& t = sd.truth;
  const mjtNum* q = d->qpos + sm.base_qpos;
  const mjtNum* v = d->qvel + sm.base_dof;
  t.base_position = Eigen::Vector3d(q[0], q[1], q[2]);
  t.base_orientation = Eigen::Quaterniond(q[3], q[4], q[5], q[6]).normalized();
  const Eigen::Matrix3d R = t.base_orientation.toRotationMatrix();  // world <- base
  t.base_velocity = R.transpose() * Eigen::Vector3d(v[0], v[1], v[2]);  // qvel[0:3] is in the world frame
  t.base_omega = Eigen::Vector3d(v[3], v[4], v[5]);                     // qvel[3:6] is in the body frame
  t.com = Eigen::Vector3d(d->subtree_com + 3 * sm.base_body);  // mj_step1's CoM stage, undeclared payloads included
  if (sm.harness_mass > 0.0) {  // the robot's CoM: without the harness's mass at the pelvis's CoM
    const double M = sm.m->body_subtreemass[sm.base_body];
    t.com = (M * t.com - sm.harness_mass * Eigen::Vector3d(d->xipos + 3 * sm.base_body)) / (M - sm.harness_mass);
  }
  for (int j = 0; j < sm.nj; ++j) {
    t.q[j] = d->qpos[sm.qpos_adr[static_cast<size_t>(j)]];
    t.v[j] = d->qvel[sm.dof_adr[static_cast<size_t>(j)]];
  }
  const WearerSim& w = sm.wearer;
  t.has_trunk = w.enabled;
  if (w.enabled) {  // the lumbar hinges are not exo joints: the trunk's own fields
    for (size_t i = 0; i < 3; ++i) {
      t.trunk_angle[static_cast<Eigen::Index>(i)] = d->qpos[w.lumbar_qpos[i]];
      t.trunk_rate[static_cast<Eigen::Index>(i)] = d->qvel[w.lumbar_dof[i]];
    }
    t.trunk_com = Eigen::Vector3d(d->xipos + 3 * w.upper_body_id);
  }
}

void stageHarness(const SimModel& sm, SimData& sd) {
  if (sm.harness_mass <= 0.0) return;
  const mjModel* m = sm.m;
  mjData* d = sd.d;
  const int b = sm.base_body;
  const Eigen::Vector3d force = -m->body_subtreemass[b] * Eigen::Vector3d(m->opt.gravity);
  const Eigen::Vector3d arm = Eigen::Vector3d(d->subtree_com + 3 * b) - Eigen::Vector3d(d->xipos + 3 * b);
  const Eigen::Vector3d torque = arm.cross(force);  // xfrc_applied acts at the body's CoM: move it to the system's
  for (int i = 0; i < 3; ++i) d->xfrc_applied[6 * b + i] = force[i], d->xfrc_applied[6 * b + 3 + i] = torque[i];
}

bool stageControl(const SimModel& sm, SimData& sd, const JointCommandSample& cmd) {
  const mjModel* m = sm.m;
  mjData* d = sd.d;
  bool ok = cmd.tau.size() == sm.nj;
  if (ok && cmd.mode == CommandMode::Torque)
    for (int j = 0; j < sm.nj; ++j) ok = ok && std::isfinite(cmd.tau[j]);
  if (!ok) {
    ++sd.stats.rejected_commands;
    std::copy(sd.ctrl_prev.begin(), sd.ctrl_prev.end(), d->ctrl);
    return false;
  }
  bool clamped = false;
  for (int j = 0; j < sm.nj; ++j) {
    const int a = sm.actuator[static_cast<size_t>(j)];
    if (a < 0) continue;  // unactuated joint: its entry is ignored
    double u = 0.0;
    switch (cmd.mode) {
      case CommandMode::Torque: {
        const size_t jj = static_cast<size_t>(j);
        // A drive closing its loop on its torque sensor applies what makes the sensor read the command.
        const double tau = sm.scenario.effects.drive_loop_on_sensor
                               ? (cmd.tau[j] - sm.torque_offset[jj]) / sm.torque_gain[jj]
                               : cmd.tau[j];
        u = tau / sm.gear[jj];
        break;
      }
      case CommandMode::HoldLastSafe: u = sd.ctrl_prev[static_cast<size_t>(a)]; break;
      case CommandMode::Damping:
        u = -sm.options.damping_gain * d->qvel[sm.dof_adr[static_cast<size_t>(j)]] / sm.gear[static_cast<size_t>(j)];
        break;
      case CommandMode::Off: u = 0.0; break;
    }
    if (m->actuator_ctrllimited[a]) {
      const double lo = m->actuator_ctrlrange[2 * a], hi = m->actuator_ctrlrange[2 * a + 1];
      if (u < lo || u > hi) {
        clamped = clamped || cmd.mode == CommandMode::Torque;
        u = std::min(hi, std::max(lo, u));
      }
    }
    d->ctrl[a] = u;
  }
  if (clamped) ++sd.stats.clamped_commands;
  std::copy(d->ctrl, d->ctrl + m->nu, sd.ctrl_prev.begin());
  return true;
}

void stageTruth(const SimModel& sm, SimData& sd) {
  const mjModel* m = sm.m;
  const mjData* d = sd.d;
  GroundTruthSample& t = sd.truth;
  const Eigen::Matrix3d R = t.base_orientation.toRotationMatrix();
  const mjtNum* a = d->qacc + sm.base_dof;
  // qacc[0:3] = d/dt of the world-frame origin velocity: the classical acceleration of the origin (gravity
  // is a force in MuJoCo, so it is already excluded). qacc[3:6] = d/dt of the body-frame omega.
  t.base_acceleration = R.transpose() * Eigen::Vector3d(a[0], a[1], a[2]);
  t.base_domega = Eigen::Vector3d(a[3], a[4], a[5]);
  for (int j = 0; j < sm.nj; ++j) {
    const int dof = sm.dof_adr[static_cast<size_t>(j)];
    t.a[j] = d->qacc[dof];
    t.tau_applied[j] = d->qfrc_actuator[dof];
  }
  // Contact wrench ON each foot from MuJoCo's contacts: the force in the contact frame acts on geom2 (the
  // normal points from geom1 to geom2), so it is negated when the foot is geom1.
  for (int i = 0; i < kNumFeet; ++i) {
    t.foot_force[static_cast<size_t>(i)].setZero();
    t.foot_moment[static_cast<size_t>(i)].setZero();
  }
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    if (con.efc_address < 0) continue;  // excluded contact: no force
    for (int i = 0; i < kNumFeet; ++i) {
      const int g = sm.foot_geom[static_cast<size_t>(i)];
      if (con.geom1 != g && con.geom2 != g) continue;
      mjtNum f6[6];
      mj_contactForce(m, d, c, f6);
      // frame rows are the contact axes in world coordinates: world = frame^T * local.
      const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> frame(con.frame);
      const double s = con.geom2 == g ? 1.0 : -1.0;
      const Eigen::Vector3d fw = s * (frame.transpose() * Eigen::Vector3d(f6[0], f6[1], f6[2]));
      const Eigen::Vector3d tw = s * (frame.transpose() * Eigen::Vector3d(f6[3], f6[4], f6[5]));
      t.foot_force[static_cast<size_t>(i)] += fw;
      t.foot_moment[static_cast<size_t>(i)] += Eigen::Vector3d(con.pos[0], con.pos[1], con.pos[2]).cross(fw) + tw;
    }
  }
}

void stageRobotSensors(const SimModel& sm, SimData& sd) {
  const mjData* d = sd.d;
  const SensorConfig& n = sm.noise;
  RobotStateSample& s = sd.state;
  for (int j = 0; j < sm.nj; ++j) s.q[j] = sd.truth.q[j] + (n.encoder_sigma > 0.0 ? n.encoder_sigma * gaussian(sd) : 0.0);
  for (int j = 0; j < sm.nj; ++j) {
    const size_t jj = static_cast<size_t>(j);
    const int adr = sm.torque_sensor_adr[jj];
    if (adr < 0) {
      s.tau[j] = 0.0;
      continue;
    }
    const double tau = d->sensordata[adr] * sm.gear[jj];  // actuator force -> joint torque
    s.tau[j] = sm.torque_gain[jj] * tau + sm.torque_offset[jj] +
               (n.torque_sigma > 0.0 ? n.torque_sigma * gaussian(sd) : 0.0);
  }
  const mjtNum* q = d->sensordata + sm.imu_quat_adr;
  const Eigen::Quaterniond q_true = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  // Orientation error: a small rotation about the world axes (roll, pitch, heading errors of an AHRS).
  const Eigen::Vector3d dtheta = gaussian3(sd, n.imu_orientation_sigma);
  const double angle = dtheta.norm();
  s.imu_orientation = angle > 0.0 ? (Eigen::Quaterniond(Eigen::AngleAxisd(angle, dtheta / angle)) * q_true).normalized()
                                  : q_true;
  s.imu_gyro = Eigen::Vector3d(d->sensordata + sm.imu_gyro_adr) + gaussian3(sd, Eigen::Vector3d::Constant(n.gyro_sigma));
  s.imu_accel =
      Eigen::Vector3d(d->sensordata + sm.imu_accel_adr) + gaussian3(sd, Eigen::Vector3d::Constant(n.accel_sigma));
}

void stagePlates(const SimModel& sm, SimData& sd) {
  const mjData* d = sd.d;
  const SensorConfig& n = sm.noise;
  for (int i = 0; i < kNumFeet; ++i) {
    const size_t ii = static_cast<size_t>(i);
    ForcePlateSample& p = sd.plates[ii];
    const Eigen::Vector3d f_raw(d->sensordata + sm.plate_force_adr[ii]);
    const Eigen::Vector3d t_raw(d->sensordata + sm.plate_torque_adr[ii]);
    p.force = kPlateSensorSign * (f_raw - sm.plate_tare_force[ii]) + gaussian3(sd, n.plate_force_sigma);
    p.moment = kPlateSensorSign * (t_raw - sm.plate_tare_torque[ii]) + gaussian3(sd, n.plate_moment_sigma);
    // CoP on the top surface (sensor origin is on it): moment of a point load at (x, y, 0) is
    // (y Fz, -x Fz, ...). Only meaningful under load: the normal load ON the plate is -Fz.
    if (-p.force.z() > n.cop_min_force) {
      p.cop = Eigen::Vector3d(-p.moment.y() / p.force.z(), p.moment.x() / p.force.z(), 0.0);
    } else {
      p.cop.setZero();
    }
    const int site = sm.plate_site[ii];
    p.plate_position = Eigen::Vector3d(d->site_xpos + 3 * site);
    mjtNum quat[4];
    mju_mat2Quat(quat, d->site_xmat + 9 * site);
    p.plate_orientation = Eigen::Quaterniond(quat[0], quat[1], quat[2], quat[3]);
  }
}

bool simStep(const SimModel& sm, SimData& sd, const JointCommandSample& command) {
  for (const SimModel::TimedPayload& tp : sm.timed_payloads) {
    if (tp.tick != sd.tick) continue;
    // Attached at the start of this tick: its state, truth CoM (mj_comPos divides by the subtree masses, a
    // derived constant updated here along the chain to the world) and plates include it. The constraint
    // solver's invweight0 (a regularisation scale) keeps its value. Fixed-size Eigen only: no allocation.
    mjModel* mm = sm.m;
    addPayload(mm, tp.body, tp.payload);
    for (int b = tp.body; b > 0; b = mm->body_parentid[b]) mm->body_subtreemass[b] += tp.payload.mass;
    mm->body_subtreemass[0] += tp.payload.mass;
    ++sd.stats.payloads_attached;
  }
  const mjModel* m = sm.m;
  mjData* d = sd.d;
  mj_step1(m, d);
  stageRecordState(sm, sd);
  stageHarness(sm, sd);
  stageWearer(sm, sd);
  const bool applied = stageControl(sm, sd, command);
  mj_step2(m, d);
  stageTruth(sm, sd);
  stageRobotSensors(sm, sd);
  stagePlates(sm, sd);

  const int64_t k = sd.tick;
  const int64_t utime = k * 1000;  // one tick = one 1 ms MuJoCo step
  sd.state.tick = sd.truth.tick = k;
  sd.state.utime = sd.truth.utime = utime;
  for (ForcePlateSample& p : sd.plates) {
    p.tick = k;
    p.utime = utime;
  }
  for (int w = 0; w < mjNWARNING; ++w) {
    sd.stats.mujoco_warnings += d->warning[w].number - sd.warnings_seen[static_cast<size_t>(w)];
    sd.warnings_seen[static_cast<size_t>(w)] = d->warning[w].number;
  }
  ++sd.stats.ticks;
  ++sd.tick;
  return applied;
}

}  // namespace exoid::sim
