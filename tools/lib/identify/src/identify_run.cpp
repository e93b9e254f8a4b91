#include "exoid/tools/identify_run.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <random>

#include "exoid/common/strict_number.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"

namespace exoid::tools {
namespace {

double seconds(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

/// The method (a "-PC" suffix: made physically consistent) and the rank rule (a name or a fixed number).
bool resolveMethod(const IdentifyRunOptions& o, estimator::IdentifyOptions& io, std::string* error) {
  std::string method = o.method;
  // --only-links: the named links' prior is what the data are to correct (a load added to them), not a value within
  // --prior-uncertainty of the truth as the jackknife rule assumes, and their few columns are well excited: full rank.
  const std::string rank = !o.only_links.empty() && !o.rank_given ? "full" : o.rank;
  io.physically_consistent = method.size() > 3 && method.compare(method.size() - 3, 3, "-PC") == 0;
  if (io.physically_consistent) method.resize(method.size() - 3);
  if (!estimator::parseMethod(method, io.method)) return *error = "unknown --method '" + method + "'", false;
  if (!estimator::parseRankRule(rank, io.rank_rule)) {
    int64_t z = 0;
    if (!common::parseInt(rank, 0, 100000, z))
      return *error = "--rank must be a number >= 0, full, validation, cv or gcv (got '" + rank + "')", false;
    io.rank_rule = estimator::RankRule::Fixed;
    io.rank = static_cast<int>(z);
  }
  io.prior_uncertainty = o.prior_uncertainty;
  if (io.rank_rule == estimator::RankRule::Validation && o.validate.empty())
    return *error = "--rank validation needs --validate", false;
  return true;
}

/// The model, its prior (URDF, --prior, --prior-perturb) and the base parameters; --only-links: every other link
/// held at the prior (*held_phi: those parameters, taken off y; empty otherwise).
bool modelAndPrior(const IdentifyRunOptions& o, IdentifyRun& run, Eigen::VectorXd* held_phi, std::string* error) {
  Model& model = run.model;
  if (!buildModelFromUrdfFile(o.model_path, !o.fixed_base, model, error)) return false;
  run.prior = model.phi;
  if (!o.prior_path.empty() && !readPrior(o.prior_path, model, run.prior, error)) return false;
  if (o.prior_perturb > 0.0) {
    std::mt19937_64 rng(o.prior_seed);
    std::uniform_real_distribution<double> u(-o.prior_perturb, o.prior_perturb);
    for (int i = 0; i < run.prior.size(); ++i) run.prior[i] *= 1.0 + u(rng);
  }
  BaseParameterOptions bo;
  if (!o.only_links.empty()) {
    bo.held.assign(static_cast<size_t>(model.nparams()), false);
    for (int i = 0; i < model.nInertialParams(); ++i) bo.held[static_cast<size_t>(i)] = true;
    for (const std::string& name : o.only_links) {
      const int b = model.bodyIndex(name);
      if (b < 0)
        return *error = "--only-links: '" + name + "' is not a moving link of " + o.model_path +
                        " (links on fixed joints are lumped into their parent)",
               false;
      for (int k = 0; k < kParamsPerBody; ++k) bo.held[static_cast<size_t>(model.bodyParamIndex(b) + k)] = false;
    }
    *held_phi = Eigen::VectorXd::Zero(model.nparams());
    for (int i = 0; i < model.nparams(); ++i)
      if (bo.held[static_cast<size_t>(i)]) (*held_phi)[i] = run.prior[i];
  }
  run.base = computeBaseParameters(model, bo);
  return true;
}

/// The training data's dataset pipeline.
SourceOptions trainingSource(const IdentifyRunOptions& o) {
  SourceOptions so;
  so.pipeline = o.pipeline == "truth" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
  so.dataset.cutoff_hz = o.cutoff_hz;
  so.dataset.filter = o.filter_mode == "parallel" ? estimator::FilterMode::Parallel : estimator::FilterMode::Inputs;
  so.dataset.derive = o.derive || o.noise > 0.0;
  so.dataset.orientation_from_legs = o.pipeline == "sensors" && o.orientation == "fused";
  so.dataset.orientation_cutoff_hz = o.orientation_cutoff_hz;
  so.dataset.encoder_noise = o.noise;
  so.dataset.noise_seed = o.seed;
  so.skip_bad_rows = o.skip_bad_rows;
  so.allow_partial = o.allow_partial;
  return so;
}

/// The validation data's: as recorded, no effects, no added noise. Truth-pipeline logs are ideal (thesis IV-A) and
/// stay unfiltered; measured validation data (sensors-pipeline logs, CSV) carry the training data's noise and get
/// its filter (unfiltered, twice-differenced encoders drown the held-out RMSE and the rank chosen with it).
SourceOptions validationSource(const IdentifyRunOptions& o, const SourceOptions& training) {
  SourceOptions vo = training;
  vo.effects = nullptr;
  vo.pipeline = (o.validate_pipeline.empty() ? "truth" : o.validate_pipeline) == "truth" ? intake::LogPipeline::Truth
                                                                                         : intake::LogPipeline::Sensors;
  vo.dataset.encoder_noise = 0.0;
  vo.dataset.orientation_from_legs = vo.pipeline == intake::LogPipeline::Sensors && o.orientation == "fused";
  vo.dataset.derive = o.derive;
  const bool ideal = vo.pipeline == intake::LogPipeline::Truth && !o.validate.empty() && !isCsvPath(o.validate.front());
  vo.dataset.cutoff_hz = ideal ? 0.0 : training.dataset.cutoff_hz;
  return vo;
}

/// Samples per --chunk-seconds time block: the sample rate is not known before reading, so assume the
/// exoskeleton's 1 kHz for logs and read the CSV's first rows' spacing.
int chunkSamples(const std::string& first_file, double chunk_s) {
  double rate = 1000.0;
  if (isCsvPath(first_file)) {
    std::ifstream in(first_file);
    std::string h, r1, r2;
    std::getline(in, h);
    if (std::getline(in, r1) && std::getline(in, r2)) {
      const double dt = std::strtod(r2.c_str(), nullptr) - std::strtod(r1.c_str(), nullptr);
      if (dt > 0.0 && std::isfinite(dt)) rate = 1.0 / dt;
    }
  }
  return std::max(1, static_cast<int>(std::lround(chunk_s * rate)));
}

/// Streams the files into acc, reporting each on stderr; run.inputs gets their statistics.
bool load(const std::vector<std::string>& files, const SourceOptions& opt, estimator::LsqAccumulator& acc,
          IdentifyRun& run, std::string* error) {
  for (const std::string& f : files) {
    intake::InputStats st;
    if (!accumulateFile(f, run.model, opt, acc, st, error)) return run.damaged = st.refused_damaged, false;
    run.inputs.emplace_back(f, st);
    std::fprintf(stderr, "exoid identify: %s: %ld samples, %ld skipped%s%s\n", f.c_str(), st.samples, st.skipped,
                 st.first_skip.empty() ? "" : " (first: ", st.first_skip.empty() ? "" : (st.first_skip + ")").c_str());
    if (!st.damage_report.empty())
      std::fprintf(stderr, "exoid identify: warning: %s: damaged log, its readable part used: %s\n", f.c_str(),
                   st.damage_report.c_str());
  }
  return true;
}

}  // namespace

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

bool runIdentify(const IdentifyRunOptions& o, IdentifyRun& run, std::string* error) {
  const auto t0 = std::chrono::steady_clock::now();
  Eigen::VectorXd held_phi;
  if (!resolveMethod(o, run.options, error) || !modelAndPrior(o, run, &held_phi, error)) return false;
  const Model& model = run.model;
  SourceOptions so = trainingSource(o);
  if (!o.only_links.empty()) so.held_phi = &held_phi;
  estimator::EffectSet effects;
  if (!o.effects_path.empty()) {
    if (!estimator::readEffects(o.effects_path, model, effects, error)) return false;
    Eigen::VectorXd probe = Eigen::VectorXd::Zero(model.nv);
    if (!estimator::correctMeasurement(model, effects, probe))
      return *error = o.effects_path + ": a time delay cannot be applied by identify (it needs the future of the torque)",
             false;
    so.effects = &effects;
  }
  estimator::AccumulatorOptions ao;
  ao.folds = o.folds;
  ao.threads = o.threads;
  ao.chunk = chunkSamples(o.data[0], o.chunk_s);
  estimator::LsqAccumulator train(model, run.base, ao);
  if (!load(o.data, so, train, run, error)) return false;
  train.flush();
  run.training_samples = train.samples();
  run.read_s = seconds(t0);
  std::unique_ptr<estimator::LsqAccumulator> val;
  if (!o.validate.empty()) {
    estimator::AccumulatorOptions va = ao;
    va.folds = 1;
    val = std::make_unique<estimator::LsqAccumulator>(model, run.base, va);
    if (!load(o.validate, validationSource(o, so), *val, run, error)) return false;
    val->flush();
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (!estimator::identify(train, model, run.prior, run.options, val.get(), run.result, error)) return false;
  run.solve_s = seconds(t1);
  return true;
}

}  // namespace exoid::tools
