// YAML loaders for the sensor noise model and scenarios. yaml-cpp throws; every call into it is wrapped so
// that a bad file becomes one line "<file>: <key>: <what>" and never an exception (startup code only).
// Numbers are strict (common::yamlNumber) and duplicate keys are refused at every level.
#include "exoid/sim/config.hpp"
#include "exoid/one_line.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string>

#include "exoid/common/yaml.hpp"

namespace exoid::sim {
namespace {

// Error sink that prefixes the file name; fail() always returns false so call sites can `return fail(...)`.
struct Ctx {
  std::string file;
  std::string* err;
  bool fail(const std::string& key, const std::string& what) const {
    if (err) *err = oneLine(file + ": " + (key.empty() ? "" : key + ": ") + what);  // may quote the file
    return false;
  }
};

std::string join(const std::string& a, const std::string& b) { return a.empty() ? b : a + "." + b; }

const char* typeName(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null: return "null";
    case YAML::NodeType::Scalar: return "a scalar";
    case YAML::NodeType::Sequence: return "a sequence";
    case YAML::NodeType::Map: return "a map";
    default: return "undefined";
  }
}

bool loadFile(const Ctx& c, YAML::Node* root) {
  try {
    *root = YAML::LoadFile(c.file);
  } catch (const YAML::BadFile&) {
    return c.fail("", "cannot open file");
  } catch (const YAML::Exception& e) {
    return c.fail("", std::string("malformed YAML: ") + e.what());
  }
  if (!root->IsMap()) return c.fail("", std::string("top level must be a map, found ") + typeName(*root));
  std::string duplicate;
  if (!common::checkNoDuplicateKeys(*root, &duplicate)) return c.fail("", duplicate);
  return true;
}

// Every key of `map` must be one of `allowed`.
bool checkKeys(const Ctx& c, const YAML::Node& map, const std::string& path,
               std::initializer_list<const char*> allowed) {
  if (!map.IsMap()) return c.fail(path, std::string("expected a map, found ") + typeName(map));
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) return c.fail(path, "keys must be scalars");
    const std::string k = kv.first.as<std::string>();
    bool ok = false;
    for (const char* a : allowed) ok = ok || k == a;
    if (!ok) {
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      return c.fail(join(path, k), "unknown key (allowed: " + list + ")");
    }
  }
  return true;
}

bool getRequired(const Ctx& c, const YAML::Node& map, const std::string& path, const char* key, YAML::Node* out) {
  const YAML::Node n = map[key];
  if (!n) return c.fail(join(path, key), "missing");
  *out = n;
  return true;
}

bool toDouble(const Ctx& c, const YAML::Node& n, const std::string& key, double* out) {
  if (!n.IsScalar()) return c.fail(key, std::string("expected a number, found ") + typeName(n));
  std::string why;
  return common::yamlNumber(n, *out, &why) || c.fail(key, why);
}

bool toNonNegative(const Ctx& c, const YAML::Node& n, const std::string& key, double* out) {
  if (!toDouble(c, n, key, out)) return false;
  if (*out < 0.0) return c.fail(key, "must be >= 0");
  return true;
}

bool toString(const Ctx& c, const YAML::Node& n, const std::string& key, std::string* out) {
  if (!n.IsScalar()) return c.fail(key, std::string("expected a string, found ") + typeName(n));
  *out = n.Scalar();
  return true;
}

template <int N>
bool toVector(const Ctx& c, const YAML::Node& n, const std::string& key, Eigen::Matrix<double, N, 1>* out,
              bool non_negative) {
  if (!n.IsSequence() || n.size() != N)
    return c.fail(key, "expected a sequence of " + std::to_string(N) + " numbers");
  for (int i = 0; i < N; ++i) {
    const std::string k = key + "[" + std::to_string(i) + "]";
    if (!(non_negative ? toNonNegative(c, n[i], k, &(*out)[i]) : toDouble(c, n[i], k, &(*out)[i]))) return false;
  }
  return true;
}

