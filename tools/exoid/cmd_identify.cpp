// exoid identify: one batch identification from logged or measured data (docs/identification.md). Thin: options ->
// tools::runIdentify (tools/lib/identify) -> the report on stdout, estimate.csv, summary.json, identified.urdf.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/estimator/sole_tilt.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/tools/identify_run.hpp"
#include "exoid/tools/urdf_inertials.hpp"
#include "base_signal_options.hpp"
#include "identify_hold_report.hpp"

namespace exoid::cli {

namespace cmd_identify {  // this file's own names: the exoid binary is a unity build
constexpr char kDescription[] =
    "Batch identification of the inertial parameters and joint friction (thesis chapter 3) from one data set:\n"
    "LCM logs of `exoid experiment` or CSVs of measured data (docs/identification.md). W and y are streamed\n"
    "through a per-coordinate QR and never held whole. Outputs the estimate (standard and base parameters,\n"
    "friction), the per-link consistency verdict, singular values, chosen rank z, condition number, the\n"
    "parameters the data did not excite, and with --out a JSON summary, the estimate as CSV and, when every\n"
    "link is physically consistent, a URDF with the identified inertials.\n\n"
    "exit codes: 0 success, 2 bad input or data that cannot support an estimate (one-line message on stderr),\n"
    "            3 the log is damaged (damaged stretches, a cut-off tail, rejected events; nothing written; see\n"
    "            --allow-partial).";

int fail(const std::string& msg) { return common::badInput("exoid identify", msg); }

/// The data, the model and the dataset pipeline.
void addDataOptions(CLI::App& app, tools::IdentifyRunOptions& o) {
  app.add_option("--data", o.data, "training data: LCM logs (exoid experiment's run.lcmlog) and/or CSVs (*.csv)")->required();
  app.add_option("--validate", o.validate, "validation data (same kinds); needed by --rank validation; its RMSE is reported, "
                 "with a warning when it is more than 2 x the training RMSE (the data differ); filtered with --cutoff "
                 "like the training data, except truth-pipeline logs (ideal, unfiltered: the thesis protocol)");
  app.add_option("--model", o.model_path, "robot URDF (default config/exo.urdf)");
  app.add_flag("--fixed-base", o.fixed_base, "the model's root link is fixed to the world (e.g. data/kuka_lwr4)");
  app.add_option("--pipeline", o.pipeline, "LCM logs: 'sensors' (encoders, torque sensors, IMU, plates; no ground truth) or "
                 "'truth' (EXO_TRUTH state and applied torques + plates: the thesis protocol)")->check(CLI::IsMember({"sensors", "truth"}));
  app.add_option("--validate-pipeline", o.validate_pipeline, "pipeline of the validation logs (default: truth, ideal as in the thesis)")
      ->check(CLI::IsMember({"sensors", "truth"}));
  app.add_option("--cutoff", o.cutoff_hz, "zero-phase 2nd-order Butterworth cutoff in Hz; 0: no filter (on sensor logs "
                 "with a warning: their encoders are then differentiated unfiltered). Default: 30 Hz where the training "
                 "data include sensor logs (the seed thesis's lowest, III-E; 10-15 Hz was better on the exoskeleton's "
                 "runs, unfiltered 500 times worse: docs/identification.md), none otherwise (CSVs, truth logs)")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("HZ")->default_str("");
  app.add_option("--filter-mode", o.filter_mode, "'inputs': filter q (and gyro), differentiate, filter again (thesis III-E); "
                 "'parallel': q only differenced, then the one filter on every column of W and on y (lag and attenuation cancel)")->check(CLI::IsMember({"inputs", "parallel"}));
  addBaseSignalOptions(app, o.base_signals);
  app.add_flag("--derive", o.derive, "differentiate q (and the base angular velocity) even where v, a are recorded");
  app.add_option("--noise", o.noise, "encoder noise sigma (rad) added to the training q (thesis: 9e-6); implies --derive")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("RAD");
  app.add_option("--seed", o.seed, "noise seed")->transform(common::strictInteger(0, INT64_MAX));
}

/// The method, the rank rule, the prior, the folds and the outputs.
void addMethodOptions(CLI::App& app, tools::IdentifyRunOptions& o, std::string* out_dir) {
  app.add_option("--method", o.method, "OLS, WLS-R, WLS-C, WLS-RC, or WLS-RC-PC (default: WLS-RC made physically "
                 "consistent, every link's pseudo-inertia positive definite; the only one whose identified.urdf is "
                 "guaranteed); case-insensitive")
      ->transform(CLI::IsMember({"OLS", "WLS-R", "WLS-C", "WLS-RC", "WLS-RC-PC"}, CLI::ignore_case));
  app.add_option("--rank", o.rank, "truncation rank z: a number, 'full', 'validation' (needs --validate; the thesis's "
                 "choice), or from the training data alone: 'jackknife' (default: the directions of least expected "
                 "error: each one's time-block jackknife variance, plus how far it moves when the same data are "
                 "processed another way (half the cutoff; with --filter-mode parallel, filtering the inputs; with the "
                 "legs' base rate or acceleration and --base-orientation fused, the IMU's below --orientation-cutoff; "
                 "with --base-rate gyro, the IMU's orientation; see --no-processing-check), against the prior's variance along it, see "
                 "--prior-uncertainty; z is the number kept), 'cv', 'cv-1se' (time-block cross-validation), 'gcv'; "
                 "docs/identification.md compares them; with --only-links the default is 'full'");
  app.add_flag("--no-processing-check", o.no_processing_check, "--rank jackknife: leave out the processing term (the "
               "training data are then read once instead of once per other processing: with --cutoff, half the "
               "cutoff, and filtering the inputs where --filter-mode is parallel; with the fused orientation, the IMU below "
               "--orientation-cutoff (the legs' rate or acceleration) or the IMU's orientation (--base-rate gyro))");
  app.add_option("--prior-uncertainty", o.prior_uncertainty, "--rank jackknife: the prior's parameters that it states (the "
                 "URDF's inertials, any kind with a nonzero entry) are within +-this relative error of the truth "
                 "(default 0.25); a kind the prior leaves at zero throughout (friction without a --prior for it) is "
                 "taken as unknown, scaled by the data")->transform(common::strictNumber(1e-6, 10.0));
  app.add_option("--prior", o.prior_path, "prior parameters, CSV name,value (default: the URDF's)");
  app.add_option("--only-links", o.only_links, "identify only these links' inertial parameters (URDF names of moving links; "
                 "the joints' friction stays free), every other link held at the prior (the --model URDF's or --prior's "
                 "values): the standard payload identification, e.g. --model identified.urdf --only-links lwr_7_link on "
                 "runs with a load on the KUKA's flange (docs/identification.md)")->type_name("LINK");
  app.add_option("--hold", o.hold_path, "a URDF of the same robot without what is to be identified, e.g. the empty "
                 "exoskeleton's identified.urdf: its links are held at its inertials, and the links that --model adds "
                 "to it (fixed-joint links with an inertial it lacks: `exoid model wearer`'s wearer_* segments, a "
                 "payload) are identified, per carrying link, from --model's values of them as the prior (the "
                 "carrying links are identified whole, the change credited to the added bodies); with --rows base and "
                 "--com-height prior by default; prints them and writes wearer.csv and wearer.png (docs/wearer.md)")
      ->type_name("URDF");
  app.add_option("--rows", o.rows, "training rows: 'all', or 'base': only the floating base's 6 rows (the base-link "
                 "dynamics: the force plates and the base's motion; no joint torque enters them, so joint effects the "
                 "model lacks, such as a wearer's passive joint moments, cannot bias the inertials; joint friction is "
                 "then not identified, left at the prior; floating base only). Default 'base' with --hold on a "
                 "floating base, 'all' otherwise; validation uses every row")
      ->check(CLI::IsMember({"all", "base"}));
  app.add_option("--com-height", o.com_height, "'prior': the whole system's CoM height (its vertical first moment in "
                 "the base frame at the standing pose, q = 0) is held at the prior's, the base link's own vertical "
                 "first moment taking up what the other parameters change; 'data': identified. Default 'prior' with "
                 "--hold on a floating base: standing balance barely excites the height, and what a rigid model lacks (a wearer's moving "
                 "trunk, passive joint moments) moved it by 30-140 mm in our runs (docs/wearer.md); 'data' otherwise")
      ->check(CLI::IsMember({"prior", "data"}));
  app.add_option("--truth-model", o.truth_model_path, "the true system's URDF (a simulated run's, e.g. `exoid model "
                 "wearer` with the scenario's seed and variation): with --hold, the added bodies' truth in the report; "
                 "with validation logs, its CoM error against the truth channel beside the prior's and the estimate's")
      ->type_name("URDF");
  app.add_option("--prior-perturb", o.prior_perturb, "scale each URDF parameter by a uniform random factor in [1-F, 1+F] for the prior")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("F");
  app.add_option("--prior-seed", o.prior_seed, "seed of --prior-perturb")->transform(common::strictInteger(0, INT64_MAX));
  app.add_option("--folds", o.folds, "time-block folds for --rank jackknife / cv")->transform(common::strictInteger(2, 50));
  app.add_option("--chunk-seconds", o.chunk_s, "length of one time block (blocks go to the folds in turn)")
      ->transform(common::strictNumber(1e-3, 1e6));
  app.add_option("--threads", o.threads, "threads for the QR updates")->transform(common::strictInteger(1, 64));
  app.add_flag("--skip-bad-rows", o.skip_bad_rows, "CSV: drop and count bad rows instead of failing at the first");
  app.add_flag("--allow-partial", o.allow_partial, "LCM logs: a damaged log (damaged stretches, a cut-off tail, events the "
               "adapters reject) is refused (exit 3, the damage on stderr); with this flag its readable part is used and "
               "the damage reported on stderr and in summary.json");
  app.add_option("--effects", o.effects_path, "sidecar effects.yaml of `exoid diagnose` (docs/diagnose.md): its effects are "
                 "applied to the training data as known corrections before identification (friction, offset, armature "
                 "torques subtracted; torque-sensor gains divided out; a time delay is refused)");
  app.add_option("--out", *out_dir, "directory for summary.json, estimate.csv and (all links consistent) identified.urdf; "
                 "with --hold also wearer.csv, plot_wearer.py and wearer.png");
}

/// The plots.
struct PlotOptions {
  bool no_plots = false;
  std::string python = "python3";
};

/// --cutoff's default where the training data include sensor logs: the seed thesis's lowest cutoff (III-E: 30, 50,
/// 70, 100 Hz). Their joint velocities and accelerations are the encoders differentiated; unfiltered, that noise
/// biases every column (docs/identification.md "2026-12-07 (stop 50)").
constexpr double kSensorLogCutoffHz = 30.0;

/// Whether the training data include LCM logs read through the sensors pipeline.
bool trainsOnSensorLogs(const tools::IdentifyRunOptions& o) {
  bool logs = false;
  for (const std::string& f : o.data) logs = logs || !tools::isCsvPath(f);
  return logs && o.pipeline == "sensors";
}

/// The report on stdout: method and rank, training and validation RMSE, consistency, excitation, and the warnings
/// (unfiltered sensor logs, data that differ; returned, for summary.json).
std::vector<std::string> printReport(const tools::IdentifyRun& run, const tools::IdentifyRunOptions& o) {
  const estimator::IdentifyResult& r = run.result;
  const Model& model = run.model;
  std::printf("%s, rank %s: z = %d of %d base parameters (numerical rank %d), condition number %.3g\n",
              estimator::methodLabel(r.method, r.physically_consistent).c_str(), estimator::rankRuleName(r.rank_rule), r.rank,
              run.base.rank, r.numerical_rank, r.condition);
  if (!run.processing_checked.empty()) {
    std::string what;
    for (const std::string& w : run.processing_checked) what += (what.empty() ? "" : ", ") + w;
    std::printf("processing check (%s): %zu directions left at the prior because the processing moves them\n",
                what.c_str(), r.curve.processing_sensitive.size());
  }
  std::printf("training: %ld samples, %ld equations, generalized-force RMSE %.6g (RMS of y %.6g)\n", run.training_samples,
              r.training_rows, r.training_rmse, r.training_y_rms);
  if (r.validation_rmse >= 0.0) {
    std::printf("validation: generalized-force RMSE %.6g (prior %.6g); per coordinate:", r.validation_rmse,
                r.prior_validation_rmse);
    for (int c = 0; c < model.nv; ++c) {
      const std::string n = c < model.nv - model.njoints ? "base" + std::to_string(c) : model.joint_names[c - (model.nv - model.njoints)];
      std::printf(" %s %.4g", n.c_str(), r.validation_rmse_per_coordinate[c]);
    }
    std::printf("\n");
  }
  int consistent = 0;
  for (const auto& l : r.links) consistent += l.consistent;
  std::printf("links physically consistent: %d of %d", consistent, static_cast<int>(r.links.size()));
  for (const auto& l : r.links)
    if (!l.consistent) std::printf("  [%s: mass %.4g, min eig(J) %.3g]", l.name.c_str(), l.mass, l.min_eigenvalue);
  std::printf("\nnot excited (left at the prior): %zu of %d parameters (estimate = prior); %zu more weakly excited "
              "(moved only through their correlation with the kept directions)\n",
              r.unexcited.size(), model.nparams(), r.weakly_excited.size());
  std::vector<std::string> warnings;
  // Sensor logs carry encoder angles only: unfiltered, their twice-differenced accelerations swamp every column, a
  // systematic error no rank rule sees (the exact prior's 5e-13 N m became 5.3 N m held-out; docs/identification.md).
  if (trainsOnSensorLogs(o) && o.cutoff_hz <= 0.0)
    warnings.push_back("sensor logs with --cutoff 0: the encoders are differentiated unfiltered, and their noise "
                       "biases the estimate far beyond what the rank rule sees; give a cutoff (default 30 Hz; 10-15 Hz "
                       "was best on the exoskeleton's runs, docs/identification.md)");
  if (r.data_differ) {
    char b[256];
    std::snprintf(b, sizeof b, "held-out RMSE is %.2f x the training RMSE (warning above %g): the data differ (a load, "
                  "a tool, another state of the robot?)", r.heldout_ratio, run.options.data_differ_ratio);
    warnings.push_back(b);
  }
  for (const std::string& w : warnings) std::printf("warning: %s\n", w.c_str());
  if (run.com_height_held)
    std::printf("system CoM height held at the prior's: %.4f m along the base z axis from the base origin at the "
                "standing pose (--com-height prior)\n", run.com_height_m);
  std::fprintf(stderr, "exoid identify: read + filter + factor %.3f s, solve + rank choice %.3f s\n", run.read_s, run.solve_s);
  return warnings;
}

/// DIR/estimate.csv: name, prior, estimate, excited (atomically).
bool writeEstimateCsv(const tools::IdentifyRun& run, const std::string& path, std::string* err) {
  const std::vector<std::string> names = run.model.paramNames();
  tools::AtomicCsvWriter w;
  if (!w.open(path, err)) return false;
  std::fprintf(w.file(), "name,prior,estimate,excited\n");
  std::vector<bool> ex(run.model.nparams(), true);
  for (int i : run.result.unexcited) ex[i] = false;
  for (int i = 0; i < run.model.nparams(); ++i)
    std::fprintf(w.file(), "%s,%.17g,%.17g,%d\n", names[i].c_str(), run.prior[i], run.result.phi[i], ex[i] ? 1 : 0);
  return w.commit(err);
}

/// The inputs of summary.json: per file, samples, skipped rows by reason, damage read past.
nlohmann::json inputsJson(const tools::IdentifyRun& run) {
  nlohmann::json inputs = nlohmann::json::array();
  for (const auto& [f, st] : run.inputs) {
    nlohmann::json why = nlohmann::json::object();
    for (const auto& [k, v] : st.why) why[k] = v;
    inputs.push_back({{"file", f}, {"samples", st.samples}, {"skipped", st.skipped}, {"skipped_by_reason", why},
                      {"rejected_log_events", st.rejected_events}});
    if (!st.first_skip.empty()) inputs.back()["first_skipped"] = st.first_skip;
    if (!st.damage_report.empty()) inputs.back()["damage"] = st.damage_report;  // read with --allow-partial
    if (st.sole_tilt.fitted) {  // --base-orientation plates
      nlohmann::json cols = nlohmann::json::array();
      for (int a = 0; a < 3; ++a) {
        nlohmann::json c = nlohmann::json::array();
        for (int k = 0; k < estimator::kSoleTiltRegressors; ++k)
          if (st.sole_tilt.columns[a] & (1 << k)) c.push_back(estimator::soleTiltColumnName(k));
        cols.push_back(c);
      }
      const auto vec = [](const Eigen::Vector3d& v) { return std::vector<double>{v[0], v[1], v[2]}; };
      inputs.back()["sole_tilt"] = {{"columns_per_axis", cols},
                                    {"explained_rms_rad", vec(st.sole_tilt.explained_rms)},
                                    {"imu_correction_rms_rad", vec(st.sole_tilt.correction_rms)},
                                    {"residual_rms_rad", vec(st.sole_tilt.residual_rms)}};
    }
    const estimator::SolePlacement& sp = st.sole_placement;
    if (sp.fitted || !sp.why_not.empty()) {  // --sole-on-plate fit
      inputs.back()["sole_placement"] = {{"fitted", sp.fitted},
                                         {"offset_m", {sp.offset.x(), sp.offset.y()}},
                                         {"standard_error_m", {sp.standard_error.x(), sp.standard_error.y()}},
                                         {"separable", {sp.separable.x(), sp.separable.y()}},
                                         {"weighted_rms_without", sp.weighted_rms_without},
                                         {"weighted_rms_with", sp.weighted_rms_with}};
      if (!sp.fitted) inputs.back()["sole_placement"]["why_not"] = sp.why_not;
    }
  }
  return inputs;
}

/// summary.json without the identified URDF's entry.
nlohmann::json summaryJson(const tools::IdentifyRun& run, const tools::IdentifyRunOptions& o,
                           const std::vector<std::string>& warnings) {
  const estimator::IdentifyResult& r = run.result;
  const std::vector<std::string> names = run.model.paramNames();
  nlohmann::json j;
  j["method"] = estimator::methodLabel(r.method, r.physically_consistent);
  if (r.physically_consistent) j["consistent_iterations"] = r.consistent_iterations;
  j["rank_rule"] = estimator::rankRuleName(r.rank_rule);
  j["rank"] = r.rank;
  j["base_parameters"] = run.base.rank;
  j["numerical_rank"] = r.numerical_rank;
  j["condition_number"] = r.condition;
  j["singular_values"] = std::vector<double>(r.singular_values.data(), r.singular_values.data() + r.singular_values.size());
  j["rank_curve"] = {{"rule", r.curve.rule}, {"score", r.curve.score}, {"order", r.curve.order},
                     {"processing_checked", run.processing_checked},
                     {"processing_sensitive", r.curve.processing_sensitive}};
  j["row_weight"] = r.row_weight;
  j["training"] = {{"samples", run.training_samples}, {"equations", r.training_rows}, {"rmse", r.training_rmse},
                   {"y_rms", r.training_y_rms}};
  if (r.validation_rmse >= 0.0)
    j["validation"] = {{"rmse", r.validation_rmse}, {"prior_rmse", r.prior_validation_rmse},
                       {"rmse_per_coordinate", r.validation_rmse_per_coordinate},
                       {"heldout_training_ratio", r.heldout_ratio}, {"data_differ", r.data_differ}};
  nlohmann::json params = nlohmann::json::object();
  for (int i = 0; i < run.model.nparams(); ++i) params[names[i]] = r.phi[i];
  j["estimate"] = params;
  j["base_estimate"] = std::vector<double>(r.phi_base.data(), r.phi_base.data() + r.phi_base.size());
  nlohmann::json links = nlohmann::json::array();
  for (const auto& l : r.links)
    links.push_back({{"link", l.name}, {"mass", l.mass}, {"min_pseudo_inertia_eigenvalue", l.min_eigenvalue}, {"consistent", l.consistent}});
  j["links"] = links;
  std::vector<std::string> unexcited, weak;
  for (int i : r.unexcited) unexcited.push_back(names[i]);
  j["not_excited"] = unexcited;
  for (int i : r.weakly_excited) weak.push_back(names[i]);
  j["weakly_excited"] = weak;
  j["warnings"] = warnings;
  j["inputs"] = inputsJson(run);
  j["options"] = {{"pipeline", o.pipeline}, {"cutoff_hz", o.cutoff_hz}, {"filter_mode", o.filter_mode}, {"noise", o.noise},
                  {"base_orientation", o.base_signals.orientation}, {"base_rate", o.base_signals.rate}, {"base_acceleration", o.base_signals.acceleration}, {"orientation_cutoff_hz", o.base_signals.orientation_cutoff_hz},
                  {"folds", o.folds}, {"chunk_seconds", o.chunk_s}, {"prior_perturb", o.prior_perturb}};
  if (!o.only_links.empty()) j["options"]["only_links"] = o.only_links;  // the other links held at the prior
  if (!o.hold_path.empty()) j["options"]["hold"] = o.hold_path;
  j["options"]["rows"] = tools::baseRowsOnly(o) ? "base" : "all";
  const auto& sp = o.base_signals.sole_on_plate;  // m, lab axes; zero: centred (the default)
  j["options"]["sole_on_plate"] = {{"right", {sp[0].x(), sp[0].y(), sp[0].z()}}, {"left", {sp[1].x(), sp[1].y(), sp[1].z()}}};
  j["com_height_held_m"] = run.com_height_held ? nlohmann::json(run.com_height_m) : nlohmann::json(nullptr);
  if (!o.truth_model_path.empty()) j["options"]["truth_model"] = o.truth_model_path;
  j["timing_s"] = {{"read_filter_factor", run.read_s}, {"solve", run.solve_s}};
  return j;
}

/// --out DIR: estimate.csv, summary.json and, only when every link is physically consistent, identified.urdf.
bool writeOutputs(const tools::IdentifyRun& run, const tools::IdentifyRunOptions& o, const std::vector<std::string>& warnings,
                  const std::string& out_dir, const PlotOptions& plots, std::string* err) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return *err = "cannot create '" + out_dir + "': " + ec.message(), false;
  if (!writeEstimateCsv(run, out_dir + "/estimate.csv", err)) return false;
  nlohmann::json j = summaryJson(run, o, warnings);
  holdJson(run, j);
  if (!writeHoldOutputs(run, out_dir, !plots.no_plots, plots.python, err)) return false;
  int consistent = 0;
  for (const auto& l : run.result.links) consistent += l.consistent;
  if (consistent == static_cast<int>(run.result.links.size())) {
    if (!tools::writeUrdfWithInertials(o.model_path, run.model, run.result.phi, out_dir + "/identified.urdf", err)) return false;
    j["identified_urdf"] = out_dir + "/identified.urdf";
  } else {
    j["identified_urdf"] = nullptr;
    std::printf("no identified.urdf: %d link(s) physically inconsistent\n", static_cast<int>(run.result.links.size()) - consistent);
  }
  std::ofstream(out_dir + "/summary.json") << j.dump(2) << "\n";
  return true;
}
}  // namespace cmd_identify

