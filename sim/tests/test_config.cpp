// (d) Sensor and scenario files: valid files parse to the written values; every kind of bad input gives one
// line naming the file and the key.
#include <gtest/gtest.h>

#include "sim_test_util.hpp"

namespace exoid::sim::test {
namespace {

const char* kGoodSensors = R"(
encoder: {sigma: 1.0e-5}
joint_torque: {sigma: 0.2}
imu: {orientation_sigma: [0.01, 0.02, 0.03], gyro_sigma: 0.004, accel_sigma: 0.05}
force_plate: {force_sigma: [0.1, 0.2, 0.3], moment_sigma: [0.01, 0.02, 0.03], cop_min_force: 15}
)";

TEST(SimConfig, SensorFileParses) {
  const std::string path = writeTemp("good_sensors.yaml", kGoodSensors);
  SensorConfig c;
  std::string err;
  ASSERT_TRUE(loadSensorConfig(path, &c, &err)) << err;
  EXPECT_DOUBLE_EQ(c.encoder_sigma, 1e-5);
  EXPECT_DOUBLE_EQ(c.torque_sigma, 0.2);
  EXPECT_DOUBLE_EQ(c.imu_orientation_sigma[2], 0.03);
  EXPECT_DOUBLE_EQ(c.gyro_sigma, 0.004);
  EXPECT_DOUBLE_EQ(c.accel_sigma, 0.05);
  EXPECT_DOUBLE_EQ(c.plate_force_sigma[1], 0.2);
  EXPECT_DOUBLE_EQ(c.plate_moment_sigma[0], 0.01);
  EXPECT_DOUBLE_EQ(c.cop_min_force, 15.0);
  const SensorConfig off = noiseOff(c);
  EXPECT_EQ(off.encoder_sigma + off.torque_sigma + off.gyro_sigma + off.accel_sigma, 0.0);
  EXPECT_EQ(off.imu_orientation_sigma.norm() + off.plate_force_sigma.norm() + off.plate_moment_sigma.norm(), 0.0);
  EXPECT_DOUBLE_EQ(off.cop_min_force, 15.0);
}

TEST(SimConfig, BadSensorFilesNameTheKey) {
  struct Case {
    std::string from, to, expect;
  };
  const std::vector<Case> cases = {
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: -1.0}", "encoder.sigma: must be >= 0"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: abc}", "encoder.sigma: expected a finite number, got 'abc' (not a number)"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: '13,5'}", "encoder.sigma: expected a finite number, got '13,5'"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: .inf}", "encoder.sigma: expected a finite number, got '.inf' (not finite)"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: 1e400}", "encoder.sigma: expected a finite number, got '1e400' (too large"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: ''}", "encoder.sigma: expected a finite number, got '' (empty"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: 1.0e-5, sigma: 2.0}", "encoder.sigma: duplicate key (line"},
      {"joint_torque: {sigma: 0.2}\n", "joint_torque: {sigma: 0.2}\njoint_torque: {sigma: 0.3}\n",
       "joint_torque: duplicate key (line"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: .nan}", "encoder.sigma: expected a finite number, got '.nan' (not finite)"},
      {"encoder: {sigma: 1.0e-5}", "encoder: {sigma: 1.0e-5, bias: 1}", "encoder.bias: unknown key"},
      {"joint_torque: {sigma: 0.2}\n", "", "joint_torque: missing"},
      {"gyro_sigma: 0.004", "gyro_sigam: 0.004", "imu.gyro_sigam: unknown key"},
      {"orientation_sigma: [0.01, 0.02, 0.03]", "orientation_sigma: [0.01, 0.02]",
       "imu.orientation_sigma: expected a sequence of 3 numbers"},
      {"force_sigma: [0.1, 0.2, 0.3]", "force_sigma: [0.1, x, 0.3]", "force_plate.force_sigma[1]: expected a finite number, got 'x'"},
      {"cop_min_force: 15", "cop_min_force: [1]", "force_plate.cop_min_force: expected a number, found a sequence"},
      {"encoder:", "encoder: [", "malformed YAML"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    std::string text = kGoodSensors;
    const size_t at = text.find(cases[i].from);
    ASSERT_NE(at, std::string::npos) << cases[i].from;
    text.replace(at, cases[i].from.size(), cases[i].to);
    const std::string path = writeTemp("bad_sensors_" + std::to_string(i) + ".yaml", text);
    SensorConfig c;
    std::string err;
    EXPECT_FALSE(loadSensorConfig(path, &c, &err)) << cases[i].expect;
    EXPECT_EQ(err.rfind(path + ": ", 0), 0u) << err;  // starts with the file name
    EXPECT_NE(err.find(cases[i].expect), std::string::npos) << err;
  }
  SensorConfig c;
  std::string err;
  EXPECT_FALSE(loadSensorConfig("/nonexistent/sensors.yaml", &c, &err));
  EXPECT_EQ(err, "/nonexistent/sensors.yaml: cannot open file");
}

