// exo_sim: the simulated exoskeleton on two force plates, as an LCM process (docs/sim.md). Thin: options -> the
// inputs loaded (simLoad, the plugin) -> runSim (sim/runner.hpp) -> the summary lines and --result.
#include <malloc.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/lcm_endpoint.hpp"
#include "exoid/render/live_view.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/runner.hpp"
#include "exoid/sim/sim.hpp"

namespace {

using exoid::common::kExitBadInput;
using exoid::common::kExitOk;
using exoid::common::kExitRuntime;
constexpr int kExitFell = 3;
constexpr int kExitControllerLost = 4;
constexpr int kExitInterrupted = 5;
constexpr double kMaxPluginRunS = 3600.0;  // cap of a plugin run that never reports finished
constexpr char kProg[] = "exo_sim";

constexpr char kDescription[] =
    "Simulates the exoskeleton standing on two force plates (MuJoCo 2.2, 1 kHz: one 1 ms step per control\n"
    "tick) and talks LCM. Every tick k it applies the command for tick k, then publishes the samples of\n"
    "tick k (utime = k * 1000, simulated microseconds). See docs/sim.md.";

constexpr char kFooter[] =
    "channels (LCM, package exoid_lcm, SI units, docs/lcm.md):\n"
    "  publishes  EXO_STATE        robot_state_t    encoders rad, joint torques N m, IMU (quaternion world<-IMU\n"
    "                                               w,x,y,z, gyro rad/s, specific force m/s^2, IMU frame)\n"
    "             EXO_PLATE_RIGHT  force_plate_t    force N / moment N m ON the plate about its sensor origin,\n"
    "             EXO_PLATE_LEFT   force_plate_t    plate frame; CoP m on the top surface (0 below 20 N load)\n"
    "             EXO_TRUTH        ground_truth_t   exact state, accelerations, applied torques, contact\n"
    "                                               wrenches ON the feet (world, moment about the world origin),\n"
    "                                               robot CoM (world, undeclared payloads included)\n"
    "             EXO_COMMAND, EXO_CONTROLLER_STATUS   with --controller-plugin: the plugin's command and status\n"
    "  subscribes EXO_COMMAND      joint_command_t  torque command N m for tick `tick`; NaN/Inf, wrong size or\n"
    "                                               names, duplicate and out-of-order ticks are rejected and\n"
    "                                               counted; torques are clamped to the actuator ranges\n"
    "                                               (not with --controller-plugin)\n"
    "             EXO_ESTIMATE     estimator_output_t with --controller-plugin: the whole estimate goes to the plugin\n"
    "\n"
    "output: a progress line per simulated second (unless --quiet), then one summary line: ticks, realtime\n"
    "factor, accepted/rejected commands by reason, fallback ticks (held, zero, timeouts), clamped commands,\n"
    "MuJoCo warnings, fell yes/no (base dropped more than 0.25 m), the loop timing (overruns: tick work over\n"
    "1 ms; realtime deadline misses: work ended after its 1 ms slot; worst tick, wall and CPU; latest start;\n"
    "preemptions, page faults; docs/sim.md \"Loop timing\"). A fall ends the run at\n"
    "the fall tick (nothing after it is worth simulating; docs/sim.md). With a plugin a second line: calls,\n"
    "good answers, failures by kind, over-budget calls, fallback ticks, call time. Last, the process's CPU\n"
    "time (user, system) and simulated seconds per CPU second (the real-time factor with a core of its own).\n"
    "\n"
    "exit codes: 0 run completed (every tick of --duration, or until the plugin finished), 1 runtime failure (LCM, --result unwritable),\n"
    "            2 bad input (options, MJCF, sensors or scenario file; a plugin that does not load, has another\n"
    "            ABI version or fails to create; one line on stderr names the problem),\n"
    "            3 the robot fell (run ended at the fall tick, printed),\n"
    "            4 the controller stopped answering (--max-missing-commands), 5 interrupted (SIGINT/SIGTERM).";

/// exo_sim's options.
struct Args {
  std::string config = exoid::common::installedConfigDir();
  std::string model_path = config + "/exo.xml";
  std::string sensors_path = config + "/sensors.yaml";
  std::string scenario_path = config + "/scenarios/nominal.yaml";
  std::string url = exoid::LcmEndpoint::defaultUrl();
  std::string mode = "lockstep";
  exoid::sim::RunOptions opt;
  std::string result_path;
  exoid::sim::PluginOptions plugin;
  double plugin_budget_us = -1.0;  // < 0: the mode's default
  int rate_hz = 1000, rt_priority = 0;
  bool no_estimate = false, view = false;
  Args() {
    plugin.model_path = config + "/exo.urdf";
    plugin.config_path = config + "/controller.yaml";
  }
};

/// The simulation's, the loop's and the LCM options.
void addSimOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  app.add_option("--model", a.model_path, "MJCF of the robot and plates")->type_name("FILE");
  app.add_option("--sensors", a.sensors_path, "realistic sensor noise")->type_name("FILE");
  app.add_option("--scenario", a.scenario_path,
                 "scenario: seed, noise (realistic|off|FILE), undeclared effects, initial state")
      ->type_name("FILE");
  app.add_option("--mode", a.mode,
                 "lockstep: wait (bounded) for the command of each tick, run as fast as the CPU\n"
                 "allows, deterministic; realtime: 1 kHz wall clock, apply the latest valid command,\n"
                 "count stale ticks and missed deadlines")
      ->check(CLI::IsMember({"lockstep", "realtime"}))->type_name("lockstep|realtime");
  app.add_option("--duration", a.opt.duration_s,
                 "simulated time in seconds (default 10; with --controller-plugin and no --duration:\n"
                 "until the plugin reports its task finished, at most 3600 s)")
      ->transform(common::strictNumber(1e-3, 1e7))->type_name("SECONDS");
  app.add_option("--lcm-url", a.url, "LCM URL; a udpm URL must have ttl=0; the default is $LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--command-timeout-ms", a.opt.command_timeout_ms, "lockstep: how long to wait for the command of tick k")
      ->transform(common::strictInteger(0, 3600000))->type_name("MS");
  app.add_option("--hold-ticks", a.opt.hold_ticks,
                 "fallback when the command of a tick is missing: hold the last valid command for\n"
                 "N ticks, then apply zero torque until a fresh command arrives; every such tick is counted")
      ->transform(common::strictInteger(0, 1000000000))->type_name("N");
  app.add_option("--start-timeout-s", a.opt.start_timeout_s,
                 "lockstep: wait up to S s for the first command, re-sending tick 0 every 100 ms\n"
                 "for a late controller; if none comes, run open loop without waiting")
      ->transform(common::strictNumber(0.0, 3600.0))->type_name("S");
  app.add_option("--max-missing-commands", a.opt.max_missing_commands,
                 "once a controller has answered: end the run (exit 4) when N consecutive\n"
                 "commands are missing (lockstep: each after a --command-timeout-ms wait, so at most\n"
                 "N x that; realtime: N x --command-timeout-ms ms without a fresh command); 0 never\n"
                 "gives up")
      ->transform(common::strictInteger(0, 1000000000))->type_name("N");
  app.add_option("--result", a.result_path,
                 "write the summary as JSON to FILE at the end (outcome, fall tick, fallback\n"
                 "ticks, ...; `exoid experiment` reads it)")
      ->type_name("FILE");
  app.add_flag("--quiet", a.opt.quiet, "no progress line (the summary line is always printed)");
  app.add_flag("--view", a.view, "a live window drawing the run as `exoid render` does (docs/render.md), where a display\n"
               "exists (without one: one line says so and the run goes on); real time with --mode realtime");
  app.add_option("--rt-priority", a.rt_priority,
                 "realtime: lock memory (mlockall) and run the loop under SCHED_FIFO priority N\n"
                 "(needs root or CAP_SYS_NICE, else a warning and normal scheduling)")
      ->transform(common::strictInteger(1, 99))->type_name("N");
}

