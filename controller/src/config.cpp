#include "exoid/controller/config.hpp"
#include "exoid/one_line.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include "exoid/common/yaml.hpp"

namespace exoid::controller {

namespace {

/// Reads typed fields from one YAML section, remembering the first error (with the full field name).
class Reader {
 public:
  Reader(const std::string& source, std::string* error) : source_(source), error_(error) {}

  bool ok() const { return ok_; }

  bool fail(const std::string& field, const std::string& what) {
    if (ok_ && error_) *error_ = oneLine(source_ + ": " + field + ": " + what);  // keys quote the file
    ok_ = false;
    return false;
  }

  /// The section `name` of `root`, a map whose keys must all be in `allowed`.
  YAML::Node section(const YAML::Node& root, const std::string& name, std::initializer_list<const char*> allowed) {
    if (!ok_) return YAML::Node();
    const YAML::Node node = root[name];
    if (!node) {
      fail(name, "missing section");
      return YAML::Node();
    }
    if (!node.IsMap()) {
      fail(name, "expected a map");
      return YAML::Node();
    }
    checkKeys(node, name, allowed);
    return node;
  }

  void checkKeys(const YAML::Node& map, const std::string& prefix, std::initializer_list<const char*> allowed) {
    for (const auto& kv : map) {
      const std::string key = kv.first.as<std::string>();
      bool known = false;
      for (const char* a : allowed) known = known || key == a;
      if (!known) fail(prefix.empty() ? key : prefix + "." + key, "unknown key");
    }
  }

  void number(const YAML::Node& sec, const std::string& sname, const char* key, double& out) {
    if (!ok_) return;
    const std::string field = sname + "." + key;
    const YAML::Node n = sec[key];
    if (!n) {
      fail(field, "missing");
      return;
    }
    if (!n.IsScalar()) {
      fail(field, "expected a number");
      return;
    }
    double v = 0.0;
    std::string why;
    if (!common::yamlNumber(n, v, &why)) {
      fail(field, why);
      return;
    }
    out = v;
  }

  void integer(const YAML::Node& sec, const std::string& sname, const char* key, int& out) {
    if (!ok_) return;
    const std::string field = sname + "." + key;
    const YAML::Node n = sec[key];
    if (!n) {
      fail(field, "missing");
      return;
    }
    int64_t v = 0;
    std::string why;
    if (!common::yamlInteger(n, INT32_MIN, INT32_MAX, v, &why)) {
      fail(field, why);
      return;
    }
    out = static_cast<int>(v);
  }

  void boolean(const YAML::Node& sec, const std::string& sname, const char* key, bool& out) {
    if (!ok_) return;
    const std::string field = sname + "." + key;
    const YAML::Node n = sec[key];
    if (!n) {
      fail(field, "missing");
      return;
    }
    bool v = false;
    if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) {
      fail(field, "expected true or false");
      return;
    }
    out = v;
  }

  void text(const YAML::Node& sec, const std::string& sname, const char* key, std::string& out) {
    if (!ok_) return;
    const std::string field = sname + "." + key;
    const YAML::Node n = sec[key];
    if (!n || !n.IsScalar() || n.Scalar().empty()) {
      fail(field, n ? "expected a non-empty string" : "missing");
      return;
    }
    out = n.Scalar();
  }

  /// A string that must be one of `options`; out is its index.
  void choice(const YAML::Node& sec, const std::string& sname, const char* key,
              std::initializer_list<const char*> options, int& out) {
    std::string v;
    text(sec, sname, key, v);
    if (!ok_) return;
    std::string list;
    int i = 0;
    for (const char* o : options) {
      if (v == o) {
        out = i;
        return;
      }
      list += (i++ ? ", " : "") + std::string(o);
    }
    fail(sname + "." + key, "expected one of " + list + ", got '" + v + "'");
  }

  template <int N>
  void vector(const YAML::Node& sec, const std::string& sname, const char* key, Eigen::Matrix<double, N, 1>& out) {
    if (!ok_) return;
    const std::string field = sname + "." + key;
    const YAML::Node n = sec[key];
    if (!n) {
      fail(field, "missing");
      return;
    }
    const std::string expect = "expected " + std::to_string(N) + " finite numbers (or one for all)";
    std::string why;
    if (n.IsScalar()) {  // one value for every component
      double v = 0.0;
      if (!common::yamlNumber(n, v, &why)) {
        fail(field, expect + ": " + why);
        return;
      }
      out.setConstant(v);
      return;
    }
    if (!n.IsSequence() || static_cast<int>(n.size()) != N) {
      fail(field, expect);
      return;
    }
    for (int i = 0; i < N; ++i) {
      double v = 0.0;
      if (!common::yamlNumber(n[i], v, &why)) {
        fail(field + "[" + std::to_string(i) + "]", why);
        return;
      }
      out[i] = v;
    }
  }

