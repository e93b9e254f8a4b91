// The wearer in the simulator (docs/wearer.md "In the simulation"): its segments welded to the exo links, its upper
// body on a compliant lumbar joint, and the per-tick passive moments, sway and reflex torques.
#include "wearer.hpp"
#include "exoid/common/fail.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

namespace exoid::sim {
namespace {

using common::fail;

tinyxml2::XMLElement* findBody(tinyxml2::XMLElement* e, const std::string& name) {
  for (tinyxml2::XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::string(c->Name()) == "body" && c->Attribute("name") && name == c->Attribute("name")) return c;
    if (tinyxml2::XMLElement* f = findBody(c, name)) return f;
  }
  return nullptr;
}

std::string numbers(std::initializer_list<double> v) {
  std::string s;
  char buf[40];
  for (double x : v) {
    std::snprintf(buf, sizeof buf, "%.17g", x);
    s += (s.empty() ? "" : " ") + std::string(buf);
  }
  return s;
}

// <inertial pos mass fullinertia> of a body whose frame sits at `origin` in the carrying link's frame.
void addInertial(tinyxml2::XMLElement* body, const MountedSegment& s, const Eigen::Vector3d& origin) {
  tinyxml2::XMLElement* in = body->InsertNewChildElement("inertial");
  const Eigen::Vector3d c = s.com - origin;
  const Eigen::Matrix3d& I = s.inertia_com;
  in->SetAttribute("pos", numbers({c.x(), c.y(), c.z()}).c_str());
  in->SetAttribute("mass", numbers({s.mass}).c_str());
  in->SetAttribute("fullinertia", numbers({I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)}).c_str());
}

// The exo's standing pose (qpos0) read from the compiled model: link poses and sole geom centres.
bool exoStandingFromMujoco(const SimModel& sm, ExoStanding& out, std::string* err) {
  const mjModel* m = sm.m;
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);
  if (!d) return fail(err, sm.mjcf_path + ": MuJoCo cannot allocate mjData");
  mj_kinematics(m, d.get());
  auto pose = [&](const std::string& name, LinkPose& p) {
    const int b = mj_name2id(m, mjOBJ_BODY, name.c_str());
    if (b < 0) return fail(err, sm.mjcf_path + ": <body name=\"" + name + "\">: missing (the wearer rides on it)");
    p.p = Eigen::Vector3d(d->xpos + 3 * b);
    p.R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->xmat + 9 * b);
    return true;
  };
  if (!pose(exoPelvisLink(), out.pelvis)) return false;
  for (int i = 0; i < 2; ++i) {
    const int side = i == 0 ? -1 : 1;
    const size_t k = static_cast<size_t>(i);
    if (!pose(exoLegLink("thigh", side), out.thigh[k]) || !pose(exoLegLink("shank", side), out.shank[k]) ||
        !pose(exoLegLink("ankle", side), out.ankle[k]) || !pose(exoLegLink("foot", side), out.foot[k]))
      return false;
    const std::string sole = exoLegLink("sole", side);  // the sole site: on the sole plane (the geom's centre is not)
    const int site = mj_name2id(m, mjOBJ_SITE, sole.c_str());
    if (site < 0)
      return fail(err, sm.mjcf_path + ": <site name=\"" + sole + "\">: missing (the wearer's foot rests on it)");
    out.sole[k] = Eigen::Vector3d(d->site_xpos + 3 * site);
  }
  return true;
}