int cmdIdentify(int argc, char** argv) {
  using namespace cmd_identify;
  CLI::App app(kDescription, "exoid identify");
  common::configureCli(app);
  tools::IdentifyRunOptions o;
  o.model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  std::string out_dir;
  addDataOptions(app, o);
  addMethodOptions(app, o, &out_dir);
  PlotOptions plots;
  app.add_flag("--no-plots", plots.no_plots, "--hold: write plot_wearer.py but do not run it");
  app.add_option("--python", plots.python, "python interpreter for the plots (default python3; needs matplotlib)");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  o.rank_given = app.get_option("--rank")->count() > 0;
  if (app.get_option("--cutoff")->count() == 0 && trainsOnSensorLogs(o)) {
    o.cutoff_hz = kSensorLogCutoffHz;
    std::fprintf(stderr, "exoid identify: --cutoff %g Hz (the default on sensor logs)\n", o.cutoff_hz);
  }
  std::string err;
  tools::IdentifyRun run;
  if (!tools::runIdentify(o, run, &err)) return run.damaged ? (fail(err), 3) : fail(err);
  const std::vector<std::string> warnings = printReport(run, o);
  printHoldReport(run);
  if (!out_dir.empty() && !writeOutputs(run, o, warnings, out_dir, plots, &err)) return fail(err);
  return 0;
}

}  // namespace exoid::cli