// A map joint -> number, e.g. {all: 0.5, right_knee: 1.0}.
bool toJointValues(const Ctx& c, const YAML::Node& n, const std::string& key, bool allow_all, bool non_negative,
                   std::vector<JointValue>* out) {
  if (!n.IsMap()) return c.fail(key, std::string("expected a map joint: value, found ") + typeName(n));
  for (const auto& kv : n) {
    JointValue jv;
    jv.joint = kv.first.as<std::string>();
    const std::string k = join(key, jv.joint);
    if (!allow_all && jv.joint == "all") return c.fail(k, "'all' is not allowed here");
    if (!(non_negative ? toNonNegative(c, kv.second, k, &jv.value) : toDouble(c, kv.second, k, &jv.value)))
      return false;
    out->push_back(jv);
  }
  return true;
}

bool parsePayload(const Ctx& c, const YAML::Node& n, const std::string& key, Payload* p) {
  if (!checkKeys(c, n, key, {"link", "mass", "com", "inertia", "attach_at_s"})) return false;
  YAML::Node v;
  if (!getRequired(c, n, key, "link", &v) || !toString(c, v, join(key, "link"), &p->link)) return false;
  if (!getRequired(c, n, key, "mass", &v) || !toDouble(c, v, join(key, "mass"), &p->mass)) return false;
  if (p->mass <= 0.0) return c.fail(join(key, "mass"), "must be > 0");
  if (n["com"] && !toVector<3>(c, n["com"], join(key, "com"), &p->com, false)) return false;
  if (n["attach_at_s"]) {
    if (!toDouble(c, n["attach_at_s"], join(key, "attach_at_s"), &p->attach_at_s)) return false;
    if (!(p->attach_at_s >= 0.0 && p->attach_at_s <= 1e6))
      return c.fail(join(key, "attach_at_s"), "must be in [0, 1e6] s");
  }
  if (n["inertia"]) {
    if (!toVector<6>(c, n["inertia"], join(key, "inertia"), &p->inertia, false)) return false;
    Eigen::Matrix3d I;
    I << p->inertia[0], p->inertia[3], p->inertia[4], p->inertia[3], p->inertia[1], p->inertia[5], p->inertia[4],
        p->inertia[5], p->inertia[2];
    // A physical inertia tensor is positive semi-definite (and obeys the triangle inequality of its
    // principal moments); anything else makes MuJoCo's body inertia meaningless.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I);
    const Eigen::Vector3d d = es.eigenvalues();
    const double tol = 1e-12 * std::max(1.0, d.cwiseAbs().maxCoeff());
    if (d.minCoeff() < -tol || d[0] + d[1] < d[2] - tol)
      return c.fail(join(key, "inertia"), "not a physical inertia tensor (ixx iyy izz ixy ixz iyz about the com)");
  }
  return true;
}

bool parseEffects(const Ctx& c, const YAML::Node& n, Effects* e) {
  const std::string key = "effects";
  if (n.IsNull()) return true;  // "effects:" with nothing = none
  if (!checkKeys(c, n, key,
                 {"joint_damping", "joint_frictionloss", "armature", "payload", "torque_sensor", "drive_torque_loop",
                  "foot_placement"}))
    return false;
  if (const YAML::Node fp = n["foot_placement"]) {
    if (!fp.IsMap())
      return c.fail("effects.foot_placement",
                    std::string("expected a map {right: [x, y], left: [x, y]}, found ") + typeName(fp));
    if (!checkKeys(c, fp, "effects.foot_placement", {"right", "left"})) return false;
    const char* sides[2] = {"right", "left"};
    for (int i = 0; i < 2; ++i) {
      if (!fp[sides[i]]) continue;
      const std::string k = join("effects.foot_placement", sides[i]);
      if (!toVector<2>(c, fp[sides[i]], k, &e->foot_placement[static_cast<size_t>(i)], false)) return false;
      if (e->foot_placement[static_cast<size_t>(i)].cwiseAbs().maxCoeff() > kMaxFootPlacement) {
        char why[96];
        std::snprintf(why, sizeof why, "each coordinate must be within +-%g m (the sole stays on its plate)",
                      kMaxFootPlacement);
        return c.fail(k, why);
      }
    }
  }
  if (const YAML::Node d = n["drive_torque_loop"]) {
    std::string mode;
    if (!toString(c, d, "effects.drive_torque_loop", &mode)) return false;
    if (mode != "ideal" && mode != "sensor")
      return c.fail("effects.drive_torque_loop", "expected ideal or sensor, got '" + mode + "'");
    e->drive_loop_on_sensor = mode == "sensor";
  }
  if (n["joint_damping"] &&
      !toJointValues(c, n["joint_damping"], "effects.joint_damping", true, true, &e->joint_damping))
    return false;
  if (n["joint_frictionloss"] &&
      !toJointValues(c, n["joint_frictionloss"], "effects.joint_frictionloss", true, true, &e->joint_frictionloss))
    return false;
  if (n["armature"] && !toJointValues(c, n["armature"], "effects.armature", true, true, &e->armature)) return false;
  if (const YAML::Node p = n["payload"]) {
    // One payload (a map) or several (a sequence of maps).
    if (p.IsSequence()) {
      for (size_t i = 0; i < p.size(); ++i) {
        Payload pl;
        if (!parsePayload(c, p[i], "effects.payload[" + std::to_string(i) + "]", &pl)) return false;
        e->payloads.push_back(pl);
      }
    } else {
      Payload pl;
      if (!parsePayload(c, p, "effects.payload", &pl)) return false;
      e->payloads.push_back(pl);
    }
  }
  if (const YAML::Node t = n["torque_sensor"]) {
    if (!t.IsMap()) return c.fail("effects.torque_sensor", "expected a map joint: {offset, gain}");
    for (const auto& kv : t) {
      TorqueSensorError ts;
      ts.joint = kv.first.as<std::string>();
      const std::string k = join("effects.torque_sensor", ts.joint);
      if (!checkKeys(c, kv.second, k, {"offset", "gain"})) return false;
      if (kv.second["offset"] && !toDouble(c, kv.second["offset"], join(k, "offset"), &ts.offset)) return false;
      if (kv.second["gain"] && !toDouble(c, kv.second["gain"], join(k, "gain"), &ts.gain)) return false;
      if (ts.gain <= 0.0) return c.fail(join(k, "gain"), "must be > 0");
      e->torque_sensor.push_back(ts);
    }
  }
  return true;
}

