#pragma once
// Plain, transport-free mirrors of exoid_lcm.controller_status_t and exoid_lcm.estimator_output_t, expanded from
// the message schema (exoid/interfaces/schema.h; the adapters in lcmtypes/adapters convert). Names (joints,
// parameters) are not stored here: like samples.hpp, arrays follow an order fixed at setup and the adapters take
// the expected name lists. Vectors are sized once on setup, so filling a sample in a loop does not allocate.
#include "exoid/interfaces/plain.hpp"

namespace exoid {

/// Controller diagnostics at one tick (exoid_lcm.controller_status_t, channel EXO_CONTROLLER_STATUS).
struct ControllerStatusSample {
  EXOID_SCHEMA_CONTROLLER_STATUS(EXOID_PLAIN_MEMBER)
};

/// Estimator output (exoid_lcm.estimator_output_t, channel EXO_ESTIMATE).
struct EstimatorOutputSample {
  EXOID_SCHEMA_ESTIMATOR_OUTPUT(EXOID_PLAIN_MEMBER)
};

}  // namespace exoid
