#include "exoid/tools/run_log.hpp"

#include <lcm/eventlog.h>

#include <cstring>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::tools {

namespace {
template <class Msg, class Sample, class Convert>
void take(const lcm_eventlog_event_t* e, std::vector<Sample>& out, RunLog& log, Convert convert) {
  Msg msg;
  Sample sample;
  std::string why;
  if (!safeDecode(e->data, e->datalen, msg)) {
    why = "undecodable bytes";
  } else if (convert(msg, sample, &why)) {
    out.push_back(std::move(sample));
    return;
  }
  ++log.rejected;
  if (log.first_rejection.empty()) log.first_rejection = std::string(e->channel) + ": " + why;
}
}  // namespace

bool readRunLog(const std::string& path, const std::vector<std::string>& joints, RunLog& log, std::string* error) {
  log = RunLog();
  lcm_eventlog_t* file = lcm_eventlog_create(path.c_str(), "r");
  if (!file) {
    if (error) *error = "cannot open LCM log '" + path + "'";
    return false;
  }
  long events = 0;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(file)) {
    ++events;
    const std::string channel(e->channel, e->channellen);
    ++log.events[channel];
    if (channel == channels::kState) {
      take<exoid_lcm::robot_state_t>(e, log.states, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
    } else if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
      const int plate = channel == channels::kPlateRight ? 0 : 1;
      take<exoid_lcm::force_plate_t>(e, log.plates[plate], log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, plate, s, w); });
    } else if (channel == channels::kTruth) {
      take<exoid_lcm::ground_truth_t>(e, log.truth, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
    } else if (channel == channels::kCommand) {
      take<exoid_lcm::joint_command_t>(e, log.commands, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
    } else if (channel == channels::kControllerStatus) {
      take<exoid_lcm::controller_status_t>(e, log.status, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, s, w); });
    } else {
      ++log.unknown_channel;
    }
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(file);
  if (events == 0) {
    if (error) *error = "'" + path + "' holds no LCM events (empty or not an LCM log)";
    return false;
  }
  return true;
}

}  // namespace exoid::tools
