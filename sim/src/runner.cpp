// exo_sim's loop: command intake (gate -> arbiter), pacing (lockstep / realtime), simStep, publishing.
#include "exoid/sim/runner.hpp"

#include <poll.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>

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
  const int64_t t0 = monoNs();
  int64_t start_deadline = 0;
  bool ok = true;

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
        } else if (arb.received > 0) {
          r = serviceUntil(ep, monoNs() + int64_t{opt.command_timeout_ms} * 1000000, fresh, stop, err);
        } else {
          // Never heard from a controller (start timeout over): run open loop without waiting.
          r = ep.handleAvailable(1000, err) < 0 ? -1 : 0;
        }
        if (r < 0) {
          ok = false;
          break;
        }
        if (!arbiterHasFresh(arb, k)) ++s.timeouts;
      }
    } else if ((!plugin_link || plugin_link->listening()) && ep.handleAvailable(1000, err) < 0) {
      ok = false;  // (a plugin loop that listens to nothing never touches LCM's receive side: no receive thread)
      break;
    }

    simStep(sm, sd, arbiterSelect(arb, k));
    s.fell = s.fell || simFell(sm, sd);
    if (!publishAll() || (plugin_link && !plugin_link->afterStep(sd.state, arb, err))) {
      ok = false;
      break;
    }
    s.ticks = k + 1;

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
  if (stop && *stop) s.interrupted = true;
  if (out) *out = s;
  return ok;
}

std::string formatSummary(const RunSummary& s) {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "exo_sim: summary: ticks %" PRId64 ", simulated %.3f s, wall %.3f s, realtime factor %.2f, commands "
                "accepted %" PRIu64 " rejected %" PRIu64 " (duplicate %" PRIu64 ", out_of_order %" PRIu64
                ", non_finite %" PRIu64 ", malformed %" PRIu64 "), fallback ticks %" PRId64 " (held %" PRId64
                ", zero %" PRId64 ", timeouts %" PRId64 "), clamped %" PRId64 ", overruns %" PRId64
                ", mujoco warnings %" PRId64 ", fell %s%s",
                s.ticks, s.sim_time_s, s.wall_time_s, s.realtime_factor, s.accepted, s.rejected,
                s.rejected_by_reason[0], s.rejected_by_reason[1], s.rejected_by_reason[2], s.rejected_by_reason[3],
                s.fallbackTicks(), s.held_ticks, s.zero_ticks, s.timeouts, s.clamped, s.overruns, s.mujoco_warnings,
                s.fell ? "yes" : "no", s.interrupted ? ", interrupted" : "");
  return buf;
}

}  // namespace exoid::sim
