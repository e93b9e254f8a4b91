#include "exoid/tools/study.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <atomic>
#include <mutex>
#include <thread>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/consistent.hpp"
#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/measurement.hpp"
#include "exoid/estimator/metrics.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/signal/filters.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::tools {

namespace {

using estimator::Method;
using estimator::Metrics;

using common::fail;

/// One scored estimate.
struct Row {
  std::string pipeline, range, method;
  double cutoff = 0.0;
  int prior = 0, z = 0, inconsistent = 0;
  Metrics val, test;
  bool has_test = false;
};

/// The training-only rank rules scored by the study (the first is the recommended one, Table II's column).
const char* kTrainingRules[] = {"jackknife", "cv", "cv-1se", "gcv"};

const char* kMetricNames[] = {"gen_force_rmse", "torque_rmse", "com_rmse_mm", "momentum_rmse", "estimation_error_pct",
                              "singular_values"};

double metricOf(const Row& r, int k) {
  switch (k) {
    case 0: return r.val.generalized_force_rmse;
    case 1: return r.val.joint_torque_rmse;
    case 2: return r.val.com_position_rmse_mm;
    case 3: return r.val.com_momentum_rmse;
    case 4: return r.val.estimation_error_percent;
    default: return r.z;
  }
}

/// Validation metrics from the ground-truth channel of a run: every stride-th tick, exact state, y from the
/// applied torques and the simulator's contact wrenches.
struct ScoredSample {
  State state;
  Eigen::VectorXd y, tau;  ///< generalized force [nv], applied joint torques [njoints]
  double t = 0.0;
};

/// A damaged log is refused unless allow_partial: false with *error naming the damage and *refused set
/// (runStudy's *damaged, the command's exit 3).
bool acceptLog(const std::string& path, const intake::RunLog& log, bool allow_partial, bool* refused,
               std::string* error) {
  if (log.intact() || allow_partial) return true;
  *refused = true;
  return fail(error, path + ": damaged log: " + log.damageReport() + " (--allow-partial reads the readable part)");
}

bool metricsFromRun(const Model& model, const std::string& path, int stride, bool allow_partial, std::string* damage,
                    bool* refused, estimator::MetricAccumulator& acc, std::string* error,
                    std::vector<ScoredSample>* keep = nullptr) {
  intake::RunLog log;
  std::string err;
  if (!intake::readRunLog(path, model.joint_names, log, &err)) return fail(error, path + ": " + err);
  if (!acceptLog(path, log, allow_partial, refused, error)) return false;
  *damage = log.damageReport();  // "" when intact
  if (log.truth.empty()) return fail(error, path + ": no EXO_TRUTH samples (needed for validation)");
  const int feet[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  if (feet[0] < 0 || feet[1] < 0) return fail(error, "model has no right_foot / left_foot body");
  Data data(model);
  Eigen::VectorXd y(model.nv);
  const ForcePlateSample* none[2] = {nullptr, nullptr};
  for (size_t k = 0; k < log.truth.size(); k += static_cast<size_t>(std::max(stride, 1))) {
    const GroundTruthSample& t = log.truth[k];
    estimator::MeasuredSample ms;
    estimator::measuredFromTruth(model, t, none, feet, ms);
    const State s = estimator::stateFromTruth(model, t);
    computeJointTorqueRegressor(model, data, s);
    generalizedForceFromMeasurements(model, data, s, ms.tau, ms.contact, ms.ncontacts, y);
    acc.add(s, data.K, y);
    if (keep) keep->push_back({s, y, ms.tau, ms.t});
  }
  acc.finish();
  if (acc.samples() == 0) return fail(error, path + ": no usable ground-truth sample");
  return true;
}

/// Chapter 4's realistic torque prediction (eq. 4.1) on a run: the encoders (noisy), their difference
/// filtered causally by a 2nd-order Butterworth (as the controller would in real time), the IMU orientation
/// and gyro, the ideal (simulator) accelerations as the desired ones, the torque sensors of the previous tick
/// for the ground reaction forces and of this tick as the measurement. Every stride-th tick is scored.
bool realisticFromRun(const Model& model, const std::string& path, int stride, double cutoff_hz, bool allow_partial,
                      bool* refused, estimator::MetricAccumulator& acc,
                      std::string* error) {  // damage: reported by metricsFromRun
  intake::RunLog log;
  std::string err;
  if (!intake::readRunLog(path, model.joint_names, log, &err)) return fail(error, path + ": " + err);
  if (!acceptLog(path, log, allow_partial, refused, error)) return false;
  std::map<int64_t, const GroundTruthSample*> truth;
  for (const GroundTruthSample& t : log.truth) truth.emplace(t.tick, &t);
  int soles[2] = {model.frameIndex("right_sole"), model.frameIndex("left_sole")};
  if (soles[0] < 0 || soles[1] < 0) return fail(error, "model has no right_sole / left_sole frame");
  LowPassFilter lp;
  lp.configure(model.njoints, cutoff_hz, 1000.0);
  Data data(model);
  State s = State::zero(model);
  Eigen::VectorXd q_prev, tau_prev, v_raw(model.njoints), v_f(model.njoints);
  Eigen::MatrixXd JgT(model.nv, 12);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model.nv);
  int64_t prev_tick = -1;
  long n = 0;
  for (const RobotStateSample& st : log.states) {
    const bool consecutive = prev_tick >= 0 && st.tick == prev_tick + 1;
    if (consecutive) {
      v_raw = (st.q - q_prev) / 1e-3;
      if (n == 0) lp.reset(v_raw);
      lp.filter(v_raw, v_f);
      const auto t = truth.find(st.tick);
      if (t != truth.end() && n % std::max(stride, 1) == 0) {
        s.q = st.q;
        s.v = v_f;
        s.a = t->second->a;
        s.base_orientation = st.imu_orientation;
        s.base_omega = st.imu_gyro;
        s.base_domega = t->second->base_domega;
        s.base_acceleration = t->second->base_acceleration;
        computeJointTorqueRegressor(model, data, s);
        for (int c = 0; c < 2; ++c) {
          const Model::Frame& f = model.frames[static_cast<size_t>(soles[c])];
          computePointJacobian(model, data, f.body, f.position, J);
          JgT.middleCols(6 * c, 6) = J.transpose();
        }
        acc.addRealistic(data.K, JgT, tau_prev, st.tau);
      }
      ++n;
    } else {
      n = 0;  // a gap restarts the filter
    }
    q_prev = st.q;
    tau_prev = st.tau;
    prev_tick = st.tick;
  }
  acc.finish();
  if (acc.realisticSamples() == 0) return fail(error, path + ": no consecutive EXO_STATE ticks with ground truth");
  return true;
}

Eigen::VectorXd randomPrior(const Model& model, const PriorRange& range, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-range.value, range.value);
  Eigen::VectorXd prior = model.phi;
  for (int i = 0; i < model.nInertialParams(); ++i)
    prior[i] = range.absolute ? model.phi[i] + u(rng) : model.phi[i] * (1.0 + u(rng));
  return prior;
}

