#include "exoid/tools/identify_run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "exoid/common/strict_number.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/sole_tilt.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
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
  // --hold keeps the jackknife: the table's segments are within its +-25 % of a person, and it kept the horizontal CoM
  // better than 'full' on every shipped wearer (docs/wearer.md "Identify the wearer").
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

/// A model built from `path` that must be --model's robot: the same moving links and joints, in the same order.
bool sameRobot(const IdentifyRunOptions& o, const Model& model, const std::string& option, const std::string& path,
               Model& other, std::string* error) {
  if (!buildModelFromUrdfFile(path, !o.fixed_base, other, error)) return *error = option + ": " + *error, false;
  if (other.body_names != model.body_names || other.joint_names != model.joint_names)
    return *error = option + " " + path + ": not the robot of " + o.model_path +
                    " (its moving links or joints differ in name or order)",
           false;
  return true;
}

/// --model's links with an inertial that `held` does not have, summed per carrying link into `added` (one entry
/// per link, in body order; frames listed in --model's order).
void addedBodies(const Model& model, const Model& held, std::vector<AddedBody>& added, bool truth) {
  std::set<std::string> held_frames;
  for (const Model::Frame& f : held.frames) held_frames.insert(f.name);
  for (const Model::Frame& f : model.frames) {
    if (f.body < 0 || held_frames.count(f.name) > 0 || f.phi.isZero(0.0)) continue;
    auto it = std::find_if(added.begin(), added.end(), [&](const AddedBody& a) { return a.body == f.body; });
    if (it == added.end()) {
      if (truth) continue;  // the caller checks that the truth adds nothing elsewhere
      AddedBody a;
      a.body = f.body;
      a.held = held.phi.segment<kParamsPerBody>(held.bodyParamIndex(f.body));
      it = added.insert(std::upper_bound(added.begin(), added.end(), a,
                                         [](const AddedBody& x, const AddedBody& y) { return x.body < y.body; }),
                        a);
    }
    if (truth) {
      it->truth += f.phi;
      it->has_truth = true;
    } else {
      it->frames.push_back(f.name);
      it->prior += f.phi;
    }
  }
}

/// --hold (and --truth-model): the carrying links to identify (*links) and their prior, the held URDF's link plus
/// what --model adds to it; every other link's prior is the held URDF's (held there, as --only-links holds).
bool holdSplit(const IdentifyRunOptions& o, IdentifyRun& run, std::vector<std::string>* links, std::string* error) {
  const Model& model = run.model;
  if (!o.only_links.empty() || !o.prior_path.empty() || o.prior_perturb > 0.0)
    return *error = "--hold sets which links are identified and their prior: not with --only-links, --prior or "
                    "--prior-perturb",
           false;
  Model held;
  if (!sameRobot(o, model, "--hold", o.hold_path, held, error)) return false;
  addedBodies(model, held, run.added, false);
  if (run.added.empty())
    return *error = "--hold " + o.hold_path + ": " + o.model_path + " has no link with an inertial that it lacks: " +
                    "nothing to identify",
           false;
  run.prior.head(model.nInertialParams()) = held.phi.head(model.nInertialParams());
  for (const AddedBody& a : run.added) {
    run.prior.segment<kParamsPerBody>(model.bodyParamIndex(a.body)) += a.prior;
    links->push_back(model.body_names[static_cast<size_t>(a.body)]);
  }
  if (o.truth_model_path.empty()) return true;
  if (!sameRobot(o, model, "--truth-model", o.truth_model_path, run.truth_model, error)) return false;
  std::vector<AddedBody> everywhere;  // the truth's added bodies on any link
  addedBodies(run.truth_model, held, everywhere, false);
  for (const AddedBody& t : everywhere)
    if (std::none_of(run.added.begin(), run.added.end(), [&](const AddedBody& a) { return a.body == t.body; }))
      return *error = "--truth-model " + o.truth_model_path + " adds to link '" + model.body_names[t.body] +
                      "', which " + o.model_path + " leaves as --hold has it",
             false;
  addedBodies(run.truth_model, held, run.added, true);
  return true;
}

