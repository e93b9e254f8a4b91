#pragma once
// Reads an lcm-logger file of a run into plain samples, channel by channel (the offline tools' whole-run
// view: export, experiment summaries, study, benchmarks). Every event is accounted for: decoded, rejected by
// the adapters (counted with a reason), or on a channel exoid does not know (counted). Every byte is
// accounted for too (log_events.hpp: the one log reader): damaged stretches and a cut-off tail are reported.
#include <map>
#include <string>
#include <vector>

#include "exoid/intake/log_events.hpp"
#include "exoid/model/model.hpp"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::intake {

struct RunLog {
  std::vector<RobotStateSample> states;        ///< EXO_STATE, in log order
  std::vector<ForcePlateSample> plates[2];     ///< EXO_PLATE_RIGHT, EXO_PLATE_LEFT
  std::vector<GroundTruthSample> truth;        ///< EXO_TRUTH
  std::vector<JointCommandSample> commands;    ///< EXO_COMMAND
  std::vector<ControllerStatusSample> status;  ///< EXO_CONTROLLER_STATUS
  std::vector<EstimatorOutputSample> estimates;  ///< EXO_ESTIMATE (checked against the names it carries)
  std::map<std::string, long> events;          ///< events per channel
  long rejected = 0;                           ///< events that failed decoding or validation
  long unknown_channel = 0;
  std::string first_rejection;                 ///< reason of the first rejected event, if any
  LogDamage damage;                            ///< damage to the file itself (event framing; docs/data-formats.md)
  int64_t last_tick = -1;         ///< largest tick decoded on any exoid channel (the readable part's end)

  /// True when nothing was damaged, cut off or rejected.
  bool intact() const { return damage.intact() && rejected == 0; }
  /// One line on what is damaged and where the readable part ends ("" when intact()).
  std::string damageReport() const;
};

/// Reads a log. joint_names: the model's joints (messages must carry exactly these). False with *error if
/// the file cannot be opened or holds no valid event; a damaged or truncated log is read as far as it can
/// be and reported in `log` (see intact(), damageReport()), the caller decides whether that is acceptable.
bool readRunLog(const std::string& path, const std::vector<std::string>& joint_names, RunLog& log, std::string* error);

}  // namespace exoid::intake
