// The diagnosis's sidecar (effects.yaml, docs/diagnose.md) and its use as known corrections: effect columns,
// measurement corrections, EffectCorrector.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/one_line.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

// ---------------------------------------------------------------------------------------------------------
namespace {
// A YAML double-quoted scalar of any text (the model's name is the user's file name): quote, backslash and control
// characters escaped, so that what is written reads back as the same string.
std::string quotedYaml(const std::string& text) {
  std::string escaped;
  for (const char ch : text) {
    if (ch == '"' || ch == '\\') escaped += '\\';
    escaped += ch;
  }
  return "\"" + oneLine(escaped) + "\"";  // control characters as \n, \r, \t, \xNN: YAML's escapes too
}

// printf into a string of the size it needs.
template <class... Args>
std::string formatted(const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  std::string out(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::snprintf(out.data(), out.size() + 1, format, args...);
  return out;
}
}  // namespace

bool writeEffects(const std::string& path, const Model& model, const EffectSet& set, std::string* error) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) return common::fail(error, "cannot write '" + tmp + "'");
    char buf[512];
    f << "# Effects the rigid-body model lacks, found by `exoid diagnose` (format: docs/diagnose.md).\n"
         "# Dynamics effects add a column on their joint's row: viscous v, coulomb tanh(v / width),\n"
         "# stribeck tanh(v / width) exp(-(v / stribeck_velocity)^2) (width: the effect's, else coulomb_width),\n"
         "# offset 1, armature dv/dt, elastic q - center, elastic_exp width (exp((q - center) / width) - 1),\n"
         "# elastic_coupled q_(angle_of) - center, elastic_exp_coupled width (exp(x / width) - 1) with\n"
         "# x = q - center + ratio (q_(angle_of) - angle_of_center) (q in rad; the elastic values are stiffnesses at\n"
         "# center, N m/rad).\n"
         "# Measurement effects correct the torque: gain g (measured = (1 + g) true), delay d (s, measured(t) =\n"
         "# true(t - d)).\n";
    f << "model: " << quotedYaml(set.model) << "\n";
    if (set.base_body_moves) {
      if (!model.floating_base) return common::fail(error, "base_body_moves needs a floating base");
      f << "base_body_moves: true  # an unmeasured body moves on the base: the online estimator keeps the prior's CoM height\n";
    }
    std::snprintf(buf, sizeof buf, "coulomb_width: %.17g  # rad/s\nstribeck_velocity: %.17g  # rad/s\neffects:\n",
                  set.shape.coulomb_width, set.shape.stribeck_velocity);
    f << buf;
    if (set.effects.empty()) f << "  []\n";
    for (const Effect& e : set.effects) {
      std::string line;  // sized to the joint names (a user's URDF may have long ones)
      if (e.joint < 0 || e.joint >= model.njoints) return common::fail(error, "effect on an unknown joint");
      if (isCoupled(e.kind) && (e.coupled < 0 || e.coupled >= model.njoints))
        return common::fail(error, std::string(effectKindName(e.kind)) + " effect without its joint");
      if (e.width > 0.0 && isDryFriction(e.kind))
        line = formatted("  - {joint: %s, kind: %s, value: %.17g, width: %.17g}  # %s, rad/s\n",
                         quotedYaml(model.joint_names[e.joint]).c_str(), effectKindName(e.kind), e.value, e.width, effectUnit(e.kind));
      else if (e.kind == EffectKind::Elastic)
        line = formatted("  - {joint: %s, kind: %s, value: %.17g, center: %.17g}  # %s, rad\n",
                         quotedYaml(model.joint_names[e.joint]).c_str(), effectKindName(e.kind), e.value, e.center, effectUnit(e.kind));
      else if (e.kind == EffectKind::ElasticCoupled)
        line = formatted("  - {joint: %s, kind: %s, value: %.17g, center: %.17g, angle_of: %s}  # %s, rad\n",
                         quotedYaml(model.joint_names[e.joint]).c_str(), effectKindName(e.kind), e.value, e.center,
                         quotedYaml(model.joint_names[e.coupled]).c_str(), effectUnit(e.kind));
      else if (e.kind == EffectKind::ElasticExpCoupled)
        line = formatted(
                         "  - {joint: %s, kind: %s, value: %.17g, center: %.17g, width: %.17g, angle_of: %s, ratio: %.17g, "
                         "angle_of_center: %.17g}  # %s, rad, rad, -, rad, rad/rad, rad\n",
                         quotedYaml(model.joint_names[e.joint]).c_str(), effectKindName(e.kind), e.value, e.center, e.width,
                         quotedYaml(model.joint_names[e.coupled]).c_str(), e.ratio, e.coupled_center, effectUnit(e.kind));
      else if (e.kind == EffectKind::ElasticExp)
        line = formatted("  - {joint: %s, kind: %s, value: %.17g, center: %.17g, width: %.17g}  # %s, rad, rad\n",
                         quotedYaml(model.joint_names[e.joint]).c_str(), effectKindName(e.kind), e.value, e.center, e.width,
                         effectUnit(e.kind));
      else
        line = formatted("  - {joint: %s, kind: %s, value: %.17g}  # %s\n", quotedYaml(model.joint_names[e.joint]).c_str(),
                         effectKindName(e.kind), e.value, effectUnit(e.kind));
      f << line;
    }
    if (!f.good()) return common::fail(error, "write failed on '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    if (error) *error = "cannot rename '" + tmp + "' to '" + path + "'";
    return false;
  }
  return true;
}

