#pragma once
// Sensor samples of a smooth made-up motion (joints swinging, base rocking, both feet loaded) for tests and
// benchmarks of the online estimator's bookkeeping and cost: they exercise every computation but are not
// dynamically consistent (the estimator tests that need physics use the simulator).
#include <cmath>
#include <random>

#include "exoid/model/model.hpp"
#include "exoid/samples.hpp"

namespace exoid::estimator::testing {

struct SensorTick {
  RobotStateSample state;
  ForcePlateSample plate[2];
};

inline SensorTick makeSensorTick(const Model& model) {
  SensorTick t;
  t.state.q = Eigen::VectorXd::Zero(model.njoints);
  t.state.tau = Eigen::VectorXd::Zero(model.njoints);
  t.state.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model.njoints, true);
  for (int i = 0; i < 2; ++i) {
    t.plate[i].plate = i;
    t.plate[i].plate_position = Eigen::Vector3d(0.0, i == 0 ? -0.1 : 0.1, -0.02);
  }
  return t;
}

/// Fills tick k (1 kHz). amplitude 0: standing still (only the noise moves).
inline void fillSensorTick(const Model& model, long k, double amplitude, double noise, std::mt19937_64& rng,
                           SensorTick& t) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double s = 1e-3 * static_cast<double>(k);
  t.state.tick = k;
  t.state.utime = 1000 * k;
  for (int j = 0; j < model.njoints; ++j) {
    t.state.q[j] = amplitude * std::sin(2.0 * M_PI * (0.3 + 0.07 * j) * s + j) + noise * 1e-3 * n(rng);
    t.state.tau[j] = 5.0 * std::sin(2.0 * M_PI * 0.5 * s + 0.3 * j) * amplitude + noise * 0.1 * n(rng);
  }
  const double roll = 0.5 * amplitude * std::sin(2.0 * M_PI * 0.4 * s);
  t.state.imu_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
  t.state.imu_gyro = Eigen::Vector3d(0.5 * amplitude * 2.0 * M_PI * 0.4 * std::cos(2.0 * M_PI * 0.4 * s), 0.0, 0.0) +
                     noise * 1e-3 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  t.state.imu_accel = t.state.imu_orientation.conjugate() * Eigen::Vector3d(0.0, 0.0, 9.81) +
                      noise * 1e-2 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  for (int i = 0; i < 2; ++i) {
    t.plate[i].tick = k;
    t.plate[i].utime = 1000 * k;
    const double share = 0.5 + (i == 0 ? 1.0 : -1.0) * 0.2 * amplitude * std::sin(2.0 * M_PI * 0.4 * s);
    t.plate[i].force = Eigen::Vector3d(0.0, 0.0, -400.0 * share) + noise * Eigen::Vector3d(n(rng), n(rng), n(rng));
    t.plate[i].moment = Eigen::Vector3d(5.0 * share, -3.0 * share, 0.0) + noise * 0.1 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
}

}  // namespace exoid::estimator::testing
