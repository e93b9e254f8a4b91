// exo_sim's loop: command intake (gate -> arbiter), pacing (lockstep / realtime), simStep, publishing.
#include "exoid/sim/runner.hpp"

#include <poll.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "exoid/common/clock.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/message_gate.hpp"
#include "plugin_link.hpp"

namespace exoid::sim {
namespace {

constexpr int64_t kPeriodNs = 1000000;  // the loop's 1 kHz

using common::monoNs;
using common::threadCpuNs;

/// The loop thread's preemptions and page faults so far (getrusage, RUSAGE_THREAD).
void threadCounts(int64_t* preemptions, int64_t* page_faults) {
  rusage ru{};
  getrusage(RUSAGE_THREAD, &ru);
  *preemptions = ru.ru_nivcsw;
  *page_faults = ru.ru_minflt + ru.ru_majflt;
}

// Dispatches LCM messages until done() or the monotonic deadline (ns) or a stop request. Returns -1 on an
// LCM error, else 1 if done() became true, 0 otherwise.
template <class Done>
int serviceUntil(LcmEndpoint& ep, int64_t deadline_ns, Done done, const volatile std::sig_atomic_t* stop,
                 std::string* err) {
  while (!done()) {
    if (stop && *stop) return 0;
    const int64_t left = deadline_ns - monoNs();
    if (left <= 0) return 0;
    pollfd pfd{ep.fileno(), POLLIN, 0};
    const timespec ts{static_cast<time_t>(left / 1000000000), static_cast<long>(left % 1000000000)};
    const int r = ppoll(&pfd, 1, &ts, nullptr);
    if (r < 0 && errno != EINTR) {
      if (err) *err = "LCM: poll failed";
      return -1;
    }
    if (r > 0 && ep.handleAvailable(1000, err) < 0) return -1;
  }
  return 1;
}

// runSim's loop: the set-up state (allocated once, in the constructor) and the per-tick stages (no allocation).
class SimLoop {
 public:
  SimLoop(const SimModel& sm, SimData& sd, LcmEndpoint& ep, const RunOptions& opt, std::string* err,
          const volatile std::sig_atomic_t* stop)
      : sm_(sm), sd_(sd), ep_(ep), opt_(opt), err_(err), stop_(stop), gate_({channels::kCommand}),
        incoming_(simZeroCommand(sm)) {
    arbiterInit(arb_, sm, opt.hold_ticks);
    why_.reserve(1024);  // rejection reasons fit without reallocating
    // With an in-loop controller plugin the loop itself publishes EXO_COMMAND: it must not read it back.
    static_assert(kNumFeet == EXOID_PLUGIN_NUM_PLATES, "the plugin gets the plates in SimData.plates order");
    if (opt.plugin) plugin_link_ = std::make_unique<PluginLink>(*opt.plugin, ep, sm.joint_names);
    if (!opt.plugin)
      subscription_ = ep.subscribeRaw(channels::kCommand, [this](const char*, const void* bytes, int size, int64_t) {
        onCommand(bytes, size);
      });
    summary.ticks_planned = std::llround(opt.duration_s * 1000.0);
    // Consecutive missing commands (only once a controller has answered: no controller at all is open loop).
    give_up_ = opt.max_missing_commands <= 0 ? 0
               : opt.mode == SimMode::Lockstep
                   ? opt.max_missing_commands
                   : int64_t{opt.max_missing_commands} * std::max(1, opt.command_timeout_ms);
    threadCounts(&preemptions0_, &page_faults0_);
    t0_ = monoNs();
  }

  RunSummary summary;

  /// Command intake before tick k: lockstep waits for the command of tick k (with the start handshake),
  /// otherwise whatever LCM has. False on an LCM failure.
  bool receive(int64_t k) {
    if (opt_.mode == SimMode::Lockstep && !opt_.plugin) return k < 1 || arbiterHasFresh(arb_, k) || awaitCommand(k);
    return receiveEstimates();
  }