 private:
  std::string source_;
  std::string* error_;
  bool ok_ = true;
};

bool failWith(std::string* error, const std::string& text) {
  if (error) *error = oneLine(text);
  return false;
}

/// The `loop` section: control period.
void readLoopSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const auto s = r.section(root, "loop", {"period"});
  r.number(s, "loop", "period", c.loop.period);
}

/// The `trajectory` section: the CoM move sequence.
void readTrajectorySection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "trajectory";
  const auto s = r.section(root, n,
                           {"moves", "move_duration", "hold_duration", "initial_hold", "final_hold",
                            "polygon_margin", "min_move_distance", "max_move_distance", "torque_budget", "vertical_min",
                            "vertical_max", "max_sampling_attempts"});
  auto& t = c.trajectory;
  r.integer(s, n, "moves", t.moves);
  r.number(s, n, "move_duration", t.move_duration);
  r.number(s, n, "hold_duration", t.hold_duration);
  r.number(s, n, "initial_hold", t.initial_hold);
  r.number(s, n, "final_hold", t.final_hold);
  r.number(s, n, "polygon_margin", t.polygon_margin);
  r.number(s, n, "min_move_distance", t.min_move_distance);
  r.number(s, n, "max_move_distance", t.max_move_distance);
  r.number(s, n, "torque_budget", t.torque_budget);
  r.number(s, n, "vertical_min", t.vertical_min);
  r.number(s, n, "vertical_max", t.vertical_max);
  r.integer(s, n, "max_sampling_attempts", t.max_sampling_attempts);
}

/// The `observer` section: the base state observer.
void readObserverSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "observer";
  const auto s = r.section(root, n,
                           {"joint_velocity_cutoff_hz", "gyro_cutoff_hz", "orientation_time_constant",
                            "initial_base_xy", "ground_height", "latch_ticks"});
  auto& e = c.observer;
  r.number(s, n, "joint_velocity_cutoff_hz", e.joint_velocity_cutoff_hz);
  r.number(s, n, "gyro_cutoff_hz", e.gyro_cutoff_hz);
  r.number(s, n, "orientation_time_constant", e.orientation_time_constant);
  r.vector<2>(s, n, "initial_base_xy", e.initial_base_xy);
  r.number(s, n, "ground_height", e.ground_height);
  r.integer(s, n, "latch_ticks", e.latch_ticks);
}

/// The `momentum` section: the momentum task.
void readMomentumSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "momentum";
  const auto s = r.section(root, n, {"kp_com", "kd_com", "kd_angular", "weight_linear", "weight_angular"});
  auto& m = c.momentum;
  r.vector<3>(s, n, "kp_com", m.kp_com);
  r.vector<3>(s, n, "kd_com", m.kd_com);
  r.vector<3>(s, n, "kd_angular", m.kd_angular);
  r.vector<3>(s, n, "weight_linear", m.weight_linear);
  r.vector<3>(s, n, "weight_angular", m.weight_angular);
}

/// The `posture` section: the posture regularization.
void readPostureSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "posture";
  const auto s = r.section(root, n, {"weight_joint", "weight_base", "kp", "kd"});
  r.number(s, n, "weight_joint", c.posture.weight_joint);
  r.number(s, n, "weight_base", c.posture.weight_base);
  r.number(s, n, "kp", c.posture.kp);
  r.number(s, n, "kd", c.posture.kd);
}

/// The `contact` section: the sole contacts.
void readContactSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "contact";
  const auto s = r.section(root, n,
                           {"right_sole_frame", "left_sole_frame", "friction_coefficient", "sole_half_length",
                            "sole_half_width", "cop_margin", "min_normal_force", "yaw_moment_coefficient", "kp",
                            "kd", "force_weight", "range_tolerance"});
  auto& k = c.contact;
  r.text(s, n, "right_sole_frame", k.right_sole_frame);
  r.text(s, n, "left_sole_frame", k.left_sole_frame);
  r.number(s, n, "friction_coefficient", k.friction_coefficient);
  r.number(s, n, "sole_half_length", k.sole_half_length);
  r.number(s, n, "sole_half_width", k.sole_half_width);
  r.number(s, n, "cop_margin", k.cop_margin);
  r.number(s, n, "min_normal_force", k.min_normal_force);
  r.number(s, n, "yaw_moment_coefficient", k.yaw_moment_coefficient);
  r.number(s, n, "kp", k.kp);
  r.number(s, n, "kd", k.kd);
  r.number(s, n, "force_weight", k.force_weight);
  r.number(s, n, "range_tolerance", k.range_tolerance);
}

