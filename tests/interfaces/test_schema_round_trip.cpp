// The schema's round trips (exoid/interfaces/schema.h): every field of every message gets a value derived from
// its row in the schema (distinct across rows and elements); plain -> LCM -> plain and plain -> plugin ABI ->
// plain are checked field by field, the intermediate message included, against those values. A converter that
// swaps two fields of the same type (in both directions, so that a plain round trip would come back intact)
// fails here: the intermediate field holds the other row's value.
#include <gtest/gtest.h>

#include <cstddef>
#include <string>
#include <vector>

#include "exoid/controller_plugin_samples.hpp"
#include "exoid/lcm/adapters.hpp"

// The ABI version 3 layout, frozen (offsets and sizes as controller_plugin.h wrote them by hand before the
// schema; x86-64 / aarch64 LP64): a row moved, added or retyped in an ABI message fails to compile here.
static_assert(sizeof(exoid_plugin_state) == 648, "ABI v4 layout");
static_assert(sizeof(exoid_plugin_force_plate) == 152, "ABI v4 layout");
static_assert(sizeof(exoid_plugin_estimate) == 96, "ABI v4 layout");
static_assert(sizeof(exoid_plugin_command) == 544, "ABI v4 layout");
static_assert(sizeof(exoid_plugin_status) == 352, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, utime) == 0 && sizeof(exoid_plugin_state::utime) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, tick) == 8 && sizeof(exoid_plugin_state::tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, num_joints) == 16 && sizeof(exoid_plugin_state::num_joints) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, reserved) == 20 && sizeof(exoid_plugin_state::reserved) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, q) == 24 && sizeof(exoid_plugin_state::q) == 256, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, tau) == 280 && sizeof(exoid_plugin_state::tau) == 256, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, has_tau) == 536 && sizeof(exoid_plugin_state::has_tau) == 32, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, imu_orientation) == 568 && sizeof(exoid_plugin_state::imu_orientation) == 32, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, imu_gyro) == 600 && sizeof(exoid_plugin_state::imu_gyro) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_state, imu_accel) == 624 && sizeof(exoid_plugin_state::imu_accel) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, utime) == 0 && sizeof(exoid_plugin_force_plate::utime) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, tick) == 8 && sizeof(exoid_plugin_force_plate::tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, plate) == 16 && sizeof(exoid_plugin_force_plate::plate) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, reserved) == 20 && sizeof(exoid_plugin_force_plate::reserved) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, force) == 24 && sizeof(exoid_plugin_force_plate::force) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, moment) == 48 && sizeof(exoid_plugin_force_plate::moment) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, cop) == 72 && sizeof(exoid_plugin_force_plate::cop) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, plate_position) == 96 && sizeof(exoid_plugin_force_plate::plate_position) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_force_plate, plate_orientation) == 120 && sizeof(exoid_plugin_force_plate::plate_orientation) == 32, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, utime) == 0 && sizeof(exoid_plugin_estimate::utime) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, tick) == 8 && sizeof(exoid_plugin_estimate::tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, valid) == 16 && sizeof(exoid_plugin_estimate::valid) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, consistent) == 20 && sizeof(exoid_plugin_estimate::consistent) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, num_params) == 24 && sizeof(exoid_plugin_estimate::num_params) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, num_coords) == 28 && sizeof(exoid_plugin_estimate::num_coords) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, params) == 32 && sizeof(exoid_plugin_estimate::params) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, tau_correction) == 40 && sizeof(exoid_plugin_estimate::tau_correction) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, excitation) == 48 && sizeof(exoid_plugin_estimate::excitation) == 8, "ABI v4 layout");
// v4 appended the uncertainty of what a controller uses (the v3 members kept their offsets).
static_assert(offsetof(exoid_plugin_estimate, com_stddev) == 56 && sizeof(exoid_plugin_estimate::com_stddev) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, mass_stddev) == 80 && sizeof(exoid_plugin_estimate::mass_stddev) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_estimate, tau_correction_stddev) == 88 && sizeof(exoid_plugin_estimate::tau_correction_stddev) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, utime) == 0 && sizeof(exoid_plugin_command::utime) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, tick) == 8 && sizeof(exoid_plugin_command::tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, source_tick) == 16 && sizeof(exoid_plugin_command::source_tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, mode) == 24 && sizeof(exoid_plugin_command::mode) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, num_joints) == 28 && sizeof(exoid_plugin_command::num_joints) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, tau) == 32 && sizeof(exoid_plugin_command::tau) == 256, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_command, tau_ff) == 288 && sizeof(exoid_plugin_command::tau_ff) == 256, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, utime) == 0 && sizeof(exoid_plugin_status::utime) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, tick) == 8 && sizeof(exoid_plugin_status::tick) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, qp_status) == 16 && sizeof(exoid_plugin_status::qp_status) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, qp_iterations) == 20 && sizeof(exoid_plugin_status::qp_iterations) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, qp_solve_us) == 24 && sizeof(exoid_plugin_status::qp_solve_us) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, tick_us) == 32 && sizeof(exoid_plugin_status::tick_us) == 8, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, move_index) == 40 && sizeof(exoid_plugin_status::move_index) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, moves_done) == 44 && sizeof(exoid_plugin_status::moves_done) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, com_ref) == 48 && sizeof(exoid_plugin_status::com_ref) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, com) == 72 && sizeof(exoid_plugin_status::com) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, com_vel_ref) == 96 && sizeof(exoid_plugin_status::com_vel_ref) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, com_vel) == 120 && sizeof(exoid_plugin_status::com_vel) == 24, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, momentum_rate_ref) == 144 && sizeof(exoid_plugin_status::momentum_rate_ref) == 48, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, momentum) == 192 && sizeof(exoid_plugin_status::momentum) == 48, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, wrench_right) == 240 && sizeof(exoid_plugin_status::wrench_right) == 48, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, wrench_left) == 288 && sizeof(exoid_plugin_status::wrench_left) == 48, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, fallbacks) == 336 && sizeof(exoid_plugin_status::fallbacks) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, rejected_inputs) == 340 && sizeof(exoid_plugin_status::rejected_inputs) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, stale_inputs) == 344 && sizeof(exoid_plugin_status::stale_inputs) == 4, "ABI v4 layout");
static_assert(offsetof(exoid_plugin_status, finished) == 348 && sizeof(exoid_plugin_status::finished) == 4, "ABI v4 layout");

