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

}  // namespace

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
  if (!c.finite(msg.q, "q") || !c.finite(msg.tau, "tau") || !c.finite(msg.imu_gyro, 3, "imu_gyro") ||
      !c.finite(msg.imu_accel, 3, "imu_accel"))
    return false;
  size_t i = 0;
  if (!unmeasuredTorquesZero(msg.tau.data(), msg.has_tau, n, &i))
    return c.fail(RejectReason::Malformed, "tau[%zu] is %g but has_tau[%zu] is false (must be 0)", i, msg.tau[i], i);
  if (!c.unitQuaternion(msg.imu_orientation, "imu_orientation")) return false;

  out.utime = msg.utime;
  out.tick = msg.tick;
  copyVector(msg.q, out.q);
  copyVector(msg.tau, out.tau);
  if (out.has_tau.size() != static_cast<Eigen::Index>(n)) out.has_tau.resize(static_cast<Eigen::Index>(n));
  for (size_t i = 0; i < n; ++i) out.has_tau[static_cast<Eigen::Index>(i)] = msg.has_tau[i] != 0;
  out.imu_orientation = normalisedQuat(msg.imu_orientation);
  out.imu_gyro = vec3(msg.imu_gyro);
  out.imu_accel = vec3(msg.imu_accel);
  return true;
}

void toLcm(const RobotStateSample& s, const std::vector<std::string>& joint_names, exoid_lcm::robot_state_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.q.size(), n, "RobotStateSample.q");
  requireSize(s.tau.size(), n, "RobotStateSample.tau");
  requireSize(s.has_tau.size(), n, "RobotStateSample.has_tau");
  msg.utime = s.utime;
  msg.tick = s.tick;
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  copyVector(s.q, msg.q);
  copyVector(s.tau, msg.tau);
  if (msg.has_tau.size() != n) msg.has_tau.resize(n);
  for (size_t i = 0; i < n; ++i) msg.has_tau[i] = s.has_tau[static_cast<Eigen::Index>(i)] ? 1 : 0;
  copyQuat(s.imu_orientation, msg.imu_orientation);
  copyFixed<3>(s.imu_gyro, msg.imu_gyro);
  copyFixed<3>(s.imu_accel, msg.imu_accel);
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
  if (!c.finite(msg.force, 3, "force") || !c.finite(msg.moment, 3, "moment") || !c.finite(msg.cop, 3, "cop") ||
      !c.finite(msg.plate_position, 3, "plate_position"))
    return false;
  if (!c.unitQuaternion(msg.plate_orientation, "plate_orientation")) return false;

  out.utime = msg.utime;
  out.tick = msg.tick;
  out.plate = plate;
  out.force = vec3(msg.force);
  out.moment = vec3(msg.moment);
  out.cop = vec3(msg.cop);
  out.plate_position = vec3(msg.plate_position);
  out.plate_orientation = normalisedQuat(msg.plate_orientation);
  return true;
}

void toLcm(const ForcePlateSample& s, exoid_lcm::force_plate_t& msg) {
  const char* name = plateName(s.plate);
  if (!name)
    throw std::invalid_argument("toLcm: ForcePlateSample.plate is " + std::to_string(s.plate) +
                                ", must be 0 (right) or 1 (left)");
  msg.utime = s.utime;
  msg.tick = s.tick;
  msg.plate_name = name;
  copyFixed<3>(s.force, msg.force);
  copyFixed<3>(s.moment, msg.moment);
  copyFixed<3>(s.cop, msg.cop);
  copyFixed<3>(s.plate_position, msg.plate_position);
  copyQuat(s.plate_orientation, msg.plate_orientation);
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

  out.utime = msg.utime;
  out.tick = msg.tick;
  out.source_tick = msg.source_tick;
  out.mode = static_cast<CommandMode>(msg.mode);
  copyVector(msg.tau, out.tau);
  copyVector(msg.tau_ff, out.tau_ff);
  return true;
}