  /// True when the controller, once heard, missed give_up consecutive commands up to tick k.
  bool controllerLost(int64_t k) {
    if (k >= 1 && arb_.received > 0) {
      missing_ = arbiterHasFresh(arb_, k) ? 0 : missing_ + 1;
      if (give_up_ > 0 && missing_ >= give_up_) return true;
    }
    if (arbiterHasFresh(arb_, k)) summary.last_fresh_tick = k;
    return false;
  }

  /// Tick k: simStep on the arbiter's command, the fall check, publishing, the plugin after the step. False on
  /// an LCM failure; *fell_now: the robot fell at this tick.
  bool step(int64_t k, bool* fell_now) {
    simStep(sm_, sd_, arbiterSelect(arb_, k));
    *fell_now = !summary.fell && simFell(sm_, sd_);
    if (*fell_now) {
      summary.fell = true;
      summary.fall_tick = k;
    }
    return publishAll() && awaitEstimate(k) &&
           !(plugin_link_ && !plugin_link_->afterStep(sd_.state, sd_.plates.data(), arb_, err_));
  }

  /// One progress line per simulated second (unless quiet).
  void progress(int64_t k) const {
    if (opt_.quiet || (k + 1) % 1000 != 0) return;
    const double wall = (monoNs() - t0_) * 1e-9;
    std::fprintf(opt_.log,
                 "exo_sim: t %.1f s  tick %" PRId64 "  rtf %.2f  base z %.3f m  rejected %" PRIu64
                 "  fallback %" PRId64 "%s\n",
                 (k + 1) * 1e-3, k, wall > 0 ? (k + 1) * 1e-3 / wall : 0.0, sd_.truth.base_position.z(),
                 gate_.rejectedTotal(), arb_.fallbackTicks(), summary.fell ? "  FELL" : "");
    std::fflush(opt_.log);
  }

  /// Tick k's work begins (realtime: its slot began at t0 + k ms).
  void beginTick(int64_t k) {
    tick_start_ = monoNs();
    tick_cpu_start_ = threadCpuNs();
    if (opt_.mode == SimMode::Realtime) start_delay_max_ = std::max(start_delay_max_, tick_start_ - t0_ - k * kPeriodNs);
  }

  /// Tick k's work is done: overrun (longer than the period), deadline (realtime: after its slot's end), worst tick.
  void endTick(int64_t k) {
    const int64_t end = monoNs(), work = end - tick_start_;
    tick_cpu_max_ = std::max(tick_cpu_max_, threadCpuNs() - tick_cpu_start_);
    tick_max_ = std::max(tick_max_, work);
    tick_sum_ += work;
    ++ticks_timed_;
    if (work > kPeriodNs) ++summary.timing.overruns;
    if (opt_.mode == SimMode::Realtime && end > t0_ + (k + 1) * kPeriodNs) ++deadline_misses_;
  }

  /// Realtime: 1 kHz wall clock, serving LCM until the next tick's slot starts. False on an LCM failure.
  bool pace(int64_t k) {
    const int64_t next = t0_ + (k + 1) * kPeriodNs;
    if (monoNs() > next) {
      // late already: the next tick starts at once (its deadline stays on the wall clock)
    } else if (plugin_link_ && !plugin_link_->listening()) {  // nothing to receive: sleep to the deadline
      const timespec ts{static_cast<time_t>(next / 1000000000), static_cast<long>(next % 1000000000)};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    } else if (serviceUntil(ep_, next, [] { return false; }, stop_, err_) < 0) {
      return false;
    }
    return true;
  }

