#include <exoid/lcm/adapters.hpp>
#include <exoid/one_line.hpp>

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <stdexcept>

namespace exoid {

const char* toString(RejectReason reason) {
  switch (reason) {
    case RejectReason::Duplicate: return "duplicate";
    case RejectReason::OutOfOrder: return "out_of_order";
    case RejectReason::NonFinite: return "non_finite";
    case RejectReason::Malformed: return "malformed";
  }
  return "unknown";
}

const char* plateName(int plate) {
  return plate == 0 ? "right" : plate == 1 ? "left" : nullptr;
}

namespace {

// Validation of one message: each check returns false after recording the first failure. Formatting only
// happens on rejection and only when the caller asked for a reason.
class Check {
 public:
  Check(const char* type, std::string* why, RejectReason* reason) : type_(type), why_(why), reason_(reason) {}

  bool fail(RejectReason r, const char* fmt, ...) __attribute__((format(printf, 3, 4))) {
    if (reason_) *reason_ = r;
    if (why_) {
      char text[256];
      va_list args;
      va_start(args, fmt);
      std::vsnprintf(text, sizeof text, fmt, args);
      va_end(args);
      *why_ = oneLine(std::string(type_) + ": " + text);  // names come from the message
    }
    return false;
  }

  bool nonNegative(int64_t value, const char* field) {
    if (value >= 0) return true;
    return fail(RejectReason::Malformed, "%s is %lld, must be >= 0", field, static_cast<long long>(value));
  }

  bool count(int32_t num, size_t expected, const char* field) {
    if (num >= 0 && static_cast<size_t>(num) == expected) return true;
    return fail(RejectReason::Malformed, "%s is %d, expected %zu", field, num, expected);
  }

  // An array declared [num] in the .lcm: a hand-built (not decoded) message may disagree.
  bool length(size_t len, int32_t num, const char* field) {
    if (static_cast<int64_t>(len) == num) return true;
    return fail(RejectReason::Malformed, "%s has %zu entries but the count field says %d", field, len, num);
  }

  bool names(const std::vector<std::string>& got, const std::vector<std::string>& expected, const char* field) {
    if (got.size() != expected.size())
      return fail(RejectReason::Malformed, "%s has %zu entries, expected %zu", field, got.size(), expected.size());
    for (size_t i = 0; i < got.size(); ++i) {
      if (got[i] != expected[i])
        return fail(RejectReason::Malformed, "%s[%zu] is '%.64s', expected '%.64s'", field, i, got[i].c_str(),
                    expected[i].c_str());
    }
    return true;
  }

  bool finite(const double* v, size_t n, const char* field) {
    if (allFiniteValues(v, n)) return true;  // the gate's rule (sample_checks.hpp); below: which one
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(v[i])) {
        if (n == 1) return fail(RejectReason::NonFinite, "%s is %f", field, v[i]);
        return fail(RejectReason::NonFinite, "%s[%zu] is %f", field, i, v[i]);
      }
    }
    return true;
  }
  bool finite(const std::vector<double>& v, const char* field) { return finite(v.data(), v.size(), field); }
  bool finite(double v, const char* field) { return finite(&v, 1, field); }

  // A measured sample's values: finite and within kMaxSampleMagnitude (the gate's rules, sample_checks.hpp).
  bool measured(const double* v, size_t n, const char* field) {
    if (!finite(v, n, field)) return false;
    size_t i = 0;
    if (withinSampleRange(v, n, &i)) return true;
    return fail(RejectReason::Malformed, "%s[%zu] is %g, beyond the %g a measured value can take", field, i, v[i],
                kMaxSampleMagnitude);
  }
  bool measured(const std::vector<double>& v, const char* field) { return measured(v.data(), v.size(), field); }

  bool nonNegative(const double* v, size_t n, const char* field) {
    for (size_t i = 0; i < n; ++i)
      if (!(v[i] >= 0.0)) return fail(RejectReason::Malformed, "%s[%zu] is %g, must be >= 0", field, i, v[i]);
    return true;
  }

  // w x y z, must be finite and unit within kQuatNormTolerance.
  bool unitQuaternion(const double q[4], const char* field) {
    if (!finite(q, 4, field)) return false;
    double norm = 0.0;
    if (exoid::unitQuaternion(q[0], q[1], q[2], q[3], &norm)) return true;
    return fail(RejectReason::Malformed, "%s has norm %.9g, must be 1 within %g", field, norm, kQuatNormTolerance);
  }

