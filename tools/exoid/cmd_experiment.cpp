// exoid experiment: sim + controller + online estimator over LCM udpm:// inside a private network namespace,
// in lockstep, logged by exoid_logger, summarised from the log (with online-vs-batch figures when the
// estimator ran). The controller runs inside the sim's loop as a plugin (default) or as its own process.
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/strict_number.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/controller/run_options.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/runner.hpp"
#include "exoid/sim/sim.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/tools/experiment_summary.hpp"
#include "exoid/tools/online_vs_batch.hpp"
#include "exoid/tools/process.hpp"
#include "exoid/intake/run_log.hpp"

namespace exoid::cli {

namespace {
// No forgetting: the exact minimiser of the batch regularised cost, the most accurate estimate of a robot whose
// inertia does not change (from a +-25 % prior its feedforward cuts the joint-torque prediction error 3.6x; with
// stabilised forgetting lambda 0.999 2.5x); the estimator's change detection (on by default) forgets when the
// robot changes (a 3 kg payload mid-run: 95 % of its mass in 0.9 s). docs/estimator.md, "Change detection".
constexpr const char* kDefaultEstimatorArgs = "--forgetting none";
constexpr char kNetnsEnv[] = "EXOID_IN_PRIVATE_NETNS";

constexpr char kDescription[] =
    "Runs the closed loop: exo_sim (MuJoCo, lockstep) with the centroidal balance QP doing the thesis's CoM\n"
    "moves, either inside the sim's loop as a plugin (default) or as the separate exo_controller process, and\n"
    "the online estimator exo_estimator (unless --no-estimator) reading the same sensor stream; every\n"
    "channel goes over LCM udpm:// with ttl=0 inside a private network namespace (unshare -n; multicast routed\n"
    "on its loopback only), recorded without loss. Writes\n"
    "  DIR/run.lcmlog       every message of every channel (lcm-logger format, recorded by exoid_logger);\n"
    "                       kept, as far as it got, when a run fails\n"
    "  DIR/summary.json     outcome, failures, moves_done, fell (tick, time, move), com_rmse_m,\n"
    "                       max_foot_slip_m, fallbacks of controller and sim, realtime_factor, ticks planned /\n"
    "                       simulated / logged, missing_ticks, log_complete, eom_residual_max_rel, ...\n"
    "  DIR/summary.md       the same as a table (also printed)\n"
    "  DIR/sim.log, DIR/sim_result.json, DIR/controller.log, DIR/logger.log   process output (the sim's\n"
    "                       progress is also printed; controller.log only with --controller process)\n"
    "  DIR/estimator.log, DIR/estimator.ckpt, DIR/online_estimate.csv   the estimator's output, checkpoint\n"
    "                       (every 0.5 s; a restarted estimator resumes from it) and final estimate; the\n"
    "                       summary then adds online vs batch: held-out joint-torque RMSE of the online\n"
    "                       estimate and of a batch WLS-RC (both learning from the first 75 % of the run,\n"
    "                       judged on the rest) and the final online estimate's difference from the batch one\n\n"
    "A run ends when the sim has simulated the planned time, or early: the robot fell (the sim stops at the\n"
    "fall), a process died or stopped answering (the others are stopped within seconds and reaped), the\n"
    "watchdog expired, or SIGINT/SIGTERM. The summary is written in every case and names what failed.";

constexpr char kFooter[] =
    "needs: root (or unprivileged user namespaces) for unshare, iproute2.\n"
    "exit codes: 0 run completed (every planned tick, nothing failed; the summary says whether the targets\n"
    "              were met)\n"
    "            1 run failed: a process died, exited early or stopped answering, the watchdog expired, or\n"
    "              the log is incomplete or damaged (summary names it; partial log kept)\n"
    "            2 bad input (options, files, output directory), before any process starts\n"
    "            3 the robot fell (the run ended at the fall; the summary says when and during which move)\n"
    "            4 interrupted by SIGINT or SIGTERM (processes stopped, summary of the partial run written)";

constexpr int kExitOk = 0, kExitFailed = 1, kExitBadInput = 2, kExitFell = 3, kExitInterrupted = 4;

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid experiment: error: %s\n", msg.c_str());
  return kExitBadInput;
}

std::string selfPath() { return common::selfExecutablePath("exoid"); }

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

/// DIR exists as a directory (created if needed) in which we can create files; else a one-line *error.
bool prepareOutDir(const std::filesystem::path& dir, std::string* error) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) {
    *error = "--out '" + dir.string() + "' exists and is not a directory";
    return false;
  }
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    *error = "--out '" + dir.string() + "': cannot create the directory: " + ec.message();
    return false;
  }
  const std::string probe = (dir / ".exoid_write_test").string();
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) {
    *error = "--out '" + dir.string() + "': cannot write there: " + std::strerror(errno);
    return false;
  }
  ::close(fd);
  ::unlink(probe.c_str());
  return true;
}