// wearer: {mass_kg, height_m, sex, seed, variation, trunk: {...}, passive_moments, joint_damping, reflex: {...}}.
bool parseWearerTrunk(const Ctx& c, const YAML::Node& n, WearerTrunk* t) {
  const std::string key = "wearer.trunk";
  if (!checkKeys(c, n, key, {"stiffness", "damping", "sway_rms", "sway_cutoff_hz"})) return false;
  YAML::Node v;
  if (!getRequired(c, n, key, "stiffness", &v) || !toVector<3>(c, v, key + ".stiffness", &t->stiffness, true) ||
      !getRequired(c, n, key, "damping", &v) || !toVector<3>(c, v, key + ".damping", &t->damping, true))
    return false;
  if (n["sway_rms"] && !toNonNegative(c, n["sway_rms"], key + ".sway_rms", &t->sway_rms)) return false;
  if (n["sway_cutoff_hz"] && !toDouble(c, n["sway_cutoff_hz"], key + ".sway_cutoff_hz", &t->sway_cutoff_hz))
    return false;
  if (!(t->sway_cutoff_hz > 0.0 && t->sway_cutoff_hz <= 100.0))
    return c.fail(key + ".sway_cutoff_hz", "must be in (0, 100] Hz");
  return true;
}

bool parseWearerReflex(const Ctx& c, const YAML::Node& n, WearerReflex* r) {
  const std::string key = "wearer.reflex";
  if (!checkKeys(c, n, key, {"rate_hz", "amplitude", "duration_s"})) return false;
  YAML::Node v;
  if (!getRequired(c, n, key, "rate_hz", &v) || !toNonNegative(c, v, key + ".rate_hz", &r->rate_hz) ||
      !getRequired(c, n, key, "amplitude", &v) || !toNonNegative(c, v, key + ".amplitude", &r->amplitude))
    return false;
  if (n["duration_s"] && !toDouble(c, n["duration_s"], key + ".duration_s", &r->duration_s)) return false;
  if (!(r->duration_s >= 0.01 && r->duration_s <= 10.0)) return c.fail(key + ".duration_s", "must be in [0.01, 10] s");
  if (r->rate_hz > 10.0) return c.fail(key + ".rate_hz", "must be <= 10 per s");
  return true;
}

