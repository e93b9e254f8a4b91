// Adapters: sample -> toLcm -> LCM encode -> LCM decode -> fromLcm -> sample, field by field; and every
// rejection leaves the output untouched and names the reason.
#include "test_helpers.hpp"

#include <cmath>
#include <limits>

namespace exoid {
namespace {

using test::encodeDecode;
using test::jointNames;
using test::coordNames;
using test::paramNames;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ----------------------------------------------------------------------------------------------------
TEST(RobotStateAdapter, RoundTripThroughLcmEncoding) {
  const RobotStateSample in = test::makeState();
  exoid_lcm::robot_state_t msg;
  toLcm(in, jointNames(), msg);
  EXPECT_EQ(msg.num_joints, 10);
  EXPECT_EQ(msg.joint_names, jointNames());
  EXPECT_EQ(msg.imu_orientation[0], in.imu_orientation.w());
  EXPECT_EQ(msg.imu_orientation[3], in.imu_orientation.z());
  const exoid_lcm::robot_state_t wire = encodeDecode(msg);
  EXPECT_EQ(wire.utime, msg.utime);
  EXPECT_EQ(wire.tick, msg.tick);
  EXPECT_EQ(wire.joint_names, msg.joint_names);
  EXPECT_EQ(wire.q, msg.q);
  EXPECT_EQ(wire.tau, msg.tau);
  EXPECT_EQ(wire.has_tau, msg.has_tau);

  RobotStateSample out;
  std::string why;
  ASSERT_TRUE(fromLcm(wire, jointNames(), out, &why)) << why;
  EXPECT_EQ(out.utime, in.utime);
  EXPECT_EQ(out.tick, in.tick);
  ASSERT_EQ(out.q.size(), 10);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(out.q[i], in.q[i]) << i;
    EXPECT_EQ(out.tau[i], in.tau[i]) << i;
    EXPECT_EQ(out.has_tau[i], in.has_tau[i]) << i;
  }
  EXPECT_FALSE(out.has_tau[4]);
  EXPECT_TRUE(out.has_tau[3]);
  EXPECT_NEAR(out.imu_orientation.angularDistance(in.imu_orientation), 0.0, 1e-15);
  EXPECT_EQ(out.imu_gyro, in.imu_gyro);
  EXPECT_EQ(out.imu_accel, in.imu_accel);
}

TEST(RobotStateAdapter, NearlyUnitQuaternionIsNormalised) {
  exoid_lcm::robot_state_t msg;
  toLcm(test::makeState(), jointNames(), msg);
  for (double& c : msg.imu_orientation) c *= 1.0 + 5e-7;
  RobotStateSample out;
  std::string why;
  ASSERT_TRUE(fromLcm(msg, jointNames(), out, &why)) << why;
  EXPECT_NEAR(out.imu_orientation.norm(), 1.0, 1e-15);
}

// Each bad message must be rejected with the given reason and leave the output exactly as it was.
template <class Msg, class Sample, class... Expected>
void expectRejected(const Msg& msg, RejectReason expected_reason, const std::string& expected_text,
                    const Sample& before, const Expected&... expected) {
  Sample out = before;
  std::string why;
  RejectReason reason = RejectReason::Duplicate;
  EXPECT_FALSE(fromLcm(msg, expected..., out, &why, &reason));
  EXPECT_EQ(reason, expected_reason) << why;
  EXPECT_NE(why.find(expected_text), std::string::npos) << "reason was: " << why;
  EXPECT_EQ(why.find('\n'), std::string::npos) << "one line: " << why;
  EXPECT_TRUE(test::same(out, before)) << "fromLcm wrote into the output while rejecting";
  // Also no crash or write without the optional outputs.
  EXPECT_FALSE(fromLcm(msg, expected..., out));
}

class RobotStateReject : public ::testing::Test {
 protected:
  void SetUp() override {
    // "before" differs from the message in every field, so a partial write would show.
    before = test::makeState();
    before.tick = 1;
    before.q.setConstant(-7);
    before.tau.setConstant(0);
    before.imu_gyro.setConstant(9);
    toLcm(test::makeState(), jointNames(), msg);
  }
  RobotStateSample before;
  exoid_lcm::robot_state_t msg;
};

TEST_F(RobotStateReject, WrongJointCount) {
  msg.num_joints = 9;
  msg.joint_names.pop_back();
  msg.q.pop_back();
  msg.tau.pop_back();
  msg.has_tau.pop_back();
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "num_joints is 9, expected 10", before, jointNames());
}