  /// After the loop: unsubscribes (the handler refers to this object), ends the plugin link, fills the counts
  /// and the outcome of summary.
  void finish(bool ok) {
    if (subscription_ > 0) ep_.unsubscribe(subscription_);
    if (plugin_link_) plugin_cpu_us_max_ = plugin_link_->callCpuUsMax();
    plugin_link_.reset();
    RunSummary& s = summary;
    s.wall_time_s = (monoNs() - t0_) * 1e-9;
    s.sim_time_s = s.ticks * 1e-3;
    s.realtime_factor = s.wall_time_s > 0 ? s.sim_time_s / s.wall_time_s : 0.0;
    s.accepted = gate_.accepted(0);
    s.rejected = gate_.rejected(0);
    for (int i = 0; i < kNumRejectReasons && i < 4; ++i)
      s.rejected_by_reason[i] = gate_.rejected(0, static_cast<RejectReason>(i));
    s.fresh_ticks = arb_.fresh_ticks;
    s.held_ticks = arb_.held_ticks;
    s.zero_ticks = arb_.zero_ticks;
    s.refused = sd_.stats.rejected_commands;
    s.clamped = sd_.stats.clamped_commands;
    s.mujoco_warnings = sd_.stats.mujoco_warnings;
    s.missing_commands = missing_;
    fillTiming(s.timing);
    if (stop_ && *stop_) s.interrupted = true;
    if (!ok) {
      s.outcome = RunOutcome::LcmFailure;
    } else if (s.interrupted && s.outcome == RunOutcome::Completed && s.ticks < s.ticks_planned) {
      s.outcome = RunOutcome::Interrupted;
    } else if (s.outcome == RunOutcome::Completed && s.fell) {
      s.outcome = RunOutcome::Fell;  // stop_on_fall off: it still did not complete its run standing
    }
  }

 private:
  /// finish's timing figures: the ticks' (beginTick/endTick), the loop thread's counts, the plugin's calls.
  void fillTiming(LoopTiming& t) const {
    const bool realtime = opt_.mode == SimMode::Realtime;
    t.deadline_misses = realtime ? deadline_misses_ : -1;
    t.start_delay_ms_max = realtime ? std::max<int64_t>(start_delay_max_, 0) * 1e-6 : -1.0;
    t.tick_ms_max = tick_max_ * 1e-6;
    t.tick_ms_mean = ticks_timed_ > 0 ? static_cast<double>(tick_sum_) / static_cast<double>(ticks_timed_) * 1e-6 : 0.0;
    t.tick_cpu_ms_max = tick_cpu_max_ * 1e-6;
    int64_t preemptions = 0, page_faults = 0;
    threadCounts(&preemptions, &page_faults);
    t.preemptions = preemptions - preemptions0_;
    t.page_faults = page_faults - page_faults0_;
    if (!opt_.plugin) return;
    const PluginStats& ps = opt_.plugin->stats();
    t.plugin_calls = ps.calls;
    t.plugin_call_us_max = ps.call_us_max;
    t.plugin_call_us_mean = ps.calls > 0 ? ps.call_us_sum / static_cast<double>(ps.calls) : 0.0;
    t.plugin_call_cpu_us_max = plugin_cpu_us_max_;
    t.plugin_budget_overruns = ps.overruns;
    t.plugin_fallback_ticks = ps.fallbackTicks();
  }

  void onCommand(const void* bytes, int size) {
    if (gate_.admitEncoded(0, bytes, size, scratch_, incoming_, &why_, sm_.joint_names)) {
      arbiterOffer(arb_, incoming_);
    } else if (reasons_logged_ < 5) {  // the first few reasons help debugging a controller; then only counts
      ++reasons_logged_;
      std::fprintf(stderr, "exo_sim: rejected command: %s\n", why_.c_str());
    }
  }

