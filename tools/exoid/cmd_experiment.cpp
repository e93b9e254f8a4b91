// exoid experiment: sim + controller (+ estimator once it exists) as separate processes over LCM udpm://
// inside a private network namespace, in lockstep, logged by exoid_logger, summarised from the log.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/sim.hpp"
#include "exoid/tools/experiment_summary.hpp"
#include "exoid/tools/process.hpp"
#include "exoid/tools/run_log.hpp"

namespace exoid::cli {

namespace {
constexpr char kNetnsEnv[] = "EXOID_IN_PRIVATE_NETNS";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid experiment: error: %s\n", msg.c_str());
  return 2;
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
  CLI::App app{
      "Runs the closed loop: exo_sim (MuJoCo, lockstep) and exo_controller (centroidal balance QP doing the\n"
      "thesis's CoM moves) as separate processes talking LCM over udpm:// with ttl=0 inside a private network\n"
      "namespace (unshare -n; multicast routed on its loopback only), recorded without loss. Writes\n"
      "  DIR/run.lcmlog       every message of every channel (lcm-logger format, recorded by exoid_logger)\n"
      "  DIR/summary.json     moves_done, fell, com_rmse_m, max_foot_slip_m, qp_solve_us_p50/p99, fallbacks,\n"
      "                       realtime_factor, missing_ticks, eom_residual_max_rel, ...\n"
      "  DIR/summary.md       the same as a table (also printed)\n"
      "  DIR/controller.log, DIR/logger.log   process output (the sim's progress is printed)",
      "exoid experiment"};
  common::configureCli(app);
  std::string scenario_path, out_dir, controller_config = config + "/controller.yaml", sensors = config + "/sensors.yaml",
      model_path = config + "/exo.urdf", mjcf = config + "/exo.xml";
  int64_t seed = 1, moves = 0;
  bool realtime = false, no_pin = false;
  app.add_option("--scenario", scenario_path, "sim scenario (config/scenarios/*.yaml): noise, undeclared effects")
      ->required()->type_name("FILE");
  app.add_option("--out", out_dir, "output directory (created)")->required()->type_name("DIR");
  app.add_option("--controller-config", controller_config, "controller configuration")->type_name("FILE");
  app.add_option("--sensors", sensors, "sensor noise configuration")->type_name("FILE");
  app.add_option("--model", model_path, "controller's model")->type_name("URDF");
  app.add_option("--mjcf", mjcf, "simulated robot")->type_name("FILE");
  // The same ranges as exo_controller's --seed and --moves, so that exoid refuses what the controller would.
  app.add_option("--seed", seed,
                 "CoM move sequence seed (use different seeds for training and validation runs)")
      ->transform(common::strictInteger(0))->type_name("N");
  app.add_option("--moves", moves, "number of CoM moves (0: the controller configuration's, 20)")
      ->transform(common::strictInteger(0, 1000))->type_name("N");
  app.add_flag("--realtime", realtime, "run the sim at wall-clock 1 kHz instead of lockstep");
  app.add_flag("--no-pin", no_pin,
               "do not pin processes to CPUs (by default, in lockstep on 2+ CPUs, sim and\n"
               "controller share the first allowed CPU; the logger is never pinned)");
  app.footer(
      "needs: root (or unprivileged user namespaces) for unshare, iproute2.\n"
      "exit codes: 0 run completed (see summary for pass/fail of the targets), 2 bad input or a process failed.");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  const std::pair<const char*, const std::string*> files[] = {{"scenario", &scenario_path},
                                                              {"controller-config", &controller_config},
                                                              {"sensors", &sensors},
                                                              {"model", &model_path},
                                                              {"mjcf", &mjcf}};
  for (const auto& [name, file] : files)
    if (!std::filesystem::is_regular_file(*file)) return fail("--" + std::string(name) + ": no such file '" + *file + "'");
  controller::ControllerConfig cc;
  if (!controller::loadControllerConfig(controller_config, cc, &err)) return fail(err);
  if (moves == 0) moves = cc.trajectory.moves;
  cc.trajectory.moves = static_cast<int>(moves);
  // The sim runs exactly as long as the controller plans to (start-up latch, moves, holds): a sim that
  // outlives the controller would apply zero torque at the end.
  const double duration = controller::plannedRunDuration(cc);