/// The `torque` section: the joint torque limits.
void readTorqueSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const auto s = r.section(root, "torque", {"limit_scale"});
  r.number(s, "torque", "limit_scale", c.torque.limit_scale);
}

/// The `solver` section: the QP solver.
void readSolverSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const auto s = r.section(root, "solver", {"eps_abs", "max_iterations"});
  r.number(s, "solver", "eps_abs", c.solver.eps_abs);
  r.integer(s, "solver", "max_iterations", c.solver.max_iterations);
}

/// The `fallback` section: the fallback (hold, then damping).
void readFallbackSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "fallback";
  const auto s = r.section(root, n,
                           {"hold_ticks", "damping", "damping_torque_limit", "recovery_ticks", "max_missed_ticks",
                            "max_quaternion_norm_error"});
  auto& f = c.fallback;
  r.integer(s, n, "hold_ticks", f.hold_ticks);
  r.number(s, n, "damping", f.damping);
  r.number(s, n, "damping_torque_limit", f.damping_torque_limit);
  r.integer(s, n, "recovery_ticks", f.recovery_ticks);
  r.integer(s, n, "max_missed_ticks", f.max_missed_ticks);
  r.number(s, n, "max_quaternion_norm_error", f.max_quaternion_norm_error);
}

/// The `estimate` section: the online estimate's use.
void readEstimateSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "estimate";
  const auto s = r.section(root, n,
                           {"enabled", "use_feedforward", "use_com", "use_com_height", "max_abs", "max_age_ticks", "lag_ticks",
                            "blend_time", "max_relative_mass_change", "trust_sigmas",
                            "trust_sigmas_horizontal_com"});
  r.boolean(s, n, "enabled", c.estimate.enabled);
  r.boolean(s, n, "use_feedforward", c.estimate.use_feedforward);
  r.boolean(s, n, "use_com", c.estimate.use_com);
  r.boolean(s, n, "use_com_height", c.estimate.use_com_height);
  r.number(s, n, "max_abs", c.estimate.max_abs);
  r.integer(s, n, "max_age_ticks", c.estimate.max_age_ticks);
  r.integer(s, n, "lag_ticks", c.estimate.lag_ticks);
  r.number(s, n, "blend_time", c.estimate.blend_time);
  r.number(s, n, "max_relative_mass_change", c.estimate.max_relative_mass_change);
  r.number(s, n, "trust_sigmas", c.estimate.trust_sigmas);
  r.number(s, n, "trust_sigmas_horizontal_com", c.estimate.trust_sigmas_horizontal_com);
}

/// The `disturbance` section: the disturbance observer.
void readDisturbanceSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "disturbance";
  const auto s =
      r.section(root, n, {"enabled", "time_constant", "max_abs", "force_plates", "max_plate_age_ticks"});
  r.boolean(s, n, "enabled", c.disturbance.enabled);
  r.number(s, n, "time_constant", c.disturbance.time_constant);
  r.number(s, n, "max_abs", c.disturbance.max_abs);
  r.boolean(s, n, "force_plates", c.disturbance.force_plates);
  r.integer(s, n, "max_plate_age_ticks", c.disturbance.max_plate_age_ticks);
}

/// The `com_observer` section: the CoM the force plates measure, fused with the model's.
void readComObserverSection(Reader& r, const YAML::Node& root, ControllerConfig& c) {
  const char* n = "com_observer";
  const auto s =
      r.section(root, n,
                {"enabled", "anchor", "upper_body_momentum", "crossover_hz", "anchor_time_constant", "settle_time"});
  r.boolean(s, n, "enabled", c.com_observer.enabled);
  int anchor = 0;
  r.choice(s, n, "anchor", {"plates", "model"}, anchor);
  c.com_observer.anchor = anchor == 0 ? ComObserverConfig::Anchor::kPlates : ComObserverConfig::Anchor::kModel;
  r.boolean(s, n, "upper_body_momentum", c.com_observer.upper_body_momentum);
  r.number(s, n, "crossover_hz", c.com_observer.crossover_hz);
  r.number(s, n, "anchor_time_constant", c.com_observer.anchor_time_constant);
  r.number(s, n, "settle_time", c.com_observer.settle_time);
}

}  // namespace

