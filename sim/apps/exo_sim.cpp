// exo_sim: the simulated exoskeleton on two force plates, as an LCM process (docs/sim.md).
#include <csignal>
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
      "  --quiet                  no progress line (the summary line is always printed)\n"
      "  --help                   this text\n"
      "\n"
      "channels (LCM, package exoid_lcm, SI units, docs/lcm.md):\n"
      "  publishes  EXO_STATE        robot_state_t    encoders rad, joint torques N m, IMU (quaternion world<-IMU\n"
      "                                               w,x,y,z, gyro rad/s, specific force m/s^2, IMU frame)\n"
      "             EXO_PLATE_RIGHT  force_plate_t    force N / moment N m ON the plate about its sensor origin,\n"
      "             EXO_PLATE_LEFT   force_plate_t    plate frame; CoP m on the top surface (0 below 20 N load)\n"
      "             EXO_TRUTH        ground_truth_t   exact state, accelerations, applied torques, contact\n"
      "                                               wrenches ON the feet (world, moment about the world origin),\n"
      "                                               robot CoM (world, undeclared payloads included)\n"
      "  subscribes EXO_COMMAND      joint_command_t  torque command N m for tick `tick`; NaN/Inf, wrong size or\n"
      "                                               names, duplicate and out-of-order ticks are rejected and\n"
      "                                               counted; torques are clamped to the actuator ranges\n"
      "\n"
      "output: a progress line per simulated second (unless --quiet), then one summary line: ticks, realtime\n"
      "factor, accepted/rejected commands by reason, fallback ticks (held, zero, timeouts), clamped commands,\n"
      "realtime overruns, MuJoCo warnings, fell yes/no (base dropped more than 0.25 m).\n"
      "\n"
      "exit codes: 0 run completed (also when interrupted by SIGINT/SIGTERM or when the robot fell),\n"
      "            1 runtime failure (LCM), 2 bad input (options, MJCF, sensors or scenario file).\n",
      EXOID_CONFIG_DIR, EXOID_CONFIG_DIR, EXOID_CONFIG_DIR, exoid::channels::kDefaultUrl);
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
    } else if (arg == "--start-timeout-s") {
      if (!parseDouble(value, &d) || d < 0.0 || d > 3600.0)
        return badInput("--start-timeout-s: expected seconds in [0, 3600], got '" + value + "'");
      opt.start_timeout_s = d;
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
  std::string normalised;
  if (!LcmEndpoint::checkUrl(url, &normalised, &err)) return badInput("--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> endpoint = LcmEndpoint::create(normalised, &err);
  if (!endpoint) {
    std::fprintf(stderr, "exo_sim: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  if (!opt.quiet) {
    std::printf("exo_sim: %s, scenario '%s' (%s), noise %s, seed %llu, %s, %.3f s, LCM %s\n", model_path.c_str(),
                scenario.name.c_str(), scenario_path.c_str(), noise.source.empty() ? "none" : noise.source.c_str(),
                static_cast<unsigned long long>(scenario.seed),
                opt.mode == SimMode::Lockstep ? "lockstep" : "realtime", opt.duration_s, endpoint->url().c_str());
    std::fflush(stdout);
  }
  RunSummary summary;
  const bool ok = runSim(model, data, *endpoint, opt, &summary, &err, &g_stop);
  std::printf("%s\n", formatSummary(summary).c_str());
  std::fflush(stdout);
  if (!ok) {
    std::fprintf(stderr, "exo_sim: %s\n", err.c_str());
    return kExitRuntime;
  }
  return kExitOk;
}