std::string fmt(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : "inf";
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

/// The thesis's Table II: metric -> {(range, method) -> value}.
using ThesisTable = std::map<std::string, std::map<std::string, double>>;

bool readThesisTable(const std::string& path, ThesisTable& out, std::string* error) {
  std::ifstream in(path);
  if (!in) return fail(error, "cannot read " + path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("range,", 0) == 0) continue;
    std::stringstream ss(line);
    std::string range, method, metric, value;
    std::getline(ss, range, ',');
    std::getline(ss, method, ',');
    std::getline(ss, metric, ',');
    std::getline(ss, value, ',');
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (end == value.c_str()) return fail(error, path + ": bad value '" + value + "' in line '" + line + "'");
    out[metric][range + "|" + method] = v;
  }
  return true;
}

/// One study in progress: the inputs read once, the priors, what the jobs found, the time spent per step.
struct Study {
  const StudyOptions& o;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  Model model;
  BaseParameters base;
  std::vector<int> actuated;
  ThesisTable thesis;
  std::unique_ptr<estimator::MetricAccumulator> vm, tm;  ///< validation and (optional) test metrics
  std::vector<ScoredSample> vsamples;                     ///< the validation run's scored samples (series.csv)
  estimator::LsqFactor vfac;                              ///< the validation factor (the thesis's rank choice)
  /// Logs read in part (--allow-partial): path -> damage report, said once and written into both tables' reports.
  std::map<std::string, std::string> partial;
  bool refused_damaged = false;  ///< a log was refused as damaged (runStudy's *damaged)
  std::vector<std::vector<Eigen::VectorXd>> priors;       ///< per range, the random priors
  std::map<std::string, std::vector<estimator::MeasuredSample>> samples;  ///< the training run's, per pipeline
  std::vector<Row> rows;
  std::map<std::string, double> seconds;  ///< time spent per step (summed over the workers), reported at the end
  std::map<std::string, Eigen::VectorXd> first_prior;  ///< "pipeline|cutoff|range|method" -> estimate of prior 0
  std::mutex say_mutex;

  explicit Study(const StudyOptions& options) : o(options) {}
  /// A progress line, prefixed by the seconds since the start.
  void say(const std::string& s) const {
    if (!o.progress) return;
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char buf[32];
    std::snprintf(buf, sizeof(buf), "[%6.1f s] ", t);
    o.progress(buf + s);
  }
  void sayLocked(const std::string& line) {
    std::lock_guard<std::mutex> lock(say_mutex);
    say(line);
  }
  void notePartial(const std::string& path, const std::string& report) {
    if (report.empty() || partial.count(path)) return;
    partial[path] = report;
    say(path + ": damaged log, its readable part used: " + report);
  }
};

