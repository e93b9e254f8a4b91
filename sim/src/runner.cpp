// exo_sim's loop: command intake (gate -> arbiter), pacing (lockstep / realtime), simStep, publishing.
#include "exoid/sim/runner.hpp"

#include <poll.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/message_gate.hpp"
#include "plugin_link.hpp"

namespace exoid::sim {
namespace {

int64_t monoNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1000000000 + ts.tv_nsec;
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

}  // namespace

bool runSim(const SimModel& sm, SimData& sd, LcmEndpoint& ep, const RunOptions& opt, RunSummary* out,
            std::string* err, const volatile std::sig_atomic_t* stop) {
  // --- setup (allocates) ---
  CommandArbiter arb;
  arbiterInit(arb, sm, opt.hold_ticks);
  MessageGate gate({channels::kCommand});
  JointCommandSample incoming = simZeroCommand(sm);
  exoid_lcm::joint_command_t scratch;
  std::string why;
  why.reserve(1024);  // rejection reasons fit without reallocating
  int reasons_logged = 0;
  // With an in-loop controller plugin the loop itself publishes EXO_COMMAND: it must not read it back.
  std::unique_ptr<PluginLink> plugin_link;
  static_assert(kNumFeet == EXOID_PLUGIN_NUM_PLATES, "the plugin gets the plates in SimData.plates order");
  if (opt.plugin) plugin_link = std::make_unique<PluginLink>(*opt.plugin, ep, sm.joint_names);
  const int subscription = opt.plugin ? 0 : ep.subscribeRaw(channels::kCommand, [&](const char*, const void* bytes, int size, int64_t) {
    if (gate.admitEncoded(0, bytes, size, scratch, incoming, &why, sm.joint_names)) {
      arbiterOffer(arb, incoming);
    } else if (reasons_logged < 5) {  // the first few reasons help debugging a controller; then only counts
      ++reasons_logged;
      std::fprintf(stderr, "exo_sim: rejected command: %s\n", why.c_str());
    }
  });
  exoid_lcm::robot_state_t state_msg;
  exoid_lcm::force_plate_t plate_msg[kNumFeet];
  exoid_lcm::ground_truth_t truth_msg;
  const char* plate_channel[kNumFeet] = {channels::kPlateRight, channels::kPlateLeft};
  auto publishAll = [&]() -> bool {
    toLcm(sd.state, sm.joint_names, state_msg);
    bool ok = ep.publish(channels::kState, state_msg, err);
    for (int i = 0; i < kNumFeet; ++i) {
      toLcm(sd.plates[static_cast<size_t>(i)], plate_msg[i]);
      ok = ok && ep.publish(plate_channel[i], plate_msg[i], err);
    }
    toLcm(sd.truth, sm.joint_names, truth_msg);
    return ok && ep.publish(channels::kTruth, truth_msg, err);
  };

  RunSummary s;
  const int64_t ticks = std::llround(opt.duration_s * 1000.0);
  s.ticks_planned = ticks;
  const int64_t t0 = monoNs();
  int64_t start_deadline = 0;
  bool ok = true;
  // Consecutive missing commands (only once a controller has answered: no controller at all is open loop).
  int64_t missing = 0;
  const int64_t give_up = opt.max_missing_commands <= 0 ? 0
                          : opt.mode == SimMode::Lockstep
                              ? opt.max_missing_commands
                              : int64_t{opt.max_missing_commands} * std::max(1, opt.command_timeout_ms);

  // --- loop (no allocation) ---
  for (int64_t k = 0; k < ticks && ok; ++k) {
    if (stop && *stop) {
      s.interrupted = true;
      break;
    }
    int r = 0;
    if (opt.mode == SimMode::Lockstep && !opt.plugin) {
      if (k >= 1 && !arbiterHasFresh(arb, k)) {
        auto fresh = [&] { return arbiterHasFresh(arb, k); };
        if (arb.received == 0 && k == 1 && opt.start_timeout_s > 0.0) {
          // Handshake: a controller that subscribed after tick 0 went out gets it again every 100 ms.
          start_deadline = monoNs() + static_cast<int64_t>(opt.start_timeout_s * 1e9);
          while (ok && (r = serviceUntil(ep, std::min(start_deadline, monoNs() + 100000000), fresh, stop, err)) == 0 &&
                 monoNs() < start_deadline && !(stop && *stop))
            ok = publishAll();
          if (!ok) break;
          if (!arbiterHasFresh(arb, k)) ++s.timeouts;
        } else if (arb.received > 0) {
          r = serviceUntil(ep, monoNs() + int64_t{opt.command_timeout_ms} * 1000000, fresh, stop, err);
          if (!arbiterHasFresh(arb, k)) ++s.timeouts;
        } else {
          // Never heard from a controller (start timeout over): run open loop without waiting.
          r = ep.handleAvailable(1000, err) < 0 ? -1 : 0;
        }
        if (r < 0) {
          ok = false;
          break;
        }
      }
    } else if ((!plugin_link || plugin_link->listening()) && ep.handleAvailable(1000, err) < 0) {
      ok = false;  // (a plugin loop that listens to nothing never touches LCM's receive side: no receive thread)
      break;
    }
    if (k >= 1 && arb.received > 0) {
      missing = arbiterHasFresh(arb, k) ? 0 : missing + 1;
      if (give_up > 0 && missing >= give_up) {
        s.outcome = RunOutcome::ControllerLost;
        break;
      }
    }
    if (arbiterHasFresh(arb, k)) s.last_fresh_tick = k;

    simStep(sm, sd, arbiterSelect(arb, k));
    const bool fell_now = !s.fell && simFell(sm, sd);
    if (fell_now) {
      s.fell = true;
      s.fall_tick = k;
    }
    if (!publishAll() || (plugin_link && !plugin_link->afterStep(sd.state, sd.plates.data(), arb, err))) {
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

    if (!opt.quiet && (k + 1) % 1000 == 0) {
      const double wall = (monoNs() - t0) * 1e-9;
      std::fprintf(opt.log,
                   "exo_sim: t %.1f s  tick %" PRId64 "  rtf %.2f  base z %.3f m  rejected %" PRIu64
                   "  fallback %" PRId64 "%s\n",
                   (k + 1) * 1e-3, k, wall > 0 ? (k + 1) * 1e-3 / wall : 0.0, sd.truth.base_position.z(),
                   gate.rejectedTotal(), arb.fallbackTicks(), s.fell ? "  FELL" : "");
      std::fflush(opt.log);
    }
    if (opt.mode == SimMode::Realtime) {
      // 1 kHz wall clock: keep serving LCM until the next tick's slot starts.
      const int64_t next = t0 + (k + 1) * 1000000;
      if (monoNs() > next) {
        ++s.overruns;
      } else if (plugin_link && !plugin_link->listening()) {  // nothing to receive: sleep to the deadline
        const timespec ts{static_cast<time_t>(next / 1000000000), static_cast<long>(next % 1000000000)};
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
      } else if (serviceUntil(ep, next, [] { return false; }, stop, err) < 0) {
        ok = false;
      }
    }
  }

  if (subscription > 0) ep.unsubscribe(subscription);  // the handler refers to this frame's locals
  plugin_link.reset();
  s.wall_time_s = (monoNs() - t0) * 1e-9;
  s.sim_time_s = s.ticks * 1e-3;
  s.realtime_factor = s.wall_time_s > 0 ? s.sim_time_s / s.wall_time_s : 0.0;
  s.accepted = gate.accepted(0);
  s.rejected = gate.rejected(0);
  for (int i = 0; i < kNumRejectReasons && i < 4; ++i)
    s.rejected_by_reason[i] = gate.rejected(0, static_cast<RejectReason>(i));
  s.fresh_ticks = arb.fresh_ticks;
  s.held_ticks = arb.held_ticks;
  s.zero_ticks = arb.zero_ticks;
  s.refused = sd.stats.rejected_commands;
  s.clamped = sd.stats.clamped_commands;
  s.mujoco_warnings = sd.stats.mujoco_warnings;
  s.missing_commands = missing;
  if (stop && *stop) s.interrupted = true;
  if (!ok) {
    s.outcome = RunOutcome::LcmFailure;
  } else if (s.interrupted && s.outcome == RunOutcome::Completed && s.ticks < ticks) {
    s.outcome = RunOutcome::Interrupted;
  } else if (s.outcome == RunOutcome::Completed && s.fell) {
    s.outcome = RunOutcome::Fell;  // stop_on_fall off: it still did not complete its run standing
  }
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

std::string formatSummary(const RunSummary& s) {
  char buf[1280];
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
                ", zero %" PRId64 ", timeouts %" PRId64 "), clamped %" PRId64 ", overruns %" PRId64
                ", mujoco warnings %" PRId64 ", fell %s%s%s",
                s.ticks, s.ticks_planned, s.sim_time_s, s.wall_time_s, s.realtime_factor, s.accepted, s.rejected,
                s.rejected_by_reason[0], s.rejected_by_reason[1], s.rejected_by_reason[2], s.rejected_by_reason[3],
                s.fallbackTicks(), s.held_ticks, s.zero_ticks, s.timeouts, s.clamped, s.overruns, s.mujoco_warnings,
                s.fell ? "yes" : "no", s.interrupted ? ", interrupted" : "",
                s.plugin_finished ? ", ended by the plugin (task finished)" : "");
  return buf;
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
  f(j, "overruns", s.overruns);
  f(j, "mujoco_warnings", s.mujoco_warnings);
  f(j, "fell", s.fell);
  f(j, "fall_tick", s.fall_tick);
  f(j, "last_fresh_tick", s.last_fresh_tick);
  f(j, "missing_commands", s.missing_commands);
  f(j, "interrupted", s.interrupted);
  f(j, "plugin_finished", s.plugin_finished);
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
