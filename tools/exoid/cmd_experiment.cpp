// exoid experiment: sim + controller + online estimator over LCM udpm:// inside a private network namespace,
// in lockstep, logged by exoid_logger, summarised from the log (with online-vs-batch figures when the
// estimator ran). Thin: options -> tools::planExperiment / runExperiment / reportExperiment
// (tools/lib/experiment) -> summary.json, summary.md.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/common/strict_number.hpp"
#include "exoid/controller/run_options.hpp"
#include "exoid/tools/experiment_run.hpp"

namespace exoid::cli {

namespace cmd_experiment {  // this file's own names: the exoid binary is a unity build
constexpr char kDescription[] =
    "Runs the closed loop: exo_sim (MuJoCo, lockstep) with the centroidal balance QP doing the thesis's CoM\n"
    "moves, either inside the sim's loop as a plugin (default) or as the separate exo_controller process, and\n"
    "the online estimator exo_estimator (unless --no-estimator) reading the same sensor stream; every\n"
    "channel goes over LCM udpm:// with ttl=0 inside a private network namespace (unshare -n; multicast routed\n"
    "on its loopback only), recorded without loss. Writes\n"
    "  DIR/run.lcmlog       every message of every channel (lcm-logger format, recorded by exoid_logger);\n"
    "                       kept, as far as it got, when a run fails\n"
    "  DIR/summary.json     outcome, failures, moves_done, fell (tick, time, move), com_rmse_m,\n"
    "                       max_foot_slip_m, fallbacks of controller and sim, loop_timing (overruns,\n"
    "                       deadline misses, worst tick, plugin calls), realtime_factor, ticks planned /\n"
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

constexpr int kExitOk = 0, kExitFailed = 1, kExitFell = 3, kExitInterrupted = 4;  // 2: bad input (fail)

int fail(const std::string& msg) { return common::badInput("exoid experiment", msg); }

/// build/lib/libexoid_controller_plugin.so next to this binary's build/bin.
std::string pluginPath() {
  return (std::filesystem::path(common::selfExecutablePath("exoid")).parent_path().parent_path() / "lib" /
          "libexoid_controller_plugin.so")
      .string();
}

/// The run's options: files, the controller's plan and mode.
void addRunOptions(CLI::App& app, tools::ExperimentOptions& o) {
  app.add_option("--scenario", o.scenario, "sim scenario (config/scenarios/*.yaml): noise, undeclared effects")
      ->required()->type_name("FILE");
  app.add_option("--out", o.out_dir, "output directory (created; must be a directory we can write)")->required()->type_name("DIR");
  app.add_option("--controller-config", o.controller_config, "controller configuration")->type_name("FILE");
  app.add_option("--sensors", o.sensors, "sensor noise configuration")->type_name("FILE");
  app.add_option("--model", o.model,
                 "the robot's URDF: the summary's model (model CoM, EoM residual), and the\n"
                 "controller's unless --controller-model")->type_name("URDF");
  app.add_option("--controller-model", o.controller_model,
                 "the URDF the controller runs on (both shapes; default --model), e.g. a wrong\n"
                 "prior from exoid model perturb; same joints as --model. Neither this nor --model\n"
                 "given and the scenario has a wearer: both are the clinic's prior, the exoskeleton\n"
                 "plus the table wearer at the scenario's mass, height and sex (OUT/wearer_prior.urdf,\n"
                 "as `exoid model wearer` writes it)")->type_name("URDF");
  app.add_option("--mjcf", o.mjcf, "simulated robot")->type_name("FILE");
  // exo_controller's own limits (controller/run_options.hpp): exoid refuses what the controller would, before
  // anything starts (a refused controller left the sim running open loop for minutes).
  app.add_option("--seed", o.seed,
                 "CoM move sequence seed (use different seeds for training and validation runs)")
      ->transform(common::strictInteger(controller::kMinSeed, controller::kMaxSeed))->type_name("N");
  app.add_option("--moves", o.moves, "number of CoM moves (0: the controller configuration's, 20)")
      ->transform(common::strictInteger(0, controller::kMaxMoves))->type_name("N");
  app.add_option("--controller", o.controller_mode,
                 "plugin: the balance controller runs inside exo_sim's loop as\n"
                 "build/lib/libexoid_controller_plugin.so (docs/plugin.md), no controller process;\n"
                 "process: exo_controller as its own process over LCM. Same commands tick by tick")
      ->check(CLI::IsMember({"plugin", "process"}))->type_name("plugin|process");
  app.add_option("--controller-plugin", o.plugin_lib, "plugin mode: the controller plugin library")->type_name("LIB");
}

/// The supervision's, the estimator's and the testing options.
void addSupervisionOptions(CLI::App& app, tools::ExperimentOptions& o) {
  app.add_flag("--realtime", o.realtime,
               "run the sim at wall-clock 1 kHz instead of lockstep (exo_sim --rt-priority 50:\n"
               "SCHED_FIFO and locked memory where allowed; exo_controller under SCHED_FIFO 50 too)");
  app.add_flag("--view", o.view, "exo_sim --view: a live window of the run where a display exists (docs/render.md)");
  app.add_flag("--no-pin", o.no_pin,
               "do not pin processes to CPUs (by default on 2+ CPUs: in lockstep sim and\n"
               "controller share the first allowed CPU; in realtime the loop has the last one\n"
               "to itself, the estimator and this supervisor the others; the logger is never\n"
               "pinned; docs/sim.md \"Loop timing\")");
  app.add_option("--max-missing-commands", o.max_missing,
                 "the sim ends the run when N consecutive commands are missing (1 s at its\n"
                 "100 ms command timeout; exo_sim --help)")
      ->transform(common::strictInteger(0, 1000000))->type_name("N");
  app.add_option("--watchdog-factor", o.watchdog_factor,
                 "watchdog: the run is stopped as failed after F x the planned simulated time\n"
                 "plus --watchdog-margin-s of wall time (a 20-move run, 62.2 s simulated, gets\n"
                 "247 s; lockstep normally takes a fifth of the simulated time)")
      ->transform(common::strictNumber(1e-6, 1e6))->type_name("F");
  app.add_option("--watchdog-margin-s", o.watchdog_margin_s, "watchdog margin, seconds")
      ->transform(common::strictNumber(0.0, 1e7))->type_name("S");
  app.add_flag("--no-estimator", o.no_estimator,
               "do not run exo_estimator (by default it runs beside the loop, reading the\n"
               "sensors and publishing EXO_ESTIMATE; the summary compares it with a batch fit)");
  app.add_flag("--estimate-feedback,!--no-estimate-feedback", o.estimate_feedback,
               "the controller uses EXO_ESTIMATE while it is valid (on by default; off with\n"
               "--no-estimate-feedback or --no-estimator): its correction in the dynamics, its mass\n"
               "and CoM in the momentum task, each only as far as it stands out of the estimate's own\n"
               "uncertainty (controller estimate.trust_sigmas, trust_sigmas_horizontal_com;\n"
               "docs/controller.md, \"Trust\"). Nominal\n"
               "(exact model): true-CoM RMSE 0.38 vs 0.37 mm; payloads and a +-25 % prior: 3-8.5x lower;\n"
               "effects the rigid model lacks can bias it (docs/estimator.md, \"Closing the loop\"). In\n"
               "lockstep the loop waits for each estimate (applied estimate.lag_ticks after its tick):\n"
               "runs are reproducible bit for bit");
  app.add_option("--estimator-args", o.estimator_args,
                 "options for exo_estimator, separated by spaces (see exo_estimator --help); they replace\n"
                 "the experiment's defaults, \"--forgetting none\". --effects FILE (a\n"
                 "diagnose sidecar) is checked before the run and applied by the summary's replay too, and\n"
                 "so is --sole-on-plate SPEC (where the soles stand: the replay's and the batch comparison's\n"
                 "base placed alike); a scenario with a wearer adds --base-body-moves (the trunk moves on the\n"
                 "pelvis on its own)")
      ->type_name("\"ARGS\"");
  app.add_option("--inject", o.inject,
                 "testing only; SPEC = ACTION,PROCESS,SECONDS written ACTION:PROCESS:SECONDS:\n"
                 "once the sim reports SECONDS simulated (its progress lines, 1 s apart), send\n"
                 "PROCESS (sim, controller, logger or estimator) SIGKILL (ACTION kill) or SIGSTOP\n"
                 "(ACTION stop: it hangs), or SIGKILL the estimator and start it again (restart:\n"
                 "it resumes from its checkpoint), e.g. --inject kill:controller:2 (controller\n"
                 "only with --controller process); stdout says at what simulated time it struck")
      ->type_name("SPEC");
}

/// summary.json and summary.md in DIR (the table printed first); false with a message on stderr.
bool writeReport(const tools::ExperimentReport& r, const std::filesystem::path& out) {
  std::printf("\n%s\n", r.table.c_str());
  for (const auto& [file, text] : {std::pair<std::string, const std::string&>{"summary.json", r.json}, {"summary.md", r.markdown}}) {
    std::ofstream f(out / file);
    if (!(f << text) || (f.close(), f.fail())) {
      std::fprintf(stderr, "exoid experiment: error: cannot write '%s'\n", (out / file).c_str());
      return false;
    }
  }
  return true;
}
}  // namespace cmd_experiment

int cmdExperiment(int argc, char** argv) {
  using namespace cmd_experiment;
  const std::string config = EXOID_CONFIG_DIR;
  CLI::App app{kDescription, "exoid experiment"};
  common::configureCli(app);
  tools::ExperimentOptions o;
  o.controller_config = config + "/controller.yaml", o.sensors = config + "/sensors.yaml";
  o.model = config + "/exo.urdf", o.mjcf = config + "/exo.xml", o.plugin_lib = pluginPath();
  addRunOptions(app, o);
  addSupervisionOptions(app, o);
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  o.model_given = app.get_option("--model")->count() + app.get_option("--controller-model")->count() > 0;
  std::string err;
  tools::ExperimentPlan plan;
  if (!tools::planExperiment(o, plan, &err) || !tools::prepareOutDir(o.out_dir, &err)) return fail(err);
  if (!plan.wearer_prior.empty() && tools::inPrivateNetns())  // said once (the command re-runs itself in a namespace)
    std::fprintf(stderr, "exoid experiment: the scenario has a wearer: the controller's and the summary's model is the "
                         "exoskeleton plus the table wearer at the typed mass, height and sex, %s (--model or "
                         "--controller-model to choose another)\n", plan.wearer_prior.c_str());
  if (!tools::inPrivateNetns()) return tools::reexecInPrivateNetns(argc, argv, &err), fail(err);
  if (!tools::configurePrivateNetns(&err)) return fail(err);
  tools::RunFacts facts;
  double wall_s = 0.0;
  if (!tools::runExperiment(plan, &facts, &wall_s, &err)) return fail(err);
  const tools::ExperimentReport r = tools::reportExperiment(plan, facts);
  const std::filesystem::path out = o.out_dir;
  if (!writeReport(r, out)) return kExitFailed;
  std::printf("written: %s, %s, %s (%.1f s wall)\n", (out / "run.lcmlog").c_str(), (out / "summary.json").c_str(),
              (out / "summary.md").c_str(), wall_s);
  const tools::ExperimentSummary& s = r.summary;
  if (s.outcome == "interrupted") return kExitInterrupted;
  if (s.outcome == "failed") {
    for (const std::string& f : s.failures) std::fprintf(stderr, "exoid experiment: run failed: %s\n", f.c_str());
    return kExitFailed;
  }
  return s.outcome == "fell" ? kExitFell : kExitOk;
}

}  // namespace exoid::cli
