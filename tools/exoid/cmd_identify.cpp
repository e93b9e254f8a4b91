// exoid identify: one batch identification from logged or measured data (docs/identification.md).
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/strict_number.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/tools/urdf_inertials.hpp"

namespace exoid::cli {

namespace {
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

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid identify: error: %s\n", msg.c_str());
  return 2;
}

double seconds(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

// Prior from a CSV with columns name,value (every parameter named once).
bool readPrior(const std::string& path, const Model& model, Eigen::VectorXd& prior, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = "cannot open prior '" + path + "'", false;
  const std::vector<std::string> names = model.paramNames();
  std::map<std::string, int> index;
  for (size_t i = 0; i < names.size(); ++i) index[names[i]] = static_cast<int>(i);
  prior = Eigen::VectorXd::Constant(model.nparams(), NAN);
  std::string line;
  long row = 0;
  while (std::getline(in, line)) {
    ++row;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#' || (row == 1 && line.rfind("name,", 0) == 0)) continue;
    const size_t comma = line.find(',');
    const std::string name = line.substr(0, comma);
    auto it = index.find(name);
    if (comma == std::string::npos || it == index.end())
      return *error = path + ": row " + std::to_string(row) + ": unknown parameter '" + name + "'", false;
    const std::string cell = line.substr(comma + 1, line.find(',', comma + 1) - comma - 1);
    double v = 0.0;
    std::string why;
    if (!common::parseDouble(cell, v, &why))
      return *error = path + ": row " + std::to_string(row) + ": '" + cell + "': " + why, false;
    prior[it->second] = v;
  }
  for (int i = 0; i < prior.size(); ++i)
    if (std::isnan(prior[i])) return *error = path + ": parameter '" + names[i] + "' missing", false;
  return true;
}
}  // namespace

int cmdIdentify(int argc, char** argv) {
  CLI::App app(kDescription, "exoid identify");
  common::configureCli(app);
  std::vector<std::string> data, validate;
  std::string model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf", pipeline = "sensors", vpipeline,
              filter_mode = "inputs", method_name = "WLS-RC-PC", rank_name = "jackknife", prior_path, out_dir,
              effects_path;
  bool fixed_base = false, derive = false, skip_bad = false;
  double cutoff = 0.0, noise = 0.0, perturb = 0.0, chunk_s = 2.0;
  uint64_t seed = 1, prior_seed = 1;
  int folds = 5, threads = 2;
  app.add_option("--data", data, "training data: LCM logs (exoid experiment's run.lcmlog) and/or CSVs (*.csv)")->required();
  app.add_option("--validate", validate, "validation data (same kinds); needed by --rank validation; its RMSE is reported, "
                 "with a warning when it is more than 2 x the training RMSE (the data differ)");
  app.add_option("--model", model_path, "robot URDF (default config/exo.urdf)");
  app.add_flag("--fixed-base", fixed_base, "the model's root link is fixed to the world (e.g. data/kuka_lwr4)");
  app.add_option("--pipeline", pipeline, "LCM logs: 'sensors' (encoders, torque sensors, IMU, plates; no ground truth) or "
                 "'truth' (EXO_TRUTH state and applied torques + plates: the thesis protocol)")->check(CLI::IsMember({"sensors", "truth"}));
  app.add_option("--validate-pipeline", vpipeline, "pipeline of the validation logs (default: truth, ideal as in the thesis)")
      ->check(CLI::IsMember({"sensors", "truth"}));
  app.add_option("--cutoff", cutoff, "zero-phase 2nd-order Butterworth cutoff in Hz (0: no filter)")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("HZ");
  app.add_option("--filter-mode", filter_mode, "'inputs': filter q (and gyro), differentiate, filter again (thesis III-E); "
                 "'parallel': q only differenced, then the one filter on every column of W and on y (lag and attenuation cancel)")->check(CLI::IsMember({"inputs", "parallel"}));
  std::string orientation = "fused";
  double orientation_cutoff = 5.0;
  app.add_option("--base-orientation", orientation, "sensors pipeline: base orientation 'fused' (leg kinematics with the "
                 "feet flat and still on the plates, corrected below --orientation-cutoff by the IMU; default) or the "
                 "'imu' alone")->check(CLI::IsMember({"fused", "imu"}));
  app.add_option("--orientation-cutoff", orientation_cutoff, "--base-orientation fused: Hz below which the IMU, above "
                 "which the legs give the orientation (default 5)")->transform(common::strictNumber(0.01, 400.0))->type_name("HZ");
  app.add_flag("--derive", derive, "differentiate q (and the base angular velocity) even where v, a are recorded");
  app.add_option("--noise", noise, "encoder noise sigma (rad) added to the training q (thesis: 9e-6); implies --derive")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("RAD");
  app.add_option("--seed", seed, "noise seed")->transform(common::strictInteger(0, INT64_MAX));
  app.add_option("--method", method_name, "OLS, WLS-R, WLS-C, WLS-RC, or WLS-RC-PC (default: WLS-RC made physically "
                 "consistent, every link's pseudo-inertia positive definite; the only one whose identified.urdf is "
                 "guaranteed); case-insensitive")
      ->transform(CLI::IsMember({"OLS", "WLS-R", "WLS-C", "WLS-RC", "WLS-RC-PC"}, CLI::ignore_case));
  double prior_uncertainty = 0.25;
  auto* rank_opt = app.add_option("--rank", rank_name, "truncation rank z: a number, 'full', 'validation' (needs --validate; the thesis's "
                 "choice), or from the training data alone: 'jackknife' (default: the z of least expected error, each "
                 "direction's time-block jackknife variance against the prior's variance along it, see "
                 "--prior-uncertainty), 'cv', 'cv-1se' (time-block cross-validation), 'gcv'; "
                 "docs/identification.md compares them; with --only-links the default is 'full'");
  app.add_option("--prior-uncertainty", prior_uncertainty, "--rank jackknife: the prior's parameters that it states (the "
                 "URDF's inertials, any kind with a nonzero entry) are within +-this relative error of the truth "
                 "(default 0.25); a kind the prior leaves at zero throughout (friction without a --prior for it) is "
                 "taken as unknown, scaled by the data")->transform(common::strictNumber(1e-6, 10.0));
  app.add_option("--prior", prior_path, "prior parameters, CSV name,value (default: the URDF's)");
  std::vector<std::string> only_links;
  app.add_option("--only-links", only_links, "identify only these links' inertial parameters (URDF names of moving links; "
                 "the joints' friction stays free), every other link held at the prior (the --model URDF's or --prior's "
                 "values): the standard payload identification, e.g. --model identified.urdf --only-links lwr_7_link on "
                 "runs with a load on the KUKA's flange (docs/identification.md)")->type_name("LINK");
  app.add_option("--prior-perturb", perturb, "scale each URDF parameter by a uniform random factor in [1-F, 1+F] for the prior")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("F");
  app.add_option("--prior-seed", prior_seed, "seed of --prior-perturb")->transform(common::strictInteger(0, INT64_MAX));
  app.add_option("--folds", folds, "time-block folds for --rank jackknife / cv")->transform(common::strictInteger(2, 50));
  app.add_option("--chunk-seconds", chunk_s, "length of one time block (blocks go to the folds in turn)")
      ->transform(common::strictNumber(1e-3, 1e6));
  app.add_option("--threads", threads, "threads for the QR updates")->transform(common::strictInteger(1, 64));
  app.add_flag("--skip-bad-rows", skip_bad, "CSV: drop and count bad rows instead of failing at the first");
  bool allow_partial = false;
  app.add_flag("--allow-partial", allow_partial, "LCM logs: a damaged log (damaged stretches, a cut-off tail, events the "
               "adapters reject) is refused (exit 3, the damage on stderr); with this flag its readable part is used and "
               "the damage reported on stderr and in summary.json");
  app.add_option("--effects", effects_path, "sidecar effects.yaml of `exoid diagnose` (docs/diagnose.md): its effects are "
                 "applied to the training data as known corrections before identification (friction, offset, armature "
                 "torques subtracted; torque-sensor gains divided out; a time delay is refused)");
  app.add_option("--out", out_dir, "directory for summary.json, estimate.csv and (all links consistent) identified.urdf");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  const auto t0 = std::chrono::steady_clock::now();
  // --only-links: the named links' prior is what the data are to correct (a load added to them), not a value within
  // --prior-uncertainty of the truth as the jackknife rule assumes, and their few columns are well excited: full rank.
  if (!only_links.empty() && rank_opt->count() == 0) rank_name = "full";
  estimator::IdentifyOptions io;
  io.physically_consistent = method_name.size() > 3 && method_name.compare(method_name.size() - 3, 3, "-PC") == 0;
  if (io.physically_consistent) method_name.resize(method_name.size() - 3);
  if (!estimator::parseMethod(method_name, io.method)) return fail("unknown --method '" + method_name + "'");
  if (!estimator::parseRankRule(rank_name, io.rank_rule)) {
    int64_t z = 0;
    if (!common::parseInt(rank_name, 0, 100000, z)) return fail("--rank must be a number >= 0, full, validation, cv or gcv (got '" + rank_name + "')");
    io.rank_rule = estimator::RankRule::Fixed;
    io.rank = static_cast<int>(z);
  }
  io.prior_uncertainty = prior_uncertainty;
  if (io.rank_rule == estimator::RankRule::Validation && validate.empty()) return fail("--rank validation needs --validate");
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(model_path, !fixed_base, model, &err)) return fail(err);
  Eigen::VectorXd prior = model.phi;
  if (!prior_path.empty() && !readPrior(prior_path, model, prior, &err)) return fail(err);
  if (perturb > 0.0) {
    std::mt19937_64 rng(prior_seed);
    std::uniform_real_distribution<double> u(-perturb, perturb);
    for (int i = 0; i < prior.size(); ++i) prior[i] *= 1.0 + u(rng);
  }
  BaseParameterOptions bo;
  Eigen::VectorXd held_phi;  // --only-links: the other links' parameters, taken off y
  if (!only_links.empty()) {
    bo.held.assign(static_cast<size_t>(model.nparams()), false);
    for (int i = 0; i < model.nInertialParams(); ++i) bo.held[static_cast<size_t>(i)] = true;
    for (const std::string& name : only_links) {
      const int b = model.bodyIndex(name);
      if (b < 0)
        return fail("--only-links: '" + name + "' is not a moving link of " + model_path +
                    " (links on fixed joints are lumped into their parent)");
      for (int k = 0; k < kParamsPerBody; ++k) bo.held[static_cast<size_t>(model.bodyParamIndex(b) + k)] = false;
    }
    held_phi = Eigen::VectorXd::Zero(model.nparams());
    for (int i = 0; i < model.nparams(); ++i)
      if (bo.held[static_cast<size_t>(i)]) held_phi[i] = prior[i];
  }
  const BaseParameters base = computeBaseParameters(model, bo);
  tools::SourceOptions so;
  if (!only_links.empty()) so.held_phi = &held_phi;
  so.pipeline = pipeline == "truth" ? tools::LogPipeline::Truth : tools::LogPipeline::Sensors;
  so.dataset.cutoff_hz = cutoff;
  so.dataset.filter = filter_mode == "parallel" ? estimator::FilterMode::Parallel : estimator::FilterMode::Inputs;
  so.dataset.derive = derive || noise > 0.0;
  so.dataset.orientation_from_legs = pipeline == "sensors" && orientation == "fused";
  so.dataset.orientation_cutoff_hz = orientation_cutoff;
  so.dataset.encoder_noise = noise;
  so.dataset.noise_seed = seed;
  so.skip_bad_rows = skip_bad;
  so.allow_partial = allow_partial;
  estimator::EffectSet effects;
  if (!effects_path.empty()) {
    if (!estimator::readEffects(effects_path, model, effects, &err)) return fail(err);
    Eigen::VectorXd probe = Eigen::VectorXd::Zero(model.nv);
    if (!estimator::correctMeasurement(model, effects, probe))
      return fail(effects_path + ": a time delay cannot be applied by identify (it needs the future of the torque)");
    so.effects = &effects;
  }
  estimator::AccumulatorOptions ao;
  ao.folds = folds;
  ao.threads = threads;
  ao.chunk = 1;  // set from the first file's rate below
  nlohmann::json inputs = nlohmann::json::array();
  bool damaged = false;  // a load failed on a damaged log: exit 3
  auto load = [&](const std::vector<std::string>& files, const tools::SourceOptions& opt, estimator::LsqAccumulator& acc) {
    for (const std::string& f : files) {
      tools::InputStats st;
      if (!tools::accumulateFile(f, model, opt, acc, st, &err)) return damaged = st.refused_damaged, false;
      nlohmann::json why = nlohmann::json::object();
      for (const auto& [k, v] : st.why) why[k] = v;
      inputs.push_back({{"file", f}, {"samples", st.samples}, {"skipped", st.skipped}, {"skipped_by_reason", why},
                        {"rejected_log_events", st.rejected_events}});
      if (!st.first_skip.empty()) inputs.back()["first_skipped"] = st.first_skip;
      if (!st.damage_report.empty()) inputs.back()["damage"] = st.damage_report;  // read with --allow-partial
      std::fprintf(stderr, "exoid identify: %s: %ld samples, %ld skipped%s%s\n", f.c_str(), st.samples, st.skipped,
                   st.first_skip.empty() ? "" : " (first: ", st.first_skip.empty() ? "" : (st.first_skip + ")").c_str());
      if (!st.damage_report.empty())
        std::fprintf(stderr, "exoid identify: warning: %s: damaged log, its readable part used: %s\n", f.c_str(),
                     st.damage_report.c_str());
    }
    return true;
  };
  // Time blocks of --chunk-seconds: the sample rate is not known before reading, so assume the exoskeleton's
  // 1 kHz for logs and read the CSV's first rows' spacing.
  double rate = 1000.0;
  if (tools::isCsvPath(data[0])) {
    std::ifstream in(data[0]);
    std::string h, r1, r2;
    std::getline(in, h);
    if (std::getline(in, r1) && std::getline(in, r2)) {
      const double dt = std::strtod(r2.c_str(), nullptr) - std::strtod(r1.c_str(), nullptr);
      if (dt > 0.0 && std::isfinite(dt)) rate = 1.0 / dt;
    }
  }
  ao.chunk = std::max(1, static_cast<int>(std::lround(chunk_s * rate)));
  estimator::LsqAccumulator train(model, base, ao);
  if (!load(data, so, train)) return damaged ? (fail(err), 3) : fail(err);
  train.flush();
  const double t_read = seconds(t0);
  std::unique_ptr<estimator::LsqAccumulator> val;
  if (!validate.empty()) {
    tools::SourceOptions vo = so;
    vo.effects = nullptr;  // validation data: as recorded (ideal by default)
    vo.pipeline = (vpipeline.empty() ? "truth" : vpipeline) == "truth" ? tools::LogPipeline::Truth : tools::LogPipeline::Sensors;
    vo.dataset.encoder_noise = 0.0;
    vo.dataset.orientation_from_legs = vo.pipeline == tools::LogPipeline::Sensors && orientation == "fused";
    vo.dataset.derive = derive;
    vo.dataset.cutoff_hz = 0.0;  // validation data are ideal (thesis IV-A)
    estimator::AccumulatorOptions va = ao;
    va.folds = 1;
    val = std::make_unique<estimator::LsqAccumulator>(model, base, va);
    if (!load(validate, vo, *val)) return damaged ? (fail(err), 3) : fail(err);
    val->flush();
  }
  const auto t1 = std::chrono::steady_clock::now();
  estimator::IdentifyResult r;
  if (!estimator::identify(train, model, prior, io, val.get(), r, &err)) return fail(err);
  const double t_solve = seconds(t1);
  // Report.
  const std::vector<std::string> names = model.paramNames();
  std::printf("%s, rank %s: z = %d of %d base parameters (numerical rank %d), condition number %.3g\n",
              estimator::methodLabel(r.method, r.physically_consistent).c_str(), estimator::rankRuleName(r.rank_rule), r.rank, base.rank,
              r.numerical_rank, r.condition);
  std::printf("training: %ld samples, %ld equations, generalized-force RMSE %.6g (RMS of y %.6g)\n", train.samples(),
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
  std::string differ;
  if (r.data_differ) {
    char b[256];
    std::snprintf(b, sizeof b, "held-out RMSE is %.2f x the training RMSE (warning above %g): the data differ (a load, "
                  "a tool, another state of the robot?)", r.heldout_ratio, io.data_differ_ratio);
    differ = b;
    std::printf("warning: %s\n", differ.c_str());
  }
  std::fprintf(stderr, "exoid identify: read + filter + factor %.3f s, solve + rank choice %.3f s\n", t_read, t_solve);
  if (!out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) return fail("cannot create '" + out_dir + "': " + ec.message());
    {
      tools::AtomicCsvWriter w;
      if (!w.open(out_dir + "/estimate.csv", &err)) return fail(err);
      std::fprintf(w.file(), "name,prior,estimate,excited\n");
      std::vector<bool> ex(model.nparams(), true);
      for (int i : r.unexcited) ex[i] = false;
      for (int i = 0; i < model.nparams(); ++i)
        std::fprintf(w.file(), "%s,%.17g,%.17g,%d\n", names[i].c_str(), prior[i], r.phi[i], ex[i] ? 1 : 0);
      if (!w.commit(&err)) return fail(err);
    }
    nlohmann::json j;
    j["method"] = estimator::methodLabel(r.method, r.physically_consistent);
    if (r.physically_consistent) j["consistent_iterations"] = r.consistent_iterations;
    j["rank_rule"] = estimator::rankRuleName(r.rank_rule);
    j["rank"] = r.rank;
    j["base_parameters"] = base.rank;
    j["numerical_rank"] = r.numerical_rank;
    j["condition_number"] = r.condition;
    j["singular_values"] = std::vector<double>(r.singular_values.data(), r.singular_values.data() + r.singular_values.size());
    j["rank_curve"] = {{"rule", r.curve.rule}, {"score", r.curve.score}};
    j["row_weight"] = r.row_weight;
    j["training"] = {{"samples", train.samples()}, {"equations", r.training_rows}, {"rmse", r.training_rmse},
                     {"y_rms", r.training_y_rms}};
    if (r.validation_rmse >= 0.0)
      j["validation"] = {{"rmse", r.validation_rmse}, {"prior_rmse", r.prior_validation_rmse},
                         {"rmse_per_coordinate", r.validation_rmse_per_coordinate},
                         {"heldout_training_ratio", r.heldout_ratio}, {"data_differ", r.data_differ}};
    nlohmann::json params = nlohmann::json::object();
    for (int i = 0; i < model.nparams(); ++i) params[names[i]] = r.phi[i];
    j["estimate"] = params;
    j["base_estimate"] = std::vector<double>(r.phi_base.data(), r.phi_base.data() + r.phi_base.size());
    nlohmann::json links = nlohmann::json::array();
    for (const auto& l : r.links)
      links.push_back({{"link", l.name}, {"mass", l.mass}, {"min_pseudo_inertia_eigenvalue", l.min_eigenvalue}, {"consistent", l.consistent}});
    j["links"] = links;
    std::vector<std::string> unexcited;
    for (int i : r.unexcited) unexcited.push_back(names[i]);
    j["not_excited"] = unexcited;
    std::vector<std::string> weak;
    for (int i : r.weakly_excited) weak.push_back(names[i]);
    j["weakly_excited"] = weak;
    j["warnings"] = differ.empty() ? nlohmann::json::array() : nlohmann::json::array({differ});
    j["inputs"] = inputs;
    j["options"] = {{"pipeline", pipeline}, {"cutoff_hz", cutoff}, {"filter_mode", filter_mode}, {"noise", noise},
                    {"base_orientation", orientation}, {"orientation_cutoff_hz", orientation_cutoff},
                    {"folds", folds}, {"chunk_seconds", chunk_s}, {"prior_perturb", perturb}};
    if (!only_links.empty()) j["options"]["only_links"] = only_links;  // the other links held at the prior
    j["timing_s"] = {{"read_filter_factor", t_read}, {"solve", t_solve}};
    // URDF with the identified inertials, only when every link is physically consistent.
    if (consistent == static_cast<int>(r.links.size())) {
      if (!tools::writeUrdfWithInertials(model_path, model, r.phi, out_dir + "/identified.urdf", &err)) return fail(err);
      j["identified_urdf"] = out_dir + "/identified.urdf";
    } else {
      j["identified_urdf"] = nullptr;
      std::printf("no identified.urdf: %d link(s) physically inconsistent\n", static_cast<int>(r.links.size()) - consistent);
    }
    std::ofstream(out_dir + "/summary.json") << j.dump(2) << "\n";
  }
  return 0;
}

}  // namespace exoid::cli