double since(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

/// The options, the run logs, the model, the output directory and the thesis's table, checked and read.
bool checkStudyInputs(Study& st, std::string* error) {
  const StudyOptions& o = st.o;
  if (o.priors < 1) return fail(error, "--priors must be >= 1");
  for (const std::string* f : {&o.train, &o.validation, &o.test})
    if (!f->empty() && !std::ifstream(*f)) return fail(error, "cannot read run log '" + *f + "'");
  std::string err;
  if (!buildModelFromUrdfFile(o.model_path, true, st.model, &err)) return fail(error, err);
  for (const std::string& p : o.pipelines)
    if (p != "thesis" && p != "sensors") return fail(error, "unknown pipeline '" + p + "' (thesis, sensors)");
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) return fail(error, "cannot create " + o.out_dir + ": " + ec.message());
  if (!o.thesis_table.empty() && !readThesisTable(o.thesis_table, st.thesis, error)) return false;
  st.base = computeBaseParameters(st.model);
  st.actuated = estimator::actuatedJoints(st.model);
  return true;
}

/// Validation (ideal) and test runs: metric forms, and the validation factor for the thesis's rank choice.
bool readValidationAndTest(Study& st, std::string* error) {
  const StudyOptions& o = st.o;
  const Model& model = st.model;
  st.say("reading the validation run " + o.validation);
  st.vm = std::make_unique<estimator::MetricAccumulator>(model, model.phi, st.actuated);
  std::string damage, err;
  bool* refused = &st.refused_damaged;
  if (!metricsFromRun(model, o.validation, o.stride, o.allow_partial, &damage, refused, *st.vm, error, &st.vsamples))
    return false;
  st.notePartial(o.validation, damage);
  if (!o.test.empty()) {
    st.say("reading the test run " + o.test);
    st.tm = std::make_unique<estimator::MetricAccumulator>(model, model.phi, st.actuated);
    if (!metricsFromRun(model, o.test, o.stride, o.allow_partial, &damage, refused, *st.tm, error)) return false;
    st.notePartial(o.test, damage);
    if (!realisticFromRun(model, o.test, o.stride, o.realistic_cutoff_hz, o.allow_partial, refused, *st.tm, error))
      return false;
  }
  SourceOptions vo;
  vo.pipeline = intake::LogPipeline::Truth;
  vo.allow_partial = o.allow_partial;
  estimator::AccumulatorOptions va;
  va.folds = 1;
  estimator::LsqAccumulator vacc(model, st.base, va);
  intake::InputStats vst;
  if (!accumulateFile(o.validation, model, vo, vacc, vst, &err))
    return st.refused_damaged = vst.refused_damaged, fail(error, err);
  st.notePartial(o.validation, vst.damage_report);
  vacc.flush();
  st.vfac = estimator::toStandard(vacc.mergedBase(), st.base.base_map);
  st.say("validation: " + std::to_string(vst.samples) + " samples (" + std::to_string(st.vm->samples()) +
         " scored, every " + std::to_string(o.stride) + "th)");
  return true;
}

/// The random priors (the same for every pipeline and cutoff), written to priors.csv so that every row can be
/// recomputed.
void drawPriors(Study& st) {
  const StudyOptions& o = st.o;
  st.priors.assign(o.ranges.size(), {});
  std::ofstream pf(o.out_dir + "/priors.csv");
  pf.precision(17);
  pf << "range,prior";
  for (const std::string& n : st.model.paramNames()) pf << "," << n;
  pf << "\n";
  for (size_t g = 0; g < o.ranges.size(); ++g) {
    const PriorRange& range = o.ranges[g];
    for (int i = 0; i < o.priors; ++i) {
      std::mt19937_64 rng(o.seed * 1000003ull + static_cast<uint64_t>(i) * 7919ull +
                          static_cast<uint64_t>(range.value * 1e6) + (range.absolute ? 17ull : 0ull));
      st.priors[g].push_back(randomPrior(st.model, range, rng));
      pf << range.name << "," << i;
      for (int k = 0; k < st.priors[g].back().size(); ++k) pf << "," << st.priors[g].back()[k];
      pf << "\n";
    }
  }
}

/// The training run's measured samples, read once per pipeline; every cutoff filters them anew.
bool readTraining(Study& st, std::string* error) {
  for (const std::string& pipe : st.o.pipelines) {
    SourceOptions so;
    so.pipeline = pipe == "thesis" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
    so.allow_partial = st.o.allow_partial;
    intake::InputStats stats;
    std::string err;
    const auto tr = std::chrono::steady_clock::now();
    if (!readSamples(st.o.train, st.model, so, st.samples[pipe], stats, &err))
      return st.refused_damaged = stats.refused_damaged, fail(error, err);
    st.notePartial(st.o.train, stats.damage_report);
    st.seconds["reading the training run"] += since(tr);
  }
  return true;
}

