// Run log -> measured samples in tick order (measured_input.hpp), on the one log reader (log_events.hpp).
#include <vector>

#include "exoid/estimator/tick_assembly.hpp"
#include "exoid/intake/measured_input.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::intake {

namespace {

// The payloads of the ticks the assembly holds, by slot.
struct Held {
  RobotStateSample state;
  ForcePlateSample plate[2];
  GroundTruthSample truth;
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
  // The one tick assembly (tick_assembly.hpp): channels may lag kLogLagWindow ticks; the first message of a
  // tick on each channel is kept.
  using estimator::TickAssembly;
  using estimator::TickPlacement;
  const unsigned main_channel = truth ? estimator::kTickTruth : estimator::kTickState;
  const unsigned needed = (1u << main_channel) | (1u << estimator::kTickPlateRight) | (1u << estimator::kTickPlateLeft);
  const int capacity = static_cast<int>(estimator::kLogLagWindow) + 2;
  TickAssembly assembly(needed, estimator::kLogLagWindow, capacity);
  std::vector<Held> held(static_cast<size_t>(capacity));
  long events = 0, needed_events = 0;
  std::string first_rejection;
  estimator::MeasuredSample sample;
  std::string sink_error;
  bool sink_failed = false;
  auto drain = [&](bool all) {
    estimator::ReleasedTick r;
    while (!sink_failed && assembly.release(r, all)) {
      const std::string where = "tick " + std::to_string(r.tick);
      if (!r.complete) {
        stats.skip("tick missing a needed message", where);
        continue;
      }
      const Held& h = held[static_cast<size_t>(r.slot)];
      const ForcePlateSample* plates[2] = {&h.plate[0], &h.plate[1]};
      if (truth) estimator::measuredFromTruth(model, h.truth, plates, feet, sample);
      else estimator::measuredFromSensors(model, h.state, plates, feet, sample);
      if (!sink(sample, &sink_error)) sink_failed = true;
      ++stats.samples;
    }
  };
  // Offers one decoded message to the assembly; on acceptance `store` copies it into its tick's slot.
  auto place = [&](int channel, int64_t tick, auto&& store) {
    int slot = -1;
    const TickPlacement p = assembly.place(channel, tick, &slot);
    if (p == TickPlacement::Accepted) store(held[static_cast<size_t>(slot)]);
    else if (p == TickPlacement::Duplicate)
      stats.skip("repeated message (the tick's first one kept)", "tick " + std::to_string(tick));
    else stats.skip("message for a tick already passed (out of order)", "tick " + std::to_string(tick));
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
      if (ok) tick = s.tick, place(estimator::kTickPlateRight + side, s.tick, [&](Held& h) { h.plate[side] = s; });
    } else if (channel == channels::kState && !truth) {
      ++needed_events;
      exoid_lcm::robot_state_t msg;
      RobotStateSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) tick = s.tick, place(estimator::kTickState, s.tick, [&](Held& h) { h.state = s; });
    } else if (channel == channels::kTruth && truth) {
      ++needed_events;
      exoid_lcm::ground_truth_t msg;
      GroundTruthSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) tick = s.tick, place(estimator::kTickTruth, s.tick, [&](Held& h) { h.truth = s; });
    }
    last_tick = std::max(last_tick, tick);
    if (!ok) {
      if (why.empty()) why = "undecodable bytes";
      ++stats.rejected_events;
      const std::string where = channel + " event " + std::to_string(events) + " at byte " + std::to_string(e.offset);
      if (first_rejection.empty()) first_rejection = printable(where + ": " + why);
      stats.skip("log event rejected", printable(where + " (" + why + ")"));
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