bool parseWearer(const Ctx& c, const YAML::Node& n, WearerConfig* w) {
  const std::string key = "wearer";
  if (!checkKeys(c, n, key, {"mass_kg", "height_m", "sex", "seed", "variation", "trunk", "passive_moments",
                             "joint_damping", "reflex"}))
    return false;
  w->enabled = true;
  YAML::Node v;
  std::string sex, why;
  if (!getRequired(c, n, key, "mass_kg", &v) || !toDouble(c, v, "wearer.mass_kg", &w->spec.mass_kg) ||
      !getRequired(c, n, key, "height_m", &v) || !toDouble(c, v, "wearer.height_m", &w->spec.height_m) ||
      !getRequired(c, n, key, "sex", &v) || !toString(c, v, "wearer.sex", &sex) ||
      !getRequired(c, n, key, "trunk", &v) || !parseWearerTrunk(c, v, &w->trunk))
    return false;
  if (sex != "m" && sex != "f") return c.fail("wearer.sex", "expected m or f, got '" + sex + "'");
  w->spec.sex = sex == "f" ? Sex::Female : Sex::Male;
  if (const YAML::Node s = n["seed"]) {
    int64_t seed = 0;
    if (!s.IsScalar()) return c.fail("wearer.seed", std::string("expected an unsigned integer, found ") + typeName(s));
    if (!common::yamlInteger(s, 0, INT64_MAX, seed, &why)) return c.fail("wearer.seed", why);
    w->spec.seed = static_cast<uint64_t>(seed);
  }
  if (n["variation"] && !toDouble(c, n["variation"], "wearer.variation", &w->spec.variation)) return false;
  if (const YAML::Node p = n["passive_moments"]) {
    if (!p.IsScalar() || (p.Scalar() != "true" && p.Scalar() != "false"))
      return c.fail("wearer.passive_moments", "expected true or false");
    w->passive_moments = p.Scalar() == "true";
  }
  if (n["joint_damping"] && !toVector<3>(c, n["joint_damping"], "wearer.joint_damping", &w->joint_damping.b, true))
    return false;
  if (n["reflex"] && !parseWearerReflex(c, n["reflex"], &w->reflex)) return false;
  Wearer check;  // the ranges of mass, height and variation are the builder's
  if (!buildWearer(w->spec, check, &why)) return c.fail(key, why);
  return true;
}

}  // namespace

bool loadSensorConfig(const std::string& path, SensorConfig* out, std::string* err) {
  const Ctx c{path, err};
  YAML::Node root;
  if (!loadFile(c, &root)) return false;
  SensorConfig s;
  s.source = path;
  try {
    if (!checkKeys(c, root, "", {"encoder", "joint_torque", "imu", "force_plate"})) return false;
    YAML::Node sec, v;
    if (!getRequired(c, root, "", "encoder", &sec) || !checkKeys(c, sec, "encoder", {"sigma"}) ||
        !getRequired(c, sec, "encoder", "sigma", &v) || !toNonNegative(c, v, "encoder.sigma", &s.encoder_sigma))
      return false;
    if (!getRequired(c, root, "", "joint_torque", &sec) || !checkKeys(c, sec, "joint_torque", {"sigma"}) ||
        !getRequired(c, sec, "joint_torque", "sigma", &v) ||
        !toNonNegative(c, v, "joint_torque.sigma", &s.torque_sigma))
      return false;
    if (!getRequired(c, root, "", "imu", &sec) ||
        !checkKeys(c, sec, "imu", {"orientation_sigma", "gyro_sigma", "accel_sigma"}) ||
        !getRequired(c, sec, "imu", "orientation_sigma", &v) ||
        !toVector<3>(c, v, "imu.orientation_sigma", &s.imu_orientation_sigma, true) ||
        !getRequired(c, sec, "imu", "gyro_sigma", &v) || !toNonNegative(c, v, "imu.gyro_sigma", &s.gyro_sigma) ||
        !getRequired(c, sec, "imu", "accel_sigma", &v) || !toNonNegative(c, v, "imu.accel_sigma", &s.accel_sigma))
      return false;
    if (!getRequired(c, root, "", "force_plate", &sec) ||
        !checkKeys(c, sec, "force_plate", {"force_sigma", "moment_sigma", "cop_min_force"}) ||
        !getRequired(c, sec, "force_plate", "force_sigma", &v) ||
        !toVector<3>(c, v, "force_plate.force_sigma", &s.plate_force_sigma, true) ||
        !getRequired(c, sec, "force_plate", "moment_sigma", &v) ||
        !toVector<3>(c, v, "force_plate.moment_sigma", &s.plate_moment_sigma, true) ||
        !getRequired(c, sec, "force_plate", "cop_min_force", &v) ||
        !toNonNegative(c, v, "force_plate.cop_min_force", &s.cop_min_force))
      return false;
  } catch (const YAML::Exception& e) {
    return c.fail("", std::string("YAML error: ") + e.what());
  }
  *out = s;
  return true;
}