/// The in-loop controller's options (docs/plugin.md); without --controller-plugin a controller process answers
/// EXO_COMMAND.
void addPluginOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  app.add_option("--controller-plugin", a.plugin.path,
                 "in-loop controller: load the controller plugin LIB (e.g.\n"
                 "build/lib/libexoid_controller_plugin.so, docs/plugin.md) and call it after each\n"
                 "step: state of tick k in, command for tick k+1 out (the one-tick delay of a\n"
                 "controller process); the loop publishes its EXO_COMMAND and EXO_CONTROLLER_STATUS\n"
                 "and hands it every EXO_ESTIMATE (set_estimate). A failed, non-finite, malformed or\n"
                 "over-budget answer is replaced by a counted fallback: hold the last good torque,\n"
                 "then damping")
      ->type_name("LIB");
  app.add_option("--controller-model", a.plugin.model_path, "robot model given to the plugin")->type_name("URDF");
  app.add_option("--controller-config", a.plugin.config_path, "the plugin's configuration")->type_name("FILE");
  app.add_option("--controller-seed", a.plugin.seed, "seed given to the plugin: the CoM move sequence (default 1)")
      ->transform(common::strictInteger(0))->type_name("N");
  app.add_option("--controller-moves", a.plugin.moves, "CoM moves given to the plugin (0: the configuration's)")
      ->transform(common::strictInteger(0, 1000))->type_name("N");
  app.add_option("--controller-rate-hz", a.rate_hz,
                 "plugin rate, a divisor of the 1000 Hz physics rate; the command is held between\n"
                 "calls")
      ->transform(common::strictInteger(1, 1000))
      ->check(CLI::Validator([](std::string& v) { return 1000 % std::stoi(v) == 0 ? std::string() : "not a divisor of 1000"; },
                             "", "divisor of 1000"))
      ->type_name("HZ");
  app.add_option("--plugin-budget-us", a.plugin_budget_us,
                 "a plugin call longer than US microseconds (wall clock) is discarded and counted\n"
                 "(default: none in lockstep, which stays deterministic; half the controller period\n"
                 "in realtime)")
      ->transform(common::strictNumber(0.0, 1e7))->type_name("US");
  app.add_option("--plugin-hold-ticks", a.plugin.hold_ticks,
                 "plugin fallback: controller ticks on the last good torque before damping")
      ->transform(common::strictInteger(0, 1000000000))->type_name("N");
  app.add_option("--estimate-lag-ticks", a.opt.estimate_lag_ticks,
                 "lockstep, with a plugin taking EXO_ESTIMATE: before the plugin's tick k, wait until an\n"
                 "estimate with tick >= k - L has arrived, so that the estimates it applies (those with\n"
                 "tick <= k - L: its configuration's estimate.lag_ticks, which L must equal) do not\n"
                 "depend on scheduling; the run is then reproducible bit for bit (docs/sim.md).\n"
                 "Default: no wait")
      ->transform(common::strictInteger(0, 1000000))->type_name("L");
  app.add_option("--estimate-timeout-ms", a.opt.estimate_timeout_ms,
                 "the longest of those waits (--start-timeout-s before the first estimate); after a\n"
                 "timeout the loop stops waiting and says so: the run is no longer reproducible")
      ->transform(common::strictInteger(1, 3600000))->type_name("MS");
  app.add_flag("--no-estimate", a.no_estimate,
               "with a plugin: do not subscribe to EXO_ESTIMATE (no estimator running: the loop then\n"
               "reads nothing back from LCM, which saves a receive per published message)");
}