  bool range(int64_t value, int64_t lo, int64_t hi, const char* field) {
    if (value >= lo && value <= hi) return true;
    return fail(RejectReason::Malformed, "%s is %lld, must be in [%lld, %lld]", field, static_cast<long long>(value),
                static_cast<long long>(lo), static_cast<long long>(hi));
  }

 private:
  const char* type_;
  std::string* why_;
  RejectReason* reason_;
};

Eigen::Quaterniond normalisedQuat(const double q[4]) {
  Eigen::Quaterniond out(q[0], q[1], q[2], q[3]);
  out.normalize();
  return out;
}

void resizeIfNeeded(Eigen::VectorXd& v, Eigen::Index n) {
  if (v.size() != n) v.resize(n);
}

Eigen::Vector3d vec3(const double v[3]) { return Eigen::Vector3d(v[0], v[1], v[2]); }
Vector6d vec6(const double v[6]) {
  Vector6d out;
  for (int i = 0; i < 6; ++i) out[i] = v[i];
  return out;
}
void copyVector(const std::vector<double>& src, Eigen::VectorXd& dst) {
  resizeIfNeeded(dst, static_cast<Eigen::Index>(src.size()));
  for (size_t i = 0; i < src.size(); ++i) dst[static_cast<Eigen::Index>(i)] = src[i];
}

// --- toLcm helpers ---
void requireSize(Eigen::Index size, size_t expected, const char* what) {
  if (size != static_cast<Eigen::Index>(expected))
    throw std::invalid_argument(std::string("toLcm: ") + what + " has " + std::to_string(size) +
                                " entries but " + std::to_string(expected) + " names were given");
}
void copyNames(const std::vector<std::string>& src, std::vector<std::string>& dst) {
  if (dst.size() != src.size()) dst.resize(src.size());
  for (size_t i = 0; i < src.size(); ++i) dst[i] = src[i];  // reuses each string's capacity
}
void copyVector(const Eigen::VectorXd& src, std::vector<double>& dst) {
  if (dst.size() != static_cast<size_t>(src.size())) dst.resize(static_cast<size_t>(src.size()));
  for (Eigen::Index i = 0; i < src.size(); ++i) dst[static_cast<size_t>(i)] = src[i];
}
template <int N>
void copyFixed(const Eigen::Matrix<double, N, 1>& src, double (&dst)[N]) {
  for (int i = 0; i < N; ++i) dst[i] = src[i];
}
void copyQuat(const Eigen::Quaterniond& q, double (&dst)[4]) {
  dst[0] = q.w();
  dst[1] = q.x();
  dst[2] = q.y();
  dst[3] = q.z();
}
int32_t count32(size_t n) { return static_cast<int32_t>(n); }

void copyFlags(const std::vector<int8_t>& src, Eigen::Matrix<bool, Eigen::Dynamic, 1>& dst) {
  if (dst.size() != static_cast<Eigen::Index>(src.size())) dst.resize(static_cast<Eigen::Index>(src.size()));
  for (size_t i = 0; i < src.size(); ++i) dst[static_cast<Eigen::Index>(i)] = src[i] != 0;
}
void copyFlags(const Eigen::Matrix<bool, Eigen::Dynamic, 1>& src, std::vector<int8_t>& dst) {
  if (dst.size() != static_cast<size_t>(src.size())) dst.resize(static_cast<size_t>(src.size()));
  for (Eigen::Index i = 0; i < src.size(); ++i) dst[static_cast<size_t>(i)] = src[i] ? 1 : 0;
}

}  // namespace