SensorConfig noiseOff(const SensorConfig& config) {
  SensorConfig s;
  s.cop_min_force = config.cop_min_force;
  s.source = config.source.empty() ? "noise off" : config.source + " (noise off)";
  return s;
}

bool loadScenario(const std::string& path, Scenario* out, std::string* err) {
  const Ctx c{path, err};
  YAML::Node root;
  if (!loadFile(c, &root)) return false;
  Scenario s;
  s.source = path;
  try {
    if (!checkKeys(c, root, "", {"name", "description", "seed", "noise", "effects", "initial_state", "harness",
                                  "wearer"}))
      return false;
    YAML::Node v;
    if (!getRequired(c, root, "", "name", &v) || !toString(c, v, "name", &s.name)) return false;
    if (s.name.empty()) return c.fail("name", "must not be empty");
    if (root["description"] && !toString(c, root["description"], "description", &s.description)) return false;
    if (!getRequired(c, root, "", "seed", &v)) return false;
    if (!v.IsScalar()) return c.fail("seed", std::string("expected an unsigned integer, found ") + typeName(v));
    int64_t seed = 0;
    std::string why;
    if (!common::yamlInteger(v, 0, INT64_MAX, seed, &why)) return c.fail("seed", why);
    s.seed = static_cast<uint64_t>(seed);
    if (!getRequired(c, root, "", "noise", &v)) return false;
    std::string noise;
    if (!toString(c, v, "noise", &noise)) return false;
    if (noise == "realistic") {
      s.noise = NoiseMode::Realistic;
    } else if (noise == "off") {
      s.noise = NoiseMode::Off;
    } else if (!noise.empty()) {
      // Any other value is a sensors file, relative to the scenario file's directory.
      s.noise = NoiseMode::File;
      const size_t slash = path.find_last_of('/');
      s.noise_file = (noise[0] == '/' || slash == std::string::npos) ? noise : path.substr(0, slash + 1) + noise;
    } else {
      return c.fail("noise", "expected realistic, off or a sensors file path");
    }
    if (root["effects"] && !parseEffects(c, root["effects"], &s.effects)) return false;
    if (const YAML::Node init = root["initial_state"]) {
      if (!checkKeys(c, init, "initial_state", {"base_height_offset", "joints"})) return false;
      if (init["base_height_offset"] &&
          !toDouble(c, init["base_height_offset"], "initial_state.base_height_offset", &s.initial.base_height_offset))
        return false;
      if (init["joints"] &&
          !toJointValues(c, init["joints"], "initial_state.joints", false, false, &s.initial.joints))
        return false;
    }
    if (const YAML::Node h = root["harness"]) {
      if (!h.IsMap()) return c.fail("harness", std::string("expected a map (e.g. {lift: 0.2}), found ") + typeName(h));
      if (!checkKeys(c, h, "harness", {"lift"})) return false;
      s.harness.enabled = true;
      if (h["lift"] && !toDouble(c, h["lift"], "harness.lift", &s.harness.lift)) return false;
      if (!(s.harness.lift >= 0.0 && s.harness.lift <= 2.0)) return c.fail("harness.lift", "must be in [0, 2] m");
    }
    if (root["wearer"] && !parseWearer(c, root["wearer"], &s.wearer)) return false;
  } catch (const YAML::Exception& e) {
    return c.fail("", std::string("YAML error: ") + e.what());
  }
  *out = s;
  return true;
}

bool resolveSensorConfig(const Scenario& scenario, const SensorConfig& realistic, SensorConfig* out,
                         std::string* err) {
  switch (scenario.noise) {
    case NoiseMode::Realistic: *out = realistic; return true;
    case NoiseMode::Off: *out = noiseOff(realistic); return true;
    case NoiseMode::File: {
      std::string e;
      if (loadSensorConfig(scenario.noise_file, out, &e)) return true;
      if (err) *err = scenario.source + ": noise: " + e;
      return false;
    }
  }
  return false;
}

}  // namespace exoid::sim