const char* kGoodScenario = R"(
name: demo
description: all fields
seed: 42
noise: off
effects:
  joint_damping: {all: 0.5, right_knee: 1.0}
  joint_frictionloss: {left_knee: 0.3}
  armature: {all: 0.01}
  payload: {link: body, mass: 3.0, com: [0.1, 0.0, 0.2], inertia: [0.03, 0.02, 0.02, 0, 0, 0]}
  torque_sensor:
    all: {offset: 0.1, gain: 1.02}
    right_knee: {gain: 0.9}
  drive_torque_loop: sensor
  foot_placement: {right: [0.01, -0.005], left: [0.0, 0.02]}
initial_state:
  base_height_offset: 0.01
  joints: {right_knee: 0.2}
harness: {lift: 0.3}
)";

TEST(SimConfig, ScenarioParses) {
  const std::string path = writeTemp("good_scenario.yaml", kGoodScenario);
  Scenario s;
  std::string err;
  ASSERT_TRUE(loadScenario(path, &s, &err)) << err;
  EXPECT_EQ(s.name, "demo");
  EXPECT_EQ(s.seed, 42u);
  EXPECT_EQ(s.noise, NoiseMode::Off);
  EXPECT_TRUE(s.effects.drive_loop_on_sensor);
  ASSERT_EQ(s.effects.joint_damping.size(), 2u);
  EXPECT_EQ(s.effects.joint_damping[1].joint, "right_knee");
  EXPECT_DOUBLE_EQ(s.effects.joint_damping[1].value, 1.0);
  ASSERT_EQ(s.effects.payloads.size(), 1u);
  EXPECT_DOUBLE_EQ(s.effects.payloads[0].mass, 3.0);
  EXPECT_DOUBLE_EQ(s.effects.payloads[0].com.x(), 0.1);
  EXPECT_DOUBLE_EQ(s.effects.payloads[0].inertia[0], 0.03);
  ASSERT_EQ(s.effects.torque_sensor.size(), 2u);
  EXPECT_DOUBLE_EQ(s.effects.torque_sensor[1].gain, 0.9);
  EXPECT_DOUBLE_EQ(s.effects.torque_sensor[1].offset, 0.0);
  EXPECT_DOUBLE_EQ(s.initial.base_height_offset, 0.01);
  ASSERT_EQ(s.initial.joints.size(), 1u);
  EXPECT_DOUBLE_EQ(s.initial.joints[0].value, 0.2);
  EXPECT_TRUE(s.effects.any());
  EXPECT_DOUBLE_EQ(s.effects.foot_placement[0].y(), -0.005);
  EXPECT_DOUBLE_EQ(s.effects.foot_placement[1].y(), 0.02);
  EXPECT_TRUE(s.harness.enabled);
  EXPECT_DOUBLE_EQ(s.harness.lift, 0.3);
  {  // no harness key: no harness; an empty map: the default lift
    Scenario plain, empty;
    ASSERT_TRUE(loadScenario(writeTemp("no_harness.yaml", "name: f\nseed: 1\nnoise: off\n"), &plain, &err)) << err;
    EXPECT_FALSE(plain.harness.enabled);
    ASSERT_TRUE(loadScenario(writeTemp("empty_harness.yaml", "name: f\nseed: 1\nnoise: off\nharness: {}\n"), &empty, &err))
        << err;
    EXPECT_TRUE(empty.harness.enabled);
    EXPECT_DOUBLE_EQ(empty.harness.lift, Harness().lift);
  }

  // noise: a sensors file, relative to the scenario's directory.
  const std::string sensors = writeTemp("rel_sensors.yaml", kGoodSensors);
  const std::string rel = sensors.substr(sensors.find_last_of('/') + 1);  // the name, relative to the directory
  const std::string p2 = writeTemp("file_noise.yaml", "name: f\nseed: 1\nnoise: " + rel + "\n");
  ASSERT_TRUE(loadScenario(p2, &s, &err)) << err;
  EXPECT_EQ(s.noise, NoiseMode::File);
  EXPECT_EQ(s.noise_file, sensors);
  SensorConfig resolved;
  ASSERT_TRUE(resolveSensorConfig(s, SensorConfig(), &resolved, &err)) << err;
  EXPECT_DOUBLE_EQ(resolved.encoder_sigma, 1e-5);
  const std::string p3 = writeTemp("missing_noise.yaml", "name: f\nseed: 1\nnoise: nowhere.yaml\n");
  ASSERT_TRUE(loadScenario(p3, &s, &err)) << err;
  EXPECT_FALSE(resolveSensorConfig(s, SensorConfig(), &resolved, &err));
  EXPECT_NE(err.find(p3 + ": noise: "), std::string::npos) << err;
  EXPECT_NE(err.find("nowhere.yaml: cannot open file"), std::string::npos) << err;
}

