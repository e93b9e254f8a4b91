// runExperiment: the processes of a closed-loop run started, supervised and stopped (docs/architecture.md,
// "exoid experiment"); the private network namespace it runs in; reportExperiment: its summary.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/sim/runner.hpp"
#include "exoid/tools/experiment_run.hpp"
#include "exoid/tools/online_vs_batch.hpp"
#include "exoid/tools/process.hpp"

namespace exoid::tools {
namespace {

constexpr char kNetnsEnv[] = "EXOID_IN_PRIVATE_NETNS";

/// Plugin mode: wall seconds without a new progress line of the sim before the run counts as hung (the sim
/// loads MuJoCo and the plugin within ~1 s and prints a line per simulated second, at >= 1x real time).
constexpr double kSimStallS = 10.0;

/// Lockstep with the estimate fed back: the longest wait for an estimate (exo_sim --estimate-timeout-ms,
/// exo_controller --wait-estimate-ms). 80 ms timed out on this 2-core machine at load 7-9 (the estimator
/// descheduled or finishing its consistent solve); a timeout only ends the waiting (the run is then no longer
/// reproducible, and says so), so a long bound costs nothing unless the estimator died.
constexpr int kEstimateWaitMs = 2000;

std::string selfPath() { return common::selfExecutablePath("exoid"); }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Realtime: the loop's SCHED_FIFO priority (exo_sim --rt-priority; exo_controller in process mode).
constexpr int kLoopPriority = 50;

/// A child of the run and how it ended.
struct Child {
  const char* name;
  pid_t pid = -1;
  bool running = false;
  int code = -1;
  double ended_at_s = -1.0;  ///< wall seconds after the sim started
};

/// One run in progress: its children, their arguments and files, what the supervisor has seen.
struct Run {
  const ExperimentPlan& plan;
  std::filesystem::path out;
  std::string url = channels::kDefaultUrl, bin, log_path, sim_log, sim_result, est_log;
  Placement loop, ctrl_place, beside, logger_place;  ///< the sim's, the controller process's, the estimator's, the logger's
  Child logger{"exoid_logger"}, ctrl{"exo_controller"}, sim{"exo_sim"}, est{"exo_estimator"};
  std::vector<std::string> est_args;
  std::string est_log_text;  ///< output of an estimator that was restarted (its log is rewritten by the new one)
  bool inject_done = false;
  std::chrono::steady_clock::time_point t0;
  std::streamoff echoed = 0;
  double sim_time = 0.0;  ///< simulated time of the sim's latest progress line

