// exoid experiment: sim + controller (+ estimator once it exists) over LCM udpm:// inside a private network
// namespace, in lockstep, logged by exoid_logger, summarised from the log. The controller runs inside the
// sim's loop as a plugin (default) or as its own process.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "commands.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/sim.hpp"
#include "exoid/tools/args.hpp"
#include "exoid/tools/experiment_summary.hpp"
#include "exoid/tools/process.hpp"
#include "exoid/tools/run_log.hpp"

namespace exoid::cli {

namespace {
constexpr char kNetnsEnv[] = "EXOID_IN_PRIVATE_NETNS";

constexpr char kHelp[] =
    "usage: exoid experiment --scenario SCENARIO.yaml --out DIR [options]\n\n"
    "Runs the closed loop: exo_sim (MuJoCo, lockstep) with the centroidal balance QP doing the thesis's CoM\n"
    "moves, either inside the sim's loop as a plugin (default) or as the separate exo_controller process; every\n"
    "channel goes over LCM udpm:// with ttl=0 inside a private network namespace (unshare -n; multicast routed\n"
    "on its loopback only), recorded without loss. Writes\n"
    "  DIR/run.lcmlog       every message of every channel (lcm-logger format, recorded by exoid_logger)\n"
    "  DIR/summary.json     moves_done, fell, com_rmse_m, max_foot_slip_m, qp_solve_us_p50/p99, fallbacks,\n"
    "                       realtime_factor, missing_ticks, eom_residual_max_rel, ...\n"
    "  DIR/summary.md       the same as a table (also printed)\n"
    "  DIR/controller.log, DIR/logger.log   process output (the sim's progress is printed; controller.log only\n"
    "                       with --controller process)\n\n"
    "options:\n"
    "  --scenario FILE          sim scenario (config/scenarios/*.yaml): noise, undeclared effects\n"
    "  --out DIR                output directory (created)\n"
    "  --controller-config FILE controller configuration (default config/controller.yaml)\n"
    "  --sensors FILE           sensor noise configuration (default config/sensors.yaml)\n"
    "  --model URDF             controller's model (default config/exo.urdf)\n"
    "  --mjcf FILE              simulated robot (default config/exo.xml)\n"
    "  --seed N                 CoM move sequence seed (default 1; use different seeds for training and\n"
    "                           validation runs)\n"
    "  --moves N                number of CoM moves (default: the controller configuration's, 20)\n"
    "  --controller plugin|process\n"
    "                           plugin (default): the balance controller runs inside exo_sim's loop as\n"
    "                           build/lib/libexoid_controller_plugin.so (docs/plugin.md), no controller process;\n"
    "                           process: exo_controller as its own process over LCM. Same commands tick by tick\n"
    "  --controller-plugin LIB  plugin mode: another controller plugin library\n"
    "  --realtime               run the sim at wall-clock 1 kHz instead of lockstep (exo_sim --rt-priority 50:\n"
    "                           SCHED_FIFO and locked memory where allowed)\n"
    "  --no-pin                 do not pin processes to CPUs (by default, in lockstep on 2+ CPUs, sim and\n"
    "                           controller share the first allowed CPU; the logger is never pinned)\n"
    "  --help                   this text\n\n"
    "needs: root (or unprivileged user namespaces) for unshare, iproute2.\n"
    "exit codes: 0 run completed (see summary for pass/fail of the targets), 2 bad input or a process failed.\n";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid experiment: error: %s\n", msg.c_str());
  return 2;
}

std::string selfPath();

/// build/lib/libexoid_controller_plugin.so next to this binary's build/bin.
std::string pluginPath() {
  return (std::filesystem::path(selfPath()).parent_path().parent_path() / "lib" / "libexoid_controller_plugin.so").string();
}

std::string selfPath() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return "exoid";
  buf[n] = '\0';
  return buf;
}