/// --com-height prior: the whole system's vertical first moment in base coordinates at the standing pose (q = 0),
///   c^T phi = sum_b m_b p_b,z + (R_b h_b)_z     (h_b = m_b c_b, the body's first moments in its own frame),
/// held at the prior's value by eliminating the base link's own h_z (c_j = 1 there: R_0 = I, p_0 = 0).
bool comHeightFunction(const IdentifyRunOptions& o, IdentifyRun& run, BaseParameterOptions& bo,
                       estimator::HeldFunction& f, std::string* error) {
  const Model& model = run.model;
  // The default holds it for a floating base only: a fixed base has no CoM to balance over.
  const bool hold = o.com_height == "prior" || (o.com_height.empty() && !o.hold_path.empty() && model.floating_base);
  if (!hold) return true;
  if (!model.floating_base) return *error = "--com-height prior needs a floating-base model", false;
  f.j = model.bodyParamIndex(0) + 3;
  if (!bo.held.empty() && bo.held[static_cast<size_t>(f.j)])
    return *error = "--com-height prior needs the base link '" + model.body_names[0] + "' identified (it takes up "
                    "the held height); add it to --only-links or use --com-height data",
           false;
  Data kin(model);
  forwardKinematics(model, kin, State::zero(model));
  f.c = Eigen::VectorXd::Zero(model.nparams());
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    f.c[i] = kin.p[static_cast<size_t>(b)].z();
    f.c.segment<3>(i + 1) = kin.R[static_cast<size_t>(b)].row(2).transpose();
  }
  f.value = f.c.dot(run.prior);
  if (bo.held.empty()) bo.held.assign(static_cast<size_t>(model.nparams()), false);
  bo.held[static_cast<size_t>(f.j)] = true;  // its column is zero after the elimination
  run.com_height_held = true;
  double mass = 0.0;
  for (int b = 0; b < model.nbodies; ++b) mass += run.prior[model.bodyParamIndex(b)];
  run.com_height_m = f.value / mass;
  return true;
}

/// The model, its prior (URDF, --prior, --prior-perturb) and the base parameters; --only-links (or --hold's
/// carrying links): every other link held at the prior (*held_phi: those parameters, taken off y; empty otherwise);
/// --com-height prior: *height (j < 0 otherwise).
bool modelAndPrior(const IdentifyRunOptions& o, IdentifyRun& run, Eigen::VectorXd* held_phi,
                   estimator::HeldFunction* height, std::string* error) {
  Model& model = run.model;
  if (!buildModelFromUrdfFile(o.model_path, !o.fixed_base, model, error)) return false;
  run.prior = model.phi;
  if (!o.prior_path.empty() && !readPrior(o.prior_path, model, run.prior, error)) return false;
  if (o.prior_perturb > 0.0) {
    std::mt19937_64 rng(o.prior_seed);
    std::uniform_real_distribution<double> u(-o.prior_perturb, o.prior_perturb);
    for (int i = 0; i < run.prior.size(); ++i) run.prior[i] *= 1.0 + u(rng);
  }
  std::vector<std::string> only_links = o.only_links;
  if (!o.hold_path.empty() && !holdSplit(o, run, &only_links, error)) return false;
  if (o.hold_path.empty() && !o.truth_model_path.empty() &&
      !sameRobot(o, model, "--truth-model", o.truth_model_path, run.truth_model, error))
    return false;
  BaseParameterOptions bo;
  if (!only_links.empty()) {
    bo.held.assign(static_cast<size_t>(model.nparams()), false);
    for (int i = 0; i < model.nInertialParams(); ++i) bo.held[static_cast<size_t>(i)] = true;
    for (const std::string& name : only_links) {
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
  if (!comHeightFunction(o, run, bo, *height, error)) return false;
  const auto& sp = o.base_signals.sole_on_plate;
  if (!model.floating_base && (o.base_signals.fit_sole_placement || !sp[0].isZero() || !sp[1].isZero()))
    return *error = "--sole-on-plate: a fixed-base robot has no soles on plates", false;
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
  applyBaseSignals(o.base_signals, so);
  so.dataset.encoder_noise = o.noise;
  so.dataset.noise_seed = o.seed;
  so.skip_bad_rows = o.skip_bad_rows;
  so.allow_partial = o.allow_partial;
  so.base_rows_only = baseRowsOnly(o);
  return so;
}

/// The validation data's: as recorded, no effects, no added noise. Truth-pipeline logs are ideal (thesis IV-A) and
/// stay unfiltered; measured validation data (sensors-pipeline logs, CSV) carry the training data's noise and get
/// its filter (unfiltered, twice-differenced encoders drown the held-out RMSE and the rank chosen with it).
SourceOptions validationSource(const IdentifyRunOptions& o, const SourceOptions& training) {
  SourceOptions vo = training;
  vo.effects = nullptr;
  vo.base_rows_only = false;  // the held-out error is every row's
  vo.pipeline = (o.validate_pipeline.empty() ? "truth" : o.validate_pipeline) == "truth" ? intake::LogPipeline::Truth
                                                                                         : intake::LogPipeline::Sensors;
  vo.dataset.encoder_noise = 0.0;
  applyBaseSignals(o.base_signals, vo);
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
    if (st.sole_tilt.fitted || st.sole_tilt.samples > 0)
      std::fprintf(stderr, "exoid identify: %s: the soles' tilt from the plates: %s\n", f.c_str(),
                   estimator::describeSoleTilt(st.sole_tilt).c_str());
    if (const estimator::SolePlacement& sp = st.sole_placement; sp.fitted || !sp.why_not.empty())
      std::fprintf(stderr, "exoid identify: %s: the soles' common offset on their plates, %s; %s\n", f.c_str(),
                   estimator::describeSolePlacement(sp).c_str(),
                   sp.fitted ? "added to the declared placement" : "the declared placement used");
    if (!st.damage_report.empty())
      std::fprintf(stderr, "exoid identify: warning: %s: damaged log, its readable part used: %s\n", f.c_str(),
                   st.damage_report.c_str());
  }
  return true;
}

/// run.system_com over the validation LCM logs that carry a truth channel (CSVs and logs without one: skipped; a log
/// the run-log reader refuses, which --allow-partial let through: skipped with a warning).
void systemComCheck(const IdentifyRunOptions& o, IdentifyRun& run) {
  const Model& model = run.model;
  const bool truth = run.truth_model.nbodies > 0;
  DynamicsData dyn(model);
  double sq[3] = {0.0, 0.0, 0.0}, sq_xy[3] = {0.0, 0.0, 0.0};
  SystemComCheck& c = run.system_com;
  for (const std::string& f : o.validate) {
    if (isCsvPath(f)) continue;
    intake::RunLog log;
    std::string why;
    if (!intake::readRunLog(f, model.joint_names, log, &why)) {  // a damaged log read with --allow-partial
      std::fprintf(stderr, "exoid identify: warning: %s: no system CoM check (%s)\n", f.c_str(), why.c_str());
      continue;
    }
    for (const GroundTruthSample& t : log.truth) {
      forwardKinematics(model, dyn.kin, estimator::stateFromTruth(model, t));
      const Eigen::Matrix3d R = t.base_orientation.toRotationMatrix();
      const Eigen::VectorXd* phis[3] = {&run.prior, &run.result.phi, truth ? &run.truth_model.phi : nullptr};
      for (int m = 0; m < 3; ++m) {
        if (!phis[m]) continue;
        centroidal(model, *phis[m], dyn);
        const Eigen::Vector3d d = t.base_position + R * dyn.com - t.com;
        const double e = d.norm();
        sq[m] += e * e;
        sq_xy[m] += d.head<2>().squaredNorm();
        if (m == 1) c.identified_max_m = std::max(c.identified_max_m, e);
      }
      ++c.samples;
    }
  }
  if (c.samples == 0) return;
  double* rmse[3] = {&c.prior_rmse_m, &c.identified_rmse_m, &c.truth_model_rmse_m};
  double* rmse_xy[3] = {&c.prior_rmse_xy_m, &c.identified_rmse_xy_m, &c.truth_model_rmse_xy_m};
  for (int m = 0; m < (truth ? 3 : 2); ++m) {
    *rmse[m] = std::sqrt(sq[m] / c.samples);
    *rmse_xy[m] = std::sqrt(sq_xy[m] / c.samples);
  }
}

}  // namespace

