// Scenario and sensor-noise YAML (sim::loadScenario, sim::loadSensorConfig) on the same input.
// Properties: a rejection is one line; what is accepted obeys the ranges docs/sim.md promises.
#include <cmath>
#include <string>

#include "exoid/sim/config.hpp"
#include "fuzz_support.hpp"

namespace {

using exoid::sim::JointValue;

void checkNonNegative(const std::vector<JointValue>& values) {
  for (const JointValue& v : values)
    EXOID_FUZZ_CHECK(std::isfinite(v.value) && v.value >= 0.0, "joint effects are finite and >= 0");
}

void checkScenario(const exoid::sim::Scenario& s) {
  EXOID_FUZZ_CHECK(!s.name.empty(), "a scenario has a name");
  EXOID_FUZZ_CHECK(s.noise != exoid::sim::NoiseMode::File || !s.noise_file.empty(), "a noise file is named");
  checkNonNegative(s.effects.joint_damping);
  checkNonNegative(s.effects.joint_frictionloss);
  checkNonNegative(s.effects.armature);
  for (const auto& p : s.effects.payloads)
    EXOID_FUZZ_CHECK(std::isfinite(p.mass) && p.mass > 0.0 && p.com.allFinite() && p.inertia.allFinite(),
                     "payload mass > 0, finite com and inertia");
  for (const auto& t : s.effects.torque_sensor)
    EXOID_FUZZ_CHECK(std::isfinite(t.offset) && std::isfinite(t.gain) && t.gain > 0.0,
                     "torque sensor offset finite, gain > 0");
  EXOID_FUZZ_CHECK(std::isfinite(s.initial.base_height_offset), "finite base height offset");
  for (const JointValue& v : s.initial.joints)
    EXOID_FUZZ_CHECK(v.joint != "all" && std::isfinite(v.value), "initial joints named, finite");
}

void checkSensors(const exoid::sim::SensorConfig& c) {
  const double sigmas[] = {c.encoder_sigma, c.torque_sigma, c.gyro_sigma, c.accel_sigma, c.cop_min_force};
  for (double v : sigmas) EXOID_FUZZ_CHECK(std::isfinite(v) && v >= 0.0, "sigmas finite and >= 0");
  for (const Eigen::Vector3d* v : {&c.imu_orientation_sigma, &c.plate_force_sigma, &c.plate_moment_sigma})
    EXOID_FUZZ_CHECK(v->allFinite() && v->minCoeff() >= 0.0, "sigma vectors finite and >= 0");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static exoid::fuzz::MemFile file;
  const std::string& path = file.write(data, size);
  std::string error;
  exoid::sim::Scenario scenario;
  if (exoid::sim::loadScenario(path, &scenario, &error))
    checkScenario(scenario);
  else
    exoid::fuzz::checkOneLine(error, "a rejected scenario gets a one-line error");
  exoid::sim::SensorConfig sensors;
  if (exoid::sim::loadSensorConfig(path, &sensors, &error))
    checkSensors(sensors);
  else
    exoid::fuzz::checkOneLine(error, "a rejected sensors file gets a one-line error");
  return 0;
}