  explicit Run(const ExperimentPlan& p)
      : plan(p),
        out(p.options.out_dir),
        bin(std::filesystem::path(selfPath()).parent_path().string()),
        log_path((out / "run.lcmlog").string()),
        sim_log((out / "sim.log").string()),
        sim_result((out / "sim_result.json").string()),
        est_log((out / "estimator.log").string()) {}
  double since() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }
  /// True once a child that was started has ended (a child never started, pid -1, never "ends").
  bool reap(Child& c) {
    if (c.running && waitFor(c.pid, 0, &c.code)) c.running = false, c.ended_at_s = since();
    return c.pid > 0 && !c.running;
  }
};

/// Copies the complete lines the sim appended to its log since the last call to stdout; run.sim_time: the
/// simulated time of its latest progress line ("exo_sim: t 3.0 s ...", one per simulated second).
void echoNewLines(Run& run) {
  std::ifstream in(run.sim_log);
  if (!in) return;
  in.seekg(run.echoed);
  std::string line;
  while (std::getline(in, line)) {
    if (in.eof()) break;  // an incomplete last line: next time
    std::printf("%s\n", line.c_str());
    double t = 0.0;
    if (std::sscanf(line.c_str(), "exo_sim: t %lf s", &t) == 1) run.sim_time = t;
    run.echoed = in.tellg();
  }
  std::fflush(stdout);
}

/// exoid_logger, then exo_controller (process mode), then exo_estimator (unless --no-estimator), 300 ms apart.
bool startListeners(Run& run, std::string* error) {
  const ExperimentOptions& o = run.plan.options;
  // exoid_logger, not Debian's lcm-logger: the latter drops bursts in LCM's user-space receive ring at the
  // lockstep rate (~30k messages/s) although the kernel delivers every datagram (docs/lcm.md).
  run.logger.pid = spawn({run.bin + "/exoid_logger", "--lcm-url", run.url, "--force", "--out", run.log_path},
                         (run.out / "logger.log").string(), error, run.logger_place);
  if (run.logger.pid < 0) return false;
  run.logger.running = true;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  if (!run.plan.use_plugin) {
    std::vector<std::string> args = {run.bin + "/exo_controller", "--model", o.controller_model, "--config",
                                     o.controller_config, "--seed", std::to_string(o.seed), "--moves",
                                     std::to_string(o.moves), "--lcm-url", run.url};
    if (!o.estimate_feedback) args.push_back("--no-estimate");
    // Lockstep with the estimate fed back: each state's estimate waited for (reproducible runs), at most
    // kEstimateWaitMs; the sim's command timeout is raised above it (startSim).
    if (o.estimate_feedback && run.plan.lockstep)
      args.insert(args.end(), {"--wait-estimate-ms", std::to_string(kEstimateWaitMs)});
    run.ctrl.pid = spawn(args, (run.out / "controller.log").string(), error, run.ctrl_place);
    if (run.ctrl.pid < 0) return stop(run.logger.pid, SIGINT, 2000), false;
    run.ctrl.running = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  // The estimator with its defaults (the summary replays the same OnlineEstimatorOptions), free on any CPU: the
  // lockstep loop waits for it only when its estimate is fed back (its estimates then arrive 31+ ticks early). Its checkpoint every 0.5 s of wall time (~1 s simulated at lockstep speed).
  // The estimator's prior and tau_correction reference is the controller's model (the correction is to that model).
  run.est_args = {run.bin + "/exo_estimator", "--model", o.controller_model, "--lcm-url", run.url,
                  "--checkpoint", (run.out / "estimator.ckpt").string(), "--checkpoint-every-s", "0.5",
                  "--final", (run.out / "online_estimate.csv").string()};
  run.est_args.insert(run.est_args.end(), run.plan.estimator_words.begin(), run.plan.estimator_words.end());
  if (o.no_estimator) return true;
  run.est.pid = spawn(run.est_args, run.est_log, error, run.beside);
  if (run.est.pid < 0) {
    if (run.ctrl.running) stop(run.ctrl.pid, SIGTERM, 2000);
    stop(run.logger.pid, SIGINT, 2000);
    return false;
  }
  run.est.running = true;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  return true;
}

/// The sim, last (lockstep: it drives the loop), with the controller plugin in its loop in plugin mode.
bool startSim(Run& run, std::string* error) {
  const ExperimentOptions& o = run.plan.options;
  char dur[32];
  std::snprintf(dur, sizeof dur, "%.3f", run.plan.duration_s);
  std::vector<std::string> args = {run.bin + "/exo_sim", "--model", o.mjcf, "--sensors", o.sensors, "--scenario",
                                   o.scenario, "--mode", run.plan.lockstep ? "lockstep" : "realtime", "--duration", dur,
                                   "--max-missing-commands", std::to_string(o.max_missing), "--result", run.sim_result,
                                   "--lcm-url", run.url};
  if (!run.plan.lockstep) args.insert(args.end(), {"--rt-priority", std::to_string(kLoopPriority)});
  if (run.plan.use_plugin)  // the controller inside the sim's loop, given what exo_controller would get
    args.insert(args.end(), {"--controller-plugin", o.plugin_lib, "--controller-model", o.controller_model,
                             "--controller-config", o.controller_config, "--controller-seed", std::to_string(o.seed),
                             "--controller-moves", std::to_string(o.moves)});
  if (run.plan.use_plugin && !o.estimate_feedback) args.push_back("--no-estimate");  // the loop need not receive at all
  if (o.estimate_feedback && run.plan.lockstep) {
    if (run.plan.use_plugin)  // the plugin's estimates waited for (exo_sim's own --estimate-timeout-ms)
      args.insert(args.end(), {"--estimate-lag-ticks", std::to_string(run.plan.estimate_lag_ticks),
                               "--estimate-timeout-ms", std::to_string(kEstimateWaitMs)});
    else  // exo_controller's answer may wait for the estimate: the sim waits longer than that for it
      args.insert(args.end(), {"--command-timeout-ms", std::to_string(kEstimateWaitMs + 1000)});
  }
  if (o.view) args.push_back("--view");  // without a display exo_sim says so in one line (shown with its output)
  run.sim.pid = spawn(args, run.sim_log, error, run.loop);
  if (run.sim.pid < 0) {
    if (run.ctrl.running) stop(run.ctrl.pid, SIGTERM, 2000);
    if (run.est.running) stop(run.est.pid, SIGTERM, 2000);
    stop(run.logger.pid, SIGINT, 2000);
    return false;
  }
  run.sim.running = true;
  return true;
}

/// --inject: once the sim reports its time, SIGKILL or SIGSTOP the process, or restart the estimator.
void injectFault(Run& run, RunFacts& facts) {
  const Injection& inject = run.plan.inject;
  if (!(inject.at_s >= 0.0 && !run.inject_done && run.sim_time >= inject.at_s)) return;
  Child& target = inject.process == "sim" ? run.sim : inject.process == "controller" ? run.ctrl
                  : inject.process == "estimator" ? run.est : run.logger;
  if (target.pid > 0) ::kill(target.pid, inject.action == "stop" ? SIGSTOP : SIGKILL);  // never kill(-1, ...)
  // The sim's progress lines come once per simulated second and are polled every 20 ms: say when it really struck.
  std::printf("exoid: --inject %s:%s done at simulated %.1f s\n", inject.action.c_str(), inject.process.c_str(),
              run.sim_time);
  std::fflush(stdout);
  if (inject.action == "restart" && target.pid > 0) {
    // Reap the killed estimator, keep what it wrote, start it again: it resumes from its checkpoint.
    waitFor(target.pid, 5000, &target.code);
    run.est_log_text += slurp(run.est_log) + "(killed by --inject restart)\n";
    std::string err;
    target.pid = spawn(run.est_args, run.est_log, &err, run.beside);
    target.running = target.pid > 0;
    if (!target.running) facts.failures.push_back("exo_estimator could not be restarted: " + err);
  }
  run.inject_done = true;
}

/// Why the run ends now (empty: it goes on; the sim done ends it with no failure): a signal, the watchdog,
/// a process that ended early, a sim that stopped making progress.
bool runEnds(Run& run, RunFacts& facts, double watchdog_s, double progress_at_s) {
  const ExperimentOptions& o = run.plan.options;
  char buf[240];
  if (run.reap(run.sim)) return true;
  if (const int sig = *common::stopFlag()) {
    facts.interrupted = true;
    std::snprintf(buf, 80, "interrupted by %s at %.1f s", sig == SIGINT ? "SIGINT" : "SIGTERM", run.since());
  } else if (run.since() > watchdog_s) {
    std::snprintf(buf, 200, "watchdog: the run was still going after %.1f s (limit %.0f x %.1f s + %.0f s)",
                  run.since(), o.watchdog_factor, run.plan.duration_s, o.watchdog_margin_s);
  } else if (run.reap(run.est)) {
    std::snprintf(buf, sizeof buf, "exo_estimator %s at %.1f s, before the run was over (see %s)",
                  describeExit(run.est.code).c_str(), run.est.ended_at_s, run.est_log.c_str());
  } else if (run.reap(run.logger)) {
    std::snprintf(buf, 200, "exoid_logger %s at %.1f s: the log ends there (see %s)",
                  describeExit(run.logger.code).c_str(), run.logger.ended_at_s, (run.out / "logger.log").c_str());
  } else if (run.plan.use_plugin && run.since() > progress_at_s + kSimStallS) {
    // With the controller in the sim there is no controller process whose idle timeout notices a hung sim:
    // the sim's own progress lines (one per simulated second, or per wall second in realtime) stand in.
    std::snprintf(buf, 200, "exo_sim stopped publishing: no progress for %.0f s (last at %.0f s simulated)",
                  kSimStallS, run.sim_time);
  } else if (!run.plan.use_plugin && run.reap(run.ctrl) && (run.ctrl.code != 0 || run.since() > run.ctrl.ended_at_s + 10.0)) {
    if (run.ctrl.code != 0)
      std::snprintf(buf, sizeof buf, "exo_controller %s at %.1f s, before the run was over%s (see %s)",
                    describeExit(run.ctrl.code).c_str(), run.ctrl.ended_at_s,
                    run.ctrl.code == 3 ? ": no robot state for its idle timeout, exo_sim stopped publishing" : "",
                    (run.out / "controller.log").c_str());
    else
      std::snprintf(buf, sizeof buf, "exo_sim did not finish within 10 s of exo_controller completing its moves");
  } else {
    return false;
  }
  facts.failures.push_back(buf);
  return true;
}

/// Supervises the run until it ends (runEnds), echoing the sim's progress, injecting the --inject fault.
void supervise(Run& run, RunFacts& facts) {
  const ExperimentOptions& o = run.plan.options;
  const double watchdog_s = run.plan.duration_s * o.watchdog_factor + o.watchdog_margin_s;
  double progress_sim_time = 0.0, progress_at_s = 0.0;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    echoNewLines(run);
    if (run.sim_time != progress_sim_time) progress_sim_time = run.sim_time, progress_at_s = run.since();
    injectFault(run, facts);
    if (runEnds(run, facts, watchdog_s, progress_at_s)) return;
  }
}

/// Stops whatever still runs: sim and controller first, the logger last (it drains what was sent). Returns whether
/// the sim had finished by itself.
bool stopChildren(Run& run, RunFacts& facts) {
  const bool sim_finished = !run.sim.running;
  if (run.sim.running) run.sim.code = stop(run.sim.pid, SIGTERM, 3000), run.sim.running = false;
  if (run.ctrl.running) {
    if (!(sim_finished && run.sim.code == 0 && waitFor(run.ctrl.pid, 5000, &run.ctrl.code)))
      run.ctrl.code = stop(run.ctrl.pid, SIGTERM, 2000);
    run.ctrl.running = false;
    if (sim_finished && run.sim.code == 0 && run.ctrl.code != 0)
      facts.failures.push_back("exo_controller " + describeExit(run.ctrl.code) + " at the end of the run (see " +
                               (run.out / "controller.log").string() + ")");
  }
  if (run.logger.running || run.est.running)
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let the logger and the estimator drain their sockets
  if (run.est.running) {  // SIGTERM: it writes its checkpoint and final estimate, exit 0
    run.est.code = stop(run.est.pid, SIGTERM, 5000);
    run.est.running = false;
    if (run.est.code != 0)
      facts.failures.push_back("exo_estimator " + describeExit(run.est.code) + " when stopped (see " + run.est_log + ")");
  }
  if (!run.est_log_text.empty()) {  // the killed estimator's output first, then its successor's
    const std::string successor = slurp(run.est_log);
    std::ofstream(run.est_log) << run.est_log_text << successor;
  }
  if (run.logger.running) {
    run.logger.code = stop(run.logger.pid, SIGINT, 5000);
    run.logger.running = false;
    if (run.logger.code != 0)
      facts.failures.push_back("exoid_logger " + describeExit(run.logger.code) + " when stopped (see " +
                               (run.out / "logger.log").string() + ")");
  }
  return sim_finished;
}

/// The sim's own report (outcome, fall tick, fallbacks, real-time factor; independent of the log) into facts.
void readSimReport(const Run& run, bool sim_finished, RunFacts& facts) {
  sim::RunSummary sr;
  std::string err;
  if (sim::parseRunSummaryJson(slurp(run.sim_result), &sr, &err)) {
    facts.sim_reported = true;
    facts.sim_outcome = sim::outcomeName(sr.outcome);
    facts.sim_ticks = sr.ticks;
    facts.sim_fall_tick = sr.fall_tick;
    facts.sim_held_ticks = sr.held_ticks;
    facts.sim_zero_ticks = sr.zero_ticks;
    facts.sim_timeouts = sr.timeouts;
    facts.sim_realtime_factor = sr.realtime_factor;
    facts.sim_wall_s = sr.wall_time_s;
    facts.sim_timing = sr.timing;
    if (sr.outcome == sim::RunOutcome::ControllerLost)
      facts.failures.push_back("exo_controller stopped answering: exo_sim ended the run after " +
                               std::to_string(sr.missing_commands) + " consecutive missing commands (last command for tick " +
                               std::to_string(sr.last_fresh_tick) + ")");
    else if (sr.outcome == sim::RunOutcome::LcmFailure)
      facts.failures.push_back("exo_sim: LCM failure (see " + run.sim_log + ")");
    else if (sr.outcome == sim::RunOutcome::Interrupted && sim_finished)
      facts.failures.push_back("exo_sim was interrupted (see " + run.sim_log + ")");
  } else if (sim_finished) {
    facts.failures.push_back("exo_sim " + describeExit(run.sim.code) + " without a result (see " + run.sim_log + ")");
  }
}

/// Where the run's processes go (docs/sim.md, "Loop timing"), on 2+ CPUs unless --no-pin.
/// Lockstep: sim and controller take turns, so they share the first CPU (cheap hand-overs: 6x real time against
/// 4.5x unpinned on 2 cores); the estimator and the logger are free to use every CPU.
/// Realtime: the loop (sim, controller process: woken on its CPU, they take turns within the 1 ms) alone on the last
/// CPU under SCHED_FIFO; the estimator (its reconcile worker too) and this supervisor on the others at normal
/// priority, so the estimator's heavy work (consistent solves, covariance) never runs on the loop's CPU; the logger
/// anywhere (it must keep every message: confined beside the estimator it lost some when others' work crowded
/// that CPU; at normal priority it cannot preempt the loop).
void placeProcesses(Run& run) {
  const std::vector<int> cpus = allowedCpus();
  const bool pin = !run.plan.options.no_pin && cpus.size() >= 2;
  if (run.plan.lockstep) {
    if (pin) run.loop.cpus = run.ctrl_place.cpus = {cpus.front()};
    return;
  }
  run.ctrl_place.fifo_priority = kLoopPriority;  // exo_sim sets its own (--rt-priority: mlockall too)
  if (!pin) return;
  run.loop.cpus = run.ctrl_place.cpus = {cpus.back()};
  run.beside.cpus.assign(cpus.begin(), cpus.end() - 1);
  run.logger_place.cpus = cpus;  // not inherited from this supervisor
  pinTo(run.beside.cpus);        // this supervisor: its polling and log reading stay off the loop's CPU
}

}  // namespace

