#pragma once
// LCM channel names and the default LCM URL of exoid (docs/lcm.md). Use these constants, never literals.

namespace exoid::channels {

inline constexpr const char* kState = "EXO_STATE";                        ///< exoid_lcm.robot_state_t
inline constexpr const char* kPlateRight = "EXO_PLATE_RIGHT";             ///< exoid_lcm.force_plate_t
inline constexpr const char* kPlateLeft = "EXO_PLATE_LEFT";               ///< exoid_lcm.force_plate_t
inline constexpr const char* kCommand = "EXO_COMMAND";                    ///< exoid_lcm.joint_command_t
inline constexpr const char* kControllerStatus = "EXO_CONTROLLER_STATUS";  ///< exoid_lcm.controller_status_t
inline constexpr const char* kEstimate = "EXO_ESTIMATE";                  ///< exoid_lcm.estimator_output_t
inline constexpr const char* kTruth = "EXO_TRUTH";                        ///< exoid_lcm.ground_truth_t

/// Default LCM URL when LCM_DEFAULT_URL is unset: UDP multicast that never leaves the host (ttl=0).
inline constexpr const char* kDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

}  // namespace exoid::channels