TEST_F(RobotStateReject, ArrayLengthDisagreesWithCount) {
  msg.q.pop_back();
  expectRejected(msg, RejectReason::Malformed, "q has 9 entries", before, jointNames());
}

TEST_F(RobotStateReject, WrongJointName) {
  msg.joint_names[3] = "right_ankle";
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "joint_names[3] is 'right_ankle', expected 'right_ankle_pd'",
                 before, jointNames());
}

TEST_F(RobotStateReject, SwappedJointNames) {
  std::swap(msg.joint_names[0], msg.joint_names[5]);
  expectRejected(msg, RejectReason::Malformed, "joint_names[0]", before, jointNames());
}

// Found by fuzz_lcm_decode: a name with a control character in it made the reason two lines. The reason
// now shows it escaped.
TEST_F(RobotStateReject, ControlCharacterInJointNameIsEscapedInTheReason) {
  msg.joint_names[0] = "\nright_hip_aa";
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "joint_names[0] is '\\nright_hip_aa'", before,
                 jointNames());
  msg.joint_names[0] = std::string("right_hip\x01_aa\r");
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "is 'right_hip\\x01_aa\\r'", before, jointNames());
}

TEST_F(RobotStateReject, NaNInJointPosition) {
  msg.q[6] = kNaN;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "q[6] is nan", before, jointNames());
}

TEST_F(RobotStateReject, InfInImu) {
  msg.imu_accel[2] = -kInf;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "imu_accel[2] is -inf", before, jointNames());
}

TEST_F(RobotStateReject, NaNInQuaternion) {
  msg.imu_orientation[1] = kNaN;
  expectRejected(msg, RejectReason::NonFinite, "imu_orientation[1]", before, jointNames());
}

TEST_F(RobotStateReject, NonUnitQuaternion) {
  for (double& c : msg.imu_orientation) c *= 1.0 + 2e-6;
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "imu_orientation has norm", before, jointNames());
}

TEST_F(RobotStateReject, ZeroQuaternion) {
  for (double& c : msg.imu_orientation) c = 0.0;
  expectRejected(msg, RejectReason::Malformed, "imu_orientation has norm 0", before, jointNames());
}

TEST_F(RobotStateReject, TorqueWithoutSensor) {
  msg.tau[4] = 0.5;
  expectRejected(msg, RejectReason::Malformed, "has_tau[4] is false", before, jointNames());
}

TEST_F(RobotStateReject, NegativeTick) {
  msg.tick = -1;
  expectRejected(msg, RejectReason::Malformed, "tick is -1", before, jointNames());
}

// ----------------------------------------------------------------------------------------------------
TEST(ForcePlateAdapter, RoundTripBothPlates) {
  for (int plate : {0, 1}) {
    const ForcePlateSample in = test::makePlate(plate);
    exoid_lcm::force_plate_t msg;
    toLcm(in, msg);
    EXPECT_EQ(msg.plate_name, plate == 0 ? "right" : "left");
    const auto wire = encodeDecode(msg);
    EXPECT_EQ(wire.plate_name, msg.plate_name);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(wire.force[i], msg.force[i]);
      EXPECT_EQ(wire.moment[i], msg.moment[i]);
      EXPECT_EQ(wire.cop[i], msg.cop[i]);
      EXPECT_EQ(wire.plate_position[i], msg.plate_position[i]);
    }
    ForcePlateSample out;
    std::string why;
    ASSERT_TRUE(fromLcm(wire, plate, out, &why)) << why;
    EXPECT_EQ(out.utime, in.utime);
    EXPECT_EQ(out.tick, in.tick);
    EXPECT_EQ(out.plate, plate);
    EXPECT_EQ(out.force, in.force);
    EXPECT_EQ(out.moment, in.moment);
    EXPECT_EQ(out.cop, in.cop);
    EXPECT_EQ(out.plate_position, in.plate_position);
    EXPECT_NEAR(out.plate_orientation.angularDistance(in.plate_orientation), 0.0, 1e-15);
    // -1 accepts either plate.
    ASSERT_TRUE(fromLcm(wire, -1, out, &why)) << why;
  }
}