TEST(SimConfig, ByteOrderMarkAndCrlfReadTheSame) {
  std::string crlf = "\xEF\xBB\xBF";
  for (char c : std::string(kGoodScenario)) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  Scenario plain, windows;
  std::string err;
  ASSERT_TRUE(loadScenario(writeTemp("plain_scenario.yaml", kGoodScenario), &plain, &err)) << err;
  ASSERT_TRUE(loadScenario(writeTemp("crlf_scenario.yaml", crlf), &windows, &err)) << err;
  EXPECT_EQ(windows.name, plain.name);
  EXPECT_EQ(windows.effects.payloads.size(), 1u);
  EXPECT_EQ(windows.effects.payloads[0].com, plain.effects.payloads[0].com);
  EXPECT_EQ(windows.initial.joints.size(), plain.initial.joints.size());
}

// Found by fuzz_sim_config: yaml-cpp's message for the bytes ff 00 0a quotes a line break, and a key or a
// value with one in it is quoted too; the error was two lines. Control characters are now escaped.
TEST(SimConfig, ErrorsQuotingLineBreaksAreOneLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {std::string("\xff\x00\n", 3), "malformed YAML"},
      {"name: demo\nseed: 1\nnoise: off\n\"nam\\ne\": x\n", "nam\\ne"},
      {"name: demo\nseed: \"4\\n2\"\nnoise: off\n", "seed: "},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = writeTemp("line_break_" + std::to_string(i) + ".yaml", cases[i].first);
    Scenario s;
    SensorConfig c;
    std::string err;
    EXPECT_FALSE(loadScenario(path, &s, &err));
    EXPECT_NE(err.find(cases[i].second), std::string::npos) << err;
    EXPECT_EQ(err.find_first_of("\r\n"), std::string::npos) << "one line: " << err;
    EXPECT_FALSE(loadSensorConfig(path, &c, &err));
    EXPECT_EQ(err.find_first_of("\r\n"), std::string::npos) << "one line: " << err;
  }
}

TEST(SimConfig, SubnormalNumbersAreNumbers) {
  std::string text = kGoodScenario;
  text.replace(text.find("armature: {all: 0.01}"), 21, "armature: {all: 1e-320}");
  const std::string path = writeTemp("subnormal_scenario.yaml", text);
  Scenario s;
  std::string err;
  ASSERT_TRUE(loadScenario(path, &s, &err)) << err;
  ASSERT_EQ(s.effects.armature.size(), 1u);
  EXPECT_EQ(s.effects.armature[0].value, std::strtod("1e-320", nullptr));
  EXPECT_GT(s.effects.armature[0].value, 0.0);
}