namespace exoid {
namespace {

constexpr int kJoints = 3, kParams = 4, kBase = 2, kCoords = 5;

// Element j of the field at row `row`: distinct per row and element, exact in binary.
double value(int row, int j) { return 100.0 * (row + 1) + j + 0.25; }

// ---- fill: one value per row, by kind -------------------------------------------------------------------
void fillI64(int64_t& v, int row, const char*) { v = 1000 - row; }  // decreasing: source_tick < tick < utime
void fillI32(int32_t& v, int row, const char*) { v = 1000 - row; }
void fillF64(double& v, int row, const char*) { v = 1.0 / (row + 2); }  // in (0, 1): excitation's range
void fillBOOL(bool& v, int row, const char*) { v = row % 2 == 0; }
void fillMODE(CommandMode& v, int row, const char*) { v = static_cast<CommandMode>(row % 4); }
void fillQP(QpStatus& v, int row, const char*) { v = static_cast<QpStatus>(row % 4); }
void fillPLATE(int& v, int, const char*) { v = 1; }  // left: the only other value is 0
template <class V>
void fillFixed(V& v, int row) {
  for (int j = 0; j < v.size(); ++j) v[j] = value(row, j);
}
void fillV3(Eigen::Vector3d& v, int row, const char*) { fillFixed(v, row); }
void fillV6(Vector6d& v, int row, const char*) { fillFixed(v, row); }
void fillQUAT(Eigen::Quaterniond& q, int row, const char*) {
  q = Eigen::Quaterniond(row + 1.0, row + 2.0, row + 3.0, row + 4.0).normalized();
}
void fillJOINTS(Eigen::VectorXd& v, int row, const char*) {
  v.resize(kJoints);
  fillFixed(v, row);
}
void fillJFLAGS(Eigen::Matrix<bool, Eigen::Dynamic, 1>& v, int row, const char*) {
  v.resize(kJoints);
  for (int j = 0; j < kJoints; ++j) v[j] = (row + j) % 2 == 0;
}
void fillVECX(Eigen::VectorXd& v, int row, const char* name) {
  const std::string n = name;
  v.resize(n == "params" || n == "param_stddev" ? kParams : n.rfind("base_", 0) == 0 ? kBase : kCoords);
  fillFixed(v, row);
}
void fillFEET3(std::array<Eigen::Vector3d, 2>& v, int row, const char*) {
  for (int j = 0; j < 3; ++j) {
    v[0][j] = value(row, j);
    v[1][j] = value(row, 10 + j);
  }
}
#define FILL_ROW(KIND, name, init, abi) FILL_ROW_##KIND(name)
#define FILL_ROW_ABI_I32(name) ++row;
#define FILL_ROW_I64(name) fillI64(s.name, row++, #name);
#define FILL_ROW_I32(name) fillI32(s.name, row++, #name);
#define FILL_ROW_F64(name) fillF64(s.name, row++, #name);
#define FILL_ROW_BOOL(name) fillBOOL(s.name, row++, #name);
#define FILL_ROW_MODE(name) fillMODE(s.name, row++, #name);
#define FILL_ROW_QP(name) fillQP(s.name, row++, #name);
#define FILL_ROW_PLATE(name) fillPLATE(s.name, row++, #name);
#define FILL_ROW_V3(name) fillV3(s.name, row++, #name);
#define FILL_ROW_V6(name) fillV6(s.name, row++, #name);
#define FILL_ROW_QUAT(name) fillQUAT(s.name, row++, #name);
#define FILL_ROW_JOINTS(name) fillJOINTS(s.name, row++, #name);
#define FILL_ROW_JFLAGS(name) fillJFLAGS(s.name, row++, #name);
#define FILL_ROW_VECX(name) fillVECX(s.name, row++, #name);
#define FILL_ROW_FEET3(name) fillFEET3(s.name, row++, #name);

// The gate's rules that tie fields together (the rows' values stay distinct).
RobotStateSample robotState() {
  RobotStateSample s;
  int row = 0;
  EXOID_SCHEMA_ROBOT_STATE(FILL_ROW)
  for (int j = 0; j < kJoints; ++j)
    if (!s.has_tau[j]) s.tau[j] = 0.0;  // no sensor, no torque
  return s;
}
ForcePlateSample forcePlate() {
  ForcePlateSample s;
  int row = 0;
  EXOID_SCHEMA_FORCE_PLATE(FILL_ROW)
  return s;
}
JointCommandSample jointCommand() {
  JointCommandSample s;
  int row = 0;
  EXOID_SCHEMA_JOINT_COMMAND(FILL_ROW)
  return s;
}
GroundTruthSample groundTruth() {
  GroundTruthSample s;
  int row = 0;
  EXOID_SCHEMA_GROUND_TRUTH(FILL_ROW)
  return s;
}
ControllerStatusSample controllerStatus() {
  ControllerStatusSample s;
  int row = 0;
  EXOID_SCHEMA_CONTROLLER_STATUS(FILL_ROW)
  return s;
}
EstimatorOutputSample estimatorOutput() {
  EstimatorOutputSample s;
  int row = 0;
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(FILL_ROW)
  s.samples_rejected = s.rejected_nonfinite + s.rejected_out_of_order + s.rejected_duplicate;
  return s;
}

// ---- checks: the field `name` of a converted message against the plain sample's `name` ------------------
template <class A, class B>
void expectSame(const A& got, const B& want, int n, const char* field) {
  for (int j = 0; j < n; ++j) EXPECT_EQ(got[j], want[j]) << field << "[" << j << "]";
}
void expectQuat(const double* got, const Eigen::Quaterniond& want, const char* field) {
  EXPECT_EQ(got[0], want.w()) << field;
  EXPECT_EQ(got[1], want.x()) << field;
  EXPECT_EQ(got[2], want.y()) << field;
  EXPECT_EQ(got[3], want.z()) << field;
}
// Back in a sample: unit quaternions come back renormalised (the LCM adapter, the plate's ABI path).
void expectQuat(const Eigen::Quaterniond& got, const Eigen::Quaterniond& want, const char* field) {
  EXPECT_NEAR(got.w(), want.w(), 1e-15) << field;
  EXPECT_NEAR(got.x(), want.x(), 1e-15) << field;
  EXPECT_NEAR(got.y(), want.y(), 1e-15) << field;
  EXPECT_NEAR(got.z(), want.z(), 1e-15) << field;
}

// Converted message `m` (LCM or ABI) against the sample `s`, row by row (ABI rows only for the ABI).
#define MSG_ROW(KIND, name, init, abi) MSG_ROW_##KIND(name)
#define MSG_ROW_I64(name) EXPECT_EQ(m.name, s.name) << #name;
#define MSG_ROW_I32(name) EXPECT_EQ(m.name, s.name) << #name;
#define MSG_ROW_F64(name) EXPECT_EQ(m.name, s.name) << #name;
#define MSG_ROW_BOOL(name) EXPECT_EQ(m.name != 0, s.name) << #name;
#define MSG_ROW_MODE(name) EXPECT_EQ(static_cast<int>(m.name), static_cast<int>(s.name)) << #name;
#define MSG_ROW_QP(name) EXPECT_EQ(static_cast<int>(m.name), static_cast<int>(s.name)) << #name;
#define MSG_ROW_V3(name) expectSame(m.name, s.name, 3, #name);
#define MSG_ROW_V6(name) expectSame(m.name, s.name, 6, #name);
#define MSG_ROW_QUAT(name) expectQuat(m.name, s.name, #name);
#define MSG_ROW_JOINTS(name) expectSame(m.name, s.name, kJoints, #name);
#define MSG_ROW_JFLAGS(name) \
  for (int j = 0; j < kJoints; ++j) EXPECT_EQ(m.name[j] != 0, s.name[j]) << #name << "[" << j << "]";
#define MSG_ROW_VECX(name) expectSame(m.name, s.name, static_cast<int>(s.name.size()), #name);
#define MSG_ROW_ABI_I32(name)
// LCM only: the plate by name, the feet as two fields.
#define MSG_ROW_PLATE(name) EXPECT_EQ(m.plate_name, std::string("left"));
#define MSG_ROW_FEET3(name)                         \
  expectSame(m.name##_right, s.name[0], 3, #name); \
  expectSame(m.name##_left, s.name[1], 3, #name);
// ABI only: the plate index, the rows the ABI does not carry skipped.
#define ABI_ROW(KIND, name, init, abi) ABI_ROW_##abi(KIND, name)
#define ABI_ROW_NO(KIND, name)
#define ABI_ROW_YES(KIND, name) ABI_ROW_##KIND(name)
#define ABI_ROW_PLATE(name) EXPECT_EQ(m.name, s.name) << #name;
#define ABI_ROW_I64 MSG_ROW_I64
#define ABI_ROW_I32 MSG_ROW_I32
#define ABI_ROW_F64 MSG_ROW_F64
#define ABI_ROW_BOOL MSG_ROW_BOOL
#define ABI_ROW_MODE MSG_ROW_MODE
#define ABI_ROW_QP MSG_ROW_QP
#define ABI_ROW_V3 MSG_ROW_V3
#define ABI_ROW_V6 MSG_ROW_V6
#define ABI_ROW_QUAT MSG_ROW_QUAT
#define ABI_ROW_JOINTS MSG_ROW_JOINTS
#define ABI_ROW_JFLAGS MSG_ROW_JFLAGS
#define ABI_ROW_VECX MSG_ROW_VECX
#define ABI_ROW_ABI_I32 MSG_ROW_ABI_I32

// Sample back `m` against the original `s`: every row of the plain struct (ABI_SAMPLE_ROW: the ABI's rows).
#define SAMPLE_ROW(KIND, name, init, abi) SAMPLE_ROW_##KIND(name)
#define SAMPLE_ROW_I64 MSG_ROW_I64
#define SAMPLE_ROW_I32 MSG_ROW_I32
#define SAMPLE_ROW_F64 MSG_ROW_F64
#define SAMPLE_ROW_BOOL(name) EXPECT_EQ(m.name, s.name) << #name;
#define SAMPLE_ROW_MODE MSG_ROW_MODE
#define SAMPLE_ROW_QP MSG_ROW_QP
#define SAMPLE_ROW_PLATE(name) EXPECT_EQ(m.name, s.name) << #name;
#define SAMPLE_ROW_V3 MSG_ROW_V3
#define SAMPLE_ROW_V6 MSG_ROW_V6
#define SAMPLE_ROW_QUAT MSG_ROW_QUAT
#define SAMPLE_ROW_JOINTS MSG_ROW_JOINTS
#define SAMPLE_ROW_JFLAGS(name) \
  for (int j = 0; j < kJoints; ++j) EXPECT_EQ(m.name[j], s.name[j]) << #name << "[" << j << "]";
#define SAMPLE_ROW_VECX(name)                                \
  ASSERT_EQ(m.name.size(), s.name.size()) << #name;          \
  expectSame(m.name, s.name, static_cast<int>(s.name.size()), #name);
#define SAMPLE_ROW_FEET3(name)                  \
  expectSame(m.name[0], s.name[0], 3, #name); \
  expectSame(m.name[1], s.name[1], 3, #name);
#define SAMPLE_ROW_ABI_I32(name)
#define ABI_SAMPLE_ROW(KIND, name, init, abi) ABI_SAMPLE_ROW_##abi(KIND, name)
#define ABI_SAMPLE_ROW_NO(KIND, name)
#define ABI_SAMPLE_ROW_YES(KIND, name) SAMPLE_ROW_##KIND(name)

std::vector<std::string> names(const char* prefix, int n) {
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) out.push_back(prefix + std::to_string(i));
  return out;
}

// ---- plain -> LCM -> plain --------------------------------------------------------------------------------
TEST(SchemaRoundTrip, LcmRobotState) {
  const RobotStateSample s = robotState();
  exoid_lcm::robot_state_t m;
  toLcm(s, names("j", kJoints), m);
  EXOID_SCHEMA_ROBOT_STATE(MSG_ROW)
  std::string why;
  RobotStateSample back;
  ASSERT_TRUE(fromLcm(m, names("j", kJoints), back, &why)) << why;
  {
    const RobotStateSample& m = back;
    EXOID_SCHEMA_ROBOT_STATE(SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, LcmForcePlate) {
  const ForcePlateSample s = forcePlate();
  exoid_lcm::force_plate_t m;
  toLcm(s, m);
  EXOID_SCHEMA_FORCE_PLATE(MSG_ROW)
  std::string why;
  ForcePlateSample back;
  ASSERT_TRUE(fromLcm(m, 1, back, &why)) << why;
  {
    const ForcePlateSample& m = back;
    EXOID_SCHEMA_FORCE_PLATE(SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, LcmJointCommand) {
  const JointCommandSample s = jointCommand();
  exoid_lcm::joint_command_t m;
  toLcm(s, names("j", kJoints), m);
  EXOID_SCHEMA_JOINT_COMMAND(MSG_ROW)
  std::string why;
  JointCommandSample back;
  ASSERT_TRUE(fromLcm(m, names("j", kJoints), back, &why)) << why;
  {
    const JointCommandSample& m = back;
    EXOID_SCHEMA_JOINT_COMMAND(SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, LcmGroundTruth) {
  const GroundTruthSample s = groundTruth();
  exoid_lcm::ground_truth_t m;
  toLcm(s, names("j", kJoints), m);
  EXOID_SCHEMA_GROUND_TRUTH(MSG_ROW)
  std::string why;
  GroundTruthSample back;
  ASSERT_TRUE(fromLcm(m, names("j", kJoints), back, &why)) << why;
  {
    const GroundTruthSample& m = back;
    EXOID_SCHEMA_GROUND_TRUTH(SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, LcmControllerStatus) {
  const ControllerStatusSample s = controllerStatus();
  exoid_lcm::controller_status_t m;
  toLcm(s, m);
  EXOID_SCHEMA_CONTROLLER_STATUS(MSG_ROW)
  std::string why;
  ControllerStatusSample back;
  ASSERT_TRUE(fromLcm(m, back, &why)) << why;
  {
    const ControllerStatusSample& m = back;
    EXOID_SCHEMA_CONTROLLER_STATUS(SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, LcmEstimatorOutput) {
  const EstimatorOutputSample s = estimatorOutput();
  exoid_lcm::estimator_output_t m;
  toLcm(s, names("p", kParams), names("c", kCoords), m);
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(MSG_ROW)
  std::string why;
  EstimatorOutputSample back;
  ASSERT_TRUE(fromLcm(m, names("p", kParams), kBase, names("c", kCoords), back, &why)) << why;
  {
    const EstimatorOutputSample& m = back;
    EXOID_SCHEMA_ESTIMATOR_OUTPUT(SAMPLE_ROW)
  }
}

// ---- plain -> plugin ABI -> plain ---------------------------------------------------------------------------
TEST(SchemaRoundTrip, AbiRobotState) {
  const RobotStateSample s = robotState();
  exoid_plugin_state m{};
  ASSERT_TRUE(plugin_abi::toPlugin(s, m));
  EXPECT_EQ(m.num_joints, kJoints);
  EXOID_SCHEMA_ROBOT_STATE(ABI_ROW)
  RobotStateSample back;
  back.q.resize(kJoints);
  back.tau.resize(kJoints);
  back.has_tau.resize(kJoints);
  ASSERT_TRUE(plugin_abi::fromPlugin(m, back));
  {
    const RobotStateSample& m = back;
    EXOID_SCHEMA_ROBOT_STATE(ABI_SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, AbiForcePlate) {
  const ForcePlateSample s = forcePlate();
  exoid_plugin_force_plate m{};
  plugin_abi::toPlugin(s, m);
  EXOID_SCHEMA_FORCE_PLATE(ABI_ROW)
  ForcePlateSample back;
  ASSERT_TRUE(plugin_abi::fromPlugin(m, 1, back));
  {
    const ForcePlateSample& m = back;
    EXOID_SCHEMA_FORCE_PLATE(ABI_SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, AbiJointCommand) {
  const JointCommandSample s = jointCommand();
  exoid_plugin_command m{};
  ASSERT_TRUE(plugin_abi::toPlugin(s, m));
  EXPECT_EQ(m.num_joints, kJoints);
  EXOID_SCHEMA_JOINT_COMMAND(ABI_ROW)
  JointCommandSample back;
  back.tau.resize(kJoints);
  back.tau_ff.resize(kJoints);
  ASSERT_TRUE(plugin_abi::fromPlugin(m, back));
  {
    const JointCommandSample& m = back;
    EXOID_SCHEMA_JOINT_COMMAND(ABI_SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, AbiControllerStatus) {
  const ControllerStatusSample s = controllerStatus();
  exoid_plugin_status m{};
  plugin_abi::toPlugin(s, m);
  EXOID_SCHEMA_CONTROLLER_STATUS(ABI_ROW)
  ControllerStatusSample back;
  plugin_abi::fromPlugin(m, back);
  {
    const ControllerStatusSample& m = back;
    EXOID_SCHEMA_CONTROLLER_STATUS(ABI_SAMPLE_ROW)
  }
}

TEST(SchemaRoundTrip, AbiEstimatorOutput) {
  const EstimatorOutputSample s = estimatorOutput();
  exoid_plugin_estimate m{};
  plugin_abi::toPlugin(s, m);
  EXPECT_EQ(m.num_params, kParams);
  EXPECT_EQ(m.num_coords, kCoords);
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(ABI_ROW)
  EstimatorOutputSample back;
  back.params.resize(kParams);
  back.tau_correction.resize(kCoords);
  back.tau_correction_stddev.resize(kCoords);
  ASSERT_TRUE(plugin_abi::fromPlugin(m, back));
  {
    const EstimatorOutputSample& m = back;
    EXOID_SCHEMA_ESTIMATOR_OUTPUT(ABI_SAMPLE_ROW)
  }
}

// The ABI's sizes refuse what does not fit instead of writing past the arrays.
TEST(SchemaRoundTrip, AbiRefusesOversizedSamples) {
  RobotStateSample s = robotState();
  s.q.resize(EXOID_PLUGIN_MAX_JOINTS + 1);
  exoid_plugin_state p{};
  EXPECT_FALSE(plugin_abi::toPlugin(s, p));
  JointCommandSample c = jointCommand();
  c.tau_ff.resize(kJoints + 1);
  exoid_plugin_command pc{};
  EXPECT_FALSE(plugin_abi::toPlugin(c, pc));
}

}  // namespace
}  // namespace exoid
