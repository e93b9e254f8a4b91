#pragma once
// Plain, transport-free samples exchanged between sim, controller and estimator, expanded from the message
// schema (exoid/interfaces/schema.h: the fields, their units and frames). LCM appears only in the adapters
// (lcmtypes/adapters), the plugin ABI only in exoid/controller_plugin.h; algorithms take and return these.
// Units SI; conventions docs/conventions.md.
#include "exoid/interfaces/plain.hpp"

namespace exoid {

/// Robot sensors at one tick (exoid_lcm.robot_state_t). Joint arrays follow Model joint order.
struct RobotStateSample {
  EXOID_SCHEMA_ROBOT_STATE(EXOID_PLAIN_MEMBER)
};

/// One 6-axis force plate at one tick (exoid_lcm.force_plate_t): what the plate's own sensor reports.
struct ForcePlateSample {
  EXOID_SCHEMA_FORCE_PLATE(EXOID_PLAIN_MEMBER)
};

/// Controller -> robot (exoid_lcm.joint_command_t).
struct JointCommandSample {
  EXOID_SCHEMA_JOINT_COMMAND(EXOID_PLAIN_MEMBER)
};

/// Exact simulator state at one tick, for validation only (exoid_lcm.ground_truth_t).
struct GroundTruthSample {
  EXOID_SCHEMA_GROUND_TRUTH(EXOID_PLAIN_MEMBER)
};

}  // namespace exoid