TEST(ForcePlateAdapter, Rejections) {
  const ForcePlateSample before = test::makePlate(1);
  exoid_lcm::force_plate_t good;
  toLcm(test::makePlate(0), good);
  auto msg = good;
  expectRejected(msg, RejectReason::Malformed, "on a channel for the left plate", before, 1);
  msg.plate_name = "middle";
  expectRejected(msg, RejectReason::Malformed, "plate_name is 'middle'", before, -1);
  msg = good;
  msg.force[2] = kNaN;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "force[2] is nan", before, 0);
  msg = good;
  msg.cop[0] = kInf;
  expectRejected(msg, RejectReason::NonFinite, "cop[0] is inf", before, 0);
  msg = good;
  msg.plate_orientation[0] = 0.9;
  expectRejected(msg, RejectReason::Malformed, "plate_orientation has norm", before, 0);
  ForcePlateSample bad;
  bad.plate = 2;
  EXPECT_THROW(toLcm(bad, msg), std::invalid_argument);
}

// ----------------------------------------------------------------------------------------------------
TEST(JointCommandAdapter, RoundTripEveryMode) {
  for (CommandMode mode : {CommandMode::Torque, CommandMode::HoldLastSafe, CommandMode::Damping, CommandMode::Off}) {
    JointCommandSample in = test::makeCommand();
    in.mode = mode;
    exoid_lcm::joint_command_t msg;
    toLcm(in, jointNames(), msg);
    const auto wire = encodeDecode(msg);
    EXPECT_EQ(wire.mode, static_cast<int8_t>(mode));
    EXPECT_EQ(wire.joint_names, jointNames());
    EXPECT_EQ(wire.tau, msg.tau);
    EXPECT_EQ(wire.tau_ff, msg.tau_ff);
    JointCommandSample out;
    std::string why;
    ASSERT_TRUE(fromLcm(wire, jointNames(), out, &why)) << why;
    EXPECT_EQ(out.utime, in.utime);
    EXPECT_EQ(out.tick, in.tick);
    EXPECT_EQ(out.source_tick, in.source_tick);
    EXPECT_EQ(out.mode, mode);
    EXPECT_EQ(out.tau, in.tau);
    EXPECT_EQ(out.tau_ff, in.tau_ff);
  }
}

TEST(JointCommandAdapter, Rejections) {
  JointCommandSample before = test::makeCommand();
  before.tau.setZero();
  exoid_lcm::joint_command_t good;
  toLcm(test::makeCommand(), jointNames(), good);
  auto msg = good;
  msg.mode = 4;
  expectRejected(msg, RejectReason::Malformed, "mode is 4", before, jointNames());
  msg = good;
  msg.source_tick = msg.tick + 1;
  expectRejected(msg, RejectReason::Malformed, "source_tick 102 is after tick 101", before, jointNames());
  msg = good;
  msg.num_joints = 11;
  msg.joint_names.push_back("extra");
  msg.tau.push_back(0);
  msg.tau_ff.push_back(0);
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "num_joints is 11", before, jointNames());
  msg = good;
  msg.joint_names[9] = "left_ankle_IE";
  expectRejected(msg, RejectReason::Malformed, "joint_names[9]", before, jointNames());
  msg = good;
  msg.tau_ff[0] = kInf;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "tau_ff[0] is inf", before, jointNames());
  msg = good;
  msg.tau[2] = kNaN;
  expectRejected(msg, RejectReason::NonFinite, "tau[2] is nan", before, jointNames());
}