bool inPrivateNetns() { return std::getenv(kNetnsEnv) != nullptr; }

void reexecInPrivateNetns(int argc, char** argv, std::string* error) {
  std::vector<std::string> args = {"unshare"};
  if (::geteuid() != 0) args.push_back("-r");
  args.insert(args.end(), {"-n", "--", selfPath()});
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  ::setenv(kNetnsEnv, "1", 1);
  std::vector<char*> c;
  for (auto& a : args) c.push_back(a.data());
  c.push_back(nullptr);
  ::execvp("unshare", c.data());
  *error = "cannot run 'unshare' (util-linux) to create a private network namespace";
}

bool configurePrivateNetns(std::string* error) {
  if (std::system("ip link set lo up") == 0 && std::system("ip route add 224.0.0.0/4 dev lo") == 0) return true;
  *error = "cannot configure the private network namespace (ip link/route failed; is iproute2 installed?)";
  return false;
}

bool runExperiment(const ExperimentPlan& plan, RunFacts* facts, double* wall_s, std::string* error) {
  const ExperimentOptions& o = plan.options;
  Run run(plan);
  std::error_code ec;
  // A new run never resumes the previous run's estimator checkpoint.
  for (const char* f : {"run.lcmlog", "logger.log", "controller.log", "sim.log", "sim_result.json", "summary.json", "summary.md",
                        "estimator.log", "estimator.ckpt", "estimator.ckpt.tmp", "online_estimate.csv"})
    std::filesystem::remove(run.out / f, ec);
  ::setenv("LCM_DEFAULT_URL", run.url.c_str(), 1);
  placeProcesses(run);
  common::installStopSignals();
  if (!startListeners(run, error)) return false;
  std::printf("exoid experiment: %ld CoM moves, %.1f s simulated, scenario %s, controller %s -> %s (watchdog %.0f s)\n",
              static_cast<long>(o.moves), plan.duration_s, o.scenario.c_str(), o.controller_mode.c_str(), run.out.c_str(),
              plan.duration_s * o.watchdog_factor + o.watchdog_margin_s);
  std::fflush(stdout);
  run.t0 = std::chrono::steady_clock::now();
  if (!startSim(run, error)) return false;
  supervise(run, *facts);
  *wall_s = run.since();
  const bool sim_finished = stopChildren(run, *facts);
  echoNewLines(run);
  readSimReport(run, sim_finished, *facts);
  facts->moves_planned = static_cast<int>(o.moves);
  facts->ticks_planned = std::llround(plan.duration_s * 1000.0);
  facts->lockstep = plan.lockstep;
  facts->estimate_feedback = plan.options.estimate_feedback;
  facts->controller_phi = plan.controller_model.phi;
  facts->payload_attach_s = plan.payload_attach_s;
  facts->payload_mass_kg = plan.payload_mass_kg;
  return true;
}

