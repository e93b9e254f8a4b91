#pragma once
// Conversions between exoid's samples (exoid/samples.hpp) and the controller plugin ABI's plain C structs
// (controller_plugin.h), expanded from the message schema (exoid/interfaces/schema.h) and shared by the host
// (exoid_sim) and the C++ plugins, so that both sides copy the same doubles the same way (plugin mode computes
// the bits process mode computes). Allocation-free. The checks of a plugin's output (finite, in range) stay
// with who receives it: the host's ControllerPlugin, the plugin's own controller.
#include <cmath>

#include "exoid/controller_plugin.h"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::plugin_abi {

namespace detail {
// Field copies by kind. Joint arrays: the plain vector's size (<= EXOID_PLUGIN_MAX_JOINTS, checked by the
// callers below); VECX: the ABI points into the sample (to), the sample is pre-sized (from).
template <int N, class V>
inline void toArray(const V& v, double (&a)[N]) {
  for (int i = 0; i < N; ++i) a[i] = v[i];
}
inline void toArray(const Eigen::Quaterniond& q, double (&a)[4]) {
  a[0] = q.w();
  a[1] = q.x();
  a[2] = q.y();
  a[3] = q.z();
}
inline void toJoints(const Eigen::VectorXd& v, double* a) {
  for (Eigen::Index i = 0; i < v.size(); ++i) a[i] = v[i];
}
inline void toJoints(const Eigen::Matrix<bool, Eigen::Dynamic, 1>& v, uint8_t* a) {
  for (Eigen::Index i = 0; i < v.size(); ++i) a[i] = v[i] ? 1 : 0;
}
template <class V>
inline void fromArray(const double* a, V& v) {
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = a[i];
}
inline void fromArray(const uint8_t* a, Eigen::Matrix<bool, Eigen::Dynamic, 1>& v) {
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = a[i] != 0;
}
inline void fromArray(const double* a, Eigen::Quaterniond& q) { q = Eigen::Quaterniond(a[0], a[1], a[2], a[3]); }
}  // namespace detail

// sample s -> ABI struct p, one statement per schema row the ABI carries (ABI_I32 rows: by the caller).
#define EXOID_TO_ABI(KIND, name, init, abi) EXOID_TO_ABI_##abi(KIND, name)
#define EXOID_TO_ABI_NO(KIND, name)
#define EXOID_TO_ABI_YES(KIND, name) EXOID_TO_ABI_##KIND(name)
#define EXOID_TO_ABI_I64(name) p.name = s.name;
#define EXOID_TO_ABI_I32(name) p.name = s.name;
#define EXOID_TO_ABI_F64(name) p.name = s.name;
#define EXOID_TO_ABI_BOOL(name) p.name = s.name ? 1 : 0;
#define EXOID_TO_ABI_MODE(name) p.name = static_cast<int32_t>(s.name);
#define EXOID_TO_ABI_QP(name) p.name = static_cast<int32_t>(s.name);
#define EXOID_TO_ABI_PLATE(name) p.name = s.name;
#define EXOID_TO_ABI_V3(name) detail::toArray<3>(s.name, p.name);
#define EXOID_TO_ABI_V6(name) detail::toArray<6>(s.name, p.name);
#define EXOID_TO_ABI_QUAT(name) detail::toArray(s.name, p.name);
#define EXOID_TO_ABI_JOINTS(name) detail::toJoints(s.name, p.name);
#define EXOID_TO_ABI_JFLAGS(name) detail::toJoints(s.name, p.name);
#define EXOID_TO_ABI_VECX(name) p.name = s.name.data();
#define EXOID_TO_ABI_ABI_I32(name)

// ABI struct p -> sample s (pre-sized), the reverse.
#define EXOID_FROM_ABI(KIND, name, init, abi) EXOID_FROM_ABI_##abi(KIND, name)
#define EXOID_FROM_ABI_NO(KIND, name)
#define EXOID_FROM_ABI_YES(KIND, name) EXOID_FROM_ABI_##KIND(name)
#define EXOID_FROM_ABI_I64(name) s.name = p.name;
#define EXOID_FROM_ABI_I32(name) s.name = p.name;
#define EXOID_FROM_ABI_F64(name) s.name = p.name;
#define EXOID_FROM_ABI_BOOL(name) s.name = p.name != 0;
#define EXOID_FROM_ABI_MODE(name) s.name = static_cast<CommandMode>(p.name);
#define EXOID_FROM_ABI_QP(name) s.name = static_cast<QpStatus>(p.name);
#define EXOID_FROM_ABI_PLATE(name) s.name = p.name;
#define EXOID_FROM_ABI_V3(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_V6(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_QUAT(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_JOINTS(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_JFLAGS(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_VECX(name) detail::fromArray(p.name, s.name);
#define EXOID_FROM_ABI_ABI_I32(name)