// The MJCF text with the wearer: welded bodies on the legs and the pelvis, the upper body on three lumbar hinges.
bool wearerMjcf(const SimModel& sm, const WearerSim& w, std::string* xml, std::string* err) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(sm.mjcf_path.c_str()) != tinyxml2::XML_SUCCESS || !doc.RootElement())
    return fail(err, sm.mjcf_path + ": cannot re-read the MJCF to add the wearer");
  for (const MountedSegment& s : w.mount.segments) {
    if (s.above_lumbar) continue;
    tinyxml2::XMLElement* link = findBody(doc.RootElement(), s.link);
    if (!link) return fail(err, sm.mjcf_path + ": <body name=\"" + s.link + "\">: missing (the wearer rides on it)");
    tinyxml2::XMLElement* b = link->InsertNewChildElement("body");
    b->SetAttribute("name", (kWearerPrefix + s.segment).c_str());
    addInertial(b, s, Eigen::Vector3d::Zero());
  }
  tinyxml2::XMLElement* pelvis = findBody(doc.RootElement(), exoPelvisLink());
  const Eigen::Vector3d& o = w.mount.lumbar_pivot;
  tinyxml2::XMLElement* ub = pelvis->InsertNewChildElement("body");
  ub->SetAttribute("name", (std::string(kWearerPrefix) + "upper_body").c_str());
  ub->SetAttribute("pos", numbers({o.x(), o.y(), o.z()}).c_str());
  const WearerTrunk& t = sm.scenario.wearer.trunk;
  const char* axes[3] = {"1 0 0", "0 1 0", "0 0 1"};
  for (int i = 0; i < 3; ++i) {
    tinyxml2::XMLElement* j = ub->InsertNewChildElement("joint");
    j->SetAttribute("name", (std::string(kWearerPrefix) + "lumbar_" + "xyz"[i]).c_str());
    j->SetAttribute("type", "hinge");
    j->SetAttribute("axis", axes[i]);
    j->SetAttribute("pos", "0 0 0");
    j->SetAttribute("stiffness", numbers({t.stiffness[i]}).c_str());
    j->SetAttribute("damping", numbers({t.damping[i]}).c_str());
  }
  addInertial(ub, w.upper_body, o);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  *xml = printer.CStr();
  return true;
}

// Compiles MJCF text through MuJoCo's virtual file system (mjVFS is ~2 MB: on the heap).
mjModel* compileText(const std::string& xml, char* mjerr, int n) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const char* name = "exoid_wearer.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), name, static_cast<int>(xml.size())) != 0) return nullptr;
  const int f = mj_findFileVFS(vfs.get(), name);
  std::memcpy(vfs->filedata[f], xml.data(), xml.size());
  mjModel* m = mj_loadXML(name, vfs.get(), mjerr, n);
  mj_deleteVFS(vfs.get());
  return m;
}

double wearerGaussian(std::mt19937_64& rng) {
  constexpr double k = 1.0 / 9007199254740992.0;  // 2^-53
  const double u1 = (static_cast<double>(rng() >> 11) + 1.0) * k;
  const double u2 = static_cast<double>(rng() >> 11) * k;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

double wearerUniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0); }

}  // namespace

bool loadWearer(SimModel& sm, std::string* err) {
  WearerSim w;
  w.enabled = true;
  ExoStanding exo;
  std::string why;
  if (!buildWearer(sm.scenario.wearer.spec, w.wearer, &why)) return fail(err, sm.scenario.source + ": wearer: " + why);
  if (!exoStandingFromMujoco(sm, exo, err)) return false;
  w.mount = mountWearer(w.wearer, exo);
  w.upper_body = lumpAboveLumbar(w.mount);
  std::string xml;
  if (!wearerMjcf(sm, w, &xml, err)) return false;
  char mjerr[1000] = "";
  mjModel* m = compileText(xml, mjerr, sizeof(mjerr));
  if (!m) return fail(err, sm.mjcf_path + ": MuJoCo cannot compile the model with the wearer: " + mjerr);
  sm.m = m;
  sm.wearer = std::move(w);
  return true;
}

bool findWearerJoints(SimModel& sm, std::string* err) {
  WearerSim& w = sm.wearer;
  if (!w.enabled) return true;
  const mjModel* m = sm.m;
  auto joint = [&](const std::string& name, int& qpos, int& dof) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j < 0) return fail(err, sm.mjcf_path + ": joint '" + name + "': missing (the wearer's moments act on it)");
    qpos = m->jnt_qposadr[j];
    dof = m->jnt_dofadr[j];
    return true;
  };
  for (int i = 0; i < 3; ++i)
    if (!joint(std::string(kWearerPrefix) + "lumbar_" + "xyz"[i], w.lumbar_qpos[i], w.lumbar_dof[i])) return false;
  const std::string upper = std::string(kWearerPrefix) + "upper_body";
  w.upper_body_id = mj_name2id(m, mjOBJ_BODY, upper.c_str());
  if (w.upper_body_id < 0) return fail(err, sm.mjcf_path + ": body '" + upper + "': missing (the wearer's trunk)");
  const char* legs[3] = {"hip_fe", "knee", "ankle_pd"};
  for (int s = 0; s < 2; ++s)
    for (int i = 0; i < 3; ++i)
      if (!joint(std::string(s == 0 ? "right_" : "left_") + legs[i], w.leg_qpos[s][i], w.leg_dof[s][i])) return false;
  w.sway_decay = std::exp(-2.0 * M_PI * sm.scenario.wearer.trunk.sway_cutoff_hz * m->opt.timestep);
  return true;
}