ExperimentReport reportExperiment(const ExperimentPlan& plan, RunFacts facts) {
  const ExperimentOptions& o = plan.options;
  const std::filesystem::path out = o.out_dir;
  intake::RunLog log;
  facts.log_readable = intake::readRunLog((out / "run.lcmlog").string(), plan.model.joint_names, log, &facts.log_error);
  facts.controller_frame = controllerFrame(plan.controller_model, plan.controller_config, log.states);
  ExperimentReport r;
  r.summary = summarizeExperiment(plan.model, log, facts);
  // Online vs batch on this run's log (the estimator's default options plus the --effects sidecar if given, the
  // controller's model as prior).
  OnlineVsBatch ovb;
  if (!o.no_estimator && facts.log_readable)
    ovb = compareOnlineBatch(plan.model, log, plan.controller_model.phi, plan.replay_options, 10,
                             (out / "online_estimate.csv").string());
  r.table = summaryTable(r.summary);
  const size_t rows_end = r.table.rfind("|\n");  // the table's last row (failure lines follow it)
  r.table.insert(rows_end == std::string::npos ? r.table.size() : rows_end + 2, onlineVsBatchTable(!o.no_estimator, ovb));
  r.json = summaryJsonWithEstimator(summaryJson(r.summary), !o.no_estimator, ovb);
  r.markdown = "# Experiment " + o.scenario + " (seed " + std::to_string(o.seed) + ")\n\n" + r.table;
  return r;
}

}  // namespace exoid::tools