// The copies, expanded from the schema (exoid/interfaces/schema.h): one statement per row, the LCM field of
// the same name (FEET3: name_right, name_left). PLATE (plate_name), the counts and the name lists are the
// hand-written parts of each converter below; ABI_I32 rows are not in the LCM types.
#define EXOID_FROM_LCM(KIND, name, init, abi) EXOID_FROM_LCM_##KIND(name)
#define EXOID_FROM_LCM_I64(name) out.name = msg.name;
#define EXOID_FROM_LCM_I32(name) out.name = msg.name;
#define EXOID_FROM_LCM_F64(name) out.name = msg.name;
#define EXOID_FROM_LCM_BOOL(name) out.name = msg.name != 0;
#define EXOID_FROM_LCM_MODE(name) out.name = static_cast<CommandMode>(msg.name);
#define EXOID_FROM_LCM_QP(name) out.name = static_cast<QpStatus>(msg.name);
#define EXOID_FROM_LCM_PLATE(name)
#define EXOID_FROM_LCM_V3(name) out.name = vec3(msg.name);
#define EXOID_FROM_LCM_V6(name) out.name = vec6(msg.name);
#define EXOID_FROM_LCM_QUAT(name) out.name = normalisedQuat(msg.name);
#define EXOID_FROM_LCM_JOINTS(name) copyVector(msg.name, out.name);
#define EXOID_FROM_LCM_JFLAGS(name) copyFlags(msg.name, out.name);
#define EXOID_FROM_LCM_VECX(name) copyVector(msg.name, out.name);
#define EXOID_FROM_LCM_FEET3(name)          \
  out.name[0] = vec3(msg.name##_right); \
  out.name[1] = vec3(msg.name##_left);
#define EXOID_FROM_LCM_ABI_I32(name)

#define EXOID_TO_LCM(KIND, name, init, abi) EXOID_TO_LCM_##KIND(name)
#define EXOID_TO_LCM_I64(name) msg.name = s.name;
#define EXOID_TO_LCM_I32(name) msg.name = s.name;
#define EXOID_TO_LCM_F64(name) msg.name = s.name;
#define EXOID_TO_LCM_BOOL(name) msg.name = s.name ? 1 : 0;
#define EXOID_TO_LCM_MODE(name) msg.name = static_cast<int8_t>(s.name);
#define EXOID_TO_LCM_QP(name) msg.name = static_cast<int8_t>(s.name);
#define EXOID_TO_LCM_PLATE(name)
#define EXOID_TO_LCM_V3(name) copyFixed<3>(s.name, msg.name);
#define EXOID_TO_LCM_V6(name) copyFixed<6>(s.name, msg.name);
#define EXOID_TO_LCM_QUAT(name) copyQuat(s.name, msg.name);
#define EXOID_TO_LCM_JOINTS(name) copyVector(s.name, msg.name);
#define EXOID_TO_LCM_JFLAGS(name) copyFlags(s.name, msg.name);
#define EXOID_TO_LCM_VECX(name) copyVector(s.name, msg.name);
#define EXOID_TO_LCM_FEET3(name)                     \
  copyFixed<3>(s.name[0], msg.name##_right); \
  copyFixed<3>(s.name[1], msg.name##_left);
#define EXOID_TO_LCM_ABI_I32(name)

// ======================================= robot_state_t ================================================
bool fromLcm(const exoid_lcm::robot_state_t& msg, const std::vector<std::string>& expected_joint_names,
             RobotStateSample& out, std::string* why, RejectReason* reason) {
  Check c("robot_state_t", why, reason);
  const size_t n = expected_joint_names.size();
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick")) return false;
  if (!c.count(msg.num_joints, n, "num_joints")) return false;
  if (!c.length(msg.joint_names.size(), msg.num_joints, "joint_names") ||
      !c.length(msg.q.size(), msg.num_joints, "q") || !c.length(msg.tau.size(), msg.num_joints, "tau") ||
      !c.length(msg.has_tau.size(), msg.num_joints, "has_tau"))
    return false;
  if (!c.names(msg.joint_names, expected_joint_names, "joint_names")) return false;
  if (!c.measured(msg.q, "q") || !c.measured(msg.tau, "tau") || !c.measured(msg.imu_gyro, 3, "imu_gyro") ||
      !c.measured(msg.imu_accel, 3, "imu_accel"))
    return false;
  size_t i = 0;
  if (!unmeasuredTorquesZero(msg.tau.data(), msg.has_tau, n, &i))
    return c.fail(RejectReason::Malformed, "tau[%zu] is %g but has_tau[%zu] is false (must be 0)", i, msg.tau[i], i);
  if (!c.unitQuaternion(msg.imu_orientation, "imu_orientation")) return false;

  EXOID_SCHEMA_ROBOT_STATE(EXOID_FROM_LCM)
  return true;
}

void toLcm(const RobotStateSample& s, const std::vector<std::string>& joint_names, exoid_lcm::robot_state_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.q.size(), n, "RobotStateSample.q");
  requireSize(s.tau.size(), n, "RobotStateSample.tau");
  requireSize(s.has_tau.size(), n, "RobotStateSample.has_tau");
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  EXOID_SCHEMA_ROBOT_STATE(EXOID_TO_LCM)
}

// ======================================= force_plate_t ================================================
bool fromLcm(const exoid_lcm::force_plate_t& msg, int expected_plate, ForcePlateSample& out, std::string* why,
             RejectReason* reason) {
  Check c("force_plate_t", why, reason);
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick")) return false;
  int plate = -1;
  if (msg.plate_name == "right") plate = 0;
  else if (msg.plate_name == "left") plate = 1;
  else return c.fail(RejectReason::Malformed, "plate_name is '%.64s', expected 'right' or 'left'", msg.plate_name.c_str());
  if (expected_plate >= 0 && plate != expected_plate)
    return c.fail(RejectReason::Malformed, "plate_name is '%s' on a channel for the %s plate", msg.plate_name.c_str(),
                  plateName(expected_plate) ? plateName(expected_plate) : "?");
  if (!c.measured(msg.force, 3, "force") || !c.measured(msg.moment, 3, "moment") || !c.measured(msg.cop, 3, "cop") ||
      !c.measured(msg.plate_position, 3, "plate_position"))
    return false;
  if (!c.unitQuaternion(msg.plate_orientation, "plate_orientation")) return false;

  out.plate = plate;
  EXOID_SCHEMA_FORCE_PLATE(EXOID_FROM_LCM)
  return true;
}

void toLcm(const ForcePlateSample& s, exoid_lcm::force_plate_t& msg) {
  const char* name = plateName(s.plate);
  if (!name)
    throw std::invalid_argument("toLcm: ForcePlateSample.plate is " + std::to_string(s.plate) +
                                ", must be 0 (right) or 1 (left)");
  msg.plate_name = name;
  EXOID_SCHEMA_FORCE_PLATE(EXOID_TO_LCM)
}

// ======================================= joint_command_t ==============================================
bool fromLcm(const exoid_lcm::joint_command_t& msg, const std::vector<std::string>& expected_joint_names,
             JointCommandSample& out, std::string* why, RejectReason* reason) {
  Check c("joint_command_t", why, reason);
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick") ||
      !c.nonNegative(msg.source_tick, "source_tick"))
    return false;
  if (msg.source_tick > msg.tick)
    return c.fail(RejectReason::Malformed, "source_tick %lld is after tick %lld",
                  static_cast<long long>(msg.source_tick), static_cast<long long>(msg.tick));
  if (!c.range(msg.mode, exoid_lcm::joint_command_t::MODE_TORQUE, exoid_lcm::joint_command_t::MODE_OFF, "mode"))
    return false;
  if (!c.count(msg.num_joints, expected_joint_names.size(), "num_joints")) return false;
  if (!c.length(msg.joint_names.size(), msg.num_joints, "joint_names") ||
      !c.length(msg.tau.size(), msg.num_joints, "tau") || !c.length(msg.tau_ff.size(), msg.num_joints, "tau_ff"))
    return false;
  if (!c.names(msg.joint_names, expected_joint_names, "joint_names")) return false;
  if (!c.finite(msg.tau, "tau") || !c.finite(msg.tau_ff, "tau_ff")) return false;

  EXOID_SCHEMA_JOINT_COMMAND(EXOID_FROM_LCM)
  return true;
}

void toLcm(const JointCommandSample& s, const std::vector<std::string>& joint_names, exoid_lcm::joint_command_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.tau.size(), n, "JointCommandSample.tau");
  requireSize(s.tau_ff.size(), n, "JointCommandSample.tau_ff");
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  EXOID_SCHEMA_JOINT_COMMAND(EXOID_TO_LCM)
}

// ======================================= ground_truth_t ===============================================
bool fromLcm(const exoid_lcm::ground_truth_t& msg, const std::vector<std::string>& expected_joint_names,
             GroundTruthSample& out, std::string* why, RejectReason* reason) {
  Check c("ground_truth_t", why, reason);
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick")) return false;
  if (!c.count(msg.num_joints, expected_joint_names.size(), "num_joints")) return false;
  if (!c.length(msg.joint_names.size(), msg.num_joints, "joint_names") ||
      !c.length(msg.q.size(), msg.num_joints, "q") || !c.length(msg.v.size(), msg.num_joints, "v") ||
      !c.length(msg.a.size(), msg.num_joints, "a") ||
      !c.length(msg.tau_applied.size(), msg.num_joints, "tau_applied"))
    return false;
  if (!c.names(msg.joint_names, expected_joint_names, "joint_names")) return false;
  if (!c.measured(msg.base_position, 3, "base_position") || !c.measured(msg.base_omega, 3, "base_omega") ||
      !c.measured(msg.base_velocity, 3, "base_velocity") || !c.measured(msg.base_domega, 3, "base_domega") ||
      !c.measured(msg.base_acceleration, 3, "base_acceleration") || !c.measured(msg.q, "q") ||
      !c.measured(msg.v, "v") || !c.measured(msg.a, "a") || !c.measured(msg.tau_applied, "tau_applied") ||
      !c.measured(msg.foot_force_right, 3, "foot_force_right") ||
      !c.measured(msg.foot_moment_right, 3, "foot_moment_right") ||
      !c.measured(msg.foot_force_left, 3, "foot_force_left") || !c.measured(msg.foot_moment_left, 3, "foot_moment_left") ||
      !c.measured(msg.com, 3, "com"))
    return false;
  if (!c.unitQuaternion(msg.base_orientation, "base_orientation")) return false;

  EXOID_SCHEMA_GROUND_TRUTH(EXOID_FROM_LCM)
  return true;
}

void toLcm(const GroundTruthSample& s, const std::vector<std::string>& joint_names, exoid_lcm::ground_truth_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.q.size(), n, "GroundTruthSample.q");
  requireSize(s.v.size(), n, "GroundTruthSample.v");
  requireSize(s.a.size(), n, "GroundTruthSample.a");
  requireSize(s.tau_applied.size(), n, "GroundTruthSample.tau_applied");
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  EXOID_SCHEMA_GROUND_TRUTH(EXOID_TO_LCM)
}