void toLcm(const JointCommandSample& s, const std::vector<std::string>& joint_names, exoid_lcm::joint_command_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.tau.size(), n, "JointCommandSample.tau");
  requireSize(s.tau_ff.size(), n, "JointCommandSample.tau_ff");
  msg.utime = s.utime;
  msg.tick = s.tick;
  msg.source_tick = s.source_tick;
  msg.mode = static_cast<int8_t>(s.mode);
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  copyVector(s.tau, msg.tau);
  copyVector(s.tau_ff, msg.tau_ff);
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
  if (!c.finite(msg.base_position, 3, "base_position") || !c.finite(msg.base_omega, 3, "base_omega") ||
      !c.finite(msg.base_velocity, 3, "base_velocity") || !c.finite(msg.base_domega, 3, "base_domega") ||
      !c.finite(msg.base_acceleration, 3, "base_acceleration") || !c.finite(msg.q, "q") ||
      !c.finite(msg.v, "v") || !c.finite(msg.a, "a") || !c.finite(msg.tau_applied, "tau_applied") ||
      !c.finite(msg.foot_force_right, 3, "foot_force_right") ||
      !c.finite(msg.foot_moment_right, 3, "foot_moment_right") ||
      !c.finite(msg.foot_force_left, 3, "foot_force_left") || !c.finite(msg.foot_moment_left, 3, "foot_moment_left") ||
      !c.finite(msg.com, 3, "com"))
    return false;
  if (!c.unitQuaternion(msg.base_orientation, "base_orientation")) return false;

  out.utime = msg.utime;
  out.tick = msg.tick;
  out.base_position = vec3(msg.base_position);
  out.base_orientation = normalisedQuat(msg.base_orientation);
  out.base_omega = vec3(msg.base_omega);
  out.base_velocity = vec3(msg.base_velocity);
  out.base_domega = vec3(msg.base_domega);
  out.base_acceleration = vec3(msg.base_acceleration);
  copyVector(msg.q, out.q);
  copyVector(msg.v, out.v);
  copyVector(msg.a, out.a);
  copyVector(msg.tau_applied, out.tau_applied);
  out.foot_force[0] = vec3(msg.foot_force_right);
  out.foot_moment[0] = vec3(msg.foot_moment_right);
  out.foot_force[1] = vec3(msg.foot_force_left);
  out.foot_moment[1] = vec3(msg.foot_moment_left);
  out.com = vec3(msg.com);
  return true;
}

void toLcm(const GroundTruthSample& s, const std::vector<std::string>& joint_names, exoid_lcm::ground_truth_t& msg) {
  const size_t n = joint_names.size();
  requireSize(s.q.size(), n, "GroundTruthSample.q");
  requireSize(s.v.size(), n, "GroundTruthSample.v");
  requireSize(s.a.size(), n, "GroundTruthSample.a");
  requireSize(s.tau_applied.size(), n, "GroundTruthSample.tau_applied");
  msg.utime = s.utime;
  msg.tick = s.tick;
  copyFixed<3>(s.base_position, msg.base_position);
  copyQuat(s.base_orientation, msg.base_orientation);
  copyFixed<3>(s.base_omega, msg.base_omega);
  copyFixed<3>(s.base_velocity, msg.base_velocity);
  copyFixed<3>(s.base_domega, msg.base_domega);
  copyFixed<3>(s.base_acceleration, msg.base_acceleration);
  msg.num_joints = count32(n);
  copyNames(joint_names, msg.joint_names);
  copyVector(s.q, msg.q);
  copyVector(s.v, msg.v);
  copyVector(s.a, msg.a);
  copyVector(s.tau_applied, msg.tau_applied);
  copyFixed<3>(s.foot_force[0], msg.foot_force_right);
  copyFixed<3>(s.foot_moment[0], msg.foot_moment_right);
  copyFixed<3>(s.foot_force[1], msg.foot_force_left);
  copyFixed<3>(s.foot_moment[1], msg.foot_moment_left);
  copyFixed<3>(s.com, msg.com);
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

  out.utime = msg.utime;
  out.tick = msg.tick;
  out.qp_status = static_cast<QpStatus>(msg.qp_status);
  out.qp_iterations = msg.qp_iterations;
  out.qp_solve_us = msg.qp_solve_us;
  out.tick_us = msg.tick_us;
  out.move_index = msg.move_index;
  out.moves_done = msg.moves_done;
  out.com_ref = vec3(msg.com_ref);
  out.com = vec3(msg.com);
  out.com_vel_ref = vec3(msg.com_vel_ref);
  out.com_vel = vec3(msg.com_vel);
  out.momentum_rate_ref = vec6(msg.momentum_rate_ref);
  out.momentum = vec6(msg.momentum);
  out.wrench_right = vec6(msg.wrench_right);
  out.wrench_left = vec6(msg.wrench_left);
  out.fallbacks = msg.fallbacks;
  out.rejected_inputs = msg.rejected_inputs;
  out.stale_inputs = msg.stale_inputs;
  return true;
}