TEST(SimConfig, BadScenariosNameTheKey) {
  struct Case {
    std::string from, to, expect;
  };
  const std::vector<Case> cases = {
      {"seed: 42", "seed: -3", "seed: expected an integer, got '-3' (out of range, expected an integer >= 0)"},
      {"seed: 42", "seed: 4.2", "seed: expected an integer, got '4.2' (not an integer)"},
      {"seed: 42", "seed: 42\nseed: 43", "seed: duplicate key (line"},
      {"seed: 42", "seed: [1]", "seed: expected an unsigned integer, found a sequence"},
      {"seed: 42\n", "", "seed: missing"},
      {"name: demo", "nmae: demo", "nmae: unknown key"},
      {"noise: off", "noise: ''", "noise: expected realistic, off or a sensors file path"},
      {"joint_damping: {all: 0.5, right_knee: 1.0}", "joint_damping: {all: -0.5}",
       "effects.joint_damping.all: must be >= 0"},
      {"joint_damping: {all: 0.5, right_knee: 1.0}", "joint_damping: [0.5]",
       "effects.joint_damping: expected a map joint: value, found a sequence"},
      {"armature: {all: 0.01}", "armature: {all: heavy}", "effects.armature.all: expected a finite number, got 'heavy'"},
      {"armature: {all: 0.01}", "armature: {all: 0.01, all: 0.02}", "effects.armature.all: duplicate key (line"},
      {"right_knee: {gain: 0.9}", "right_knee: {gain: 0.9, gain: 0.8}",
       "effects.torque_sensor.right_knee.gain: duplicate key (line 13; first on line 13)"},
      {"payload: {link: body, mass: 3.0, com: [0.1, 0.0, 0.2], inertia: [0.03, 0.02, 0.02, 0, 0, 0]}",
       "payload: [{link: body, mass: 1.0}, {link: body, mass: 2.0, link: body}]",
       "effects.payload[1].link: duplicate key"},
      {"effects:\n", "effects:\n  armature: {all: 0.02}\n", "effects.armature: duplicate key (line 10; first on line 7)"},
      {"armature: {all: 0.01}", "armatures: {all: 0.01}", "effects.armatures: unknown key"},
      {"mass: 3.0", "mass: -3.0", "effects.payload.mass: must be > 0"},
      {"mass: 3.0", "mass: 3.0, attach_at_s: -1", "effects.payload.attach_at_s: must be in [0, 1e6] s"},
      {"mass: 3.0", "mass: 3.0, attach_at_s: soon", "effects.payload.attach_at_s: expected a finite number, got 'soon'"},
      {"mass: 3.0, ", "", "effects.payload.mass: missing"},
      {"com: [0.1, 0.0, 0.2]", "com: [0.1, 0.0]", "effects.payload.com: expected a sequence of 3 numbers"},
      {"inertia: [0.03, 0.02, 0.02, 0, 0, 0]", "inertia: [0.03, 0.01, 0.01, 0, 0, 0]",
       "effects.payload.inertia: not a physical inertia tensor"},
      {"link: body, ", "link: body, colour: red, ", "effects.payload.colour: unknown key"},
      {"right_knee: {gain: 0.9}", "right_knee: {gain: 0}", "effects.torque_sensor.right_knee.gain: must be > 0"},
      {"right_knee: {gain: 0.9}", "right_knee: {bias: 0.9}", "effects.torque_sensor.right_knee.bias: unknown key"},
      {"drive_torque_loop: sensor", "drive_torque_loop: motor",
       "effects.drive_torque_loop: expected ideal or sensor, got 'motor'"},
      {"right: [0.01, -0.005]", "right: [0.06, -0.005]",
       "effects.foot_placement.right: each coordinate must be within +-0.05 m (the sole stays on its plate)"},
      {"right: [0.01, -0.005]", "right: [0.01]", "effects.foot_placement.right: expected a sequence of 2 numbers"},
      {"left: [0.0, 0.02]", "middle: [0.0, 0.02]", "effects.foot_placement.middle: unknown key"},
      {"foot_placement: {right: [0.01, -0.005], left: [0.0, 0.02]}", "foot_placement: [0.01, 0.0]",
       "effects.foot_placement: expected a map {right: [x, y], left: [x, y]}, found a sequence"},
      {"joints: {right_knee: 0.2}", "joints: {all: 0.2}", "initial_state.joints.all: 'all' is not allowed here"},
      {"base_height_offset: 0.01", "base_height: 0.01", "initial_state.base_height: unknown key"},
      {"name: demo", "name: [demo]", "name: expected a string, found a sequence"},
      {"harness: {lift: 0.3}", "harness: {lift: -0.1}", "harness.lift: must be in [0, 2] m"},
      {"harness: {lift: 0.3}", "harness: {lift: high}", "harness.lift: expected a finite number, got 'high'"},
      {"harness: {lift: 0.3}", "harness: {height: 0.3}", "harness.height: unknown key"},
      {"harness: {lift: 0.3}", "harness: 0.3", "harness: expected a map (e.g. {lift: 0.2}), found a scalar"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    std::string text = kGoodScenario;
    const size_t at = text.find(cases[i].from);
    ASSERT_NE(at, std::string::npos) << cases[i].from;
    text.replace(at, cases[i].from.size(), cases[i].to);
    const std::string path = writeTemp("bad_scenario_" + std::to_string(i) + ".yaml", text);
    Scenario s;
    std::string err;
    EXPECT_FALSE(loadScenario(path, &s, &err)) << cases[i].expect;
    EXPECT_EQ(err.rfind(path + ": ", 0), 0u) << err;
    EXPECT_NE(err.find(cases[i].expect), std::string::npos) << "expected '" << cases[i].expect << "' in: " << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << err;
  }
  Scenario s;
  std::string err;
  const std::string list = writeTemp("list_scenario.yaml", "- name: x\n");
  EXPECT_FALSE(loadScenario(list, &s, &err));
  EXPECT_NE(err.find("top level must be a map"), std::string::npos) << err;
}

}  // namespace
}  // namespace exoid::sim::test
