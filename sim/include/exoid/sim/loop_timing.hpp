#pragma once
// How exo_sim's 1 kHz loop kept time (docs/sim.md, "Loop timing"): part of its result (RunSummary::timing,
// exo_sim --result), read back by `exoid experiment` into summary.json and summary.md. No dependencies.
#include <cstdint>

namespace exoid::sim {

/// A tick's work runs from its start (the top of the loop; lockstep waiting for a controller process: the
/// command's arrival) to the end of its publishing (receive, step, the plugin, the messages, the progress line).
/// In realtime tick k owns the slot [t0 + k ms, t0 + (k + 1) ms), t0 the loop's start.
struct LoopTiming {
  int64_t overruns = 0;              ///< ticks whose work took longer than the 1 ms period (every mode)
  int64_t deadline_misses = -1;      ///< realtime: ticks whose work ended after their slot's end (-1: lockstep)
  double tick_ms_max = 0.0;          ///< the longest tick's work, wall time
  double tick_ms_mean = 0.0;         ///< mean wall time of a tick's work
  double tick_cpu_ms_max = 0.0;      ///< the most CPU time the loop thread spent on one tick's work
  double start_delay_ms_max = -1.0;  ///< realtime: the latest a tick started after its slot began (-1: lockstep)
  int64_t preemptions = 0;           ///< involuntary context switches of the loop thread during the loop
  int64_t page_faults = 0;           ///< page faults (minor and major) of the loop thread during the loop
  // The in-loop controller plugin (0 without one).
  int64_t plugin_calls = 0;              ///< its tick calls
  double plugin_call_us_max = 0.0;       ///< wall time of its longest call
  double plugin_call_us_mean = 0.0;      ///< mean wall time of a call
  double plugin_call_cpu_us_max = 0.0;   ///< the most CPU time one call took (host stage included)
  int64_t plugin_budget_overruns = 0;    ///< calls longer than --plugin-budget-us (discarded: a fallback tick)
  int64_t plugin_fallback_ticks = 0;     ///< controller ticks on the host's fallback (held, then damping)
};

/// Every field of LoopTiming with its JSON name, for the writers and readers of exo_sim's result and summary.json:
/// f(name, field) in declaration order.
template <class Timing, class F>
void forEachTimingField(Timing& t, F f) {
  f("overruns", t.overruns);
  f("deadline_misses", t.deadline_misses);
  f("tick_ms_max", t.tick_ms_max);
  f("tick_ms_mean", t.tick_ms_mean);
  f("tick_cpu_ms_max", t.tick_cpu_ms_max);
  f("start_delay_ms_max", t.start_delay_ms_max);
  f("preemptions", t.preemptions);
  f("page_faults", t.page_faults);
  f("plugin_calls", t.plugin_calls);
  f("plugin_call_us_max", t.plugin_call_us_max);
  f("plugin_call_us_mean", t.plugin_call_us_mean);
  f("plugin_call_cpu_us_max", t.plugin_call_cpu_us_max);
  f("plugin_budget_overruns", t.plugin_budget_overruns);
  f("plugin_fallback_ticks", t.plugin_fallback_ticks);
}

}  // namespace exoid::sim
