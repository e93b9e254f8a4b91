#pragma once
// Shared fixtures of the LCM adapter tests: deterministic, non-trivial samples and an encode/decode helper.
#include <exoid/lcm/adapters.hpp>

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace exoid::test {

inline const std::vector<std::string>& jointNames() {
  static const std::vector<std::string> names = {
      "right_hip_aa", "right_hip_fe", "right_knee", "right_ankle_pd", "right_ankle_ie",
      "left_hip_aa",  "left_hip_fe",  "left_knee",  "left_ankle_pd",  "left_ankle_ie"};
  return names;
}

inline const std::vector<std::string>& paramNames() {
  static const std::vector<std::string> names = {"body.m", "body.mx", "right_thigh.Ixx", "right_knee.fv",
                                                 "right_knee.fc"};
  return names;
}

inline const std::vector<std::string>& coordNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"base_nx", "base_ny", "base_nz", "base_fx", "base_fy", "base_fz"};
    n.insert(n.end(), jointNames().begin(), jointNames().end());
    return n;
  }();
  return names;
}
inline constexpr size_t kNumBase = 3;

/// Distinct, non-round values so a swapped or dropped field shows up.
inline double value(int field, int i) { return 0.1 * field + 0.013 * (i + 1) - 0.5 * (i % 3); }

inline Eigen::Quaterniond someRotation() {
  return Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()));
}

inline RobotStateSample makeState(int n = 10) {
  RobotStateSample s;
  s.utime = 1'700'000'000'123'456;
  s.tick = 4242;
  s.q.resize(n);
  s.tau.resize(n);
  s.has_tau.resize(n);
  for (int i = 0; i < n; ++i) {
    s.q[i] = value(1, i);
    s.has_tau[i] = (i % 5) != 4;  // ankle in/eversion joints have no torque sensor
    s.tau[i] = s.has_tau[i] ? value(2, i) : 0.0;
  }
  s.imu_orientation = someRotation();
  s.imu_gyro = Eigen::Vector3d(0.1, -0.2, 0.3);
  s.imu_accel = Eigen::Vector3d(0.4, -0.5, 9.7);
  return s;
}

inline ForcePlateSample makePlate(int plate) {
  ForcePlateSample s;
  s.utime = 123456789;
  s.tick = 77;
  s.plate = plate;
  s.force = Eigen::Vector3d(1.5, -2.5, 350.25);
  s.moment = Eigen::Vector3d(-3.25, 4.5, 0.125);
  s.cop = Eigen::Vector3d(0.01, -0.02, 0.0);
  s.plate_position = Eigen::Vector3d(0.0, plate == 0 ? -0.15 : 0.15, 0.0);
  s.plate_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(plate == 0 ? 0.1 : -0.2, Eigen::Vector3d::UnitZ()));
  return s;
}

inline JointCommandSample makeCommand(int n = 10) {
  JointCommandSample s;
  s.utime = 99;
  s.tick = 101;
  s.source_tick = 100;
  s.mode = CommandMode::Damping;
  s.tau.resize(n);
  s.tau_ff.resize(n);
  for (int i = 0; i < n; ++i) {
    s.tau[i] = value(3, i);
    s.tau_ff[i] = value(4, i);
  }
  return s;
}

inline GroundTruthSample makeTruth(int n = 10) {
  GroundTruthSample s;
  s.utime = 5;
  s.tick = 6;
  s.base_position = Eigen::Vector3d(0.1, 0.2, 0.9);
  s.base_orientation = someRotation().conjugate();
  s.base_omega = Eigen::Vector3d(0.01, 0.02, 0.03);
  s.base_velocity = Eigen::Vector3d(0.11, 0.12, 0.13);
  s.base_domega = Eigen::Vector3d(-0.1, -0.2, -0.3);
  s.base_acceleration = Eigen::Vector3d(1.1, 1.2, 1.3);
  s.q.resize(n);
  s.v.resize(n);
  s.a.resize(n);
  s.tau_applied.resize(n);
  for (int i = 0; i < n; ++i) {
    s.q[i] = value(5, i);
    s.v[i] = value(6, i);
    s.a[i] = value(7, i);
    s.tau_applied[i] = value(8, i);
  }
  s.foot_force[0] = Eigen::Vector3d(1, 2, 300);
  s.foot_force[1] = Eigen::Vector3d(-1, -2, 310);
  s.foot_moment[0] = Eigen::Vector3d(3, 4, 5);
  s.foot_moment[1] = Eigen::Vector3d(-3, -4, -5);
  s.com = Eigen::Vector3d(-0.03, 0.002, 0.92);
  s.has_trunk = true;
  s.trunk_angle = Eigen::Vector3d(0.04, -0.05, 0.06);
  s.trunk_rate = Eigen::Vector3d(-0.4, 0.5, -0.6);
  s.trunk_com = Eigen::Vector3d(0.01, -0.02, 1.31);
  return s;
}