  {  // Validate every input here, before any process starts, so that errors name the file and key.
    Model controller_model;
    if (!buildModelFromUrdfFile(model_path, true, controller_model, &err)) return fail(err);
    sim::SensorConfig realistic, noise;
    sim::Scenario scenario;
    sim::SimModel probe;
    if (!sim::loadSensorConfig(sensors, &realistic, &err) || !sim::loadScenario(scenario_path, &scenario, &err) ||
        !sim::resolveSensorConfig(scenario, realistic, &noise, &err) || !sim::simLoad(mjcf, noise, scenario, probe, &err))
      return fail(err);
  }
  if (!std::getenv(kNetnsEnv)) return reexecInPrivateNetns(argc, argv);
  // Inside the namespace: loopback up, multicast routed to it; nothing can leave this namespace.
  if (std::system("ip link set lo up") != 0 || std::system("ip route add 224.0.0.0/4 dev lo") != 0)
    return fail("cannot configure the private network namespace (ip link/route failed; is iproute2 installed?)");

  const std::filesystem::path out = out_dir;
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
  const int loop_cpu = (!no_pin && cpus.size() >= 2) ? cpus.front() : -1;

  // exoid_logger, not Debian's lcm-logger: the latter drops bursts in LCM's user-space receive ring at the
  // lockstep rate (~30k messages/s) although the kernel delivers every datagram (docs/lcm.md).
  pid_t logger = tools::spawn({bin + "/exoid_logger", "--lcm-url", url, "--force", "--out", log_path},
                              (out / "logger.log").string(), &err);
  if (logger < 0) return fail(err);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  pid_t ctrl = tools::spawn({bin + "/exo_controller", "--model", model_path, "--config", controller_config,
                             "--seed", std::to_string(seed), "--moves", std::to_string(moves), "--lcm-url", url},
                            (out / "controller.log").string(), &err, realtime ? -1 : loop_cpu);
  if (ctrl < 0) return tools::stop(logger, SIGINT, 2000), fail(err);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  char dur[32];
  std::snprintf(dur, sizeof dur, "%.3f", duration);
  std::printf("exoid experiment: %ld CoM moves, %.1f s simulated, scenario %s -> %s\n", moves, duration,
              scenario_path.c_str(), out.c_str());
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  pid_t sim = tools::spawn({bin + "/exo_sim", "--model", mjcf, "--sensors", sensors, "--scenario",
                            scenario_path, "--mode", realtime ? "realtime" : "lockstep",
                            "--duration", dur, "--lcm-url", url},
                           "", &err, realtime ? -1 : loop_cpu);
  if (sim < 0) return tools::stop(ctrl, SIGTERM, 2000), tools::stop(logger, SIGINT, 2000), fail(err);
  int sim_code = -1, ctrl_code = -1;
  tools::waitFor(sim, -1, &sim_code);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!tools::waitFor(ctrl, 5000, &ctrl_code)) ctrl_code = tools::stop(ctrl, SIGTERM, 2000);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let the logger drain its socket
  tools::stop(logger, SIGINT, 5000);
  if (sim_code != 0) return fail("exo_sim exited with code " + std::to_string(sim_code));
  if (ctrl_code != 0)
    std::fprintf(stderr, "exoid experiment: warning: exo_controller exited with code %d (see %s)\n", ctrl_code,
                 (out / "controller.log").c_str());

  Model model;
  if (!buildModelFromUrdfFile(model_path, true, model, &err)) return fail(err);
  tools::RunLog log;
  if (!tools::readRunLog(log_path, model.joint_names, log, &err)) return fail(err);
  tools::ExperimentSummary s;
  if (!tools::summarizeExperiment(model, log, static_cast<int>(moves), wall, s, &err)) return fail(err);
  const std::string table = tools::summaryTable(s);
  std::ofstream(out / "summary.json") << tools::summaryJson(s);
  std::ofstream(out / "summary.md") << "# Experiment " << scenario_path << " (seed " << seed << ")\n\n" << table;
  std::printf("\n%s\nwritten: %s, %s, %s\n", table.c_str(), log_path.c_str(), (out / "summary.json").c_str(),
              (out / "summary.md").c_str());
  return 0;
}

}  // namespace exoid::cli
