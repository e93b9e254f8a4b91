#pragma once
// Scenario::wearer at load time (sim/src/wearer.cpp): the MJCF recompiled with the wearer's bodies. Internal to exoid_sim.
#include <string>

#include "exoid/sim/sim.hpp"

namespace exoid::sim {

/// sm.m holds the exo's MJCF as compiled from sm.mjcf_path. Builds the wearer of sm.scenario.wearer, mounts it on the
/// exo's standing pose (qpos0), adds its bodies and lumbar hinges to the MJCF and recompiles it into sm.m; fills
/// sm.wearer except the joint addresses (findWearerJoints, after findJoints). False with a one-line *err.
bool loadWearer(SimModel& sm, std::string* err);

/// The lumbar hinges and the exo leg joints the passive moments act on (by name); the sway filter constant.
bool findWearerJoints(SimModel& sm, std::string* err);

/// The wearer's state at reset: its generator reseeded, the sway at a draw from its stationary distribution.
void resetWearerState(const SimModel& sm, SimData& sd);

/// Name prefix of the bodies and joints the wearer adds (its hinges are not exo joints).
inline constexpr const char* kWearerPrefix = "wearer_";

}  // namespace exoid::sim