inline ControllerStatusSample makeStatus() {
  ControllerStatusSample s;
  s.utime = 1000;
  s.tick = 10;
  s.qp_status = QpStatus::MaxIterations;
  s.qp_iterations = 37;
  s.qp_solve_us = 123.5;
  s.tick_us = 456.25;
  s.move_index = 2;
  s.moves_done = 2;
  s.com_ref = Eigen::Vector3d(0.01, 0.02, 0.95);
  s.com = Eigen::Vector3d(0.011, 0.019, 0.951);
  s.com_vel_ref = Eigen::Vector3d(0.1, 0, 0);
  s.com_vel = Eigen::Vector3d(0.09, 0.001, -0.002);
  for (int i = 0; i < 6; ++i) {
    s.momentum_rate_ref[i] = value(9, i);
    s.momentum[i] = value(10, i);
    s.wrench_right[i] = value(11, i);
    s.wrench_left[i] = value(12, i);
  }
  s.fallbacks = 1;
  s.rejected_inputs = 3;
  s.stale_inputs = 4;
  return s;
}

inline EstimatorOutputSample makeEstimate() {
  EstimatorOutputSample s;
  s.utime = 2000;
  s.tick = 20;
  s.valid = true;
  s.consistent = true;
  s.samples_used = 1234567890123;
  s.rejected_nonfinite = 5;
  s.rejected_out_of_order = 4;
  s.rejected_duplicate = 3;
  s.samples_rejected = 12;
  s.samples_missing = 7;
  s.excitation = 0.625;
  s.effective_samples = 9999.5;
  const int np = static_cast<int>(paramNames().size()), nc = static_cast<int>(coordNames().size());
  const int nb = static_cast<int>(kNumBase);
  s.params.resize(np);
  s.param_stddev.resize(np);
  for (int i = 0; i < np; ++i) {
    s.params[i] = value(13, i);
    s.param_stddev[i] = 0.001 * (i + 1);
  }
  s.base_params.resize(nb);
  s.base_stddev.resize(nb);
  for (int i = 0; i < nb; ++i) {
    s.base_params[i] = value(15, i);
    s.base_stddev[i] = 0.002 * (i + 1);
  }
  s.tau_correction.resize(nc);
  s.residual_rms.resize(nc);
  s.tau_correction_stddev.resize(nc);
  for (int i = 0; i < nc; ++i) {
    s.tau_correction[i] = value(14, i);
    s.residual_rms[i] = 0.01 * (i + 1);
    s.tau_correction_stddev[i] = 0.003 * (i + 1);
  }
  s.com_stddev = Eigen::Vector3d(0.0011, 0.0012, 0.0043);
  s.mass_stddev = 0.021;
  return s;
}

