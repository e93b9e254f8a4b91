#pragma once
#include <unistd.h>
// Shared helpers of the sim tests: a fixture that turns MuJoCo warnings into failures, a tiny inline biped
// that satisfies the sim's MJCF contract, temp files, and the global allocation counter (test_sim_core.cpp).
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "exoid/sim/config.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::sim::test {

#ifndef EXOID_CONFIG_DIR
#error "EXOID_CONFIG_DIR must point to config/"
#endif
inline std::string configPath(const std::string& rel) { return std::string(EXOID_CONFIG_DIR) + "/" + rel; }

/// Collects MuJoCo warnings; every test of the sim runs under it and fails on any warning.
class MujocoWarningsFail : public ::testing::Test {
 protected:
  static std::vector<std::string>& warnings() {
    static std::vector<std::string> w;
    return w;
  }
  static void onWarning(const char* msg) { warnings().push_back(msg); }
  void SetUp() override {
    warnings().clear();
    previous_ = mju_user_warning;
    mju_user_warning = &MujocoWarningsFail::onWarning;
  }
  void TearDown() override {
    mju_user_warning = previous_;
    for (const std::string& w : warnings()) ADD_FAILURE() << "MuJoCo warning: " << w;
  }

 private:
  void (*previous_)(const char*) = nullptr;
};

/// Writes `text` to a fresh file under the test's temp dir and returns its path.
/// Writes a file private to this process (ctest runs test cases as parallel processes: a shared name raced).
inline std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/exoid_sim_" + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path) << text;
  return path;
}

/// A 5-body biped on two plates with the sim's names: free base "body" with site "imu", per leg a hip and
/// an ankle hinge, sole boxes on the plates (sole bottoms at z = 0 = plate tops), motors on both hips and the
/// right ankle only (left ankle unactuated, so it has no torque sensor). Mass 5 + 2 * (2 + 0.5) = 10 kg.
inline const char* kTinyBiped = R"(
<mujoco model="tiny_biped">
  <option timestep="0.001" gravity="0 0 -9.81" integrator="Euler" cone="elliptic" impratio="10"
          solver="Newton" iterations="100" tolerance="1e-12"/>
  <default>
    <geom contype="0" conaffinity="0" density="0"/>
    <default class="contact"><geom contype="1" conaffinity="1" friction="1 0.005 0.0001" solref="0.005 1"
                                   solimp="0.95 0.99 0.001"/></default>
  </default>
  <worldbody>
    <body name="right_plate" pos="0 -0.1 -0.02">
      <inertial pos="0 0 0" mass="5" diaginertia="0.1 0.1 0.1"/>
      <geom name="right_plate_top" class="contact" type="box" size="0.2 0.08 0.02"/>
      <site name="right_plate_sensor" pos="0 0 0.02"/>
    </body>
    <body name="left_plate" pos="0 0.1 -0.02">
      <inertial pos="0 0 0" mass="5" diaginertia="0.1 0.1 0.1"/>
      <geom name="left_plate_top" class="contact" type="box" size="0.2 0.08 0.02"/>
      <site name="left_plate_sensor" pos="0 0 0.02"/>
    </body>
    <body name="body" pos="0 0 0.5">
      <freejoint name="base"/>
      <inertial pos="0.01 0.005 0.1" mass="5" diaginertia="0.1 0.08 0.05"/>
      <site name="imu"/>
      <body name="right_leg" pos="0 -0.1 0">
        <joint name="right_hip" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="2" diaginertia="0.02 0.02 0.002"/>
        <body name="right_foot" pos="0 0 -0.45">
          <joint name="right_ankle" type="hinge" axis="0 1 0"/>
          <inertial pos="0.02 0 -0.02" mass="0.5" diaginertia="0.001 0.002 0.002"/>
          <geom name="right_sole" class="contact" type="box" size="0.1 0.04 0.01" pos="0.02 0 -0.04"/>
        </body>
      </body>
      <body name="left_leg" pos="0 0.1 0">
        <joint name="left_hip" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="2" diaginertia="0.02 0.02 0.002"/>
        <body name="left_foot" pos="0 0 -0.45">
          <joint name="left_ankle" type="hinge" axis="1 0 0"/>
          <inertial pos="0.02 0 -0.02" mass="0.5" diaginertia="0.001 0.002 0.002"/>
          <geom name="left_sole" class="contact" type="box" size="0.1 0.04 0.01" pos="0.02 0 -0.04"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="right_hip" joint="right_hip" gear="2" ctrllimited="true" ctrlrange="-20 20"/>
    <motor name="right_ankle" joint="right_ankle" ctrllimited="true" ctrlrange="-30 30"/>
    <motor name="left_hip" joint="left_hip" ctrllimited="true" ctrlrange="-40 40"/>
  </actuator>
  <sensor>
    <actuatorfrc actuator="right_hip"/>
    <actuatorfrc actuator="right_ankle"/>
    <actuatorfrc actuator="left_hip"/>
    <framequat objtype="site" objname="imu"/>
    <gyro site="imu"/>
    <accelerometer site="imu"/>
    <force site="right_plate_sensor"/>
    <torque site="right_plate_sensor"/>
    <force site="left_plate_sensor"/>
    <torque site="left_plate_sensor"/>
  </sensor>
</mujoco>
)";

inline std::string tinyBipedPath() { return writeTemp("tiny_biped.xml", kTinyBiped); }

/// A scenario in memory (no file): seed, noise mode, effects as given.
inline Scenario makeScenario(NoiseMode noise, uint64_t seed = 1) {
  Scenario s;
  s.name = "test";
  s.source = "test-scenario";
  s.seed = seed;
  s.noise = noise;
  return s;
}

/// The realistic sensors file of the repository (asserts it loads).
inline SensorConfig realisticSensors() {
  SensorConfig c;
  std::string err;
  EXPECT_TRUE(loadSensorConfig(configPath("sensors.yaml"), &c, &err)) << err;
  return c;
}

}  // namespace exoid::sim::test
