#pragma once
// Pure conversions between the generated LCM messages (package exoid_lcm) and exoid's plain samples.
//
// fromLcm(msg, <expected names...>, out, why, reason):
//   validates the message completely BEFORE writing anything; on rejection it returns false, leaves `out`
//   untouched, writes a one-line reason to *why and the category to *reason (both optional), and never
//   throws. Checks: utime, tick >= 0; array lengths = num_joints (num_params); names equal, in order, to the
//   expected list; enums in range; every double finite; quaternions unit-norm within kQuatNormTolerance (then
//   normalised exactly). The output's vectors are resized only when their size differs (first call), so a
//   reused sample does not allocate.
// toLcm(sample, <names...>, msg):
//   fills every field. Reusing `msg` across calls reuses its vectors/strings (no allocation once sized).
//   Throws std::invalid_argument (one line) if the sample's sizes disagree with the names: a setup bug.
#include <exoid/sample_checks.hpp>
#include <exoid/samples.hpp>
#include <exoid/status_samples.hpp>
#include <exoid_lcm/controller_status_t.hpp>
#include <exoid_lcm/estimator_output_t.hpp>
#include <exoid_lcm/force_plate_t.hpp>
#include <exoid_lcm/ground_truth_t.hpp>
#include <exoid_lcm/joint_command_t.hpp>
#include <exoid_lcm/robot_state_t.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace exoid {

/// Why an input message was rejected (adapters and MessageGate).
enum class RejectReason : uint8_t {
  Duplicate = 0,   ///< same tick as the last accepted message on the channel
  OutOfOrder = 1,  ///< older tick than the last accepted message on the channel
  NonFinite = 2,   ///< a NaN or Inf value
  Malformed = 3,   ///< undecodable bytes, wrong sizes or names, bad enum, non-unit quaternion, negative tick...
};
inline constexpr int kNumRejectReasons = 4;
/// "duplicate", "out_of_order", "non_finite", "malformed".
const char* toString(RejectReason reason);

/// Largest accepted | |q| - 1 | of a quaternion in a message: the gate's one threshold (sample_checks.hpp).
inline constexpr double kQuatNormTolerance = kUnitQuaternionTolerance;

// --- robot_state_t <-> RobotStateSample --------------------------------------------------------------
/// Also rejects tau != 0 where has_tau is false.
bool fromLcm(const exoid_lcm::robot_state_t& msg, const std::vector<std::string>& expected_joint_names,
             RobotStateSample& out, std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const RobotStateSample& sample, const std::vector<std::string>& joint_names,
           exoid_lcm::robot_state_t& msg);

// --- force_plate_t <-> ForcePlateSample --------------------------------------------------------------
/// plate_name must be "right" (plate 0) or "left" (plate 1); expected_plate 0 or 1 also requires that one
/// (pass the one matching the channel), -1 accepts either.
bool fromLcm(const exoid_lcm::force_plate_t& msg, int expected_plate, ForcePlateSample& out,
             std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const ForcePlateSample& sample, exoid_lcm::force_plate_t& msg);
/// "right" for 0, "left" for 1, nullptr otherwise.
const char* plateName(int plate);

// --- joint_command_t <-> JointCommandSample ----------------------------------------------------------
/// Also rejects a mode outside 0..3 and source_tick > tick.
bool fromLcm(const exoid_lcm::joint_command_t& msg, const std::vector<std::string>& expected_joint_names,
             JointCommandSample& out, std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const JointCommandSample& sample, const std::vector<std::string>& joint_names,
           exoid_lcm::joint_command_t& msg);

// --- ground_truth_t <-> GroundTruthSample ------------------------------------------------------------
bool fromLcm(const exoid_lcm::ground_truth_t& msg, const std::vector<std::string>& expected_joint_names,
             GroundTruthSample& out, std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const GroundTruthSample& sample, const std::vector<std::string>& joint_names,
           exoid_lcm::ground_truth_t& msg);

// --- controller_status_t <-> ControllerStatusSample --------------------------------------------------
/// Also rejects qp_status outside 0..3, negative counters/times/iterations, move_index < -1.
bool fromLcm(const exoid_lcm::controller_status_t& msg, ControllerStatusSample& out,
             std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const ControllerStatusSample& sample, exoid_lcm::controller_status_t& msg);

// --- estimator_output_t <-> EstimatorOutputSample ----------------------------------------------------
/// Sizes are checked against the model: the parameter names (Model::paramNames), the number of base
/// parameters and the generalized-coordinate names (Model::coordinateNames). Also rejects negative counters,
/// standard deviations or residuals, a samples_rejected that is not the sum of its reasons, excitation
/// outside [0, 1]. A consumer that does not use the base parameters (the controller: it needs only params
/// and tau_ff, and the base-parameter count is estimator maths) passes kAnyNumBase; the lengths must still agree.
inline constexpr size_t kAnyNumBase = static_cast<size_t>(-1);
bool fromLcm(const exoid_lcm::estimator_output_t& msg, const std::vector<std::string>& expected_param_names,
             size_t expected_num_base, const std::vector<std::string>& expected_coord_names,
             EstimatorOutputSample& out, std::string* why = nullptr, RejectReason* reason = nullptr);
void toLcm(const EstimatorOutputSample& sample, const std::vector<std::string>& param_names,
           const std::vector<std::string>& coord_names, exoid_lcm::estimator_output_t& msg);

}  // namespace exoid