// ----------------------------------------------------------------------------------------------------
TEST(GroundTruthAdapter, RoundTrip) {
  const GroundTruthSample in = test::makeTruth();
  exoid_lcm::ground_truth_t msg;
  toLcm(in, jointNames(), msg);
  const auto wire = encodeDecode(msg);
  EXPECT_EQ(wire.q, msg.q);
  EXPECT_EQ(wire.a, msg.a);
  EXPECT_EQ(wire.foot_moment_left[2], -5.0);
  GroundTruthSample out;
  std::string why;
  ASSERT_TRUE(fromLcm(wire, jointNames(), out, &why)) << why;
  EXPECT_EQ(out.utime, in.utime);
  EXPECT_EQ(out.tick, in.tick);
  EXPECT_EQ(out.base_position, in.base_position);
  EXPECT_NEAR(out.base_orientation.angularDistance(in.base_orientation), 0.0, 1e-15);
  EXPECT_EQ(out.base_omega, in.base_omega);
  EXPECT_EQ(out.base_velocity, in.base_velocity);
  EXPECT_EQ(out.base_domega, in.base_domega);
  EXPECT_EQ(out.base_acceleration, in.base_acceleration);
  EXPECT_EQ(out.q, in.q);
  EXPECT_EQ(out.v, in.v);
  EXPECT_EQ(out.a, in.a);
  EXPECT_EQ(out.tau_applied, in.tau_applied);
  for (int f = 0; f < 2; ++f) {
    EXPECT_EQ(out.foot_force[f], in.foot_force[f]) << f;
    EXPECT_EQ(out.foot_moment[f], in.foot_moment[f]) << f;
  }
  EXPECT_EQ(out.com, in.com);
}

TEST(GroundTruthAdapter, Rejections) {
  GroundTruthSample before = test::makeTruth();
  before.v.setConstant(3);
  exoid_lcm::ground_truth_t good;
  toLcm(test::makeTruth(), jointNames(), good);
  auto msg = good;
  msg.v[7] = kNaN;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "v[7] is nan", before, jointNames());
  msg = good;
  msg.foot_force_left[1] = kInf;
  expectRejected(msg, RejectReason::NonFinite, "foot_force_left[1]", before, jointNames());
  msg = good;
  msg.com[2] = kNaN;
  expectRejected(msg, RejectReason::NonFinite, "com[2]", before, jointNames());
  msg = good;
  msg.base_orientation[0] += 1e-5;
  expectRejected(msg, RejectReason::Malformed, "base_orientation has norm", before, jointNames());
  const std::vector<std::string> nine(jointNames().begin(), jointNames().end() - 1);
  expectRejected(good, RejectReason::Malformed, "num_joints is 10, expected 9", before, nine);
}

// ----------------------------------------------------------------------------------------------------
TEST(ControllerStatusAdapter, RoundTrip) {
  const ControllerStatusSample in = test::makeStatus();
  exoid_lcm::controller_status_t msg;
  toLcm(in, msg);
  const auto wire = encodeDecode(msg);
  EXPECT_EQ(wire.qp_status, 1);
  EXPECT_EQ(wire.wrench_left[5], msg.wrench_left[5]);
  ControllerStatusSample out;
  std::string why;
  ASSERT_TRUE(fromLcm(wire, out, &why)) << why;
  EXPECT_EQ(out.utime, in.utime);
  EXPECT_EQ(out.tick, in.tick);
  EXPECT_EQ(out.qp_status, in.qp_status);
  EXPECT_EQ(out.qp_iterations, in.qp_iterations);
  EXPECT_EQ(out.qp_solve_us, in.qp_solve_us);
  EXPECT_EQ(out.tick_us, in.tick_us);
  EXPECT_EQ(out.move_index, in.move_index);
  EXPECT_EQ(out.moves_done, in.moves_done);
  EXPECT_EQ(out.com_ref, in.com_ref);
  EXPECT_EQ(out.com, in.com);
  EXPECT_EQ(out.com_vel_ref, in.com_vel_ref);
  EXPECT_EQ(out.com_vel, in.com_vel);
  EXPECT_EQ(out.momentum_rate_ref, in.momentum_rate_ref);
  EXPECT_EQ(out.momentum, in.momentum);
  EXPECT_EQ(out.wrench_right, in.wrench_right);
  EXPECT_EQ(out.wrench_left, in.wrench_left);
  EXPECT_EQ(out.fallbacks, in.fallbacks);
  EXPECT_EQ(out.rejected_inputs, in.rejected_inputs);
  EXPECT_EQ(out.stale_inputs, in.stale_inputs);
}