bool parseControllerConfig(const std::string& yaml, const std::string& source, ControllerConfig& c,
                           std::string* error) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    std::string msg = e.what();
    for (char& ch : msg)
      if (ch == '\n') ch = ' ';
    return failWith(error, source + ": YAML syntax error: " + msg);
  }
  if (!root.IsMap()) return failWith(error, source + ": expected a YAML map of sections");
  std::string duplicate;
  if (!common::checkNoDuplicateKeys(root, &duplicate)) return failWith(error, source + ": " + duplicate);

  Reader r(source, error);
  try {
    r.checkKeys(root, "", {"loop", "trajectory", "observer", "momentum", "posture", "contact", "torque", "solver",
                           "fallback", "estimate", "disturbance", "com_observer"});
    readLoopSection(r, root, c);
    readTrajectorySection(r, root, c);
    readObserverSection(r, root, c);
    readMomentumSection(r, root, c);
    readPostureSection(r, root, c);
    readContactSection(r, root, c);
    readTorqueSection(r, root, c);
    readSolverSection(r, root, c);
    readFallbackSection(r, root, c);
    readEstimateSection(r, root, c);
    readDisturbanceSection(r, root, c);
    readComObserverSection(r, root, c);
  } catch (const YAML::Exception& e) {
    return failWith(error, source + ": " + e.what());
  }
  if (!r.ok()) return false;
  std::string why;
  if (!validateControllerConfig(c, &why)) return failWith(error, source + ": " + why);
  return true;
}

bool loadControllerConfig(const std::string& path, ControllerConfig& config, std::string* error) {
  std::ifstream in(path);
  if (!in) return failWith(error, path + ": cannot open controller config");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseControllerConfig(ss.str(), path, config, error);
}

