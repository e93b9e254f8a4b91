// exo_sim: the simulated exoskeleton on two force plates, as an LCM process (docs/sim.md).
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>

#include <csignal>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/lcm_endpoint.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/runner.hpp"
#include "exoid/sim/sim.hpp"

namespace {

#ifndef EXOID_CONFIG_DIR
#define EXOID_CONFIG_DIR "config"
#endif

constexpr int kExitOk = 0;
constexpr int kExitRuntime = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitFell = 3;
constexpr int kExitControllerLost = 4;
constexpr int kExitInterrupted = 5;

volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

void printHelp() {
  std::printf(
      "usage: exo_sim [options]\n"
      "\n"
      "Simulates the exoskeleton standing on two force plates (MuJoCo 2.2, 1 kHz: one 1 ms step per control\n"
      "tick) and talks LCM. Every tick k it applies the command for tick k, then publishes the samples of\n"
      "tick k (utime = k * 1000, simulated microseconds). See docs/sim.md.\n"
      "\n"
      "options:\n"
      "  --model FILE             MJCF of the robot and plates (default %s/exo.xml)\n"
      "  --sensors FILE           realistic sensor noise (default %s/sensors.yaml)\n"
      "  --scenario FILE          scenario: seed, noise (realistic|off|FILE), undeclared effects, initial state\n"
      "                           (default %s/scenarios/nominal.yaml)\n"
      "  --mode lockstep|realtime lockstep (default): wait (bounded) for the command of each tick, run as fast as\n"
      "                           the CPU allows, deterministic; realtime: 1 kHz wall clock, apply the latest\n"
      "                           valid command, count stale ticks and missed deadlines\n"
      "  --duration SECONDS       simulated time (default 10)\n"
      "  --lcm-url URL            LCM URL (default $LCM_DEFAULT_URL, else %s); a udpm URL must have ttl=0\n"
      "  --command-timeout-ms MS  lockstep: how long to wait for the command of tick k (default 100)\n"
      "  --hold-ticks N           fallback when the command of a tick is missing: hold the last valid command for\n"
      "                           N ticks, then apply zero torque until a fresh command arrives (default 50);\n"
      "                           every such tick is counted\n"
      "  --start-timeout-s S      lockstep: wait up to S s for the first command, re-sending tick 0 every 100 ms\n"
      "                           for a late controller; if none comes, run open loop without waiting (default 5)\n"
      "  --max-missing-commands N once a controller has answered: end the run (exit 4) when N consecutive\n"
      "                           commands are missing (lockstep: each after a --command-timeout-ms wait, so\n"
      "                           at most N x that; realtime: N x --command-timeout-ms ms without a fresh\n"
      "                           command); 0 never gives up (default 10)\n"
      "  --result FILE            write the summary as JSON to FILE at the end (outcome, fall tick, fallback\n"
      "                           ticks, ...; `exoid experiment` reads it)\n"
      "  --quiet                  no progress line (the summary line is always printed)\n"
      "  --rt-priority N          realtime: lock memory (mlockall) and run the loop under SCHED_FIFO priority N\n"
      "                           (1..99; needs root or CAP_SYS_NICE, else a warning and normal scheduling)\n"
      "\n"
      "in-loop controller (docs/plugin.md; without --controller-plugin a controller process answers EXO_COMMAND):\n"
      "  --controller-plugin LIB  load the controller plugin LIB (e.g. build/lib/libexoid_controller_plugin.so)\n"
      "                           and call it from the loop after each step: state of tick k in, command for\n"
      "                           tick k+1 out (the same one-tick delay as a controller process); the loop\n"
      "                           publishes its EXO_COMMAND and EXO_CONTROLLER_STATUS and feeds EXO_ESTIMATE's\n"
      "                           feedforward to it. A failed, non-finite, malformed or over-budget answer is\n"
      "                           replaced by a counted fallback: hold the last good torque, then damping\n"
      "  --controller-model URDF  robot model given to the plugin (default %s/exo.urdf)\n"
      "  --controller-config FILE the plugin's configuration (default %s/controller.yaml)\n"
      "  --controller-seed N      seed given to the plugin: the CoM move sequence (default 1)\n"
      "  --controller-moves N     CoM moves (default 0: the configuration's)\n"
      "  --controller-rate-hz HZ  plugin rate, a divisor of the 1000 Hz physics rate (default 1000); the command\n"
      "                           is held between calls\n"
      "  --plugin-budget-us US    a call longer than US microseconds (wall clock) is discarded and counted\n"
      "                           (default: none in lockstep, which stays deterministic; half the controller\n"
      "                           period in realtime)\n"
      "  --plugin-hold-ticks N    fallback: controller ticks on the last good torque before damping (default 20)\n"
      "  --no-estimate            do not subscribe to EXO_ESTIMATE (no estimator running: the loop then reads\n"
      "                           nothing back from LCM, which saves a receive per published message)\n"
      "  --help                   this text\n"
      "\n"
      "channels (LCM, package exoid_lcm, SI units, docs/lcm.md):\n"
      "  publishes  EXO_STATE        robot_state_t    encoders rad, joint torques N m, IMU (quaternion world<-IMU\n"
      "                                               w,x,y,z, gyro rad/s, specific force m/s^2, IMU frame)\n"
      "             EXO_PLATE_RIGHT  force_plate_t    force N / moment N m ON the plate about its sensor origin,\n"
      "             EXO_PLATE_LEFT   force_plate_t    plate frame; CoP m on the top surface (0 below 20 N load)\n"
      "             EXO_TRUTH        ground_truth_t   exact state, accelerations, applied torques, contact\n"
      "                                               wrenches ON the feet (world, moment about the world origin)\n"
      "             EXO_COMMAND, EXO_CONTROLLER_STATUS   with --controller-plugin: the plugin's command and status\n"
      "  subscribes EXO_COMMAND      joint_command_t  torque command N m for tick `tick`; NaN/Inf, wrong size or\n"
      "                                               names, duplicate and out-of-order ticks are rejected and\n"
      "                                               counted; torques are clamped to the actuator ranges\n"
      "                                               (not with --controller-plugin)\n"
      "             EXO_ESTIMATE     estimator_output_t with --controller-plugin: its tau_ff goes to the plugin\n"
      "\n"
      "output: a progress line per simulated second (unless --quiet), then one summary line: ticks, realtime\n"
      "factor, accepted/rejected commands by reason, fallback ticks (held, zero, timeouts), clamped commands,\n"
      "realtime overruns, MuJoCo warnings, fell yes/no (base dropped more than 0.25 m). A fall ends the run at\n"
      "the fall tick (nothing after it is worth simulating; docs/sim.md). With a plugin a second line: calls,\n"
      "good answers, failures by kind, over-budget calls, fallback ticks, call time. Last, the process's CPU\n"
      "time (user, system) and simulated seconds per CPU second (the real-time factor with a core of its own).\n"
      "\n"
      "exit codes: 0 run completed (every tick of --duration), 1 runtime failure (LCM), 2 bad input (options,\n"
      "            MJCF, sensors or scenario file; a plugin that does not load, has another ABI version or fails\n"
      "            to create), 3 the robot fell (run ended at the fall tick, printed),\n"
      "            4 the controller stopped answering (--max-missing-commands), 5 interrupted (SIGINT/SIGTERM).\n",
      EXOID_CONFIG_DIR, EXOID_CONFIG_DIR, EXOID_CONFIG_DIR, EXOID_CONFIG_DIR, EXOID_CONFIG_DIR,
      exoid::channels::kDefaultUrl);
}

int badInput(const std::string& msg) {
  std::fprintf(stderr, "exo_sim: %s\n", msg.c_str());
  return kExitBadInput;
}

bool parseDouble(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return end && *end == '\0' && std::isfinite(*out);
}

bool parseInt(const std::string& s, long* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  *out = std::strtol(s.c_str(), &end, 10);
  return end && *end == '\0';
}

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::sim;
  const std::string config = EXOID_CONFIG_DIR;
  std::string model_path = config + "/exo.xml";
  std::string sensors_path = config + "/sensors.yaml";
  std::string scenario_path = config + "/scenarios/nominal.yaml";
  std::string url = LcmEndpoint::defaultUrl();
  RunOptions opt;
  PluginOptions plugin_opt;
  plugin_opt.model_path = config + "/exo.urdf";
  plugin_opt.config_path = config + "/controller.yaml";
  double plugin_budget_us = -1.0;  // < 0: the mode's default
  long rt_priority = 0;
  std::string result_path;

  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i], value;
    if (arg == "--help" || arg == "-h") {
      printHelp();
      return kExitOk;
    }
    if (arg == "--quiet") {
      opt.quiet = true;
      continue;
    }
    if (arg == "--no-estimate") {
      plugin_opt.listen_estimate = false;
      continue;
    }
    const size_t eq = arg.find('=');
    if (arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      return badInput(arg + ": missing value (see --help)");
    }
    double d = 0.0;
    long n = 0;
    if (arg == "--model") {
      model_path = value;
    } else if (arg == "--sensors") {
      sensors_path = value;
    } else if (arg == "--scenario") {
      scenario_path = value;
    } else if (arg == "--lcm-url") {
      url = value;
    } else if (arg == "--mode") {
      if (value == "lockstep") {
        opt.mode = SimMode::Lockstep;
      } else if (value == "realtime") {
        opt.mode = SimMode::Realtime;
      } else {
        return badInput("--mode: expected lockstep or realtime, got '" + value + "'");
      }
    } else if (arg == "--duration") {
      if (!parseDouble(value, &d) || d <= 0.0 || d > 1e7)
        return badInput("--duration: expected a positive number of seconds, got '" + value + "'");
      opt.duration_s = d;
    } else if (arg == "--command-timeout-ms") {
      if (!parseInt(value, &n) || n < 0 || n > 3600000)
        return badInput("--command-timeout-ms: expected milliseconds >= 0, got '" + value + "'");
      opt.command_timeout_ms = static_cast<int>(n);
    } else if (arg == "--hold-ticks") {
      if (!parseInt(value, &n) || n < 0 || n > 1000000000)
        return badInput("--hold-ticks: expected a tick count >= 0, got '" + value + "'");
      opt.hold_ticks = static_cast<int>(n);
    } else if (arg == "--max-missing-commands") {
      if (!parseInt(value, &n) || n < 0 || n > 1000000000)
        return badInput("--max-missing-commands: expected a count >= 0, got '" + value + "'");
      opt.max_missing_commands = static_cast<int>(n);
    } else if (arg == "--result") {
      result_path = value;
    } else if (arg == "--start-timeout-s") {
      if (!parseDouble(value, &d) || d < 0.0 || d > 3600.0)
        return badInput("--start-timeout-s: expected seconds in [0, 3600], got '" + value + "'");
      opt.start_timeout_s = d;
    } else if (arg == "--rt-priority") {
      if (!parseInt(value, &n) || n < 1 || n > 99)
        return badInput("--rt-priority: expected 1..99, got '" + value + "'");
      rt_priority = n;
    } else if (arg == "--controller-plugin") {
      plugin_opt.path = value;
    } else if (arg == "--controller-model") {
      plugin_opt.model_path = value;
    } else if (arg == "--controller-config") {
      plugin_opt.config_path = value;
    } else if (arg == "--controller-seed") {
      char* end = nullptr;
      errno = 0;
      const unsigned long long seed = std::strtoull(value.c_str(), &end, 10);
      if (value.empty() || value[0] == '-' || errno != 0 || *end != '\0')
        return badInput("--controller-seed: expected an unsigned integer, got '" + value + "'");
      plugin_opt.seed = seed;
    } else if (arg == "--controller-moves") {
      if (!parseInt(value, &n) || n < 0 || n > 1000)
        return badInput("--controller-moves: expected 0..1000, got '" + value + "'");
      plugin_opt.moves = static_cast<int>(n);
    } else if (arg == "--controller-rate-hz") {
      if (!parseInt(value, &n) || n < 1 || n > 1000 || 1000 % n != 0)
        return badInput("--controller-rate-hz: expected a divisor of 1000 (1000, 500, 250, 200, ...), got '" + value + "'");
      plugin_opt.divisor = static_cast<int>(1000 / n);
    } else if (arg == "--plugin-budget-us") {
      if (!parseDouble(value, &d) || d < 0.0 || d > 1e7)
        return badInput("--plugin-budget-us: expected microseconds >= 0, got '" + value + "'");
      plugin_budget_us = d;
    } else if (arg == "--plugin-hold-ticks") {
      if (!parseInt(value, &n) || n < 0 || n > 1000000000)
        return badInput("--plugin-hold-ticks: expected a tick count >= 0, got '" + value + "'");
      plugin_opt.hold_ticks = static_cast<int>(n);
    } else {
      return badInput("unknown option '" + arg + "' (see --help)");
    }
  }

  // Inputs: every problem is one line naming the file and the field.
  std::string err;
  Scenario scenario;
  SensorConfig realistic, noise;
  if (!loadScenario(scenario_path, &scenario, &err)) return badInput(err);
  if (!loadSensorConfig(sensors_path, &realistic, &err)) return badInput(err);
  if (!resolveSensorConfig(scenario, realistic, &noise, &err)) return badInput(err);
  SimModel model;
  SimData data;
  if (!simLoad(model_path, noise, scenario, model, &err)) return badInput(err);
  if (!simMakeData(model, data, &err)) return badInput(err);
  std::unique_ptr<ControllerPlugin> plugin;
  if (!plugin_opt.path.empty()) {
    plugin_opt.budget_us = plugin_budget_us >= 0.0                 ? plugin_budget_us
                           : opt.mode == SimMode::Realtime ? 500.0 * plugin_opt.divisor
                                                           : 0.0;
    plugin = ControllerPlugin::load(plugin_opt, model.joint_names, model.m->opt.timestep, &err);
    if (!plugin) return badInput(err);
    opt.plugin = plugin.get();
  }
  std::string normalised;
  if (!LcmEndpoint::checkUrl(url, &normalised, &err)) return badInput("--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> endpoint = LcmEndpoint::create(normalised, &err);
  if (!endpoint) {
    std::fprintf(stderr, "exo_sim: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }

  if (rt_priority > 0) {  // no page faults and no time-sharing preemption inside the 1 kHz loop
    sched_param sp{};
    sp.sched_priority = static_cast<int>(rt_priority);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0 || sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
      std::fprintf(stderr, "exo_sim: warning: --rt-priority %ld: %s (running with normal scheduling)\n", rt_priority,
                   std::strerror(errno));
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  if (!opt.quiet) {
    if (plugin)
      std::printf("exo_sim: controller plugin '%s' (%s) at %d Hz, seed %llu\n", plugin->name(), plugin_opt.path.c_str(),
                  1000 / plugin_opt.divisor, static_cast<unsigned long long>(plugin_opt.seed));
    std::printf("exo_sim: %s, scenario '%s' (%s), noise %s, seed %llu, %s, %.3f s, LCM %s\n", model_path.c_str(),
                scenario.name.c_str(), scenario_path.c_str(), noise.source.empty() ? "none" : noise.source.c_str(),
                static_cast<unsigned long long>(scenario.seed),
                opt.mode == SimMode::Lockstep ? "lockstep" : "realtime", opt.duration_s, endpoint->url().c_str());
    std::fflush(stdout);
  }
  RunSummary summary;
  const bool ok = runSim(model, data, *endpoint, opt, &summary, &err, &g_stop);
  std::printf("%s\n", formatSummary(summary).c_str());
  if (plugin) std::printf("%s\n", plugin->formatStats().c_str());
  {  // CPU time: what the loop costs, whatever else the machine runs (wall time counts waiting for the CPU)
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double user = ru.ru_utime.tv_sec + 1e-6 * ru.ru_utime.tv_usec, sys = ru.ru_stime.tv_sec + 1e-6 * ru.ru_stime.tv_usec;
    std::printf("exo_sim: cpu user %.3f s, system %.3f s: %.2f simulated s per cpu s\n", user, sys,
                user + sys > 0 ? summary.sim_time_s / (user + sys) : 0.0);
  }
  std::fflush(stdout);
  if (!result_path.empty()) {
    std::FILE* f = std::fopen(result_path.c_str(), "w");
    const std::string json = runSummaryJson(summary);
    if (!f || std::fputs(json.c_str(), f) < 0 || std::fclose(f) != 0) {
      std::fprintf(stderr, "exo_sim: cannot write --result '%s': %s\n", result_path.c_str(), std::strerror(errno));
      return kExitRuntime;
    }
  }
  if (!ok) {
    std::fprintf(stderr, "exo_sim: %s\n", err.c_str());
    return kExitRuntime;
  }
  switch (summary.outcome) {
    case RunOutcome::Completed: return kExitOk;
    case RunOutcome::Fell: return kExitFell;
    case RunOutcome::ControllerLost: return kExitControllerLost;
    case RunOutcome::Interrupted: return kExitInterrupted;
    case RunOutcome::LcmFailure: return kExitRuntime;
  }
  return kExitRuntime;
}