// Exact, size-checked equality of every field (a partial write by a rejecting fromLcm shows up here).
template <class A, class B>
bool sameMat(const A& a, const B& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.size() == 0 || (a.array() == b.array()).all());
}
inline bool sameQuat(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return sameMat(a.coeffs(), b.coeffs());
}
inline bool same(const RobotStateSample& a, const RobotStateSample& b) {
  return a.utime == b.utime && a.tick == b.tick && sameMat(a.q, b.q) && sameMat(a.tau, b.tau) &&
         sameMat(a.has_tau, b.has_tau) && sameQuat(a.imu_orientation, b.imu_orientation) &&
         sameMat(a.imu_gyro, b.imu_gyro) && sameMat(a.imu_accel, b.imu_accel);
}
inline bool same(const ForcePlateSample& a, const ForcePlateSample& b) {
  return a.utime == b.utime && a.tick == b.tick && a.plate == b.plate && sameMat(a.force, b.force) &&
         sameMat(a.moment, b.moment) && sameMat(a.cop, b.cop) && sameMat(a.plate_position, b.plate_position) &&
         sameQuat(a.plate_orientation, b.plate_orientation);
}
inline bool same(const JointCommandSample& a, const JointCommandSample& b) {
  return a.utime == b.utime && a.tick == b.tick && a.source_tick == b.source_tick && a.mode == b.mode &&
         sameMat(a.tau, b.tau) && sameMat(a.tau_ff, b.tau_ff);
}
inline bool same(const GroundTruthSample& a, const GroundTruthSample& b) {
  bool feet = true;
  for (int f = 0; f < 2; ++f)
    feet = feet && sameMat(a.foot_force[f], b.foot_force[f]) && sameMat(a.foot_moment[f], b.foot_moment[f]);
  return feet && a.utime == b.utime && a.tick == b.tick && sameMat(a.base_position, b.base_position) &&
         sameQuat(a.base_orientation, b.base_orientation) && sameMat(a.base_omega, b.base_omega) &&
         sameMat(a.base_velocity, b.base_velocity) && sameMat(a.base_domega, b.base_domega) &&
         sameMat(a.base_acceleration, b.base_acceleration) && sameMat(a.q, b.q) && sameMat(a.v, b.v) &&
         sameMat(a.a, b.a) && sameMat(a.tau_applied, b.tau_applied);
}
inline bool same(const ControllerStatusSample& a, const ControllerStatusSample& b) {
  return a.utime == b.utime && a.tick == b.tick && a.qp_status == b.qp_status &&
         a.qp_iterations == b.qp_iterations && a.qp_solve_us == b.qp_solve_us && a.tick_us == b.tick_us &&
         a.move_index == b.move_index && a.moves_done == b.moves_done && sameMat(a.com_ref, b.com_ref) &&
         sameMat(a.com, b.com) && sameMat(a.com_vel_ref, b.com_vel_ref) && sameMat(a.com_vel, b.com_vel) &&
         sameMat(a.momentum_rate_ref, b.momentum_rate_ref) && sameMat(a.momentum, b.momentum) &&
         sameMat(a.wrench_right, b.wrench_right) && sameMat(a.wrench_left, b.wrench_left) &&
         a.fallbacks == b.fallbacks && a.rejected_inputs == b.rejected_inputs && a.stale_inputs == b.stale_inputs;
}
inline bool same(const EstimatorOutputSample& a, const EstimatorOutputSample& b) {
  return a.utime == b.utime && a.tick == b.tick && a.valid == b.valid && a.consistent == b.consistent &&
         a.samples_used == b.samples_used && a.samples_rejected == b.samples_rejected &&
         a.rejected_nonfinite == b.rejected_nonfinite && a.rejected_out_of_order == b.rejected_out_of_order &&
         a.rejected_duplicate == b.rejected_duplicate && a.samples_missing == b.samples_missing &&
         a.excitation == b.excitation && a.effective_samples == b.effective_samples && sameMat(a.params, b.params) &&
         sameMat(a.param_stddev, b.param_stddev) && sameMat(a.base_params, b.base_params) &&
         sameMat(a.base_stddev, b.base_stddev) && sameMat(a.tau_correction, b.tau_correction) && sameMat(a.residual_rms, b.residual_rms) &&
         sameMat(a.tau_correction_stddev, b.tau_correction_stddev) && sameMat(a.com_stddev, b.com_stddev) &&
         a.mass_stddev == b.mass_stddev;
}

/// Encodes with LCM's own encoder and decodes into a fresh message.
template <class Msg>
Msg encodeDecode(const Msg& msg) {
  const int size = msg.getEncodedSize();
  EXPECT_GT(size, 0);
  std::vector<uint8_t> buf(static_cast<size_t>(size));
  EXPECT_EQ(msg.encode(buf.data(), 0, size), size);
  Msg out;
  EXPECT_EQ(out.decode(buf.data(), 0, size), size);
  return out;
}

}  // namespace exoid::test