/// One (pipeline, cutoff): independent of the others, run by a worker, merged in order.
struct Job {
  std::string pipe;
  double cutoff = 0.0;
  std::vector<Row> rows;
  std::ostringstream sv, le;  ///< its lines of singular_values.csv and link_error.csv
  std::map<std::string, double> seconds;
  std::map<std::string, Eigen::VectorXd> first;
  std::string error;
};

/// The training factor of one job and what does not depend on the prior: the row-weighted factors (all folds,
/// each fold left out).
struct JobFactors {
  std::unique_ptr<estimator::LsqAccumulator> train;
  estimator::TrainingFactors plain, weighted;
};

/// Scores one estimate of prior i of a range: validation (and test) metrics, link estimation errors.
void scoreEstimate(const Study& st, Job& job, const PriorRange& range, int i, const std::string& method,
                   const Eigen::VectorXd& phi, int z) {
  const Model& model = st.model;
  Row r;
  r.pipeline = job.pipe;
  r.range = range.name;
  r.method = method;
  r.cutoff = job.cutoff;
  r.prior = i;
  r.z = z;
  r.inconsistent = countInconsistent(checkConsistency(model, phi));
  r.val = st.vm->evaluate(phi);
  if (st.tm) {
    r.test = st.tm->evaluate(phi);
    r.has_test = true;
  }
  job.rows.push_back(r);
  if (i == 0) job.first[job.pipe + "|" + fmt(job.cutoff) + "|" + range.name + "|" + method] = phi;
  if (method == "WLS-RC" || method == "WLS-RC-PC" || method == "OLS" || method == "Ref") {
    const Eigen::VectorXd e = estimator::linkEstimationErrorPercent(model, phi, model.phi);
    job.le << job.pipe << "," << job.cutoff << "," << range.name << "," << method << "," << i;
    for (int b = 0; b < model.nbodies; ++b) job.le << "," << e[b];
    job.le << "\n";
  }
}

/// The validation-ranked methods (OLS, WLS-R, WLS-C, WLS-RC) from one prior, scored; returns WLS-RC's scaled
/// problem and its rank in *rc, *z_rc.
void scoreValidationRanked(const Study& st, Job& job, const JobFactors& jf, const PriorRange& range, int i,
                           const Eigen::VectorXd& prior, estimator::ScaledProblem* rc, int* z_rc) {
  using estimator::Method;
  estimator::FillOptions fill;
  fill.absolute_prior = range.absolute;
  for (Method m : {Method::Ols, Method::WlsR, Method::WlsC, Method::WlsRC}) {
    const auto tp = std::chrono::steady_clock::now();
    const bool row_scaled = m == Method::WlsR || m == Method::WlsRC;
    const estimator::ScaledProblem sp =
        estimator::scaleProblem(row_scaled ? jf.weighted.all : jf.plain.all, st.model, prior, m, fill);
    const estimator::RankCurve curve = estimator::rankByValidation(sp, st.vfac);
    job.seconds["OLS/WLS-R/WLS-C/WLS-RC"] += since(tp);
    scoreEstimate(st, job, range, i, estimator::methodName(m), estimator::solveAtRank(sp, curve.best), curve.best);
    if (i == 0 && range.name == st.o.ranges.front().name) {
      for (int k = 0; k < sp.s.size(); ++k)
        job.sv << job.pipe << "," << job.cutoff << "," << estimator::methodName(m) << "," << k + 1 << "," << sp.s[k]
               << "," << curve.best << "\n";
    }
    if (m == Method::WlsRC) {
      *rc = sp;
      *z_rc = curve.best;
    }
  }
}