  bool publishAll() {
    toLcm(sd_.state, sm_.joint_names, state_msg_);
    bool ok = ep_.publish(channels::kState, state_msg_, err_);
    const char* plate_channel[kNumFeet] = {channels::kPlateRight, channels::kPlateLeft};
    for (int i = 0; i < kNumFeet; ++i) {
      toLcm(sd_.plates[static_cast<size_t>(i)], plate_msg_[i]);
      ok = ok && ep_.publish(plate_channel[i], plate_msg_[i], err_);
    }
    toLcm(sd_.truth, sm_.joint_names, truth_msg_);
    return ok && ep_.publish(channels::kTruth, truth_msg_, err_);
  }

  // Lockstep, the command of tick k >= 1 not there yet: the start handshake (tick 0 re-sent every 100 ms until
  // a controller answers or start_timeout_s), the wait of command_timeout_ms once one has answered, or open
  // loop without waiting when none ever did. False on an LCM failure.
  bool awaitCommand(int64_t k) {
    auto fresh = [&] { return arbiterHasFresh(arb_, k); };
    int r = 0;
    if (arb_.received == 0 && k == 1 && opt_.start_timeout_s > 0.0) {
      const int64_t start_deadline = monoNs() + static_cast<int64_t>(opt_.start_timeout_s * 1e9);
      bool ok = true;
      while (ok && (r = serviceUntil(ep_, std::min(start_deadline, monoNs() + 100000000), fresh, stop_, err_)) == 0 &&
             monoNs() < start_deadline && !(stop_ && *stop_))
        ok = publishAll();
      if (!ok) return false;
      if (!arbiterHasFresh(arb_, k)) ++summary.timeouts;
    } else if (arb_.received > 0) {
      r = serviceUntil(ep_, monoNs() + int64_t{opt_.command_timeout_ms} * 1000000, fresh, stop_, err_);
      if (!arbiterHasFresh(arb_, k)) ++summary.timeouts;
    } else {
      r = ep_.handleAvailable(1000, err_) < 0 ? -1 : 0;
    }
    return r >= 0;
  }

  // Lockstep with the plugin taking EXO_ESTIMATE (opt.estimate_lag_ticks >= 0), before its tick k: every estimate
  // with tick <= k - L must be in, as they are once one with tick >= k - L is (LCM keeps the order). Waits
  // estimate_timeout_ms (start_timeout_s before the first estimate); after a timeout no more waiting, said once.
  // State k is already published: the estimator needs it. False on an LCM failure.
  bool awaitEstimate(int64_t k) {
    if (opt_.estimate_lag_ticks < 0 || opt_.mode != SimMode::Lockstep || !plugin_link_ ||
        !plugin_link_->takesEstimates() || summary.estimate_timeouts > 0)
      return true;
    const int64_t need = k - opt_.estimate_lag_ticks;
    const auto arrived = [&] { return plugin_link_->newestEstimateTick() >= need; };
    if (need < 0 || arrived()) return true;
    ++summary.estimate_waits;
    const bool first = plugin_link_->newestEstimateTick() < 0;
    const int64_t wait_ns = first ? static_cast<int64_t>(opt_.start_timeout_s * 1e9)
                                  : int64_t{opt_.estimate_timeout_ms} * 1000000;
    const int64_t t0 = monoNs();
    const int r = receiveEstimatesUntil(t0 + wait_ns, arrived);
    summary.estimate_wait_s += (monoNs() - t0) * 1e-9;
    if (r < 0) return false;
    if (r == 0 && !(stop_ && *stop_)) {
      ++summary.estimate_timeouts;
      summary.estimate_wait_stopped_tick = k;
      std::fprintf(opt_.log,
                   "exo_sim: no EXO_ESTIMATE with tick >= %" PRId64 " within %.3f s at tick %" PRId64
                   " (%s): the loop goes on without waiting; from here the run depends on scheduling\n",
                   need, wait_ns * 1e-9, k, first ? "none received yet" : "the estimator stopped answering");
    }
    return true;
  }