// ======================================= controller_status_t ==========================================
bool fromLcm(const exoid_lcm::controller_status_t& msg, ControllerStatusSample& out, std::string* why,
             RejectReason* reason) {
  Check c("controller_status_t", why, reason);
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick")) return false;
  if (!c.range(msg.qp_status, 0, 3, "qp_status") || !c.nonNegative(msg.qp_iterations, "qp_iterations") ||
      !c.range(msg.move_index, -1, INT32_MAX, "move_index") || !c.nonNegative(msg.moves_done, "moves_done") ||
      !c.nonNegative(msg.fallbacks, "fallbacks") || !c.nonNegative(msg.rejected_inputs, "rejected_inputs") ||
      !c.nonNegative(msg.stale_inputs, "stale_inputs"))
    return false;
  if (!c.finite(msg.qp_solve_us, "qp_solve_us") || !c.finite(msg.tick_us, "tick_us") ||
      !c.finite(msg.com_ref, 3, "com_ref") || !c.finite(msg.com, 3, "com") ||
      !c.finite(msg.com_vel_ref, 3, "com_vel_ref") || !c.finite(msg.com_vel, 3, "com_vel") ||
      !c.finite(msg.momentum_rate_ref, 6, "momentum_rate_ref") || !c.finite(msg.momentum, 6, "momentum") ||
      !c.finite(msg.wrench_right, 6, "wrench_right") || !c.finite(msg.wrench_left, 6, "wrench_left"))
    return false;
  if (!c.nonNegative(&msg.qp_solve_us, 1, "qp_solve_us") || !c.nonNegative(&msg.tick_us, 1, "tick_us")) return false;

  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_FROM_LCM)
  return true;
}

