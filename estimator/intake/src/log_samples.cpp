// Run log -> measured samples in tick order (measured_input.hpp), on the one log reader (log_events.hpp).
#include <algorithm>
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

/// Assembles the run log's events into ticks (the one tick assembly, tick_assembly.hpp: channels may lag
/// kLogLagWindow ticks; the first message of a tick on each channel is kept) and hands each complete tick to
/// the sink as a measured sample; skips and rejections are counted in stats.
class RunLogAssembler {
 public:
  RunLogAssembler(const Model& model, bool truth, const int feet[2], const SampleSink& sink, InputStats& stats)
      : model_(model),
        truth_(truth),
        feet_(feet),
        sink_(sink),
        stats_(stats),
        assembly_(neededChannels(truth), estimator::kLogLagWindow, kCapacity),
        held_(static_cast<size_t>(kCapacity)) {}

  /// One log event: decoded and placed if on a channel of the pipeline, else ignored; then the ticks that
  /// are due are released. False once the sink has failed (stops the reading).
  bool onEvent(const LogEvent& e) {
    ++events_;
    const std::string channel(e.channel, static_cast<size_t>(e.channel_length));
    std::string why;
    int64_t tick = -1;
    const bool ok = decodeAndPlace(channel, e, tick, why);
    last_tick_ = std::max(last_tick_, tick);
    if (!ok) {
      if (why.empty()) why = "undecodable bytes";
      ++stats_.rejected_events;
      const std::string where = channel + " event " + std::to_string(events_) + " at byte " + std::to_string(e.offset);
      if (first_rejection_.empty()) first_rejection_ = printable(where + ": " + why);
      stats_.skip("log event rejected", printable(where + " (" + why + ")"));
    }
    drain(false);
    return !sink_failed_;
  }

  /// Releases the ticks that are due (all: every tick still held, at the end of the log).
  void drain(bool all) {
    estimator::ReleasedTick r;
    while (!sink_failed_ && assembly_.release(r, all)) {
      const std::string where = "tick " + std::to_string(r.tick);
      if (!r.complete) {
        stats_.skip("tick missing a needed message", where);
        continue;
      }
      const Held& h = held_[static_cast<size_t>(r.slot)];
      const ForcePlateSample* plates[2] = {&h.plate[0], &h.plate[1]};
      if (truth_) estimator::measuredFromTruth(model_, h.truth, plates, feet_, sample_);
      else estimator::measuredFromSensors(model_, h.state, plates, feet_, sample_);
      if (!sink_(sample_, &sink_error_)) sink_failed_ = true;
      ++stats_.samples;
    }
  }

  bool sinkFailed() const { return sink_failed_; }
  const std::string& sinkError() const { return sink_error_; }
  long neededEvents() const { return needed_events_; }
  const std::string& firstRejection() const { return first_rejection_; }
  int64_t lastTick() const { return last_tick_; }

 private:
  static constexpr int kCapacity = static_cast<int>(estimator::kLogLagWindow) + 2;
  static unsigned neededChannels(bool truth) {
    const unsigned main_channel = truth ? estimator::kTickTruth : estimator::kTickState;
    return (1u << main_channel) | (1u << estimator::kTickPlateRight) | (1u << estimator::kTickPlateLeft);
  }

  /// Decodes an event of a needed channel (plates; the state or the truth) and places it; false (why) when
  /// it does not decode.
  bool decodeAndPlace(const std::string& channel, const LogEvent& e, int64_t& tick, std::string& why) {
    bool ok = true;
    if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
      ++needed_events_;
      const int side = channel == channels::kPlateRight ? 0 : 1;
      exoid_lcm::force_plate_t msg;
      ForcePlateSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, side, s, &why);
      if (ok) tick = s.tick, place(estimator::kTickPlateRight + side, s.tick, [&](Held& h) { h.plate[side] = s; });
    } else if (channel == channels::kState && !truth_) {
      ++needed_events_;
      exoid_lcm::robot_state_t msg;
      RobotStateSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model_.joint_names, s, &why);
      if (ok) tick = s.tick, place(estimator::kTickState, s.tick, [&](Held& h) { h.state = s; });
    } else if (channel == channels::kTruth && truth_) {
      ++needed_events_;
      exoid_lcm::ground_truth_t msg;
      GroundTruthSample s;
      ok = safeDecode(e.data, e.data_length, msg) && fromLcm(msg, model_.joint_names, s, &why);
      if (ok) tick = s.tick, place(estimator::kTickTruth, s.tick, [&](Held& h) { h.truth = s; });
    }
    return ok;
  }

  /// Offers one decoded message to the assembly; on acceptance `store` copies it into its tick's slot.
  template <class Store>
  void place(int channel, int64_t tick, Store&& store) {
    int slot = -1;
    const estimator::TickPlacement p = assembly_.place(channel, tick, &slot);
    if (p == estimator::TickPlacement::Accepted) store(held_[static_cast<size_t>(slot)]);
    else if (p == estimator::TickPlacement::Duplicate)
      stats_.skip("repeated message (the tick's first one kept)", "tick " + std::to_string(tick));
    else stats_.skip("message for a tick already passed (out of order)", "tick " + std::to_string(tick));
  }

  const Model& model_;
  bool truth_;
  const int* feet_;
  const SampleSink& sink_;
  InputStats& stats_;
  estimator::TickAssembly assembly_;
  std::vector<Held> held_;
  long events_ = 0, needed_events_ = 0;
  std::string first_rejection_;
  estimator::MeasuredSample sample_;
  std::string sink_error_;
  bool sink_failed_ = false;
  int64_t last_tick_ = -1;
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
  RunLogAssembler assembler(model, truth, feet, sink, stats);
  const LogEventSink read = [&](const LogEvent& e) { return assembler.onEvent(e); };
  if (!readLogEvents(path, read, stats.damage, error)) return false;
  if (assembler.sinkFailed()) return fail(assembler.sinkError());
  assembler.drain(true);
  if (assembler.sinkFailed()) return fail(assembler.sinkError());
  stats.damage_report =
      damageReport(stats.damage, stats.rejected_events, assembler.firstRejection(), assembler.lastTick());
  if (!stats.damage_report.empty() && !allow_partial) {
    stats.refused_damaged = true;
    return fail(path + ": damaged log: " + stats.damage_report + " (--allow-partial reads the readable part)");
  }
  if (assembler.neededEvents() == 0) {
    return fail("'" + path + "' has none of the channels the " + std::string(truth ? "truth" : "sensors") +
                " pipeline needs (" + (truth ? "EXO_TRUTH" : "EXO_STATE") + ", EXO_PLATE_RIGHT, EXO_PLATE_LEFT)");
  }
  return true;
}

}  // namespace exoid::intake
