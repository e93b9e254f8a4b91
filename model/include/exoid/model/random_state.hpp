#pragma once
// Random states that excite every term of the dynamics: any base orientation, joint angles over a full
// turn, brisk velocities and accelerations. Used for structural base parameters and for tests.
#include <random>

#include "exoid/model/model.hpp"

namespace exoid {

/// Fills state (sized for the model): orientation a normalised uniform random 4-vector,
/// position and linear velocity in [-1, 1] m, m/s; angular velocity in [-2, 2] rad/s; angular and linear
/// accelerations in [-10, 10]; q in [-pi, pi], v in [-3, 3], a in [-20, 20].
inline void randomState(const Model& model, std::mt19937_64& rng, State& s) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto vec = [&](double scale) { return Eigen::Vector3d(scale * u(rng), scale * u(rng), scale * u(rng)); };
  s.base_orientation = Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized());
  s.base_position = vec(1.0);
  s.base_omega = vec(2.0);
  s.base_velocity = vec(1.0);
  s.base_domega = vec(10.0);
  s.base_acceleration = vec(10.0);
  for (int j = 0; j < model.njoints; ++j) {
    s.q[j] = M_PI * u(rng);
    s.v[j] = 3.0 * u(rng);
    s.a[j] = 20.0 * u(rng);
  }
}

}  // namespace exoid