/// Every method from prior i of a range, scored: Ref (the prior), the validation-ranked ones, the training-only
/// rank choices (time-block cross-validation, minimum and paired one-standard-error; GCV; the jackknife cap;
/// docs/identification.md) and WLS-RC-PC.
void scorePrior(const Study& st, Job& job, const JobFactors& jf, const PriorRange& range, int i,
                const Eigen::VectorXd& prior) {
  scoreEstimate(st, job, range, i, "Ref", prior, 0);
  estimator::ScaledProblem rc;
  int z_rc = 0;
  scoreValidationRanked(st, job, jf, range, i, prior, &rc, &z_rc);
  estimator::FillOptions fill;
  fill.absolute_prior = range.absolute;
  std::pair<estimator::RankCurve, estimator::RankCurve> cv;  // one pass gives both cross-validation rules
  for (const char* rule : kTrainingRules) {
    auto tc = std::chrono::steady_clock::now();
    const std::string r = rule;
    estimator::RankCurve c;
    if (r == "jackknife") {
      c = estimator::rankByJackknife(jf.weighted, st.model, prior, range.value);
    } else if (r == "gcv") {
      c = estimator::rankByGcv(rc);
    } else {
      if (cv.first.score.empty()) cv = estimator::rankByCrossValidationBoth(jf.weighted, *jf.train, st.model, prior, fill);
      c = r == "cv" ? cv.first : cv.second;
    }
    job.seconds[r == "jackknife" || r == "gcv" ? "WLS-RC " + r + " rank choice" : "WLS-RC cv rank choices"] += since(tc);
    scoreEstimate(st, job, range, i, "WLS-RC (" + r + ")", estimator::solveAtRank(estimator::orderDirections(rc, c.order), c.best),
                  c.best);
  }
  estimator::ConsistentOptions co;
  co.max_iterations = st.o.pc_iterations;
  const auto tpc = std::chrono::steady_clock::now();
  const estimator::ConsistentResult pc =
      estimator::solveConsistentAtRank(st.model, rc, std::max(z_rc, 1), st.o.pc_nullspace, 1e-6, co);
  job.seconds["WLS-RC-PC"] += since(tpc);
  scoreEstimate(st, job, range, i, "WLS-RC-PC", pc.phi, z_rc);
}

/// One job: the training factor at its cutoff through its pipeline, then every prior of every range scored.
void runJob(Study& st, Job& job, int workers) {
  const StudyOptions& o = st.o;
  const std::string& pipe = job.pipe;
  SourceOptions so;
  so.pipeline = pipe == "thesis" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
  so.allow_partial = o.allow_partial;
  so.dataset.cutoff_hz = job.cutoff;
  if (pipe == "sensors" && o.parallel_filter) so.dataset.filter = estimator::FilterMode::Parallel;
  applyBaseSignals(o.base_signals, so);
  if (pipe == "thesis") {  // thesis III-E: encoder noise on q, filtered, differentiated
    so.dataset.encoder_noise = 9e-6;
    so.dataset.derive = true;
    so.dataset.noise_seed = o.seed;
  }
  estimator::AccumulatorOptions ao;
  ao.folds = 5;
  ao.chunk = 2000;
  ao.threads = workers > 1 ? 1 : 2;  // the workers already share the cores
  JobFactors jf;
  jf.train = std::make_unique<estimator::LsqAccumulator>(st.model, st.base, ao);
  intake::InputStats stats;
  std::string jerr;
  const auto ta = std::chrono::steady_clock::now();
  if (!accumulateSamples(st.samples.at(pipe), st.model, so, *jf.train, stats, &jerr)) {
    job.error = o.train + ": " + jerr;
    return;
  }
  jf.train->flush();
  job.seconds["training factor"] += since(ta);
  const std::string at = pipe + " pipeline, cutoff " + (job.cutoff > 0 ? fmt(job.cutoff) + " Hz" : std::string("none"));
  const estimator::SolePlacement& sp = stats.sole_placement;  // --sole-on-plate fit
  const std::string placed = sp.fitted || !sp.why_not.empty()
                                 ? ", the soles' common offset on their plates " + estimator::describeSolePlacement(sp)
                                 : std::string();
  st.sayLocked(at + ": " + std::to_string(stats.samples) + " training samples" + placed);
  // The row-weighted factors (all folds, each fold left out) do not depend on the prior: once per data set.
  const auto tf0 = std::chrono::steady_clock::now();
  jf.plain = estimator::trainingFactors(*jf.train, st.model, estimator::Method::Ols);
  jf.weighted = estimator::trainingFactors(*jf.train, st.model, estimator::Method::WlsRC);
  job.seconds["weighted factors"] += since(tf0);
  for (size_t g = 0; g < o.ranges.size(); ++g) {
    for (int i = 0; i < o.priors; ++i) scorePrior(st, job, jf, o.ranges[g], i, st.priors[g][static_cast<size_t>(i)]);
    st.sayLocked(at + ", prior " + o.ranges[g].name + ": " + std::to_string(o.priors) + " priors done");
  }
}