/// A fault to inject (testing): `action` to `process` at `at_s` seconds after the sim started.
struct Injection {
  std::string action, process;
  double at_s = -1.0;
  bool done = false;
};

bool parseInjection(const std::string& text, Injection* inj, std::string* error) {
  std::stringstream ss(text);
  std::string seconds;
  std::getline(ss, inj->action, ':');
  std::getline(ss, inj->process, ':');
  std::getline(ss, seconds);
  char* end = nullptr;
  inj->at_s = std::strtod(seconds.c_str(), &end);
  if ((inj->action != "kill" && inj->action != "stop" && inj->action != "restart") ||
      (inj->process != "sim" && inj->process != "controller" && inj->process != "logger" &&
       inj->process != "estimator") ||
      (inj->action == "restart" && inj->process != "estimator") || seconds.empty() || *end != '\0' ||
      !(inj->at_s >= 0.0 && inj->at_s < 1e6)) {
    *error = "--inject: expected kill|stop:sim|controller|logger|estimator:SECONDS or restart:estimator:SECONDS, got '" +
             text + "'";
    return false;
  }
  return true;
}

volatile sig_atomic_t g_signal = 0;
void onSignal(int sig) { g_signal = sig; }

/// A child of the run and how it ended.
struct Child {
  const char* name;
  pid_t pid = -1;
  bool running = false;
  int code = -1;
  double ended_at_s = -1.0;  ///< wall seconds after the sim started
};

/// build/lib/libexoid_controller_plugin.so next to this binary's build/bin.
std::string pluginPath() {
  return (std::filesystem::path(selfPath()).parent_path().parent_path() / "lib" / "libexoid_controller_plugin.so").string();
}

/// Plugin mode: wall seconds without a new progress line of the sim before the run counts as hung (the sim
/// loads MuJoCo and the plugin within ~1 s and prints a line per simulated second, at >= 1x real time).
constexpr double kSimStallS = 10.0;

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Copies the complete lines the sim appended to its log since the last call to stdout; *sim_time_s: the
/// simulated time of its latest progress line ("exo_sim: t 3.0 s ...", one per simulated second).
void echoNewLines(const std::string& path, std::streamoff* offset, double* sim_time_s) {
  std::ifstream in(path);
  if (!in) return;
  in.seekg(*offset);
  std::string line;
  while (std::getline(in, line)) {
    if (in.eof()) break;  // an incomplete last line: next time
    std::printf("%s\n", line.c_str());
    double t = 0.0;
    if (std::sscanf(line.c_str(), "exo_sim: t %lf s", &t) == 1) *sim_time_s = t;
    *offset = in.tellg();
  }
  std::fflush(stdout);
}
}  // namespace