/// The simulated robot and its inputs: every problem is one line naming the file and the field.
bool loadInputs(Args& a, exoid::sim::Scenario& scenario, exoid::sim::SensorConfig& noise, exoid::sim::SimModel& model,
                exoid::sim::SimData& data, std::unique_ptr<exoid::sim::ControllerPlugin>& plugin, std::string* err) {
  using namespace exoid::sim;
  SensorConfig realistic;
  if (!loadScenario(a.scenario_path, &scenario, err) || !loadSensorConfig(a.sensors_path, &realistic, err) ||
      !resolveSensorConfig(scenario, realistic, &noise, err) || !simLoad(a.model_path, noise, scenario, model, err) ||
      !simMakeData(model, data, err))
    return false;
  if (a.plugin.path.empty()) return true;
  a.plugin.budget_us = a.plugin_budget_us >= 0.0            ? a.plugin_budget_us
                       : a.opt.mode == SimMode::Realtime ? 500.0 * a.plugin.divisor
                                                         : 0.0;
  plugin = ControllerPlugin::load(a.plugin, model.joint_names, model.m->opt.timestep, err);
  if (!plugin) return false;
  a.opt.plugin = plugin.get();
  return true;
}

/// Touches kStackPrefault bytes of stack below the caller, so the loop's deeper calls find their pages mapped.
constexpr size_t kStackPrefault = 512 * 1024;
__attribute__((noinline)) void prefaultStack() {
  char stack[kStackPrefault];
  std::memset(stack, 0, sizeof stack);
  asm volatile("" : : "r"(stack) : "memory");  // the writes happen
}