/// Every (pipeline, cutoff) job, run by o.threads workers, merged in order into st (rows, times, prior-0
/// estimates) and into singular_values.csv and link_error.csv.
bool runJobs(Study& st, std::string* error) {
  const StudyOptions& o = st.o;
  std::vector<std::unique_ptr<Job>> jobs;
  for (const std::string& pipe : o.pipelines)
    for (double cutoff : o.cutoffs) {
      jobs.push_back(std::make_unique<Job>());
      jobs.back()->pipe = pipe;
      jobs.back()->cutoff = cutoff;
    }
  const int workers = std::max(1, std::min(o.threads, static_cast<int>(jobs.size())));
  {
    std::atomic<size_t> next{0};
    auto worker = [&] {
      for (size_t k = next++; k < jobs.size(); k = next++) runJob(st, *jobs[k], workers);
    };
    std::vector<std::thread> pool;
    for (int w = 1; w < workers; ++w) pool.emplace_back(worker);
    worker();
    for (std::thread& t : pool) t.join();
  }
  std::ofstream sv(o.out_dir + "/singular_values.csv");
  sv << "pipeline,cutoff_hz,method,index,singular_value,z_validation\n";
  std::ofstream le(o.out_dir + "/link_error.csv");
  le << "pipeline,cutoff_hz,range,method,prior";
  for (const std::string& n : st.model.body_names) le << "," << n;
  le << "\n";
  for (const auto& job : jobs) {
    if (!job->error.empty()) return fail(error, job->error);
    st.rows.insert(st.rows.end(), job->rows.begin(), job->rows.end());
    sv << job->sv.str();
    le << job->le.str();
    for (const auto& [k, v] : job->seconds) st.seconds[k] += v;
    st.first_prior.insert(job->first.begin(), job->first.end());
  }
  return true;
}

/// results.csv: every estimate.
void writeResults(const Study& st) {
  std::ofstream f(st.o.out_dir + "/results.csv");
  f.precision(12);
  f << "pipeline,cutoff_hz,range,prior,method,z,inconsistent_links,gen_force_rmse,torque_rmse,com_rmse_mm,"
       "momentum_rmse,estimation_error_pct,test_gen_force_rmse,test_torque_rmse,test_com_rmse_mm,"
       "test_momentum_rmse,test_realistic_torque_rmse\n";
  for (const Row& r : st.rows)
    f << r.pipeline << "," << r.cutoff << "," << r.range << "," << r.prior << "," << r.method << "," << r.z << ","
      << r.inconsistent << "," << r.val.generalized_force_rmse << "," << r.val.joint_torque_rmse << ","
      << r.val.com_position_rmse_mm << "," << r.val.com_momentum_rmse << "," << r.val.estimation_error_percent
      << "," << (r.has_test ? r.test.generalized_force_rmse : NAN) << ","
      << (r.has_test ? r.test.joint_torque_rmse : NAN) << "," << (r.has_test ? r.test.com_position_rmse_mm : NAN)
      << "," << (r.has_test ? r.test.com_momentum_rmse : NAN) << ","
      << (r.has_test ? r.test.realistic_torque_rmse : NAN) << "\n";
}

/// Means over the priors per (pipeline, range, method, cutoff): Table C.1's cells.
struct Agg {
  double sum[6] = {0, 0, 0, 0, 0, 0};
  double realistic = 0.0;  ///< test run, eq. 4.1
  int n = 0, consistent_priors = 0;
};
using AggTable = std::map<std::string, Agg>;

std::string aggKey(const std::string& p, const std::string& r, const std::string& m, double c) {
  return p + "|" + r + "|" + m + "|" + fmt(c);
}

/// The methods in the tables' order.
std::vector<std::string> tableMethods() {
  std::vector<std::string> methods{"Ref", "OLS", "WLS-R", "WLS-C", "WLS-RC", "WLS-RC-PC"};
  for (const char* r : kTrainingRules) methods.push_back(std::string("WLS-RC (") + r + ")");
  return methods;
}

AggTable aggregate(const std::vector<Row>& rows) {
  AggTable c1;
  for (const Row& r : rows) {
    Agg& a = c1[aggKey(r.pipeline, r.range, r.method, r.cutoff)];
    for (int k = 0; k < 6; ++k) a.sum[k] += metricOf(r, k);
    a.n += 1;
    a.consistent_priors += r.inconsistent == 0 ? 1 : 0;
    a.realistic += r.has_test ? r.test.realistic_torque_rmse : NAN;
  }
  return c1;
}

/// table_c1.csv and table_c1.md: means over the priors per (pipeline, range, method, cutoff).
void writeTableC1(const Study& st, const AggTable& c1, const std::string& partial_note) {
  const StudyOptions& o = st.o;
  std::ofstream f(o.out_dir + "/table_c1.csv"), md(o.out_dir + "/table_c1.md");
  f << "pipeline,range,method,cutoff_hz,gen_force_rmse,torque_rmse,com_rmse_mm,momentum_rmse,"
       "estimation_error_pct,singular_values,all_links_consistent_pct,test_realistic_torque_rmse\n";
  md << "# Table C.1 analogue: means over " << o.priors << " priors (validation run)\n\n" << partial_note
     << "| pipeline | prior | method | cutoff (Hz) | gen. force RMSE | torque RMSE (N m) | CoM RMSE (mm) | "
        "CoM mom. RMSE | est. error (%) | sing. values | consistent (%) | realistic torque RMSE, test (N m) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& p : o.pipelines)
    for (const PriorRange& rg : o.ranges)
      for (const std::string& m : tableMethods())
        for (double c : o.cutoffs) {
          const auto it = c1.find(aggKey(p, rg.name, m, c));
          if (it == c1.end()) continue;
          const Agg& a = it->second;
          f << p << "," << rg.name << "," << m << "," << c;
          md << "| " << p << " | " << rg.name << " | " << m << " | " << (c > 0 ? fmt(c) : "none");
          for (int k = 0; k < 6; ++k) {
            f << "," << a.sum[k] / a.n;
            md << " | " << fmt(a.sum[k] / a.n);
          }
          f << "," << 100.0 * a.consistent_priors / a.n << "," << a.realistic / a.n << "\n";
          md << " | " << fmt(100.0 * a.consistent_priors / a.n) << " | " << fmt(a.realistic / a.n) << " |\n";
        }
}