TEST(ControllerStatusAdapter, Rejections) {
  ControllerStatusSample before;
  exoid_lcm::controller_status_t good;
  toLcm(test::makeStatus(), good);
  auto msg = good;
  msg.qp_status = 7;
  expectRejected(msg, RejectReason::Malformed, "qp_status is 7", before);
  msg = good;
  msg.move_index = -2;
  expectRejected(msg, RejectReason::Malformed, "move_index is -2", before);
  msg = good;
  msg.momentum[4] = kNaN;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "momentum[4] is nan", before);
  msg = good;
  msg.qp_solve_us = -1;
  expectRejected(msg, RejectReason::Malformed, "qp_solve_us", before);
}

// ----------------------------------------------------------------------------------------------------
TEST(EstimatorOutputAdapter, RoundTrip) {
  const EstimatorOutputSample in = test::makeEstimate();
  exoid_lcm::estimator_output_t msg;
  toLcm(in, paramNames(), coordNames(), msg);
  const auto wire = encodeDecode(msg);
  EXPECT_EQ(wire.param_names, paramNames());
  EXPECT_EQ(wire.coord_names, coordNames());
  EXPECT_EQ(wire.params, msg.params);
  EstimatorOutputSample out;
  std::string why;
  ASSERT_TRUE(fromLcm(wire, paramNames(), test::kNumBase, coordNames(), out, &why)) << why;
  EXPECT_TRUE(test::same(out, in));
  EXPECT_EQ(out.tau_correction.size(), 16);
  EXPECT_EQ(out.base_params.size(), 3);
}

TEST(EstimatorOutputAdapter, Rejections) {
  const EstimatorOutputSample before;
  exoid_lcm::estimator_output_t good;
  toLcm(test::makeEstimate(), paramNames(), coordNames(), good);
  const auto& pn = paramNames();
  const auto& cn = coordNames();
  const size_t nb = test::kNumBase;
  auto msg = good;
  msg.param_names[2] = "right_thigh.Iyy";
  expectRejected(msg, RejectReason::Malformed, "param_names[2] is 'right_thigh.Iyy'", before, pn, nb, cn);
  msg = good;
  msg.coord_names[0] = "base_fx";
  expectRejected(msg, RejectReason::Malformed, "coord_names[0] is 'base_fx'", before, pn, nb, cn);
  msg = good;
  msg.param_stddev[1] = -0.1;
  expectRejected(msg, RejectReason::Malformed, "param_stddev[1]", before, pn, nb, cn);
  msg = good;
  msg.base_stddev[2] = -0.1;
  expectRejected(msg, RejectReason::Malformed, "base_stddev[2]", before, pn, nb, cn);
  msg = good;
  msg.residual_rms[4] = -1.0;
  expectRejected(msg, RejectReason::Malformed, "residual_rms[4]", before, pn, nb, cn);
  msg = good;
  msg.params[0] = kNaN;
  expectRejected(encodeDecode(msg), RejectReason::NonFinite, "params[0] is nan", before, pn, nb, cn);
  msg = good;
  msg.base_params[1] = kInf;
  expectRejected(msg, RejectReason::NonFinite, "base_params[1] is inf", before, pn, nb, cn);
  msg = good;
  msg.tau_correction[9] = kInf;
  expectRejected(msg, RejectReason::NonFinite, "tau_correction[9] is inf", before, pn, nb, cn);
  msg = good;
  msg.excitation = 1.5;
  expectRejected(msg, RejectReason::Malformed, "excitation 1.5 outside [0, 1]", before, pn, nb, cn);
  msg = good;
  msg.excitation = kNaN;
  expectRejected(msg, RejectReason::NonFinite, "excitation", before, pn, nb, cn);
  msg = good;
  msg.rejected_duplicate += 1;
  expectRejected(msg, RejectReason::Malformed, "not the sum of its reasons", before, pn, nb, cn);
  msg = good;
  msg.num_base = 4;
  msg.base_params.push_back(0.0);
  msg.base_stddev.push_back(0.0);
  expectRejected(encodeDecode(msg), RejectReason::Malformed, "num_base is 4, expected 3", before, pn, nb, cn);
  msg = good;
  msg.residual_rms.pop_back();
  expectRejected(msg, RejectReason::Malformed, "residual_rms has 15 entries", before, pn, nb, cn);
}