void resetWearerState(const SimModel& sm, SimData& sd) {
  SimData::WearerState& st = sd.wearer;
  st = SimData::WearerState();
  if (!sm.wearer.enabled) return;
  // Its own stream, seeded from the wearer's seed (a fixed odd constant mixed in keeps it apart from the noise's).
  st.rng.seed(sm.scenario.wearer.spec.seed ^ 0x9E3779B97F4A7C15ull);
  const double rms = sm.scenario.wearer.trunk.sway_rms;
  for (int i = 0; i < 3; ++i) st.sway[i] = rms > 0.0 ? rms * wearerGaussian(st.rng) : 0.0;  // stationary start
}

void stageWearer(const SimModel& sm, SimData& sd) {
  const WearerSim& w = sm.wearer;
  if (!w.enabled) return;
  const WearerConfig& cfg = sm.scenario.wearer;
  SimData::WearerState& st = sd.wearer;
  mjData* d = sd.d;
  // Reflex bursts: Poisson onsets (probability rate h per tick), one at a time, a half sine on one leg joint.
  const double h = sm.m->opt.timestep;
  if (st.reflex_joint < 0 && cfg.reflex.rate_hz > 0.0 && wearerUniform(st.rng) < cfg.reflex.rate_hz * h) {
    st.reflex_joint = static_cast<int>(st.rng() % 6);
    st.reflex_sign = wearerUniform(st.rng) < 0.5 ? -1.0 : 1.0;
    st.reflex_start = sd.tick;
    st.reflex_ticks = std::max<int64_t>(1, std::llround(cfg.reflex.duration_s / h));
    ++st.reflexes;
  }
  for (auto& r : st.reflex) r.setZero();
  if (st.reflex_joint >= 0) {
    const int64_t t = sd.tick - st.reflex_start;
    if (t >= st.reflex_ticks) {
      st.reflex_joint = -1;
    } else {
      const double phase = M_PI * static_cast<double>(t) / static_cast<double>(st.reflex_ticks);
      st.reflex[static_cast<size_t>(st.reflex_joint / 3)][st.reflex_joint % 3] =
          st.reflex_sign * cfg.reflex.amplitude * std::sin(phase);
    }
  }
  for (size_t s = 0; s < 2; ++s) {
    const std::array<int, 3>& qa = w.leg_qpos[s];
    const std::array<int, 3>& da = w.leg_dof[s];
    const LegJoints q(d->qpos[qa[0]], d->qpos[qa[1]], d->qpos[qa[2]]);
    const LegJoints v(d->qvel[da[0]], d->qvel[da[1]], d->qvel[da[2]]);
    st.passive[s] = cfg.passive_moments ? passiveJointMoments(q, v, cfg.joint_damping) : LegJoints::Zero();
    for (int i = 0; i < 3; ++i) d->qfrc_applied[da[static_cast<size_t>(i)]] = st.passive[s][i] + st.reflex[s][i];
  }
  // Active sway: first-order low-pass Gaussian noise with a stationary RMS of sway_rms per axis.
  const double a = w.sway_decay, rms = cfg.trunk.sway_rms;
  for (int i = 0; i < 3; ++i) {
    if (rms > 0.0) st.sway[i] = a * st.sway[i] + std::sqrt(1.0 - a * a) * rms * wearerGaussian(st.rng);
    d->qfrc_applied[w.lumbar_dof[static_cast<size_t>(i)]] = st.sway[i];
  }
}

}  // namespace exoid::sim