namespace {
// Why the sidecar's top-level mapping is not one (empty: it is): known keys only, positive finite shape constants.
std::string readShape(const YAML::Node& root, const Model& model, EffectSet& set) {
  if (!root.IsMap()) return "expected a mapping with 'effects'";
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    if (key != "model" && key != "coulomb_width" && key != "stribeck_velocity" && key != "effects" &&
        key != "base_body_moves")
      return "unknown key '" + key + "'";
  }
  if (root["model"]) set.model = root["model"].as<std::string>();
  if (root["base_body_moves"]) {  // YAML 1.1's yes/on/y are not taken: true or false only
    const YAML::Node& b = root["base_body_moves"];
    if (!b.IsScalar() || (b.Scalar() != "true" && b.Scalar() != "false")) return "base_body_moves must be true or false";
    set.base_body_moves = b.Scalar() == "true";
    if (set.base_body_moves && !model.floating_base) return "base_body_moves needs a floating base";
  }
  if (root["coulomb_width"]) set.shape.coulomb_width = root["coulomb_width"].as<double>();
  if (root["stribeck_velocity"]) set.shape.stribeck_velocity = root["stribeck_velocity"].as<double>();
  if (!(set.shape.coulomb_width > 0) || !std::isfinite(set.shape.coulomb_width) || !(set.shape.stribeck_velocity > 0) ||
      !std::isfinite(set.shape.stribeck_velocity))
    return "coulomb_width and stribeck_velocity must be positive and finite";
  return "";
}

// One entry of 'effects' (where: "effects[i]"), or why not (empty: read): a known joint and kind, a finite value, a
// positive finite width on dry friction only, no other key.
std::string readEffect(const YAML::Node& e, const std::string& where, const Model& model, Effect& ef) {
  if (!e.IsMap() || !e["joint"] || !e["kind"] || !e["value"]) return where + ": needs joint, kind and value";
  ef.joint = model.jointIndex(e["joint"].as<std::string>());
  if (ef.joint < 0) return where + ": unknown joint '" + e["joint"].as<std::string>() + "'";
  if (!parseEffectKind(e["kind"].as<std::string>(), ef.kind)) return where + ": unknown kind '" + e["kind"].as<std::string>() + "'";
  ef.value = e["value"].as<double>();
  if (!std::isfinite(ef.value)) return where + ": value is not finite";
  for (auto kv = e.begin(); kv != e.end(); ++kv) {
    const std::string k = kv->first.as<std::string>();
    if (k != "joint" && k != "kind" && k != "value" && k != "width" && k != "center" && k != "angle_of" && k != "ratio" &&
        k != "angle_of_center")
      return where + ": unknown key '" + k + "'";
  }
  const std::string kind = effectKindName(ef.kind);
  if (e["angle_of"]) {
    if (!isCoupled(ef.kind)) return where + ": angle_of belongs to elastic_coupled and elastic_exp_coupled effects only";
    ef.coupled = model.jointIndex(e["angle_of"].as<std::string>());
    if (ef.coupled < 0 || ef.coupled == ef.joint)
      return where + ": angle_of must name another joint of the model ('" + e["angle_of"].as<std::string>() + "')";
  } else if (isCoupled(ef.kind)) {
    return where + ": an " + kind + " effect needs angle_of (the joint whose angle it reads)";
  }
  for (const char* key : {"ratio", "angle_of_center"}) {
    if (!e[key]) {
      if (ef.kind == EffectKind::ElasticExpCoupled) return where + ": an elastic_exp_coupled effect needs its " + key;
      continue;
    }
    if (ef.kind != EffectKind::ElasticExpCoupled) return where + ": " + key + " belongs to elastic_exp_coupled effects only";
    const double x = e[key].as<double>();
    if (!std::isfinite(x)) return where + ": " + key + " is not finite";
    (std::string(key) == "ratio" ? ef.ratio : ef.coupled_center) = x;
  }
  if (e["center"]) {
    if (!isElastic(ef.kind)) return where + ": a center belongs to the elastic kinds only";
    ef.center = e["center"].as<double>();
    if (!std::isfinite(ef.center)) return where + ": center is not finite";
  } else if (isElastic(ef.kind)) {
    return where + ": an elastic effect needs its center (rad)";
  }
  if (ef.kind == EffectKind::ElasticExp || ef.kind == EffectKind::ElasticExpCoupled) {
    if (!e["width"]) return where + ": an " + kind + " effect needs its width (the exponential's scale, rad)";
    ef.width = e["width"].as<double>();
    if (ef.width == 0.0 || !std::isfinite(ef.width)) return where + ": width must be nonzero and finite";
    return "";
  }
  if (!e["width"]) return "";
  ef.width = e["width"].as<double>();
  if (!(ef.width > 0) || !std::isfinite(ef.width)) return where + ": width must be positive and finite";
  if (!isDryFriction(ef.kind))
    return where + ": a width belongs to coulomb, stribeck, elastic_exp and elastic_exp_coupled effects only";
  return "";
}
}  // namespace