/// Host -> plugin: the state of one physics tick (num_joints = s.q.size()). False (p untouched) when the
/// joint arrays disagree in size or exceed EXOID_PLUGIN_MAX_JOINTS.
inline bool toPlugin(const RobotStateSample& s, exoid_plugin_state& p) {
  const Eigen::Index n = s.q.size();
  if (n > EXOID_PLUGIN_MAX_JOINTS || s.tau.size() != n || s.has_tau.size() != n) return false;
  EXOID_SCHEMA_ROBOT_STATE(EXOID_TO_ABI)
  p.num_joints = static_cast<int32_t>(n);
  p.reserved = 0;
  return true;
}

/// Plugin side: the host's state into s, pre-sized for the plugin's joints. False (s untouched) on another
/// joint count.
inline bool fromPlugin(const exoid_plugin_state& p, RobotStateSample& s) {
  if (p.num_joints != s.q.size() || s.tau.size() != s.q.size() || s.has_tau.size() != s.q.size()) return false;
  EXOID_SCHEMA_ROBOT_STATE(EXOID_FROM_ABI)
  return true;
}

/// Plugin side: the command into the ABI (num_joints = s.tau.size()). False (p untouched) on sizes that
/// disagree or exceed EXOID_PLUGIN_MAX_JOINTS.
inline bool toPlugin(const JointCommandSample& s, exoid_plugin_command& p) {
  const Eigen::Index n = s.tau.size();
  if (n > EXOID_PLUGIN_MAX_JOINTS || s.tau_ff.size() != n) return false;
  EXOID_SCHEMA_JOINT_COMMAND(EXOID_TO_ABI)
  p.num_joints = static_cast<int32_t>(n);
  return true;
}

/// Host side: the plugin's command into s, pre-sized for the host's joints (p.num_joints, tick, mode and
/// finiteness are the host's checks, made before).
inline bool fromPlugin(const exoid_plugin_command& p, JointCommandSample& s) {
  if (p.num_joints != s.tau.size() || s.tau_ff.size() != s.tau.size()) return false;
  EXOID_SCHEMA_JOINT_COMMAND(EXOID_FROM_ABI)
  return true;
}

/// Plugin side: the status into the ABI (finished: the plugin's own, left as it is).
inline void toPlugin(const ControllerStatusSample& s, exoid_plugin_status& p) {
  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_TO_ABI)
}

/// Host side: the plugin's status into s (ranges and finiteness are the host's checks, made before).
inline void fromPlugin(const exoid_plugin_status& p, ControllerStatusSample& s) {
  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_FROM_ABI)
}

inline void toPlugin(const ForcePlateSample& s, exoid_plugin_force_plate& p) {
  EXOID_SCHEMA_FORCE_PLATE(EXOID_TO_ABI)
  p.reserved = 0;
}

/// The checks and the conversion exo_controller's fromLcm(force_plate_t) applies (adapters.cpp): plate index
/// as expected, everything finite, orientation unit within 1e-6 (kQuatNormTolerance) and then normalised, so
/// the controller gets the same bits in both shapes. False (s untouched) otherwise.
inline bool fromPlugin(const exoid_plugin_force_plate& p, int expected_plate, ForcePlateSample& s) {
  if (p.utime < 0 || p.tick < 0 || p.plate != expected_plate) return false;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(p.force[i]) || !std::isfinite(p.moment[i]) || !std::isfinite(p.cop[i]) ||
        !std::isfinite(p.plate_position[i]))
      return false;
  const double* q = p.plate_orientation;
  if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]) || !std::isfinite(q[3]) ||
      !(std::abs(std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) - 1.0) <= 1e-6))
    return false;
  EXOID_SCHEMA_FORCE_PLATE(EXOID_FROM_ABI)
  s.plate_orientation.normalize();
  return true;
}

/// The estimate as the ABI carries it: p's arrays point into s (valid while s is unchanged).
inline void toPlugin(const EstimatorOutputSample& s, exoid_plugin_estimate& p) {
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_TO_ABI)
  p.num_params = static_cast<int32_t>(s.params.size());
  p.num_coords = static_cast<int32_t>(s.tau_correction.size());
}

/// Copies the ABI's estimate into s, whose params and tau_correction are already sized for the plugin's model
/// (the values are copied as they are: the controller's setEstimate judges them). False (s untouched) on other
/// sizes or missing arrays.
inline bool fromPlugin(const exoid_plugin_estimate& p, EstimatorOutputSample& s) {
  if (!p.params || !p.tau_correction || !p.tau_correction_stddev || p.num_params != s.params.size() ||
      p.num_coords != s.tau_correction.size() || p.num_coords != s.tau_correction_stddev.size())
    return false;
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_FROM_ABI)
  return true;
}

}  // namespace exoid::plugin_abi