bool baseRowsOnly(const IdentifyRunOptions& o) {
  return o.rows == "base" || (o.rows.empty() && !o.hold_path.empty() && !o.fixed_base);
}

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
  estimator::HeldFunction height;
  if (!resolveMethod(o, run.options, error) || !modelAndPrior(o, run, &held_phi, &height, error)) return false;
  const Model& model = run.model;
  SourceOptions so = trainingSource(o);
  if (held_phi.size() > 0) so.held_phi = &held_phi;
  if (height.j >= 0) so.held_function = &height;
  run.options.held_function = height;
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
  // The default rank rule's processing term: the same training data under each other processing choice.
  std::vector<std::unique_ptr<estimator::LsqAccumulator>> alternatives;
  std::vector<const estimator::LsqAccumulator*> processing;
  if (run.options.rank_rule == estimator::RankRule::Jackknife && !o.no_processing_check) {
    bool logs = model.floating_base;
    for (const std::string& f : o.data) logs = logs && !isCsvPath(f);
    for (const ProcessingAlternative& alt : processingAlternatives(so, logs)) {
      alternatives.push_back(std::make_unique<estimator::LsqAccumulator>(model, run.base, ao));
      for (const std::string& f : o.data) {
        intake::InputStats st;  // the files were read (and reported) above
        if (!accumulateFile(f, model, alt.source, *alternatives.back(), st, error)) return false;
      }
      alternatives.back()->flush();
      processing.push_back(alternatives.back().get());
      run.processing_checked.push_back(alt.what);
    }
    run.read_s = seconds(t0);
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (!estimator::identify(train, model, run.prior, run.options, val.get(), run.result, error, processing)) return false;
  run.solve_s = seconds(t1);
  std::vector<bool> excited(static_cast<size_t>(model.nparams()), true);
  for (int i : run.result.unexcited) excited[static_cast<size_t>(i)] = false;
  for (int i : run.result.weakly_excited) excited[static_cast<size_t>(i)] = false;
  for (AddedBody& a : run.added) {
    const int i0 = model.bodyParamIndex(a.body);
    a.identified = run.result.phi.segment<kParamsPerBody>(i0) - a.held;
    for (int k = 0; k < kParamsPerBody; ++k) a.excited += excited[static_cast<size_t>(i0 + k)] ? 1 : 0;
  }
  systemComCheck(o, run);
  return true;
}

}  // namespace exoid::tools
