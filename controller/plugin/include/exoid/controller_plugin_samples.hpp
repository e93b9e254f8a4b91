#pragma once
// Conversions between exoid's samples (exoid/samples.hpp) and the controller plugin ABI's plain C structs
// (controller_plugin.h), shared by the host (exoid_sim) and the C++ plugins so that both sides copy the same
// doubles the same way (plugin mode computes the bits process mode computes). Allocation-free.
#include <cmath>

#include "exoid/controller_plugin.h"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::plugin_abi {

inline void toPlugin(const ForcePlateSample& s, exoid_plugin_force_plate& p) {
  p.utime = s.utime;
  p.tick = s.tick;
  p.plate = s.plate;
  p.reserved = 0;
  for (int i = 0; i < 3; ++i) {
    p.force[i] = s.force[i];
    p.moment[i] = s.moment[i];
    p.cop[i] = s.cop[i];
    p.plate_position[i] = s.plate_position[i];
  }
  p.plate_orientation[0] = s.plate_orientation.w();
  p.plate_orientation[1] = s.plate_orientation.x();
  p.plate_orientation[2] = s.plate_orientation.y();
  p.plate_orientation[3] = s.plate_orientation.z();
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
  s.utime = p.utime;
  s.tick = p.tick;
  s.plate = p.plate;
  s.force = Eigen::Vector3d(p.force[0], p.force[1], p.force[2]);
  s.moment = Eigen::Vector3d(p.moment[0], p.moment[1], p.moment[2]);
  s.cop = Eigen::Vector3d(p.cop[0], p.cop[1], p.cop[2]);
  s.plate_position = Eigen::Vector3d(p.plate_position[0], p.plate_position[1], p.plate_position[2]);
  s.plate_orientation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  s.plate_orientation.normalize();
  return true;
}

/// The estimate as the ABI carries it: p's arrays point into s (valid while s is unchanged).
inline void toPlugin(const EstimatorOutputSample& s, exoid_plugin_estimate& p) {
  p.utime = s.utime;
  p.tick = s.tick;
  p.valid = s.valid ? 1 : 0;
  p.consistent = s.consistent ? 1 : 0;
  p.num_params = static_cast<int32_t>(s.params.size());
  p.num_coords = static_cast<int32_t>(s.tau_ff.size());
  p.params = s.params.data();
  p.tau_ff = s.tau_ff.data();
  p.excitation = s.excitation;
}

/// Copies the ABI's estimate into s, whose params and tau_ff are already sized for the plugin's model (the
/// values are copied as they are: the controller's setEstimate judges them). False (s untouched) on other
/// sizes or missing arrays.
inline bool fromPlugin(const exoid_plugin_estimate& p, EstimatorOutputSample& s) {
  if (!p.params || !p.tau_ff || p.num_params != s.params.size() || p.num_coords != s.tau_ff.size()) return false;
  s.utime = p.utime;
  s.tick = p.tick;
  s.valid = p.valid != 0;
  s.consistent = p.consistent != 0;
  s.excitation = p.excitation;
  for (int i = 0; i < p.num_params; ++i) s.params[i] = p.params[i];
  for (int i = 0; i < p.num_coords; ++i) s.tau_ff[i] = p.tau_ff[i];
  return true;
}

}  // namespace exoid::plugin_abi
