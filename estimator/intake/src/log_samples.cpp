// Run log -> measured samples in tick order (measured_input.hpp), on the one log reader (log_events.hpp).
#include <optional>

#include "exoid/intake/measured_input.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::intake {

namespace {
void skip(InputStats& st, const std::string& reason, const std::string& where) {
  ++st.skipped;
  ++st.why[reason];
  if (st.first_skip.empty()) st.first_skip = where + ": " + reason;
}

struct Pending {
  std::optional<RobotStateSample> state;
  std::optional<ForcePlateSample> plate[2];
  std::optional<GroundTruthSample> truth;
};
}  // namespace

bool streamRunLog(const std::string& path, const Model& model, LogPipeline pipeline, const int feet[2],
                  bool allow_partial, const SampleSink& sink, InputStats& stats, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  stats = InputStats();
  const bool truth = pipeline == LogPipeline::Truth;
  std::map<int64_t, Pending> pending;  // by tick; complete ticks leave in tick order
  int64_t last_done = -1, newest = -1;
  constexpr int64_t kWindow = 200;      // ticks a channel may lag before a tick is declared incomplete
  long events = 0, needed_events = 0;
  std::string first_rejection;
  estimator::MeasuredSample sample;
  std::string sink_error;
  bool sink_failed = false;
  auto complete = [&](const Pending& p) { return p.plate[0] && p.plate[1] && (truth ? p.truth.has_value() : p.state.has_value()); };
  auto emit = [&](const Pending& p) {
    const ForcePlateSample* plates[2] = {&*p.plate[0], &*p.plate[1]};
    if (truth) estimator::measuredFromTruth(model, *p.truth, plates, feet, sample);
    else estimator::measuredFromSensors(model, *p.state, plates, feet, sample);
    if (!sink(sample, &sink_error)) sink_failed = true;
    ++stats.samples;
  };
  auto drain = [&](bool all) {
    while (!pending.empty() && !sink_failed) {
      auto it = pending.begin();
      if (complete(it->second)) {
        emit(it->second);
      } else if (all || newest - it->first > kWindow) {
        skip(stats, "tick missing a needed message", "tick " + std::to_string(it->first));
      } else {
        break;
      }
      last_done = it->first;
      pending.erase(it);
    }
  };
  auto place = [&](int64_t tick, auto&& assign) {
    if (tick <= last_done) {
      skip(stats, "message for a tick already passed (out of order or repeated)", "tick " + std::to_string(tick));
      return;
    }
    newest = std::max(newest, tick);
    assign(pending[tick]);
  };
  int64_t last_tick = -1;
  const LogEventSink read = [&](const LogEvent& e) {
    ++events;
    const std::string channel(e.channel, static_cast<size_t>(e.channel_length));
    std::string why;
    bool ok = true;
    int64_t tick = -1;
    if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
      ++needed_events;
      const int side = channel == channels::kPlateRight ? 0 : 1;
      exoid_lcm::force_plate_t msg;
      ForcePlateSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, side, s, &why);
      if (ok) tick = s.tick, place(s.tick, [&](Pending& p) { if (!p.plate[side]) p.plate[side] = s; });
    } else if (channel == channels::kState && !truth) {
      ++needed_events;
      exoid_lcm::robot_state_t msg;
      RobotStateSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) tick = s.tick, place(s.tick, [&](Pending& p) { if (!p.state) p.state = s; });
    } else if (channel == channels::kTruth && truth) {
      ++needed_events;
      exoid_lcm::ground_truth_t msg;
      GroundTruthSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) tick = s.tick, place(s.tick, [&](Pending& p) { if (!p.truth) p.truth = s; });
    }
    last_tick = std::max(last_tick, tick);
    if (!ok) {
      if (why.empty()) why = "undecodable bytes";
      ++stats.rejected_events;
      const std::string where = channel + " event " + std::to_string(events) + " at byte " + std::to_string(e.offset);
      if (first_rejection.empty()) first_rejection = printable(where + ": " + why);
      skip(stats, "log event rejected", printable(where + " (" + why + ")"));
    }
    drain(false);
    return !sink_failed;
  };
  if (!readLogEvents(path, read, stats.damage, error)) return false;
  if (sink_failed) return fail(sink_error);
  drain(true);
  if (sink_failed) return fail(sink_error);
  stats.damage_report = damageReport(stats.damage, stats.rejected_events, first_rejection, last_tick);
  if (!stats.damage_report.empty() && !allow_partial) {
    stats.refused_damaged = true;
    return fail(path + ": damaged log: " + stats.damage_report + " (--allow-partial reads the readable part)");
  }
  if (needed_events == 0) {
    return fail("'" + path + "' has none of the channels the " + std::string(truth ? "truth" : "sensors") +
                " pipeline needs (" + (truth ? "EXO_TRUTH" : "EXO_STATE") + ", EXO_PLATE_RIGHT, EXO_PLATE_LEFT)");
  }
  return true;
}

}  // namespace exoid::intake