/// Table II's cell: metric k of (pipeline, range, method) at its best cutoff (thesis V; the number of singular
/// values at the cutoff where the generalized force RMSE is best). *best_c: that cutoff (NaN: none).
double bestOverCutoffs(const Study& st, const AggTable& c1, const std::string& p, const std::string& range,
                       const std::string& m, int k, double* best_c) {
  const int by = k < 5 ? k : 0;
  double best = NAN;
  *best_c = NAN;
  for (double c : st.o.cutoffs) {
    const auto it = c1.find(aggKey(p, range, m, c));
    if (it == c1.end()) continue;
    const double v = it->second.sum[by] / it->second.n;
    if (std::isnan(best) || v < best) {
      best = v;
      *best_c = c;
    }
  }
  if (k == 5 && !std::isnan(*best_c)) {
    const Agg& a = c1.at(aggKey(p, range, m, *best_c));
    best = a.sum[5] / a.n;
  }
  return best;
}

/// table2.csv and table2.md: per (pipeline, range, method) the best mean over the cutoffs, per metric (thesis
/// V), the thesis's value beside it.
void writeTable2(const Study& st, const AggTable& c1, const std::string& partial_note) {
  const StudyOptions& o = st.o;
  const std::vector<std::string> methods = tableMethods();
  std::ofstream f(o.out_dir + "/table2.csv"), md(o.out_dir + "/table2.md");
  f << "pipeline,range,method,metric,value,best_cutoff_hz,thesis\n";
  md << "# Table II analogue: best mean over the cutoffs per metric (" << o.priors
     << " priors each), thesis value in brackets\n\n" << partial_note;
  const char* labels[] = {"Gen. force RMSE (N & N m)", "Torque RMSE (N m)", "CoM position RMSE (mm)",
                          "CoM momentum RMSE (N s & N m s)", "Avg. estimation error (%)", "Avg. singular values (#)"};
  for (const std::string& p : o.pipelines)
    for (const PriorRange& rg : o.ranges) {
      md << "## " << p << " pipeline, prior " << rg.name << "\n\n| metric |";
      for (const std::string& m : methods) md << " " << m << " |";
      md << "\n|---|";
      for (size_t k = 0; k < methods.size(); ++k) md << "---|";
      md << "\n";
      for (int k = 0; k < 6; ++k) {
        md << "| " << labels[k] << " |";
        for (const std::string& m : methods) {
          double best_c = NAN;
          const double best = bestOverCutoffs(st, c1, p, rg.name, m, k, &best_c);
          const auto tm_it = st.thesis.find(kMetricNames[k]);
          double th = NAN;
          if (tm_it != st.thesis.end()) {
            const auto v = tm_it->second.find(rg.name + "|" + m);
            if (v != tm_it->second.end()) th = v->second;
          }
          f << p << "," << rg.name << "," << m << "," << kMetricNames[k] << "," << best << "," << best_c << "," << th
            << "\n";
          md << " " << fmt(best) << (std::isnan(th) ? "" : " (" + fmt(th) + ")") << " |";
        }
        md << "\n";
      }
      md << "\n";
    }
}