bool readEffects(const std::string& path, const Model& model, EffectSet& set, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = oneLine(path + ": " + m);  // YAML's messages and the keys may quote the file's own bytes
    return false;
  };
  if (std::ifstream probe(path); !probe) return fail("cannot open the file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return fail(std::string("not readable YAML: ") + e.what());
  }
  EffectSet read;  // the caller's set changes only on success
  try {
    if (const std::string why = readShape(root, model, read); !why.empty()) return fail(why);
    const YAML::Node effects = root["effects"];
    if (!effects || !effects.IsSequence()) return fail("'effects' must be a list");
    for (size_t i = 0; i < effects.size(); ++i) {
      Effect ef;
      if (const std::string why = readEffect(effects[i], "effects[" + std::to_string(i) + "]", model, ef); !why.empty())
        return fail(why);
      read.effects.push_back(ef);
    }
  } catch (const std::exception& ex) {
    return fail(std::string("malformed: ") + ex.what());
  }
  set = read;
  return true;
}

// ---------------------------------------------------------------------------------------------------------
int effectColumnCount(const EffectSet& set) {
  int n = 0;
  for (const Effect& e : set.effects) n += isMeasurementEffect(e.kind) ? 0 : 1;
  return n;
}

void effectColumns(const Model& model, const EffectSet& set, const Eigen::Ref<const Eigen::VectorXd>& q,
                   const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& a,
                   Eigen::Ref<Eigen::MatrixXd> E) {
  E.setZero();
  int col = 0;
  for (const Effect& e : set.effects) {
    if (isMeasurementEffect(e.kind)) continue;
    E(model.jointRow(e.joint), col++) = effectSignal(e.kind, effectShape(set.shape, e), effectAngle(e, q[e.joint], q[signalJoint(e)]),
                                                     v[e.joint], a[e.joint], 0.0, 0.0);
  }
}

bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y,
                        const Eigen::Ref<const Eigen::VectorXd>& tau_sensor) {
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::Delay) return false;
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::GainError) {
      const int r = model.jointRow(e.joint);
      y[r] += tau_sensor[r] / (1.0 + e.value) - tau_sensor[r];
    }
  return true;
}

bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y) {
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::Delay) return false;
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::GainError) y[model.jointRow(e.joint)] /= 1.0 + e.value;  // y is the sensor torque
  return true;
}

EffectCorrector::EffectCorrector(const Model& model, const EffectSet& set, RowSink sink)
    : model_(model), set_(set), sink_(std::move(sink)) {
  E_ = Eigen::MatrixXd::Zero(model.nv, effectColumnCount(set));
  q_ = v_ = v_prev_ = a_ = Eigen::VectorXd::Zero(model.njoints);
  for (const Effect& e : set.effects) needs_q_ = needs_q_ || isElastic(e.kind);
}

bool EffectCorrector::add(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd* tau_sensor,
                          const Eigen::VectorXd* q) {
  if (needs_q_ && (!q || q->size() != model_.njoints)) return false;
  Eigen::VectorXd v(model_.njoints);
  for (int j = 0; j < model_.njoints; ++j) v[j] = K(model_.jointRow(j), model_.frictionParamIndex(j));
  if (pending_) emit(t, v);
  K_ = K, y_ = y, tau_ = tau_sensor ? *tau_sensor : y, v_ = v, t_ = t;
  if (q) q_ = *q;
  pending_ = true;
  return true;
}

void EffectCorrector::finish() {
  if (pending_) emit(t_, v_);
  pending_ = false;
}

void EffectCorrector::emit(double t_next, const Eigen::VectorXd& v_next) {
  // Central difference over the neighbours (one-sided at the ends), as the diagnosis's derivative().
  const double t_lo = has_prev_ ? t_prev_ : t_;
  const Eigen::VectorXd& v_lo = has_prev_ ? v_prev_ : v_;
  a_ = t_next > t_lo ? Eigen::VectorXd((v_next - v_lo) / (t_next - t_lo)) : Eigen::VectorXd::Zero(model_.njoints);
  effectColumns(model_, set_, q_, v_, a_, E_);
  int col = 0;
  for (const Effect& e : set_.effects)
    if (!isMeasurementEffect(e.kind)) y_ -= e.value * E_.col(col++);
  correctMeasurement(model_, set_, y_, tau_);
  sink_(t_, K_, y_);
  t_prev_ = t_, v_prev_ = v_, has_prev_ = true;
}

}  // namespace exoid::estimator
