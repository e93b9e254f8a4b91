#pragma once
// The gate's value rules, written once, with one set of thresholds: the LCM adapters' fromLcm (and through it
// MessageGate and every log reader) apply them to a message's fields, the online estimator's admit to the
// in-process samples. The order rule (duplicate, out of order) is the tick assembly's (tick_assembly.hpp) or
// MessageGate's (tick_order.hpp). Real-time safe: no allocation, no exception.
#include <cmath>
#include <cstddef>

#include "exoid/samples.hpp"

namespace exoid {

/// Largest accepted | |q| - 1 | of an orientation quaternion (IMU, plate): a unit quaternion from any double or
/// float32 source is within 1e-7; a larger error is a corrupted or unnormalised value, not rounding.
inline constexpr double kUnitQuaternionTolerance = 1e-6;

/// Largest accepted |value| of a measured sample (state, plate, truth), SI units. Not a physical limit (the
/// CSV intake has those, per quantity): the range within which what the consumers compute from a sample
/// (rotations, r x F, v^2, normal equations, sums of a few such terms) stays far inside a double's range.
/// No sensor of a legged robot reads 1e9 (1 GN, 1000 km, 1e9 rad/s); a larger value is a corrupted one.
inline constexpr double kMaxSampleMagnitude = 1e9;

enum class SampleFault {
  None,
  Malformed,  ///< wrong size, plate index, a non-unit quaternion, a torque where the joint has no sensor,
              ///< a finite value beyond kMaxSampleMagnitude
  NonFinite,  ///< a NaN or Inf value
};

/// Every v[i] finite.
inline bool allFiniteValues(const double* v, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

/// Every |v[i]| <= kMaxSampleMagnitude (finite values assumed checked); *bad: the first offending i.
inline bool withinSampleRange(const double* v, size_t n, size_t* bad = nullptr) {
  for (size_t i = 0; i < n; ++i)
    if (!(std::abs(v[i]) <= kMaxSampleMagnitude)) {
      if (bad) *bad = i;
      return false;
    }
  return true;
}

/// | sqrt(w^2 + x^2 + y^2 + z^2) - 1 | <= kUnitQuaternionTolerance (finite components assumed checked).
inline bool unitQuaternion(double w, double x, double y, double z, double* norm = nullptr) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  if (norm) *norm = n;
  return std::abs(n - 1.0) <= kUnitQuaternionTolerance;
}

/// tau[i] == 0 wherever has_tau[i] is false (an unmeasured torque must read 0); *bad: the first offending i.
template <class Flags>
bool unmeasuredTorquesZero(const double* tau, const Flags& has_tau, size_t n, size_t* bad = nullptr) {
  for (size_t i = 0; i < n; ++i)
    if (!has_tau[i] && tau[i] != 0.0) {
      if (bad) *bad = i;
      return false;
    }
  return true;
}

/// Sizes of a state sample against the model: q, tau, has_tau [njoints].
inline bool stateSizesOk(const RobotStateSample& s, int njoints) {
  return s.q.size() == njoints && s.tau.size() == njoints && s.has_tau.size() == njoints;
}

/// Values of a state sample of the right sizes: finite q, tau, IMU within kMaxSampleMagnitude; unit
/// orientation; tau 0 where no sensor.
inline SampleFault checkStateValues(const RobotStateSample& s) {
  const Eigen::Quaterniond& o = s.imu_orientation;
  if (!allFiniteValues(s.q.data(), static_cast<size_t>(s.q.size())) ||
      !allFiniteValues(s.tau.data(), static_cast<size_t>(s.tau.size())) || !allFiniteValues(s.imu_gyro.data(), 3) ||
      !allFiniteValues(s.imu_accel.data(), 3) || !allFiniteValues(o.coeffs().data(), 4))
    return SampleFault::NonFinite;
  if (!withinSampleRange(s.q.data(), static_cast<size_t>(s.q.size())) ||
      !withinSampleRange(s.tau.data(), static_cast<size_t>(s.tau.size())) || !withinSampleRange(s.imu_gyro.data(), 3) ||
      !withinSampleRange(s.imu_accel.data(), 3))
    return SampleFault::Malformed;
  if (!unitQuaternion(o.w(), o.x(), o.y(), o.z())) return SampleFault::Malformed;
  if (!unmeasuredTorquesZero(s.tau.data(), s.has_tau, static_cast<size_t>(s.tau.size()))) return SampleFault::Malformed;
  return SampleFault::None;
}

/// Plate index 0 (right) or 1 (left).
inline bool plateIndexOk(const ForcePlateSample& p) { return p.plate == 0 || p.plate == 1; }

/// Values of a plate sample: finite force, moment, CoP, position within kMaxSampleMagnitude; unit orientation.
inline SampleFault checkPlateValues(const ForcePlateSample& p) {
  const Eigen::Quaterniond& o = p.plate_orientation;
  if (!allFiniteValues(p.force.data(), 3) || !allFiniteValues(p.moment.data(), 3) || !allFiniteValues(p.cop.data(), 3) ||
      !allFiniteValues(p.plate_position.data(), 3) || !allFiniteValues(o.coeffs().data(), 4))
    return SampleFault::NonFinite;
  if (!withinSampleRange(p.force.data(), 3) || !withinSampleRange(p.moment.data(), 3) ||
      !withinSampleRange(p.cop.data(), 3) || !withinSampleRange(p.plate_position.data(), 3))
    return SampleFault::Malformed;
  if (!unitQuaternion(o.w(), o.x(), o.y(), o.z())) return SampleFault::Malformed;
  return SampleFault::None;
}

}  // namespace exoid