bool validateControllerConfig(const ControllerConfig& c, std::string* error) {
  auto positive = [&](double v, const char* field) {
    return v > 0.0 ? true : failWith(error, std::string(field) + ": must be > 0");
  };
  auto nonneg = [&](double v, const char* field) {
    return v >= 0.0 ? true : failWith(error, std::string(field) + ": must be >= 0");
  };
  auto nonneg3 = [&](const Eigen::Vector3d& v, const char* field) {
    return (v.array() >= 0.0).all() ? true : failWith(error, std::string(field) + ": every component must be >= 0");
  };
  const auto& t = c.trajectory;
  const auto& e = c.observer;
  const auto& k = c.contact;
  const auto& f = c.fallback;
  return positive(c.loop.period, "loop.period") &&
         (t.moves >= 1 ? true : failWith(error, "trajectory.moves: must be >= 1")) &&
         positive(t.move_duration, "trajectory.move_duration") && nonneg(t.hold_duration, "trajectory.hold_duration") &&
         nonneg(t.initial_hold, "trajectory.initial_hold") && nonneg(t.final_hold, "trajectory.final_hold") &&
         nonneg(t.polygon_margin, "trajectory.polygon_margin") &&
         (t.torque_budget >= 0.0 && t.torque_budget <= 1.0
              ? true
              : failWith(error, "trajectory.torque_budget: must be in [0, 1]")) &&
         nonneg(t.min_move_distance, "trajectory.min_move_distance") &&
         (t.max_move_distance > t.min_move_distance
              ? true
              : failWith(error, "trajectory.max_move_distance: must be > trajectory.min_move_distance")) &&
         (t.vertical_max >= t.vertical_min ? true
                                           : failWith(error, "trajectory.vertical_max: must be >= vertical_min")) &&
         (t.max_sampling_attempts >= 1 ? true : failWith(error, "trajectory.max_sampling_attempts: must be >= 1")) &&
         positive(e.joint_velocity_cutoff_hz, "observer.joint_velocity_cutoff_hz") &&
         (e.joint_velocity_cutoff_hz < 0.5 / c.loop.period
              ? true
              : failWith(error, "observer.joint_velocity_cutoff_hz: must be below the Nyquist frequency")) &&
         nonneg(e.gyro_cutoff_hz, "observer.gyro_cutoff_hz") &&
         (e.gyro_cutoff_hz < 0.5 / c.loop.period
              ? true
              : failWith(error, "observer.gyro_cutoff_hz: must be below the Nyquist frequency")) &&
         nonneg(e.orientation_time_constant, "observer.orientation_time_constant") &&
         (e.latch_ticks >= 1 ? true : failWith(error, "observer.latch_ticks: must be >= 1")) &&
         nonneg3(c.momentum.kp_com, "momentum.kp_com") && nonneg3(c.momentum.kd_com, "momentum.kd_com") &&
         nonneg3(c.momentum.kd_angular, "momentum.kd_angular") &&
         nonneg3(c.momentum.weight_linear, "momentum.weight_linear") &&
         nonneg3(c.momentum.weight_angular, "momentum.weight_angular") &&
         positive(c.posture.weight_joint, "posture.weight_joint") &&
         positive(c.posture.weight_base, "posture.weight_base") && nonneg(c.posture.kp, "posture.kp") &&
         nonneg(c.posture.kd, "posture.kd") && positive(k.friction_coefficient, "contact.friction_coefficient") &&
         positive(k.sole_half_length, "contact.sole_half_length") &&
         positive(k.sole_half_width, "contact.sole_half_width") && nonneg(k.cop_margin, "contact.cop_margin") &&
         (k.cop_margin < k.sole_half_length && k.cop_margin < k.sole_half_width
              ? true
              : failWith(error, "contact.cop_margin: must be smaller than the sole half length and half width")) &&
         nonneg(k.min_normal_force, "contact.min_normal_force") &&
         nonneg(k.yaw_moment_coefficient, "contact.yaw_moment_coefficient") && nonneg(k.kp, "contact.kp") &&
         nonneg(k.kd, "contact.kd") && positive(k.force_weight, "contact.force_weight") &&
         positive(k.range_tolerance, "contact.range_tolerance") &&
         (c.torque.limit_scale > 0.0 && c.torque.limit_scale <= 1.0
              ? true
              : failWith(error, "torque.limit_scale: must be in (0, 1]")) &&
         positive(c.solver.eps_abs, "solver.eps_abs") &&
         (c.solver.max_iterations >= 1 ? true : failWith(error, "solver.max_iterations: must be >= 1")) &&
         (f.hold_ticks >= 0 ? true : failWith(error, "fallback.hold_ticks: must be >= 0")) &&
         nonneg(f.damping, "fallback.damping") && nonneg(f.damping_torque_limit, "fallback.damping_torque_limit") &&
         (f.recovery_ticks >= 1 ? true : failWith(error, "fallback.recovery_ticks: must be >= 1")) &&
         (f.max_missed_ticks >= 0 ? true : failWith(error, "fallback.max_missed_ticks: must be >= 0")) &&
         positive(f.max_quaternion_norm_error, "fallback.max_quaternion_norm_error") &&
         nonneg(c.estimate.max_abs, "estimate.max_abs") &&
         (c.estimate.max_age_ticks >= 0 ? true : failWith(error, "estimate.max_age_ticks: must be >= 0")) &&
         (c.estimate.lag_ticks >= 0 && c.estimate.lag_ticks < c.estimate.max_age_ticks
              ? true
              : failWith(error, "estimate.lag_ticks: must be >= 0 and below estimate.max_age_ticks (an estimate "
                                "applied that late is already stale)")) &&
         nonneg(c.estimate.blend_time, "estimate.blend_time") &&
         positive(c.estimate.max_relative_mass_change, "estimate.max_relative_mass_change") &&
         nonneg(c.estimate.trust_sigmas, "estimate.trust_sigmas") &&
         nonneg(c.estimate.trust_sigmas_horizontal_com, "estimate.trust_sigmas_horizontal_com") &&
         positive(c.disturbance.time_constant, "disturbance.time_constant") &&
         nonneg(c.disturbance.max_abs, "disturbance.max_abs") &&
         (c.disturbance.max_plate_age_ticks >= 0 ? true
                                                  : failWith(error, "disturbance.max_plate_age_ticks: must be >= 0")) &&
         // forward Euler at the control period: the filter's poles must sit far below the control rate
         (c.com_observer.crossover_hz > 0.0 && c.com_observer.crossover_hz * c.loop.period <= 0.02
              ? true
              : failWith(error, "com_observer.crossover_hz: must be > 0 and at most 1/50 of the control rate")) &&
         positive(c.com_observer.anchor_time_constant, "com_observer.anchor_time_constant") &&
         positive(c.com_observer.settle_time, "com_observer.settle_time");
}

}  // namespace exoid::controller
