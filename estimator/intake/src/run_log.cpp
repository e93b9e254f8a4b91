#include "exoid/intake/run_log.hpp"

#include <algorithm>

#include "exoid/intake/log_events.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::intake {

namespace {
template <class Msg, class Sample, class Convert>
void take(const LogEvent& e, const std::string& channel, std::vector<Sample>& out, RunLog& log, Convert convert) {
  Msg msg;
  Sample sample;
  std::string why;
  if (!safeDecode(e.data, e.data_length, msg)) {
    why = "undecodable bytes";
  } else if (convert(msg, sample, &why)) {
    log.last_tick = std::max<int64_t>(log.last_tick, sample.tick);
    out.push_back(std::move(sample));
    return;
  }
  ++log.rejected;
  if (log.first_rejection.empty()) log.first_rejection = printable(channel + " at byte " + std::to_string(e.offset) + ": " + why);
}

void dispatch(const LogEvent& e, const std::vector<std::string>& joints, RunLog& log) {
  const std::string channel(e.channel, static_cast<size_t>(e.channel_length));
  ++log.events[channel];
  if (channel == channels::kState) {
    take<exoid_lcm::robot_state_t>(e, channel, log.states, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
    const int plate = channel == channels::kPlateRight ? 0 : 1;
    take<exoid_lcm::force_plate_t>(e, channel, log.plates[plate], log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, plate, s, w); });
  } else if (channel == channels::kTruth) {
    take<exoid_lcm::ground_truth_t>(e, channel, log.truth, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kCommand) {
    take<exoid_lcm::joint_command_t>(e, channel, log.commands, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kControllerStatus) {
    take<exoid_lcm::controller_status_t>(e, channel, log.status, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, s, w); });
  } else if (channel == channels::kEstimate) {
    // The reader does not know the estimator's model: the message is checked against its own names (sizes
    // agree, values valid); the summary checks the parameter count against its model.
    take<exoid_lcm::estimator_output_t>(e, channel, log.estimates, log, [&](auto& m, auto& s, auto* w) {
      return fromLcm(m, m.param_names, kAnyNumBase, m.coord_names, s, w);
    });
  } else {
    ++log.unknown_channel;
  }
}
}  // namespace

std::string RunLog::damageReport() const {
  return intake::damageReport(damage, rejected, first_rejection, last_tick);
}

bool readRunLog(const std::string& path, const std::vector<std::string>& joints, RunLog& log, std::string* error) {
  log = RunLog();
  return readLogEvents(path, [&](const LogEvent& e) { return dispatch(e, joints, log), true; }, log.damage, error);
}

}  // namespace exoid::intake