/// Re-executes this command inside a new network namespace (root: unshare -n; otherwise unshare -r -n).
int reexecInPrivateNetns(int argc, char** argv) {
  std::vector<std::string> args = {"unshare"};
  if (::geteuid() != 0) args.push_back("-r");
  args.insert(args.end(), {"-n", "--", selfPath()});
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  ::setenv(kNetnsEnv, "1", 1);
  std::vector<char*> c;
  for (auto& a : args) c.push_back(a.data());
  c.push_back(nullptr);
  ::execvp("unshare", c.data());
  return fail("cannot run 'unshare' (util-linux) to create a private network namespace");
}
}  // namespace

int cmdExperiment(int argc, char** argv) {
  const std::string config = EXOID_CONFIG_DIR;
  tools::Args args;
  args.option("scenario").option("out").option("controller-config", config + "/controller.yaml");
  args.option("sensors", config + "/sensors.yaml").option("model", config + "/exo.urdf");
  args.option("mjcf", config + "/exo.xml").option("seed", "1").option("moves", "0");
  args.option("controller", "plugin").option("controller-plugin", pluginPath());
  args.flag("realtime").flag("no-pin").flag("help");
  std::string err;
  if (!args.parse(argc, argv, 2, &err)) return fail(err);
  if (args.has("help")) return std::fputs(kHelp, stdout), 0;
  if (!args.has("scenario") || !args.has("out")) return fail("--scenario and --out are required (exoid experiment --help)");
  for (const char* f : {"scenario", "controller-config", "sensors", "model", "mjcf"})
    if (!std::filesystem::is_regular_file(args.get(f))) return fail("--" + std::string(f) + ": no such file '" + args.get(f) + "'");
  const bool use_plugin = args.get("controller") == "plugin";
  if (!use_plugin && args.get("controller") != "process")
    return fail("--controller: expected plugin or process, got '" + args.get("controller") + "'");
  if (use_plugin && !std::filesystem::is_regular_file(args.get("controller-plugin")))
    return fail("--controller-plugin: no such file '" + args.get("controller-plugin") + "'");
  long seed = 0, moves = 0;
  if (!args.getInt("seed", seed, &err) || !args.getInt("moves", moves, &err)) return fail(err);
  controller::ControllerConfig cc;
  if (!controller::loadControllerConfig(args.get("controller-config"), cc, &err)) return fail(err);
  if (moves < 0) return fail("--moves must be >= 0");
  if (moves == 0) moves = cc.trajectory.moves;
  cc.trajectory.moves = static_cast<int>(moves);
  // The sim runs exactly as long as the controller plans to (start-up latch, moves, holds): a sim that
  // outlives the controller would apply zero torque at the end.
  const double duration = controller::plannedRunDuration(cc);

  {  // Validate the sim's inputs here, before any process starts, so that errors name the file and key.
    sim::SensorConfig realistic, noise;
    sim::Scenario scenario;
    sim::SimModel probe;
    if (!sim::loadSensorConfig(args.get("sensors"), &realistic, &err) || !sim::loadScenario(args.get("scenario"), &scenario, &err) ||
        !sim::resolveSensorConfig(scenario, realistic, &noise, &err) || !sim::simLoad(args.get("mjcf"), noise, scenario, probe, &err))
      return fail(err);
  }
  if (!std::getenv(kNetnsEnv)) return reexecInPrivateNetns(argc, argv);
  // Inside the namespace: loopback up, multicast routed to it; nothing can leave this namespace.
  if (std::system("ip link set lo up") != 0 || std::system("ip route add 224.0.0.0/4 dev lo") != 0)
    return fail("cannot configure the private network namespace (ip link/route failed; is iproute2 installed?)");

  const std::filesystem::path out = args.get("out");
  std::filesystem::create_directories(out);
  const std::string log_path = (out / "run.lcmlog").string();
  for (const char* f : {"run.lcmlog", "logger.log", "controller.log", "summary.json", "summary.md"})
    std::filesystem::remove(out / f);
  const std::string url = channels::kDefaultUrl;
  const std::string bin = std::filesystem::path(selfPath()).parent_path().string();
  ::setenv("LCM_DEFAULT_URL", url.c_str(), 1);
  // Lockstep sim and controller take turns, so they share one CPU (cheap hand-overs: 6x real time against
  // 4.5x unpinned on 2 cores); the logger stays free to use every CPU.
  const std::vector<int> cpus = tools::allowedCpus();
  const int loop_cpu = (!args.has("no-pin") && cpus.size() >= 2) ? cpus.front() : -1;

  // exoid_logger, not Debian's lcm-logger: the latter drops bursts in LCM's user-space receive ring at the
  // lockstep rate (~30k messages/s) although the kernel delivers every datagram (docs/lcm.md).
  pid_t logger = tools::spawn({bin + "/exoid_logger", "--lcm-url", url, "--force", "--out", log_path},
                              (out / "logger.log").string(), &err);
  if (logger < 0) return fail(err);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  pid_t ctrl = use_plugin ? 0 : tools::spawn({bin + "/exo_controller", "--model", args.get("model"), "--config", args.get("controller-config"),
                             "--seed", std::to_string(seed), "--moves", std::to_string(moves), "--lcm-url", url},
                            (out / "controller.log").string(), &err, args.has("realtime") ? -1 : loop_cpu);
  if (ctrl < 0) return tools::stop(logger, SIGINT, 2000), fail(err);
  if (!use_plugin) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  char dur[32];
  std::snprintf(dur, sizeof dur, "%.3f", duration);
  std::printf("exoid experiment: %ld CoM moves, %.1f s simulated, scenario %s, controller %s -> %s\n", moves,
              duration, args.get("scenario").c_str(), args.get("controller").c_str(), out.c_str());
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> sim_args = {bin + "/exo_sim", "--model", args.get("mjcf"), "--sensors", args.get("sensors"),
                                       "--scenario", args.get("scenario"), "--mode",
                                       args.has("realtime") ? "realtime" : "lockstep", "--duration", dur, "--lcm-url", url};
  if (args.has("realtime")) sim_args.insert(sim_args.end(), {"--rt-priority", "50"});  // SCHED_FIFO where allowed
  if (use_plugin)  // the controller inside the sim's loop, given what exo_controller would get
    sim_args.insert(sim_args.end(), {"--controller-plugin", args.get("controller-plugin"), "--controller-model",
                                     args.get("model"), "--controller-config", args.get("controller-config"),
                                     "--controller-seed", std::to_string(seed), "--controller-moves", std::to_string(moves),
                                     "--no-estimate"});  // no estimator runs: the loop need not receive at all
  pid_t sim = tools::spawn(sim_args, "", &err, args.has("realtime") ? -1 : loop_cpu);
  if (sim < 0) {
    if (ctrl > 0) tools::stop(ctrl, SIGTERM, 2000);
    tools::stop(logger, SIGINT, 2000);
    return fail(err);
  }
  int sim_code = -1, ctrl_code = 0;
  tools::waitFor(sim, -1, &sim_code);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (ctrl > 0 && !tools::waitFor(ctrl, 5000, &ctrl_code)) ctrl_code = tools::stop(ctrl, SIGTERM, 2000);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let the logger drain its socket
  tools::stop(logger, SIGINT, 5000);
  if (sim_code != 0) return fail("exo_sim exited with code " + std::to_string(sim_code));
  if (ctrl_code != 0)
    std::fprintf(stderr, "exoid experiment: warning: exo_controller exited with code %d (see %s)\n", ctrl_code,
                 (out / "controller.log").c_str());

  Model model;
  if (!buildModelFromUrdfFile(args.get("model"), true, model, &err)) return fail(err);
  tools::RunLog log;
  if (!tools::readRunLog(log_path, model.joint_names, log, &err)) return fail(err);
  tools::ExperimentSummary s;
  if (!tools::summarizeExperiment(model, log, static_cast<int>(moves), wall, s, &err)) return fail(err);
  const std::string table = tools::summaryTable(s);
  std::ofstream(out / "summary.json") << tools::summaryJson(s);
  std::ofstream(out / "summary.md") << "# Experiment " << args.get("scenario") << " (seed " << seed << ")\n\n" << table;
  std::printf("\n%s\nwritten: %s, %s, %s\n", table.c_str(), log_path.c_str(), (out / "summary.json").c_str(),
              (out / "summary.md").c_str());
  return 0;
}

}  // namespace exoid::cli