  // The plugin loop's intake: LCM when something is subscribed there (a plugin loop that listens to nothing
  // never touches LCM's receive side: no receive thread), and the plugin link's own socket. False on a failure.
  bool receiveEstimates() {
    return !((!plugin_link_ || plugin_link_->listening()) && ep_.handleAvailable(1000, err_) < 0) &&
           !(plugin_link_ && !plugin_link_->drain(err_));
  }

  // serviceUntil for the estimates (receiveEstimates' two sources). -1 on a failure, 1 when arrived() became
  // true, 0 at the deadline or a stop request.
  template <class Done>
  int receiveEstimatesUntil(int64_t deadline_ns, Done arrived) {
    const int raw = plugin_link_->rawFd();
    while (!arrived()) {
      const int64_t left = deadline_ns - monoNs();
      if (left <= 0 || (stop_ && *stop_)) return 0;
      pollfd pfd[2] = {{raw, POLLIN, 0}, {plugin_link_->listening() ? ep_.fileno() : -1, POLLIN, 0}};
      const timespec ts{static_cast<time_t>(left / 1000000000), static_cast<long>(left % 1000000000)};
      if (ppoll(pfd, 2, &ts, nullptr) < 0 && errno != EINTR) {
        if (err_) *err_ = "poll failed while waiting for EXO_ESTIMATE";
        return -1;
      }
      if (!receiveEstimates()) return -1;
    }
    return 1;
  }

