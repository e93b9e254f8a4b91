#pragma once
// Reads an lcm-logger file of a run into plain samples, channel by channel (the offline tools' view of a
// run). Every event is accounted for: decoded, rejected by the adapters (counted with a reason), or on a
// channel exoid does not know (counted).
#include <map>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::tools {

struct RunLog {
  std::vector<RobotStateSample> states;        ///< EXO_STATE, in log order
  std::vector<ForcePlateSample> plates[2];     ///< EXO_PLATE_RIGHT, EXO_PLATE_LEFT
  std::vector<GroundTruthSample> truth;        ///< EXO_TRUTH
  std::vector<JointCommandSample> commands;    ///< EXO_COMMAND
  std::vector<ControllerStatusSample> status;  ///< EXO_CONTROLLER_STATUS
  std::map<std::string, long> events;          ///< events per channel
  long rejected = 0;                           ///< events that failed decoding or validation
  long unknown_channel = 0;
  std::string first_rejection;                 ///< reason of the first rejected event, if any
};

/// Reads a log. joint_names: the model's joints (messages must carry exactly these). False with *error if
/// the file cannot be opened or is not an LCM log.
bool readRunLog(const std::string& path, const std::vector<std::string>& joint_names, RunLog& log, std::string* error);

}  // namespace exoid::tools