void toLcm(const ControllerStatusSample& s, exoid_lcm::controller_status_t& msg) {
  msg.utime = s.utime;
  msg.tick = s.tick;
  msg.qp_status = static_cast<int8_t>(s.qp_status);
  msg.qp_iterations = s.qp_iterations;
  msg.qp_solve_us = s.qp_solve_us;
  msg.tick_us = s.tick_us;
  msg.move_index = s.move_index;
  msg.moves_done = s.moves_done;
  copyFixed<3>(s.com_ref, msg.com_ref);
  copyFixed<3>(s.com, msg.com);
  copyFixed<3>(s.com_vel_ref, msg.com_vel_ref);
  copyFixed<3>(s.com_vel, msg.com_vel);
  copyFixed<6>(s.momentum_rate_ref, msg.momentum_rate_ref);
  copyFixed<6>(s.momentum, msg.momentum);
  copyFixed<6>(s.wrench_right, msg.wrench_right);
  copyFixed<6>(s.wrench_left, msg.wrench_left);
  msg.fallbacks = s.fallbacks;
  msg.rejected_inputs = s.rejected_inputs;
  msg.stale_inputs = s.stale_inputs;
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
      !c.length(msg.tau_ff.size(), msg.num_coords, "tau_ff") ||
      !c.length(msg.residual_rms.size(), msg.num_coords, "residual_rms"))
    return false;
  if (!c.names(msg.param_names, expected_param_names, "param_names") ||
      !c.names(msg.coord_names, expected_coord_names, "coord_names"))
    return false;
  if (!c.finite(msg.params, "params") || !c.finite(msg.param_stddev, "param_stddev") ||
      !c.finite(msg.base_params, "base_params") || !c.finite(msg.base_stddev, "base_stddev") ||
      !c.finite(msg.tau_ff, "tau_ff") || !c.finite(msg.residual_rms, "residual_rms"))
    return false;
  if (!c.nonNegative(msg.param_stddev.data(), msg.param_stddev.size(), "param_stddev") ||
      !c.nonNegative(msg.base_stddev.data(), msg.base_stddev.size(), "base_stddev") ||
      !c.nonNegative(msg.residual_rms.data(), msg.residual_rms.size(), "residual_rms"))
    return false;

  out.utime = msg.utime;
  out.tick = msg.tick;
  out.valid = msg.valid != 0;
  out.consistent = msg.consistent != 0;
  out.samples_used = msg.samples_used;
  out.samples_rejected = msg.samples_rejected;
  out.rejected_nonfinite = msg.rejected_nonfinite;
  out.rejected_out_of_order = msg.rejected_out_of_order;
  out.rejected_duplicate = msg.rejected_duplicate;
  out.samples_missing = msg.samples_missing;
  out.excitation = msg.excitation;
  out.effective_samples = msg.effective_samples;
  copyVector(msg.params, out.params);
  copyVector(msg.param_stddev, out.param_stddev);
  copyVector(msg.base_params, out.base_params);
  copyVector(msg.base_stddev, out.base_stddev);
  copyVector(msg.tau_ff, out.tau_ff);
  copyVector(msg.residual_rms, out.residual_rms);
  return true;
}

void toLcm(const EstimatorOutputSample& s, const std::vector<std::string>& param_names,
           const std::vector<std::string>& coord_names, exoid_lcm::estimator_output_t& msg) {
  requireSize(s.params.size(), param_names.size(), "EstimatorOutputSample.params");
  requireSize(s.param_stddev.size(), param_names.size(), "EstimatorOutputSample.param_stddev");
  requireSize(s.base_stddev.size(), static_cast<size_t>(s.base_params.size()), "EstimatorOutputSample.base_stddev");
  requireSize(s.tau_ff.size(), coord_names.size(), "EstimatorOutputSample.tau_ff");
  requireSize(s.residual_rms.size(), coord_names.size(), "EstimatorOutputSample.residual_rms");
  msg.utime = s.utime;
  msg.tick = s.tick;
  msg.valid = s.valid ? 1 : 0;
  msg.consistent = s.consistent ? 1 : 0;
  msg.samples_used = s.samples_used;
  msg.samples_rejected = s.samples_rejected;
  msg.rejected_nonfinite = s.rejected_nonfinite;
  msg.rejected_out_of_order = s.rejected_out_of_order;
  msg.rejected_duplicate = s.rejected_duplicate;
  msg.samples_missing = s.samples_missing;
  msg.excitation = s.excitation;
  msg.effective_samples = s.effective_samples;
  msg.num_params = count32(param_names.size());
  copyNames(param_names, msg.param_names);
  copyVector(s.params, msg.params);
  copyVector(s.param_stddev, msg.param_stddev);
  msg.num_base = count32(static_cast<size_t>(s.base_params.size()));
  copyVector(s.base_params, msg.base_params);
  copyVector(s.base_stddev, msg.base_stddev);
  msg.num_coords = count32(coord_names.size());
  copyNames(coord_names, msg.coord_names);
  copyVector(s.tau_ff, msg.tau_ff);
  copyVector(s.residual_rms, msg.residual_rms);
}

}  // namespace exoid