  const SimModel& sm_;
  SimData& sd_;
  LcmEndpoint& ep_;
  const RunOptions& opt_;
  std::string* err_;
  const volatile std::sig_atomic_t* stop_;
  CommandArbiter arb_;
  MessageGate gate_;
  JointCommandSample incoming_;
  exoid_lcm::joint_command_t scratch_;
  std::string why_;
  int reasons_logged_ = 0;
  std::unique_ptr<PluginLink> plugin_link_;
  int subscription_ = 0;
  exoid_lcm::robot_state_t state_msg_;
  exoid_lcm::force_plate_t plate_msg_[kNumFeet];
  exoid_lcm::ground_truth_t truth_msg_;
  int64_t t0_ = 0;
  int64_t missing_ = 0;
  int64_t give_up_ = 0;
  // Loop timing (fillTiming), ns
  int64_t tick_start_ = 0, tick_cpu_start_ = 0, tick_max_ = 0, tick_sum_ = 0, tick_cpu_max_ = 0, ticks_timed_ = 0;
  int64_t start_delay_max_ = 0, deadline_misses_ = 0, preemptions0_ = 0, page_faults0_ = 0;
  double plugin_cpu_us_max_ = 0.0;
};

}  // namespace

bool runSim(const SimModel& sm, SimData& sd, LcmEndpoint& ep, const RunOptions& opt, RunSummary* out,
            std::string* err, const volatile std::sig_atomic_t* stop) {
  SimLoop loop(sm, sd, ep, opt, err, stop);  // setup (allocates)
  RunSummary& s = loop.summary;
  bool ok = true;
  for (int64_t k = 0; k < s.ticks_planned && ok; ++k) {  // no allocation
    if (stop && *stop) {
      s.interrupted = true;
      break;
    }
    const bool waits = opt.mode == SimMode::Lockstep && !opt.plugin;  // for the controller process's command
    if (!waits) loop.beginTick(k);
    if (!loop.receive(k)) {
      ok = false;
      break;
    }
    if (waits) loop.beginTick(k);
    if (loop.controllerLost(k)) {
      s.outcome = RunOutcome::ControllerLost;
      break;
    }
    bool fell_now = false;
    if (!loop.step(k, &fell_now)) {
      ok = false;
      break;
    }
    s.ticks = k + 1;
    if (fell_now && opt.stop_on_fall) {
      s.outcome = RunOutcome::Fell;
      break;
    }
    if (opt.end_when_plugin_finished && opt.plugin && opt.plugin->finished()) {
      s.plugin_finished = true;  // its task is over: the run is complete (outcome stays Completed)
      break;
    }
    loop.progress(k);
    loop.endTick(k);
    if (opt.mode == SimMode::Realtime) ok = loop.pace(k);
  }
  loop.finish(ok);
  if (out) *out = s;
  return ok;
}

const char* outcomeName(RunOutcome o) {
  switch (o) {
    case RunOutcome::Completed: return "completed";
    case RunOutcome::Fell: return "fell";
    case RunOutcome::ControllerLost: return "controller_lost";
    case RunOutcome::Interrupted: return "interrupted";
    case RunOutcome::LcmFailure: return "lcm_failure";
  }
  return "unknown";
}

namespace {
/// formatSummary's timing part (docs/sim.md, "Loop timing").
std::string formatTiming(const LoopTiming& t) {
  char misses[32] = "n/a (lockstep)", delay[32] = "n/a (lockstep)", buf[320];
  if (t.deadline_misses >= 0) std::snprintf(misses, sizeof misses, "%" PRId64, t.deadline_misses);
  if (t.start_delay_ms_max >= 0) std::snprintf(delay, sizeof delay, "%.3f ms", t.start_delay_ms_max);
  std::snprintf(buf, sizeof buf,
                "; timing: overruns %" PRId64 " (tick work > 1 ms), deadline misses %s, tick max %.3f ms (cpu %.3f ms) "
                "mean %.3f ms, start delay max %s, preemptions %" PRId64 ", page faults %" PRId64,
                t.overruns, misses, t.tick_ms_max, t.tick_cpu_ms_max, t.tick_ms_mean, delay, t.preemptions,
                t.page_faults);
  return buf;
}
}  // namespace

std::string formatSummary(const RunSummary& s) {
  char buf[1536];
  int n = std::snprintf(buf, sizeof buf, "exo_sim: summary: %s", outcomeName(s.outcome));
  if (s.fall_tick >= 0)
    n += std::snprintf(buf + n, sizeof buf - n, " (fall at tick %" PRId64 ", t %.3f s)", s.fall_tick, s.fall_tick * 1e-3);
  if (s.outcome == RunOutcome::ControllerLost)
    n += std::snprintf(buf + n, sizeof buf - n,
                       " (%" PRId64 " consecutive commands missing; last fresh command at tick %" PRId64 ")",
                       s.missing_commands, s.last_fresh_tick);
  std::snprintf(buf + n, sizeof buf - n,
                     ", ticks %" PRId64 " of %" PRId64 ", simulated %.3f s, wall %.3f s, realtime factor %.2f, commands "
                     "accepted %" PRIu64 " rejected %" PRIu64 " (duplicate %" PRIu64 ", out_of_order %" PRIu64
                     ", non_finite %" PRIu64 ", malformed %" PRIu64 "), fallback ticks %" PRId64 " (held %" PRId64
                     ", zero %" PRId64 ", timeouts %" PRId64 "), clamped %" PRId64 ", mujoco warnings %" PRId64
                     ", fell %s%s%s",
                     s.ticks, s.ticks_planned, s.sim_time_s, s.wall_time_s, s.realtime_factor, s.accepted, s.rejected,
                     s.rejected_by_reason[0], s.rejected_by_reason[1], s.rejected_by_reason[2], s.rejected_by_reason[3],
                     s.fallbackTicks(), s.held_ticks, s.zero_ticks, s.timeouts, s.clamped, s.mujoco_warnings,
                     s.fell ? "yes" : "no", s.interrupted ? ", interrupted" : "",
                     s.plugin_finished ? ", ended by the plugin (task finished)" : "");
  if (s.estimate_waits > 0 || s.estimate_timeouts > 0) {
    const size_t used = std::strlen(buf);
    std::snprintf(buf + used, sizeof buf - used, ", estimate waits %" PRId64 " (%.3f s, timeouts %" PRId64 "%s)",
                  s.estimate_waits, s.estimate_wait_s, s.estimate_timeouts,
                  s.estimate_timeouts > 0 ? ": not reproducible" : "");
  }
  return buf + formatTiming(s.timing);
}

namespace {
// One list of the summary's fields, for both directions.
template <class Json, class Summary, class F>
void eachField(Json& j, Summary& s, F f) {
  f(j, "ticks_planned", s.ticks_planned);
  f(j, "ticks", s.ticks);
  f(j, "sim_time_s", s.sim_time_s);
  f(j, "wall_time_s", s.wall_time_s);
  f(j, "realtime_factor", s.realtime_factor);
  f(j, "commands_accepted", s.accepted);
  f(j, "commands_rejected", s.rejected);
  f(j, "rejected_duplicate", s.rejected_by_reason[0]);
  f(j, "rejected_out_of_order", s.rejected_by_reason[1]);
  f(j, "rejected_non_finite", s.rejected_by_reason[2]);
  f(j, "rejected_malformed", s.rejected_by_reason[3]);
  f(j, "fresh_ticks", s.fresh_ticks);
  f(j, "held_ticks", s.held_ticks);
  f(j, "zero_ticks", s.zero_ticks);
  f(j, "timeouts", s.timeouts);
  f(j, "refused", s.refused);
  f(j, "clamped", s.clamped);
  f(j, "mujoco_warnings", s.mujoco_warnings);
  f(j, "fell", s.fell);
  f(j, "fall_tick", s.fall_tick);
  f(j, "last_fresh_tick", s.last_fresh_tick);
  f(j, "missing_commands", s.missing_commands);
  f(j, "interrupted", s.interrupted);
  f(j, "plugin_finished", s.plugin_finished);
  f(j, "estimate_waits", s.estimate_waits);
  f(j, "estimate_wait_s", s.estimate_wait_s);
  f(j, "estimate_timeouts", s.estimate_timeouts);
  f(j, "estimate_wait_stopped_tick", s.estimate_wait_stopped_tick);
  forEachTimingField(s.timing, [&](const char* key, auto& v) { f(j, key, v); });  // docs/sim.md, "Loop timing"
}
}  // namespace

std::string runSummaryJson(const RunSummary& s) {
  nlohmann::ordered_json j;
  j["outcome"] = outcomeName(s.outcome);
  eachField(j, s, [](nlohmann::ordered_json& js, const char* key, const auto& v) { js[key] = v; });
  return j.dump(2) + "\n";
}

bool parseRunSummaryJson(const std::string& text, RunSummary* out, std::string* error) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  auto fail = [&](const std::string& why) {
    if (error) *error = "exo_sim result: " + why;
    return false;
  };
  if (!j.is_object()) return fail("not a JSON object");
  RunSummary s;
  const auto outcome = j.find("outcome");
  if (outcome == j.end() || !outcome->is_string()) return fail("no outcome");
  bool known = false;
  for (RunOutcome o : {RunOutcome::Completed, RunOutcome::Fell, RunOutcome::ControllerLost, RunOutcome::Interrupted,
                       RunOutcome::LcmFailure})
    if (outcome->get<std::string>() == outcomeName(o)) s.outcome = o, known = true;
  if (!known) return fail("unknown outcome '" + outcome->get<std::string>() + "'");
  std::string bad;
  eachField(j, s, [&](const nlohmann::json& js, const char* key, auto& v) {
    using T = std::decay_t<decltype(v)>;
    const auto it = js.find(key);
    const bool ok = it != js.end() && (std::is_same_v<T, bool> ? it->is_boolean()
                                       : std::is_floating_point_v<T> ? it->is_number()
                                                                     : it->is_number_integer());
    if (!ok) {
      if (bad.empty()) bad = key;
      return;
    }
    v = it->template get<T>();
  });
  if (!bad.empty()) return fail("missing or mistyped field '" + bad + "'");
  *out = s;
  return true;
}

}  // namespace exoid::sim