/// One line of series.csv: the true, Ref and WLS-RC CoM (world), actuated joint torques (external forces known)
/// and centroidal momentum (about the true CoM, world axes) at one validation sample.
void writeSeriesRow(const Study& st, const ScoredSample& smp, const Eigen::VectorXd* const phis[3], DynamicsData& dyn,
                    std::ostream& f) {
  const Model& model = st.model;
  const Eigen::Matrix3d R = smp.state.base_orientation.toRotationMatrix();
  Eigen::Vector3d com[3];
  Eigen::Matrix<double, 6, 1> mom[3];
  Eigen::VectorXd tau[3];
  for (int w = 0; w < 3; ++w) {
    forwardKinematics(model, dyn.kin, smp.state);
    centroidal(model, *phis[w], dyn);
    com[w] = dyn.com;
    mom[w] = dyn.momentum_origin;
    // Predicted torque with the external forces known: K phi - (y - S^T f_a) on the actuated rows.
    rnea(model, *phis[w], dyn, smp.state);
    tau[w] = dyn.tau;
  }
  f << smp.t;
  for (int w = 0; w < 3; ++w) {
    const Eigen::Vector3d c = smp.state.base_position + R * com[w];
    f << "," << c.x() << "," << c.y() << "," << c.z();
  }
  for (int j : st.actuated) {
    const int row = model.jointRow(j);
    // y_row = f_a + (J^T f_e)_row: with f_e known the prediction is f_a = (K phi)_row - (y_row - f_a); for
    // "true" the applied torque itself.
    const double external = smp.y[row] - smp.tau[j];
    f << "," << smp.tau[j];
    for (int w = 1; w < 3; ++w) f << "," << tau[w][row] - external;
  }
  for (int w = 0; w < 3; ++w) {
    const Eigen::Vector3d k = R * (mom[w].head<3>() - com[0].cross(mom[w].tail<3>()));
    const Eigen::Vector3d pl = R * mom[w].tail<3>();
    f << "," << k.x() << "," << k.y() << "," << k.z() << "," << pl.x() << "," << pl.y() << "," << pl.z();
  }
  f << "\n";
}

/// series.csv: the thesis's Figs. 3-5 on the validation run: CoM position, joint torques (external forces known)
/// and centroidal momentum predicted by Ref and WLS-RC (prior 0 of the +-25 % range, or the first range), first
/// pipeline, at the cutoff with the best mean WLS-RC generalized force RMSE.
void writeSeries(const Study& st, const AggTable& c1) {
  const StudyOptions& o = st.o;
  const std::string pipe = o.pipelines.front();
  std::string rname = o.ranges.front().name;
  for (const PriorRange& rg : o.ranges)
    if (rg.name == "25%") rname = rg.name;
  double best = INFINITY, best_c = o.cutoffs.front();
  for (double c : o.cutoffs) {
    const auto it = c1.find(aggKey(pipe, rname, "WLS-RC", c));
    if (it != c1.end() && it->second.sum[0] / it->second.n < best) {
      best = it->second.sum[0] / it->second.n;
      best_c = c;
    }
  }
  const Eigen::VectorXd& ref = st.first_prior.at(pipe + "|" + fmt(best_c) + "|" + rname + "|Ref");
  const Eigen::VectorXd& rc = st.first_prior.at(pipe + "|" + fmt(best_c) + "|" + rname + "|WLS-RC");
  std::ofstream f(o.out_dir + "/series.csv");
  // Units and frames: docs/study.md (CoM world m; torques N m, external forces known; momentum about the
  // true CoM, world axes).
  f << "# " << pipe << " pipeline, prior " << rname << " #0, cutoff " << (best_c > 0 ? fmt(best_c) + " Hz" : "none")
    << "\nt";
  const char* who[] = {"true", "ref", "rc"};
  for (const char* w : who) f << ",com_x_" << w << ",com_y_" << w << ",com_z_" << w;
  for (int j : st.actuated)
    for (const char* w : who) f << ",tau_" << st.model.joint_names[j] << "_" << w;
  for (const char* w : who)
    for (const char* c : {"kx", "ky", "kz", "px", "py", "pz"}) f << ",mom_" << c << "_" << w;
  f << "\n";
  DynamicsData dyn(st.model);
  const Eigen::VectorXd* const phis[3] = {&st.model.phi, &ref, &rc};
  for (const ScoredSample& smp : st.vsamples) writeSeriesRow(st, smp, phis, dyn, f);
}

}  // namespace

bool runStudy(const StudyOptions& o, std::string* error, bool* damaged) {
  Study st(o);
  bool read = checkStudyInputs(st, error) && readValidationAndTest(st, error);
  if (read) {
    drawPriors(st);
    read = readTraining(st, error);
  }
  if (damaged) *damaged = st.refused_damaged;
  if (!read || !runJobs(st, error)) return false;
  writeResults(st);
  const AggTable c1 = aggregate(st.rows);
  std::string partial_note;  // the logs read in part, first in each report
  for (const auto& pr : st.partial) partial_note += "Read in part (--allow-partial): `" + pr.first + "`: " + pr.second + "\n\n";
  writeTableC1(st, c1, partial_note);
  writeTable2(st, c1, partial_note);
  writeSeries(st, c1);
  std::string timing = "time spent:";
  for (const auto& [k, v] : st.seconds) timing += " " + k + " " + fmt(v) + " s;";
  st.say(timing);
  st.say("wrote " + o.out_dir + "/{results,table_c1,table2,singular_values,link_error,series}.csv and the Markdown tables");
  return true;
}

}  // namespace exoid::tools