void toLcm(const ControllerStatusSample& s, exoid_lcm::controller_status_t& msg) {
  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_TO_LCM)
}

// ======================================= estimator_output_t ===========================================
bool fromLcm(const exoid_lcm::estimator_output_t& msg, const std::vector<std::string>& expected_param_names,
             size_t expected_num_base, const std::vector<std::string>& expected_coord_names,
             EstimatorOutputSample& out, std::string* why, RejectReason* reason) {
  Check c("estimator_output_t", why, reason);
  if (!c.nonNegative(msg.utime, "utime") || !c.nonNegative(msg.tick, "tick") ||
      !c.nonNegative(msg.samples_used, "samples_used") || !c.nonNegative(msg.samples_rejected, "samples_rejected") ||
      !c.nonNegative(msg.rejected_nonfinite, "rejected_nonfinite") ||
      !c.nonNegative(msg.rejected_out_of_order, "rejected_out_of_order") ||
      !c.nonNegative(msg.rejected_duplicate, "rejected_duplicate") ||
      !c.nonNegative(msg.samples_missing, "samples_missing"))
    return false;
  if (static_cast<int64_t>(msg.rejected_nonfinite) + msg.rejected_out_of_order + msg.rejected_duplicate !=
      msg.samples_rejected)
    return c.fail(RejectReason::Malformed, "samples_rejected %d is not the sum of its reasons", msg.samples_rejected);
  if (!c.finite(msg.excitation, "excitation") || !c.finite(msg.effective_samples, "effective_samples")) return false;
  if (msg.excitation < 0.0 || msg.excitation > 1.0)
    return c.fail(RejectReason::Malformed, "excitation %g outside [0, 1]", msg.excitation);
  if (msg.effective_samples < 0.0)
    return c.fail(RejectReason::Malformed, "effective_samples %g is negative", msg.effective_samples);
  if (!c.count(msg.num_params, expected_param_names.size(), "num_params") ||
      (expected_num_base != kAnyNumBase && !c.count(msg.num_base, expected_num_base, "num_base")) ||
      !c.nonNegative(msg.num_base, "num_base") ||
      !c.count(msg.num_coords, expected_coord_names.size(), "num_coords"))
    return false;
  if (!c.length(msg.param_names.size(), msg.num_params, "param_names") ||
      !c.length(msg.params.size(), msg.num_params, "params") ||
      !c.length(msg.param_stddev.size(), msg.num_params, "param_stddev") ||
      !c.length(msg.base_params.size(), msg.num_base, "base_params") ||
      !c.length(msg.base_stddev.size(), msg.num_base, "base_stddev") ||
      !c.length(msg.coord_names.size(), msg.num_coords, "coord_names") ||
      !c.length(msg.tau_correction.size(), msg.num_coords, "tau_correction") ||
      !c.length(msg.residual_rms.size(), msg.num_coords, "residual_rms") ||
      !c.length(msg.tau_correction_stddev.size(), msg.num_coords, "tau_correction_stddev"))
    return false;
  if (!c.names(msg.param_names, expected_param_names, "param_names") ||
      !c.names(msg.coord_names, expected_coord_names, "coord_names"))
    return false;
  if (!c.finite(msg.params, "params") || !c.finite(msg.param_stddev, "param_stddev") ||
      !c.finite(msg.base_params, "base_params") || !c.finite(msg.base_stddev, "base_stddev") ||
      !c.finite(msg.tau_correction, "tau_correction") || !c.finite(msg.residual_rms, "residual_rms") ||
      !c.finite(msg.tau_correction_stddev, "tau_correction_stddev"))
    return false;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(msg.com_stddev[i]) || msg.com_stddev[i] < 0.0)
      return c.fail(std::isfinite(msg.com_stddev[i]) ? RejectReason::Malformed : RejectReason::NonFinite,
                    "com_stddev[%d] %g is not a finite one-sigma value", i, msg.com_stddev[i]);
  if (!c.nonNegative(msg.param_stddev.data(), msg.param_stddev.size(), "param_stddev") ||
      !c.nonNegative(msg.base_stddev.data(), msg.base_stddev.size(), "base_stddev") ||
      !c.nonNegative(msg.residual_rms.data(), msg.residual_rms.size(), "residual_rms") ||
      !c.nonNegative(msg.tau_correction_stddev.data(), msg.tau_correction_stddev.size(), "tau_correction_stddev"))
    return false;

  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_FROM_LCM)
  return true;
}

void toLcm(const EstimatorOutputSample& s, const std::vector<std::string>& param_names,
           const std::vector<std::string>& coord_names, exoid_lcm::estimator_output_t& msg) {
  requireSize(s.params.size(), param_names.size(), "EstimatorOutputSample.params");
  requireSize(s.param_stddev.size(), param_names.size(), "EstimatorOutputSample.param_stddev");
  requireSize(s.base_stddev.size(), static_cast<size_t>(s.base_params.size()), "EstimatorOutputSample.base_stddev");
  requireSize(s.tau_correction.size(), coord_names.size(), "EstimatorOutputSample.tau_correction");
  requireSize(s.residual_rms.size(), coord_names.size(), "EstimatorOutputSample.residual_rms");
  requireSize(s.tau_correction_stddev.size(), coord_names.size(), "EstimatorOutputSample.tau_correction_stddev");
  msg.num_params = count32(param_names.size());
  copyNames(param_names, msg.param_names);
  msg.num_base = count32(static_cast<size_t>(s.base_params.size()));
  msg.num_coords = count32(coord_names.size());
  copyNames(coord_names, msg.coord_names);
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_TO_LCM)
}

}  // namespace exoid
