#pragma once
// The exo_sim loop over LCM (library exoid_sim_runner, so tests can drive it in-process over memq://).
// Per tick k: obtain the command for tick k (lockstep: wait for it, bounded; realtime: the latest valid one
// at the 1 kHz deadline), simStep, publish EXO_STATE, EXO_PLATE_RIGHT, EXO_PLATE_LEFT, EXO_TRUTH for tick k.
// Commands on EXO_COMMAND pass a MessageGate (duplicate, out-of-order, non-finite, malformed: rejected and
// counted) before the CommandArbiter sees them. No allocation per tick once running.
// A run ends early, with its outcome, when the robot falls (at the fall tick: nothing after a fall is worth
// simulating), when a controller that was answering stops (max_missing_commands), or on a stop request.
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <string>

#include "exoid/lcm/lcm_endpoint.hpp"
#include "exoid/sim/command.hpp"
#include "exoid/sim/controller_plugin.hpp"
#include "exoid/sim/loop_timing.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::sim {

struct RunOptions {
  SimMode mode = SimMode::Lockstep;
  double duration_s = 10.0;       ///< simulated seconds (ticks = round(duration * 1000))
  int command_timeout_ms = 100;   ///< lockstep: wait this long for the command of tick k, then fall back
  int hold_ticks = 50;            ///< fallback: hold the last valid command this many ticks, then zero torque
  double start_timeout_s = 5.0;   ///< lockstep: wait this long for the first command (re-sending tick 0)
  /// Once a command arrived: end the run (ControllerLost) when this many consecutive commands are missing.
  /// Lockstep: a command is missing when it did not arrive within command_timeout_ms (so the sim gives up
  /// after at most max_missing_commands * command_timeout_ms); realtime: after that many milliseconds
  /// without a fresh command. 0: never give up.
  int max_missing_commands = 10;
  bool stop_on_fall = true;       ///< end the run at the tick the robot fell (Fell)
  bool quiet = false;             ///< no progress lines
  std::FILE* log = stdout;        ///< progress and summary
  /// In-loop controller (exo_sim --controller-plugin, docs/plugin.md): runs after each step instead of
  /// waiting for EXO_COMMAND; the loop publishes its EXO_COMMAND and EXO_CONTROLLER_STATUS.
  ControllerPlugin* plugin = nullptr;
  /// With a plugin: end the run (Completed) at the first tick after which the plugin's status says its task
  /// is finished (balance: moves and final hold done), instead of running all of duration_s.
  bool end_when_plugin_finished = false;
  /// Lockstep with a plugin that takes EXO_ESTIMATE: >= 0 waits, before the plugin's tick k, until an estimate
  /// with tick >= k - estimate_lag_ticks has arrived (LCM keeps the order: then every estimate the controller
  /// applies at tick k, those with tick <= k - lag_ticks, is in), so that the run does not depend on scheduling.
  /// Must be the plugin's controller configuration's estimate.lag_ticks. -1: no wait.
  int estimate_lag_ticks = -1;
  /// The longest wait for it (start_timeout_s before the first estimate); after one timeout the loop stops
  /// waiting for the rest of the run (counted and said: the run is no longer reproducible).
  int estimate_timeout_ms = 1000;
};

/// How a run ended (exo_sim's exit code follows it, docs/sim.md).
enum class RunOutcome { Completed, Fell, ControllerLost, Interrupted, LcmFailure };
const char* outcomeName(RunOutcome outcome);

struct RunSummary {
  RunOutcome outcome = RunOutcome::Completed;
  int64_t ticks_planned = 0;       ///< round(duration * 1000)
  int64_t ticks = 0;               ///< ticks simulated (and published)
  double sim_time_s = 0.0, wall_time_s = 0.0, realtime_factor = 0.0;
  uint64_t accepted = 0;           ///< commands admitted by the gate
  uint64_t rejected = 0;           ///< commands rejected by the gate (sum of the four reasons)
  uint64_t rejected_by_reason[4] = {0, 0, 0, 0};  ///< duplicate, out_of_order, non_finite, malformed
  int64_t fresh_ticks = 0;         ///< ticks that applied a fresh command
  int64_t held_ticks = 0;          ///< stale ticks on the held command
  int64_t zero_ticks = 0;          ///< stale ticks on zero torque
  int64_t timeouts = 0;            ///< lockstep waits that ended without the command
  int64_t refused = 0;             ///< commands simStep refused (cannot happen after the gate; kept as a check)
  int64_t clamped = 0;             ///< commands with a torque clamped to the actuator range
  int64_t mujoco_warnings = 0;
  bool fell = false;               ///< base dropped more than kFallDrop at some tick
  int64_t fall_tick = -1;          ///< first tick after which the base was more than kFallDrop down
  int64_t last_fresh_tick = -1;    ///< last tick that applied a fresh command
  int64_t missing_commands = 0;    ///< consecutive missing commands when the run ended
  bool interrupted = false;        ///< stopped early by the stop flag (SIGINT/SIGTERM)
  bool plugin_finished = false;    ///< the run ended because the plugin reported its task finished
  // The lockstep wait for the estimate (RunOptions::estimate_lag_ticks).
  int64_t estimate_waits = 0;      ///< ticks whose estimate had not arrived yet (the loop waited)
  double estimate_wait_s = 0.0;    ///< wall seconds spent in those waits
  int64_t estimate_timeouts = 0;   ///< waits that ended without it (the loop stopped waiting: not reproducible)
  int64_t estimate_wait_stopped_tick = -1;  ///< tick of that timeout (-1: none)
  LoopTiming timing;               ///< overruns, deadline misses, worst tick, the plugin's calls (docs/sim.md)
  int64_t fallbackTicks() const { return held_ticks + zero_ticks; }
};

/// Runs the simulation loop on `endpoint` (data must be freshly reset). Returns false on an LCM failure
/// (*err one line). `stop`, if given, ends the run early when it becomes non-zero.
bool runSim(const SimModel& model, SimData& data, LcmEndpoint& endpoint, const RunOptions& options,
            RunSummary* summary, std::string* err, const volatile std::sig_atomic_t* stop = nullptr);

/// The final one-line summary (no trailing newline).
std::string formatSummary(const RunSummary& s);

/// The summary as JSON (exo_sim --result FILE; read back by `exoid experiment`), and back. Every field of
/// RunSummary, outcome by name, the timing's fields at the top level.
std::string runSummaryJson(const RunSummary& s);
bool parseRunSummaryJson(const std::string& text, RunSummary* s, std::string* error);

}  // namespace exoid::sim
