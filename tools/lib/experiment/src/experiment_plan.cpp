// planExperiment: every input of `exoid experiment` checked before any process starts, so that an error names
// the option or file (a refused controller once left the sim running open loop for minutes).
#include <algorithm>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>

#include "exoid/common/strict_number.hpp"
#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/config.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/sim/sim.hpp"
#include "exoid/tools/experiment_run.hpp"
#include "exoid/tools/wearer_urdf.hpp"

namespace exoid::tools {
namespace {

/// ACTION:PROCESS:SECONDS of --inject.
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

/// The input files exist, the injection parses and fits the run's processes, the options agree.
bool checkOptions(const ExperimentOptions& o, Injection* inject, std::string* error) {
  const std::pair<const char*, const std::string*> files[] = {
      {"scenario", &o.scenario}, {"controller-config", &o.controller_config}, {"sensors", &o.sensors},
      {"model", &o.model},       {"controller-model", &o.controller_model},   {"mjcf", &o.mjcf}};
  for (const auto& [name, file] : files)
    if (std::error_code ec; !std::filesystem::is_regular_file(*file, ec)) {  // the throwing overload aborted on odd paths
      *error = "--" + std::string(name) + ": no such file '" + *file + "'" + (ec ? " (" + ec.message() + ")" : "");
      return false;
    }
  if (!o.inject.empty() && !parseInjection(o.inject, inject, error)) return false;
  const bool use_plugin = o.controller_mode == "plugin";
  if (std::error_code ec; use_plugin && !std::filesystem::is_regular_file(o.plugin_lib, ec))
    *error = "--controller-plugin: no such file '" + o.plugin_lib + "'" + (ec ? " (" + ec.message() + ")" : "");
  else if (use_plugin && inject->process == "controller")
    *error = "--inject: there is no controller process with --controller plugin";
  else if (o.no_estimator && inject->process == "estimator")
    *error = "--inject: there is no estimator with --no-estimator";
  else
    return true;
  return false;
}

/// The controller's configuration, plan and models: what exo_controller checks at start-up, here.
bool checkController(ExperimentPlan& plan, std::string* error) {
  ExperimentOptions& o = plan.options;
  controller::ControllerConfig cc;
  if (!controller::loadControllerConfig(o.controller_config, cc, error)) return false;
  if (o.moves == 0) o.moves = cc.trajectory.moves;
  cc.trajectory.moves = static_cast<int>(o.moves);
  // The sim runs exactly as long as the controller plans to (start-up latch, moves, holds): a sim that
  // outlives the controller would apply zero torque at the end.
  plan.duration_s = controller::plannedRunDuration(cc);
  plan.estimate_lag_ticks = cc.estimate.lag_ticks;
  plan.controller_config = cc;
  if (!buildModelFromUrdfFile(o.model, true, plan.model, error) ||
      !buildModelFromUrdfFile(o.controller_model, true, plan.controller_model, error))
    return false;
  if (plan.controller_model.joint_names != plan.model.joint_names ||
      plan.controller_model.body_names != plan.model.body_names) {
    *error = "--controller-model " + o.controller_model + ": other links or joints than --model " + o.model;
    return false;
  }
  controller::BalanceController probe(plan.controller_model, cc, static_cast<uint64_t>(o.seed));
  if (!probe.ok()) *error = o.controller_config + ": " + probe.error();
  return probe.ok();
}

/// exo_estimator's arguments. A diagnose sidecar (--effects FILE) is read here too, with the estimator's model: a
/// bad one stops the experiment before any process starts, its path is made absolute for the estimator, and the
/// summary's replay applies it like the process does (online held-out RMSE with and without it). So is where the
/// soles stand (--sole-on-plate SPEC): the replay and the batch comparison place the base as the process does.
bool checkEstimatorArgs(ExperimentPlan& plan, std::string* error) {
  std::vector<std::string>& words = plan.estimator_words;
  std::istringstream in(plan.options.estimator_args);
  for (std::string w; in >> w;) words.push_back(w);
  for (size_t i = 0; i < words.size(); ++i) {
    std::string name = words[i], inline_value;
    if (const size_t eq = name.find('='); name.rfind("--", 0) == 0 && eq != std::string::npos)
      inline_value = name.substr(eq + 1), name = name.substr(0, eq);
    if (name != "--effects" && name != "--effect-prior-factor" && name != "--sole-on-plate") continue;
    if (!inline_value.empty()) {  // --name=VALUE: split, so the value can be rewritten
      words[i] = name;
      words.insert(words.begin() + static_cast<std::ptrdiff_t>(i + 1), inline_value);
    }
    if (i + 1 >= words.size()) return *error = "--estimator-args: " + name + " needs a value", false;
    std::string* value = &words[++i];
    if (name == "--effects") {
      *value = std::filesystem::absolute(*value).string();
      if (!estimator::readEffects(*value, plan.controller_model, plan.replay_options.effects, error))
        return *error = "--estimator-args --effects " + *error, false;
    } else if (name == "--sole-on-plate") {
      std::string why;
      if (!estimator::parseSoleOnPlate(*value, plan.replay_options.sole_on_plate, &why))
        return *error = "--estimator-args " + why, false;
    } else if (!common::parseDouble(*value, plan.replay_options.effect_prior_factor)) {
      return *error = "--estimator-args --effect-prior-factor: not a number '" + *value + "'", false;
    }
  }
  if (!plan.replay_options.effects.effects.empty()) {  // what exo_estimator refuses (a delay), refused before the run
    const Model& m = plan.controller_model;
    const estimator::OnlineEstimator probe(m, computeBaseParameters(m), m.phi, plan.replay_options);
    if (!probe.ok()) return *error = "--estimator-args: " + probe.error(), false;
  }
  return true;
}

/// The sim's inputs, validated here too so that errors name the file and key; the scenario's mid-run payload
/// (the summary's mass response).
bool checkSimInputs(ExperimentPlan& plan, std::string* error) {
  const ExperimentOptions& o = plan.options;
  sim::SensorConfig realistic, noise;
  sim::Scenario scenario;
  sim::SimModel probe;
  if (!sim::loadSensorConfig(o.sensors, &realistic, error) || !sim::loadScenario(o.scenario, &scenario, error) ||
      !sim::resolveSensorConfig(scenario, realistic, &noise, error) || !sim::simLoad(o.mjcf, noise, scenario, probe, error))
    return false;
  if (scenario.harness.enabled) {  // the balance controller needs the feet on the plates
    *error = o.scenario + ": harness: a calibration set-up (the pelvis held, the feet free); run it with "
                          "`exoid calibrate`";
    return false;
  }
  for (const sim::Payload& p : scenario.effects.payloads)
    if (p.attach_at_s > 0.0) plan.payload_attach_s = p.attach_at_s, plan.payload_mass_kg = p.mass;
  // A person is strapped in: their trunk moves on the pelvis on its own, which the estimator has to be told
  // (exo_estimator --base-body-moves; the summary's replay alike). What a clinic knows, not the person's parameters.
  if (scenario.wearer.enabled) {
    plan.replay_options.base_body_moves = true;
    if (std::find(plan.estimator_words.begin(), plan.estimator_words.end(), "--base-body-moves") ==
        plan.estimator_words.end())
      plan.estimator_words.push_back("--base-body-moves");
  }
  return true;
}

/// ExperimentOptions::model_given false and a `wearer:` in the scenario: writes the table prior into the output
/// directory (created) and makes it --model and --controller-model (plan.wearer_prior). Scenario errors are left to
/// checkSimInputs.
bool wearerPrior(ExperimentPlan& plan, std::string* error) {
  ExperimentOptions& o = plan.options;
  sim::Scenario scenario;
  std::string ignored;
  if (o.model_given || !sim::loadScenario(o.scenario, &scenario, &ignored) || !scenario.wearer.enabled) return true;
  WearerSpec typed = scenario.wearer.spec;  // what a clinic types: mass, height, sex; not the person's variation
  typed.variation = 0.0;
  typed.seed = 1;
  const std::string path = std::filesystem::absolute(std::filesystem::path(o.out_dir) / "wearer_prior.urdf").string();
  if (!prepareOutDir(o.out_dir, error) || !writeWearerPrior(o.model, typed, path, nullptr, error))
    return *error = "the wearer's prior (" + path + "): " + *error, false;
  o.model = o.controller_model = plan.wearer_prior = path;
  return true;
}

}  // namespace

bool planExperiment(const ExperimentOptions& options, ExperimentPlan& plan, std::string* error) {
  plan.options = options;
  if (plan.options.controller_model.empty()) plan.options.controller_model = options.model;
  if (options.no_estimator) plan.options.estimate_feedback = false;  // nothing to feed back
  plan.use_plugin = options.controller_mode == "plugin";
  plan.lockstep = !options.realtime;
  return checkOptions(plan.options, &plan.inject, error) && wearerPrior(plan, error) && checkController(plan, error) &&
         checkEstimatorArgs(plan, error) && checkSimInputs(plan, error);
}

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

}  // namespace exoid::tools
