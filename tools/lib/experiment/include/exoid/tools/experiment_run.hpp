#pragma once
// The closed-loop experiment (`exoid experiment`, its --help): exo_sim with the balance controller (in its loop as
// a plugin, or as the exo_controller process), exo_estimator beside the loop and exoid_logger recording every
// channel, over LCM udpm:// inside a private network namespace; supervised until the sim finishes or something
// ends the run early; summarised from the log (with online-vs-batch figures when the estimator ran).
// In stages: planExperiment (every input checked before any process starts) -> the private network namespace ->
// runExperiment (start, supervise, stop, the sim's own report) -> reportExperiment (summary from the log).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "exoid/controller/config.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/model/model.hpp"
#include "exoid/tools/experiment_summary.hpp"

namespace exoid::tools {

/// What `exoid experiment` is asked to run (its options; the paths as given).
struct ExperimentOptions {
  std::string scenario, out_dir, controller_config, sensors, model, mjcf;
  std::string controller_model;        ///< empty: --model
  /// --model or --controller-model was given. Neither, on a scenario with a `wearer:`: both are the clinic's prior,
  /// the exoskeleton plus the table wearer at the scenario's typed mass, height and sex (OUT/wearer_prior.urdf,
  /// `exoid model wearer`), since the exoskeleton's URDF alone is half the system's mass.
  bool model_given = false;
  std::string controller_mode = "plugin";  ///< plugin | process
  std::string plugin_lib;
  std::string inject;                  ///< testing: ACTION:PROCESS:SECONDS (empty: none)
  /// No forgetting: the exact minimiser of the batch regularised cost, the most accurate estimate of a robot
  /// whose inertia does not change (from a +-25 % prior its feedforward cuts the joint-torque prediction error
  /// 3.6x; with stabilised forgetting lambda 0.999 2.5x); the estimator's change detection (on by default)
  /// forgets when the robot changes (a 3 kg payload mid-run: 95 % of its mass in 0.9 s). docs/estimator.md,
  /// "Change detection".
  std::string estimator_args = "--forgetting none";
  int64_t seed = 1, moves = 0, max_missing = 10;  ///< moves 0: the controller configuration's
  double watchdog_factor = 3.0, watchdog_margin_s = 60.0;
  bool realtime = false, no_pin = false, no_estimator = false;
  bool estimate_feedback = true;  ///< the controller uses the estimate (off with no_estimator)
  bool view = false;  ///< exo_sim --view: a live window where a display exists (docs/render.md)
};

/// A fault to inject (testing): `action` to `process` at `at_s` seconds simulated.
struct Injection {
  std::string action, process;
  double at_s = -1.0;
};

/// An experiment whose inputs were all checked (what each process would refuse, refused before any starts).
struct ExperimentPlan {
  ExperimentOptions options;         ///< controller_model and moves resolved
  Model model;                       ///< --model: the summary's
  Model controller_model;            ///< the controller's and the estimator's prior
  double duration_s = 0.0;           ///< the controller's planned run (start-up latch, moves, holds)
  int estimate_lag_ticks = 0;        ///< the controller configuration's estimate.lag_ticks (the lockstep wait)
  controller::ControllerConfig controller_config;  ///< as loaded (its world for the summary: controllerFrame)
  bool use_plugin = true, lockstep = true;
  Injection inject;
  std::vector<std::string> estimator_words;  ///< exo_estimator's extra arguments (--effects made absolute)
  estimator::OnlineEstimatorOptions replay_options;  ///< the summary's replay of the estimator
  double payload_attach_s = -1.0, payload_mass_kg = 0.0;  ///< a mid-run payload of the scenario (-1: none)
  std::string wearer_prior;  ///< the table prior written for a wearer scenario (ExperimentOptions::model_given); "" none
};

/// The controller's world for the summary's true-CoM figures: from cc.observer its latch tick, initial_base_xy and
/// ground_height, and the soles where it latched them (ControllerFrame::sole_xy, has_soles): its base state observer
/// (the controller's model, cc.observer, cc.loop.period, resolveObserverFrames) replayed over the logged states, in
/// tick order, until it latches. The controller ran the same observer on the same samples (lockstep and plugin:
/// every state; a state it refused would be missing here too). has_soles false when the log latches nothing.
ControllerFrame controllerFrame(const Model& controller_model, const controller::ControllerConfig& cc,
                                const std::vector<RobotStateSample>& states);

/// Checks every input and fills *plan; false with a one-line *error naming the option or file.
bool planExperiment(const ExperimentOptions& options, ExperimentPlan& plan, std::string* error);

/// DIR exists as a directory (created if needed) in which we can create files; else a one-line *error.
bool prepareOutDir(const std::filesystem::path& dir, std::string* error);

/// True inside the private network namespace this command re-executed itself into.
bool inPrivateNetns();
/// Re-executes this process (argv) inside a new network namespace (root: unshare -n; otherwise unshare -r -n).
/// Returns only on failure, with *error.
void reexecInPrivateNetns(int argc, char** argv, std::string* error);
/// Inside the namespace: loopback up, multicast routed to it (nothing can leave the namespace).
bool configurePrivateNetns(std::string* error);

/// Runs the planned experiment in options.out_dir (the previous run's outputs removed first): starts the
/// processes, echoes the sim's progress, ends the run at the first of {the sim done, a process ended early,
/// the watchdog, SIGINT/SIGTERM}, stops what still runs and reads the sim's report. *facts: what the
/// supervisor knows beyond the log; *wall_s: the run's wall time. False (*error) only when a process could not be
/// started (the ones already started are stopped).
bool runExperiment(const ExperimentPlan& plan, RunFacts* facts, double* wall_s, std::string* error);

/// The run's summary from its log (summarizeExperiment) and, when the estimator ran, online vs batch.
struct ExperimentReport {
  ExperimentSummary summary;
  std::string table;     ///< the summary as a table with the online-vs-batch rows (printed, and in summary.md)
  std::string json;      ///< summary.json
  std::string markdown;  ///< summary.md
};
ExperimentReport reportExperiment(const ExperimentPlan& plan, RunFacts facts);

}  // namespace exoid::tools