/// --rt-priority: no page faults and no time-sharing preemption inside the 1 kHz loop (a warning if refused).
/// Every page mapped now and later is locked and populated (mlockall), the heap is never given back to the system
/// (a later allocation would fault it in again), and the stack the loop needs is touched once here.
void lockMemoryAndPriority(int rt_priority) {
  mallopt(M_TRIM_THRESHOLD, -1);
  mallopt(M_MMAP_MAX, 0);
  sched_param sp{};
  sp.sched_priority = rt_priority;
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0 || sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
    std::fprintf(stderr, "exo_sim: warning: --rt-priority %d: %s (running with normal scheduling)\n", rt_priority,
                 std::strerror(errno));
  prefaultStack();
}

void printStart(const Args& a, const exoid::sim::Scenario& scenario, const exoid::sim::SensorConfig& noise,
                const exoid::sim::ControllerPlugin* plugin, const exoid::LcmEndpoint& endpoint) {
  if (plugin)
    std::printf("exo_sim: controller plugin '%s' (%s) at %d Hz, seed %llu\n", plugin->name(), a.plugin.path.c_str(),
                a.rate_hz, static_cast<unsigned long long>(a.plugin.seed));
  std::printf("exo_sim: %s, scenario '%s' (%s), noise %s, seed %llu, %s, %.3f s, LCM %s\n", a.model_path.c_str(),
              scenario.name.c_str(), a.scenario_path.c_str(), noise.source.empty() ? "none" : noise.source.c_str(),
              static_cast<unsigned long long>(scenario.seed),
              a.opt.mode == exoid::sim::SimMode::Lockstep ? "lockstep" : "realtime", a.opt.duration_s,
              endpoint.url().c_str());
  std::fflush(stdout);
}

/// The summary lines, the process's CPU time, --result; the exit code.
int report(const Args& a, bool ok, const exoid::sim::RunSummary& summary, const exoid::sim::ControllerPlugin* plugin,
           const std::string& err) {
  using namespace exoid::sim;
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
  if (!a.result_path.empty()) {
    std::FILE* f = std::fopen(a.result_path.c_str(), "w");
    const std::string json = runSummaryJson(summary);
    if (!f || std::fputs(json.c_str(), f) < 0 || std::fclose(f) != 0) {
      std::fprintf(stderr, "exo_sim: cannot write --result '%s': %s\n", a.result_path.c_str(), std::strerror(errno));
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

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::sim;
  CLI::App app{kDescription, kProg};
  common::configureCli(app);
  Args a;
  addSimOptions(app, a);
  addPluginOptions(app, a);
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc, argv); code >= 0) return code;
  a.opt.mode = a.mode == "realtime" ? SimMode::Realtime : SimMode::Lockstep;
  if (!a.plugin.path.empty() && app.count("--duration") == 0) {
    a.opt.end_when_plugin_finished = true;  // the plugin knows when its task is over (ABI status.finished)
    a.opt.duration_s = kMaxPluginRunS;
  }
  a.plugin.divisor = 1000 / a.rate_hz;
  a.plugin.listen_estimate = !a.no_estimate;
  // From here on a stop request ends the run cleanly (exit 5, --result written), also while loading.
  const volatile std::sig_atomic_t* stop = common::installStopSignals();
  std::string err;
  Scenario scenario;
  SensorConfig noise;
  SimModel model;
  SimData data;
  std::unique_ptr<ControllerPlugin> plugin;
  if (!loadInputs(a, scenario, noise, model, data, plugin, &err)) return common::badInput(kProg, err);
  std::string normalised;
  if (!LcmEndpoint::checkUrl(a.url, &normalised, &err)) return common::badInput(kProg, "--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> endpoint = LcmEndpoint::create(normalised, &err);
  if (!endpoint) {
    std::fprintf(stderr, "exo_sim: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }
  if (a.rt_priority > 0) lockMemoryAndPriority(a.rt_priority);
  if (!a.opt.quiet) printStart(a, scenario, noise, plugin.get(), *endpoint);
  std::unique_ptr<render::LiveView> live;  // its own thread and subscription: the loop never waits for it
  if (a.view) {
    render::LiveViewOptions lv{a.model_path, a.config + "/exo.urdf", endpoint->url(), scenario};
    if (!(live = render::LiveView::start(lv, &err))) std::fprintf(stderr, "exo_sim: --view: %s\n", err.c_str());
  }
  RunSummary summary;
  const bool ok = runSim(model, data, *endpoint, a.opt, &summary, &err, stop);
  return report(a, ok, summary, plugin.get(), err);
}