int cmdExperiment(int argc, char** argv) {
  const std::string config = EXOID_CONFIG_DIR;
  CLI::App app{kDescription, "exoid experiment"};
  common::configureCli(app);
  std::string scenario_path, out_dir, controller_config = config + "/controller.yaml", sensors = config + "/sensors.yaml",
      model_path = config + "/exo.urdf", mjcf = config + "/exo.xml", inject_text, controller_mode = "plugin",
      plugin_lib = pluginPath(), controller_model;
  int64_t seed = 1, moves = 0, max_missing = 10;
  double watchdog_factor = 3.0, watchdog_margin = 60.0;
  bool realtime = false, no_pin = false, no_estimator = false, estimate_feedback = false;
  std::string estimator_args = kDefaultEstimatorArgs;
  app.add_option("--scenario", scenario_path, "sim scenario (config/scenarios/*.yaml): noise, undeclared effects")
      ->required()->type_name("FILE");
  app.add_option("--out", out_dir, "output directory (created; must be a directory we can write)")->required()->type_name("DIR");
  app.add_option("--controller-config", controller_config, "controller configuration")->type_name("FILE");
  app.add_option("--sensors", sensors, "sensor noise configuration")->type_name("FILE");
  app.add_option("--model", model_path,
                 "the robot's URDF: the summary's model (model CoM, EoM residual), and the\n"
                 "controller's unless --controller-model")->type_name("URDF");
  app.add_option("--controller-model", controller_model,
                 "the URDF the controller runs on (both shapes; default --model), e.g. a wrong\n"
                 "prior from exoid model perturb; same joints as --model")->type_name("URDF");
  app.add_option("--mjcf", mjcf, "simulated robot")->type_name("FILE");
  // exo_controller's own limits (controller/run_options.hpp): exoid refuses what the controller would, before
  // anything starts (a refused controller left the sim running open loop for minutes).
  app.add_option("--seed", seed,
                 "CoM move sequence seed (use different seeds for training and validation runs)")
      ->transform(common::strictInteger(controller::kMinSeed, controller::kMaxSeed))->type_name("N");
  app.add_option("--moves", moves, "number of CoM moves (0: the controller configuration's, 20)")
      ->transform(common::strictInteger(0, controller::kMaxMoves))->type_name("N");
  app.add_option("--controller", controller_mode,
                 "plugin: the balance controller runs inside exo_sim's loop as\n"
                 "build/lib/libexoid_controller_plugin.so (docs/plugin.md), no controller process;\n"
                 "process: exo_controller as its own process over LCM. Same commands tick by tick")
      ->check(CLI::IsMember({"plugin", "process"}))->type_name("plugin|process");
  app.add_option("--controller-plugin", plugin_lib, "plugin mode: the controller plugin library")->type_name("LIB");
  app.add_flag("--realtime", realtime,
               "run the sim at wall-clock 1 kHz instead of lockstep (exo_sim --rt-priority 50:\n"
               "SCHED_FIFO and locked memory where allowed)");
  app.add_flag("--no-pin", no_pin,
               "do not pin processes to CPUs (by default, in lockstep on 2+ CPUs, sim and\n"
               "controller share the first allowed CPU; the logger is never pinned)");
  app.add_option("--max-missing-commands", max_missing,
                 "the sim ends the run when N consecutive commands are missing (1 s at its\n"
                 "100 ms command timeout; exo_sim --help)")
      ->transform(common::strictInteger(0, 1000000))->type_name("N");
  app.add_option("--watchdog-factor", watchdog_factor,
                 "watchdog: the run is stopped as failed after F x the planned simulated time\n"
                 "plus --watchdog-margin-s of wall time (a 20-move run, 62.2 s simulated, gets\n"
                 "247 s; lockstep normally takes a fifth of the simulated time)")
      ->transform(common::strictNumber(1e-6, 1e6))->type_name("F");
  app.add_option("--watchdog-margin-s", watchdog_margin, "watchdog margin, seconds")
      ->transform(common::strictNumber(0.0, 1e7))->type_name("S");
  app.add_flag("--no-estimator", no_estimator,
               "do not run exo_estimator (by default it runs beside the loop, reading the\n"
               "sensors and publishing EXO_ESTIMATE; the summary compares it with a batch fit)");
  app.add_flag("--estimate-feedback", estimate_feedback,
               "let the controller use EXO_ESTIMATE while it is valid (feedforward in its dynamics,\n"
               "the estimate's CoM in its momentum task; docs/controller.md). Off by default:\n"
               "it pays where the controller's model is wrong (a +-25 % prior: joint-torque prediction\n"
               "error 6.4x lower, true-CoM error 12x; undeclared payloads: true-CoM error 2.5-8.9x lower in\n"
               "8 of 8), while on an exact model the estimate's noise costs a little (nominal: true-CoM\n"
               "RMSE 2.75 vs 0.37 mm; docs/estimator.md, \"Closing the loop\")");
  app.add_option("--estimator-args", estimator_args,
                 "options for exo_estimator, separated by spaces (see exo_estimator --help); they replace\n"
                 "the experiment's defaults, \"--forgetting none\". --effects FILE (a\n"
                 "diagnose sidecar) is checked before the run and applied by the summary's replay too")
      ->type_name("\"ARGS\"");
  app.add_option("--inject", inject_text,
                 "testing only; SPEC = ACTION,PROCESS,SECONDS written ACTION:PROCESS:SECONDS:\n"
                 "once the sim reports SECONDS simulated (its progress lines, 1 s apart), send\n"
                 "PROCESS (sim, controller, logger or estimator) SIGKILL (ACTION kill) or SIGSTOP\n"
                 "(ACTION stop: it hangs), or SIGKILL the estimator and start it again (restart:\n"
                 "it resumes from its checkpoint), e.g. --inject kill:controller:2 (controller\n"
                 "only with --controller process)")
      ->type_name("SPEC");
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  const std::pair<const char*, const std::string*> files[] = {{"scenario", &scenario_path},
                                                              {"controller-config", &controller_config},
                                                              {"sensors", &sensors},
                                                              {"model", &model_path},
                                                              {"controller-model", &controller_model},
                                                              {"mjcf", &mjcf}};
  if (controller_model.empty()) controller_model = model_path;
  for (const auto& [name, file] : files)
    if (std::error_code ec; !std::filesystem::is_regular_file(*file, ec))  // the throwing overload aborted on odd paths
      return fail("--" + std::string(name) + ": no such file '" + *file + "'" + (ec ? " (" + ec.message() + ")" : ""));
  Injection inject;
  if (!inject_text.empty() && !parseInjection(inject_text, &inject, &err)) return fail(err);
  const bool use_plugin = controller_mode == "plugin";
  if (std::error_code ec; use_plugin && !std::filesystem::is_regular_file(plugin_lib, ec))
    return fail("--controller-plugin: no such file '" + plugin_lib + "'" + (ec ? " (" + ec.message() + ")" : ""));
  if (use_plugin && inject.process == "controller")
    return fail("--inject: there is no controller process with --controller plugin");
  if (no_estimator && estimate_feedback) return fail("--estimate-feedback needs the estimator (not --no-estimator)");
  if (no_estimator && inject.process == "estimator") return fail("--inject: there is no estimator with --no-estimator");
  controller::ControllerConfig cc;
  if (!controller::loadControllerConfig(controller_config, cc, &err)) return fail(err);
  if (moves == 0) moves = cc.trajectory.moves;
  cc.trajectory.moves = static_cast<int>(moves);
  // The sim runs exactly as long as the controller plans to (start-up latch, moves, holds): a sim that
  // outlives the controller would apply zero torque at the end.
  const double duration = controller::plannedRunDuration(cc);
  const bool lockstep = !realtime;

  Model model;
  Model ctrl_model;
  if (!buildModelFromUrdfFile(model_path, true, model, &err) ||
      !buildModelFromUrdfFile(controller_model, true, ctrl_model, &err))
    return fail(err);
  if (ctrl_model.joint_names != model.joint_names || ctrl_model.body_names != model.body_names)
    return fail("--controller-model " + controller_model + ": other links or joints than --model " + model_path);
  {  // What exo_controller checks at start-up (configuration against the model, move sequence), here.
    controller::BalanceController probe(ctrl_model, cc, static_cast<uint64_t>(seed));
    if (!probe.ok()) return fail(controller_config + ": " + probe.error());
  }
  // exo_estimator's arguments. A diagnose sidecar (--effects FILE) is read here too, with the estimator's model:
  // a bad one stops the experiment before any process starts, its path is made absolute for the estimator, and
  // the summary's replay applies it like the process does (online held-out RMSE with and without it).
  std::vector<std::string> est_words;
  estimator::OnlineEstimatorOptions replay_options;
  {
    std::istringstream words(estimator_args);
    for (std::string w; words >> w;) est_words.push_back(w);
    for (size_t i = 0; i < est_words.size(); ++i) {
      std::string* value = nullptr;
      std::string name = est_words[i], inline_value;
      if (const size_t eq = name.find('='); name.rfind("--", 0) == 0 && eq != std::string::npos)
        inline_value = name.substr(eq + 1), name = name.substr(0, eq);
      if (name != "--effects" && name != "--effect-prior-factor") continue;
      if (!inline_value.empty()) {  // --name=VALUE: split, so the value can be rewritten
        est_words[i] = name;
        est_words.insert(est_words.begin() + static_cast<std::ptrdiff_t>(i + 1), inline_value);
      }
      if (i + 1 >= est_words.size()) return fail("--estimator-args: " + name + " needs a value");
      value = &est_words[++i];
      if (name == "--effects") {
        *value = std::filesystem::absolute(*value).string();
        if (!estimator::readEffects(*value, ctrl_model, replay_options.effects, &err))
          return fail("--estimator-args --effects " + err);
      } else if (!common::parseDouble(*value, replay_options.effect_prior_factor)) {
        return fail("--estimator-args --effect-prior-factor: not a number '" + *value + "'");
      }
    }
    if (!replay_options.effects.effects.empty()) {  // what exo_estimator refuses (a delay), refused before the run
      const estimator::OnlineEstimator probe(ctrl_model, computeBaseParameters(ctrl_model), ctrl_model.phi, replay_options);
      if (!probe.ok()) return fail("--estimator-args: " + probe.error());
    }
  }
  double payload_attach_s = -1.0, payload_mass_kg = 0.0;  // a mid-run payload (the summary's mass response)
  {  // Validate the sim's inputs here too, before any process starts, so that errors name the file and key.
    sim::SensorConfig realistic, noise;
    sim::Scenario scenario;
    sim::SimModel probe;
    if (!sim::loadSensorConfig(sensors, &realistic, &err) || !sim::loadScenario(scenario_path, &scenario, &err) ||
        !sim::resolveSensorConfig(scenario, realistic, &noise, &err) || !sim::simLoad(mjcf, noise, scenario, probe, &err))
      return fail(err);
    if (scenario.harness.enabled)  // the balance controller needs the feet on the plates
      return fail(scenario_path + ": harness: a calibration set-up (the pelvis held, the feet free); run it with "
                  "`exoid calibrate`");
    for (const sim::Payload& p : scenario.effects.payloads)
      if (p.attach_at_s > 0.0) payload_attach_s = p.attach_at_s, payload_mass_kg = p.mass;
  }
  const std::filesystem::path out = out_dir;
  if (!prepareOutDir(out, &err)) return fail(err);
  if (!std::getenv(kNetnsEnv)) return reexecInPrivateNetns(argc, argv);
  // Inside the namespace: loopback up, multicast routed to it; nothing can leave this namespace.
  if (std::system("ip link set lo up") != 0 || std::system("ip route add 224.0.0.0/4 dev lo") != 0)
    return fail("cannot configure the private network namespace (ip link/route failed; is iproute2 installed?)");

  const std::string log_path = (out / "run.lcmlog").string(), sim_log = (out / "sim.log").string();
  const std::string sim_result = (out / "sim_result.json").string();
  std::error_code ec;
  // A new run never resumes the previous run's estimator checkpoint.
  for (const char* f : {"run.lcmlog", "logger.log", "controller.log", "sim.log", "sim_result.json", "summary.json", "summary.md",
                        "estimator.log", "estimator.ckpt", "estimator.ckpt.tmp", "online_estimate.csv"})
    std::filesystem::remove(out / f, ec);
  const std::string url = channels::kDefaultUrl;
  const std::string bin = std::filesystem::path(selfPath()).parent_path().string();
  ::setenv("LCM_DEFAULT_URL", url.c_str(), 1);
  // Lockstep sim and controller take turns, so they share one CPU (cheap hand-overs: 6x real time against
  // 4.5x unpinned on 2 cores); the logger stays free to use every CPU.
  const std::vector<int> cpus = tools::allowedCpus();
  const int loop_cpu = (!no_pin && cpus.size() >= 2 && lockstep) ? cpus.front() : -1;
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);

  // exoid_logger, not Debian's lcm-logger: the latter drops bursts in LCM's user-space receive ring at the
  // lockstep rate (~30k messages/s) although the kernel delivers every datagram (docs/lcm.md).
  Child logger{"exoid_logger"}, ctrl{"exo_controller"}, sim{"exo_sim"}, est{"exo_estimator"};
  logger.pid = tools::spawn({bin + "/exoid_logger", "--lcm-url", url, "--force", "--out", log_path},
                            (out / "logger.log").string(), &err);
  if (logger.pid < 0) return fail(err);
  logger.running = true;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  if (!use_plugin) {
    std::vector<std::string> ctrl_args = {bin + "/exo_controller", "--model", controller_model, "--config",
                                          controller_config, "--seed", std::to_string(seed), "--moves",
                                          std::to_string(moves), "--lcm-url", url};
    if (!estimate_feedback) ctrl_args.push_back("--no-estimate");
    ctrl.pid = tools::spawn(ctrl_args,
                            (out / "controller.log").string(), &err, loop_cpu);
    if (ctrl.pid < 0) return tools::stop(logger.pid, SIGINT, 2000), fail(err);
    ctrl.running = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  // The estimator with its defaults (the summary replays the same OnlineEstimatorOptions), free on any CPU: the
  // lockstep loop never waits for it. Its checkpoint every 0.5 s of wall time (~1 s simulated at lockstep speed).
  const std::string est_ckpt = (out / "estimator.ckpt").string(), est_final = (out / "online_estimate.csv").string();
  // The estimator's prior and tau_correction reference is the controller's model (the correction is to that model).
  std::vector<std::string> est_args = {bin + "/exo_estimator", "--model", controller_model, "--lcm-url", url,
                                       "--checkpoint", est_ckpt, "--checkpoint-every-s", "0.5",
                                       "--final", est_final};
  est_args.insert(est_args.end(), est_words.begin(), est_words.end());
  std::string est_log_text;  // output of an estimator that was restarted (its log is rewritten by the new one)
  if (!no_estimator) {
    est.pid = tools::spawn(est_args, (out / "estimator.log").string(), &err);
    if (est.pid < 0) {
      if (ctrl.running) tools::stop(ctrl.pid, SIGTERM, 2000);
      tools::stop(logger.pid, SIGINT, 2000);
      return fail(err);
    }
    est.running = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  char dur[32];
  std::snprintf(dur, sizeof dur, "%.3f", duration);
  const double watchdog_s = duration * watchdog_factor + watchdog_margin;
  std::printf("exoid experiment: %ld CoM moves, %.1f s simulated, scenario %s, controller %s -> %s (watchdog %.0f s)\n",
              static_cast<long>(moves), duration, scenario_path.c_str(), controller_mode.c_str(), out.c_str(), watchdog_s);
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> sim_args = {bin + "/exo_sim", "--model", mjcf, "--sensors", sensors, "--scenario",
                                       scenario_path, "--mode", lockstep ? "lockstep" : "realtime", "--duration", dur,
                                       "--max-missing-commands", std::to_string(max_missing), "--result", sim_result,
                                       "--lcm-url", url};
  if (!lockstep) sim_args.insert(sim_args.end(), {"--rt-priority", "50"});  // SCHED_FIFO where allowed
  if (use_plugin)  // the controller inside the sim's loop, given what exo_controller would get
    sim_args.insert(sim_args.end(), {"--controller-plugin", plugin_lib, "--controller-model", controller_model,
                                     "--controller-config", controller_config, "--controller-seed", std::to_string(seed),
                                     "--controller-moves", std::to_string(moves)});
  if (use_plugin && !estimate_feedback) sim_args.push_back("--no-estimate");  // the loop need not receive at all
  sim.pid = tools::spawn(sim_args, sim_log, &err, loop_cpu);
  if (sim.pid < 0) {
    if (ctrl.running) tools::stop(ctrl.pid, SIGTERM, 2000);
    if (est.running) tools::stop(est.pid, SIGTERM, 2000);
    tools::stop(logger.pid, SIGINT, 2000);
    return fail(err);
  }
  sim.running = true;

  // Supervise: the first of {sim done, a process ended early, watchdog, signal} ends the run.
  tools::RunFacts facts;
  auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  // True once a child that was started has ended (a child never started, pid -1, never "ends").
  auto reap = [&](Child& c) {
    if (c.running && tools::waitFor(c.pid, 0, &c.code)) c.running = false, c.ended_at_s = since();
    return c.pid > 0 && !c.running;
  };
  std::streamoff echoed = 0;
  double sim_time = 0.0, progress_sim_time = 0.0, progress_at_s = 0.0;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    echoNewLines(sim_log, &echoed, &sim_time);
    if (sim_time != progress_sim_time) progress_sim_time = sim_time, progress_at_s = since();
    if (inject.at_s >= 0.0 && !inject.done && sim_time >= inject.at_s) {
      Child& target = inject.process == "sim" ? sim : inject.process == "controller" ? ctrl
                      : inject.process == "estimator" ? est : logger;
      if (target.pid > 0) ::kill(target.pid, inject.action == "stop" ? SIGSTOP : SIGKILL);  // never kill(-1, ...)
      if (inject.action == "restart" && target.pid > 0) {
        // Reap the killed estimator, keep what it wrote, start it again: it resumes from its checkpoint.
        tools::waitFor(target.pid, 5000, &target.code);
        est_log_text += slurp((out / "estimator.log").string()) + "(killed by --inject restart)\n";
        target.pid = tools::spawn(est_args, (out / "estimator.log").string(), &err);
        target.running = target.pid > 0;
        if (!target.running) facts.failures.push_back("exo_estimator could not be restarted: " + err);
      }
      inject.done = true;
    }
    if (reap(sim)) break;
    if (g_signal) {
      facts.interrupted = true;
      char buf[80];
      std::snprintf(buf, sizeof buf, "interrupted by %s at %.1f s", g_signal == SIGINT ? "SIGINT" : "SIGTERM", since());
      facts.failures.push_back(buf);
      break;
    }
    if (since() > watchdog_s) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "watchdog: the run was still going after %.1f s (limit %.0f x %.1f s + %.0f s)",
                    since(), watchdog_factor, duration, watchdog_margin);
      facts.failures.push_back(buf);
      break;
    }
    if (reap(est)) {
      char buf[240];
      std::snprintf(buf, sizeof buf, "exo_estimator %s at %.1f s, before the run was over (see %s)",
                    tools::describeExit(est.code).c_str(), est.ended_at_s, (out / "estimator.log").c_str());
      facts.failures.push_back(buf);
      break;
    }
    if (reap(logger)) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "exoid_logger %s at %.1f s: the log ends there (see %s)",
                    tools::describeExit(logger.code).c_str(), logger.ended_at_s, (out / "logger.log").c_str());
      facts.failures.push_back(buf);
      break;
    }
    // With the controller in the sim there is no controller process whose idle timeout notices a hung sim:
    // the sim's own progress lines (one per simulated second, or per wall second in realtime) stand in.
    if (use_plugin && since() > progress_at_s + kSimStallS) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "exo_sim stopped publishing: no progress for %.0f s (last at %.0f s simulated)",
                    kSimStallS, sim_time);
      facts.failures.push_back(buf);
      break;
    }
    if (!use_plugin && reap(ctrl) && (ctrl.code != 0 || since() > ctrl.ended_at_s + 10.0)) {
      char buf[240];
      if (ctrl.code != 0)
        std::snprintf(buf, sizeof buf, "exo_controller %s at %.1f s, before the run was over%s (see %s)",
                      tools::describeExit(ctrl.code).c_str(), ctrl.ended_at_s,
                      ctrl.code == 3 ? ": no robot state for its idle timeout, exo_sim stopped publishing" : "",
                      (out / "controller.log").c_str());
      else
        std::snprintf(buf, sizeof buf, "exo_sim did not finish within 10 s of exo_controller completing its moves");
      facts.failures.push_back(buf);
      break;
    }
  }
  const double wall = since();

  // Stop whatever still runs: sim and controller first, the logger last (it drains what was sent).
  const bool sim_finished = !sim.running;
  if (sim.running) sim.code = tools::stop(sim.pid, SIGTERM, 3000), sim.running = false;
  if (ctrl.running) {
    if (!(sim_finished && sim.code == 0 && tools::waitFor(ctrl.pid, 5000, &ctrl.code)))
      ctrl.code = tools::stop(ctrl.pid, SIGTERM, 2000);
    ctrl.running = false;
    if (sim_finished && sim.code == 0 && ctrl.code != 0)
      facts.failures.push_back("exo_controller " + tools::describeExit(ctrl.code) + " at the end of the run (see " +
                               (out / "controller.log").string() + ")");
  }
  if (logger.running || est.running)
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let the logger and the estimator drain their sockets
  if (est.running) {  // SIGTERM: it writes its checkpoint and final estimate, exit 0
    est.code = tools::stop(est.pid, SIGTERM, 5000);
    est.running = false;
    if (est.code != 0)
      facts.failures.push_back("exo_estimator " + tools::describeExit(est.code) + " when stopped (see " +
                               (out / "estimator.log").string() + ")");
  }
  if (!est_log_text.empty()) {  // the killed estimator's output first, then its successor's
    const std::string successor = slurp((out / "estimator.log").string());
    std::ofstream((out / "estimator.log").string()) << est_log_text << successor;
  }
  if (logger.running) {
    logger.code = tools::stop(logger.pid, SIGINT, 5000);
    logger.running = false;
    if (logger.code != 0)
      facts.failures.push_back("exoid_logger " + tools::describeExit(logger.code) + " when stopped (see " +
                               (out / "logger.log").string() + ")");
  }
  echoNewLines(sim_log, &echoed, &sim_time);

  // The sim's own report: outcome, fall tick, fallbacks, real-time factor (independent of the log).
  sim::RunSummary sr;
  if (sim::parseRunSummaryJson(slurp(sim_result), &sr, &err)) {
    facts.sim_reported = true;
    facts.sim_outcome = sim::outcomeName(sr.outcome);
    facts.sim_ticks = sr.ticks;
    facts.sim_fall_tick = sr.fall_tick;
    facts.sim_held_ticks = sr.held_ticks;
    facts.sim_zero_ticks = sr.zero_ticks;
    facts.sim_timeouts = sr.timeouts;
    facts.sim_realtime_factor = sr.realtime_factor;
    facts.sim_wall_s = sr.wall_time_s;
    if (sr.outcome == sim::RunOutcome::ControllerLost)
      facts.failures.push_back("exo_controller stopped answering: exo_sim ended the run after " +
                               std::to_string(sr.missing_commands) + " consecutive missing commands (last command for tick " +
                               std::to_string(sr.last_fresh_tick) + ")");
    else if (sr.outcome == sim::RunOutcome::LcmFailure)
      facts.failures.push_back("exo_sim: LCM failure (see " + sim_log + ")");
    else if (sr.outcome == sim::RunOutcome::Interrupted && sim_finished)
      facts.failures.push_back("exo_sim was interrupted (see " + sim_log + ")");
  } else if (sim_finished) {
    facts.failures.push_back("exo_sim " + tools::describeExit(sim.code) + " without a result (see " + sim_log + ")");
  }

  facts.moves_planned = static_cast<int>(moves);
  facts.ticks_planned = std::llround(duration * 1000.0);
  facts.lockstep = lockstep;
  facts.controller_phi = ctrl_model.phi;
  facts.payload_attach_s = payload_attach_s;
  facts.payload_mass_kg = payload_mass_kg;
  intake::RunLog log;
  facts.log_readable = intake::readRunLog(log_path, model.joint_names, log, &facts.log_error);
  const tools::ExperimentSummary s = tools::summarizeExperiment(model, log, facts);
  // Online vs batch on this run's log (the estimator's default options plus the --effects sidecar if given, the
  // controller's model as prior).
  tools::OnlineVsBatch ovb;
  if (!no_estimator && facts.log_readable)
    ovb = tools::compareOnlineBatch(model, log, ctrl_model.phi, replay_options, 10, est_final);
  std::string table = tools::summaryTable(s);
  const size_t rows_end = table.rfind("|\n");  // the table's last row (failure lines follow it)
  table.insert(rows_end == std::string::npos ? table.size() : rows_end + 2, tools::onlineVsBatchTable(!no_estimator, ovb));
  std::printf("\n%s\n", table.c_str());
  for (const auto& [file, text] : {std::pair<std::string, std::string>{"summary.json", tools::summaryJsonWithEstimator(tools::summaryJson(s), !no_estimator, ovb)},
                                   {"summary.md", "# Experiment " + scenario_path + " (seed " + std::to_string(seed) +
                                                      ")\n\n" + table}}) {
    std::ofstream f(out / file);
    if (!(f << text) || (f.close(), f.fail())) {
      std::fprintf(stderr, "exoid experiment: error: cannot write '%s'\n", (out / file).c_str());
      return kExitFailed;
    }
  }
  std::printf("written: %s, %s, %s (%.1f s wall)\n", log_path.c_str(), (out / "summary.json").c_str(),
              (out / "summary.md").c_str(), wall);
  if (s.outcome == "interrupted") return kExitInterrupted;
  if (s.outcome == "failed") {
    for (const std::string& f : s.failures) std::fprintf(stderr, "exoid experiment: run failed: %s\n", f.c_str());
    return kExitFailed;
  }
  return s.outcome == "fell" ? kExitFell : kExitOk;
}

}  // namespace exoid::cli