// ----------------------------------------------------------------------------------------------------
TEST(ToLcm, SizeMismatchIsASetupErrorWithOneLineMessage) {
  RobotStateSample s = test::makeState(9);
  exoid_lcm::robot_state_t msg;
  try {
    toLcm(s, jointNames(), msg);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("RobotStateSample.q has 9 entries but 10 names"), std::string::npos)
        << e.what();
  }
}

TEST(ToLcm, ReusedMessageKeepsItsStorage) {
  exoid_lcm::robot_state_t msg;
  toLcm(test::makeState(), jointNames(), msg);
  const double* q_data = msg.q.data();
  const char* name_data = msg.joint_names[0].data();
  RobotStateSample s = test::makeState();
  s.q.setConstant(0.25);
  toLcm(s, jointNames(), msg);
  EXPECT_EQ(msg.q.data(), q_data);
  EXPECT_EQ(msg.joint_names[0].data(), name_data);
  EXPECT_EQ(msg.q[3], 0.25);
}

}  // namespace
}  // namespace exoid

namespace exoid {
namespace {
// ----------------------------------------------------------------------------------------------------
// The gate's value rules are written once (sample_checks.hpp): fromLcm's verdict on a message is the sample
// checks' verdict on the same values, case by case, at the one quaternion tolerance (1e-6) and either side of it.
RejectReason expectedReason(SampleFault f) { return f == SampleFault::NonFinite ? RejectReason::NonFinite : RejectReason::Malformed; }

TEST(Gate, FromLcmAndTheSampleChecksGiveTheSameVerdict) {
  std::vector<std::pair<const char*, RobotStateSample>> states;
  const RobotStateSample clean = test::makeState();
  states.push_back({"clean", clean});
  RobotStateSample s = clean;
  s.q[3] = kNaN;
  states.push_back({"q NaN", s});
  s = clean;
  s.imu_gyro.y() = kInf;
  states.push_back({"gyro Inf", s});
  s = clean;
  s.imu_orientation.coeffs() *= 1.0 + 2e-6;
  states.push_back({"|q| 1 + 2e-6", s});
  s = clean;
  s.imu_orientation.coeffs() *= 1.0 + 5e-7;
  states.push_back({"|q| 1 + 5e-7", s});
  s = clean;
  s.has_tau[2] = false;
  s.tau[2] = 1.0;
  states.push_back({"torque without sensor", s});
  s = clean;
  s.imu_accel.z() = -1.0001 * kMaxSampleMagnitude;
  states.push_back({"accel beyond the range", s});
  s = clean;
  s.q[0] = kMaxSampleMagnitude;
  states.push_back({"q at the range", s});
  const SampleFault want_state[] = {SampleFault::None,      SampleFault::NonFinite, SampleFault::NonFinite,
                                    SampleFault::Malformed, SampleFault::None,      SampleFault::Malformed,
                                    SampleFault::Malformed, SampleFault::None};
  for (size_t i = 0; i < states.size(); ++i) {
    const RobotStateSample& in = states[i].second;
    ASSERT_TRUE(stateSizesOk(in, static_cast<int>(jointNames().size())));
    const SampleFault f = checkStateValues(in);
    EXPECT_EQ(f, want_state[i]) << states[i].first;
    exoid_lcm::robot_state_t msg;
    toLcm(in, jointNames(), msg);
    RobotStateSample out;
    RejectReason reason = RejectReason::Duplicate;
    EXPECT_EQ(fromLcm(encodeDecode(msg), jointNames(), out, nullptr, &reason), f == SampleFault::None) << states[i].first;
    if (f != SampleFault::None) { EXPECT_EQ(reason, expectedReason(f)) << states[i].first; }
  }
  std::vector<std::pair<const char*, ForcePlateSample>> plates;
  const ForcePlateSample pclean = test::makePlate(1);
  plates.push_back({"clean", pclean});
  ForcePlateSample p = pclean;
  p.cop.x() = kNaN;
  plates.push_back({"cop NaN", p});
  p = pclean;
  p.plate_orientation.coeffs() *= 1.0 - 2e-6;
  plates.push_back({"|q| 1 - 2e-6", p});
  p = pclean;
  p.plate_orientation.coeffs() *= 1.0 - 5e-7;
  plates.push_back({"|q| 1 - 5e-7", p});
  p = pclean;
  p.force.z() = -1e200, p.plate_position.y() = 1e200;  // finite, but p x F overflows (fuzz_log_samples' find)
  plates.push_back({"force and position 1e200", p});
  p = pclean;
  p.plate_position.x() = -kMaxSampleMagnitude;
  plates.push_back({"position at the range", p});
  const SampleFault want_plate[] = {SampleFault::None, SampleFault::NonFinite, SampleFault::Malformed, SampleFault::None,
                                    SampleFault::Malformed, SampleFault::None};
  for (size_t i = 0; i < plates.size(); ++i) {
    const ForcePlateSample& in = plates[i].second;
    const SampleFault f = checkPlateValues(in);
    EXPECT_EQ(f, want_plate[i]) << plates[i].first;
    exoid_lcm::force_plate_t msg;
    toLcm(in, msg);
    ForcePlateSample out;
    RejectReason reason = RejectReason::Duplicate;
    EXPECT_EQ(fromLcm(encodeDecode(msg), 1, out, nullptr, &reason), f == SampleFault::None) << plates[i].first;
    if (f != SampleFault::None) { EXPECT_EQ(reason, expectedReason(f)) << plates[i].first; }
  }
}

// A value beyond the range is named with its field and index; the truth, which the gate has no sample check
// for, gets the same rule.
TEST(Gate, AValueBeyondTheSampleRangeIsNamed) {
  ForcePlateSample p = test::makePlate(0);
  p.force.z() = 3e12;
  exoid_lcm::force_plate_t msg;
  toLcm(p, msg);
  std::string why;
  RejectReason reason = RejectReason::Duplicate;
  EXPECT_FALSE(fromLcm(encodeDecode(msg), 0, p, &why, &reason));
  EXPECT_EQ(reason, RejectReason::Malformed);
  EXPECT_EQ(why, "force_plate_t: force[2] is 3e+12, beyond the 1e+09 a measured value can take");

  GroundTruthSample t = test::makeTruth();
  t.foot_moment[1].x() = -2e10;
  exoid_lcm::ground_truth_t tmsg;
  toLcm(t, jointNames(), tmsg);
  EXPECT_FALSE(fromLcm(encodeDecode(tmsg), jointNames(), t, &why, &reason));
  EXPECT_EQ(reason, RejectReason::Malformed);
  EXPECT_EQ(why, "ground_truth_t: foot_moment_left[0] is -2e+10, beyond the 1e+09 a measured value can take");
}

}  // namespace
}  // namespace exoid
