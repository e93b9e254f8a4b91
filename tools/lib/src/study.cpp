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
#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/signal/filters.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/intake/run_log.hpp"

namespace exoid::tools {

namespace {

using estimator::Method;
using estimator::Metrics;

bool fail(std::string* error, const std::string& msg) {
  if (error) *error = msg;
  return false;
}

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

bool metricsFromRun(const Model& model, const std::string& path, int stride, bool allow_partial, std::string* damage,
                    estimator::MetricAccumulator& acc, std::string* error, std::vector<ScoredSample>* keep = nullptr) {
  intake::RunLog log;
  std::string err;
  if (!intake::readRunLog(path, model.joint_names, log, &err)) return fail(error, path + ": " + err);
  if (!log.intact() && !allow_partial)
    return fail(error, path + ": damaged log: " + log.damageReport() + " (--allow-partial reads the readable part)");
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
                      estimator::MetricAccumulator& acc, std::string* error) {  // damage: reported by metricsFromRun
  intake::RunLog log;
  std::string err;
  if (!intake::readRunLog(path, model.joint_names, log, &err)) return fail(error, path + ": " + err);
  if (!log.intact() && !allow_partial)
    return fail(error, path + ": damaged log: " + log.damageReport() + " (--allow-partial reads the readable part)");
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

}  // namespace

bool runStudy(const StudyOptions& o, std::string* error) {
  const auto t0 = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (o.progress) {
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char buf[32];
      std::snprintf(buf, sizeof(buf), "[%6.1f s] ", t);
      o.progress(buf + s);
    }
  };
  if (o.priors < 1) return fail(error, "--priors must be >= 1");
  for (const std::string* f : {&o.train, &o.validation, &o.test})
    if (!f->empty() && !std::ifstream(*f)) return fail(error, "cannot read run log '" + *f + "'");
  Model model;
  std::string err;
  if (!buildModelFromUrdfFile(o.model_path, true, model, &err)) return fail(error, err);
  for (const std::string& p : o.pipelines)
    if (p != "thesis" && p != "sensors") return fail(error, "unknown pipeline '" + p + "' (thesis, sensors)");
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) return fail(error, "cannot create " + o.out_dir + ": " + ec.message());
  ThesisTable thesis;
  if (!o.thesis_table.empty() && !readThesisTable(o.thesis_table, thesis, error)) return false;

  const BaseParameters base = computeBaseParameters(model);
  const std::vector<int> actuated = estimator::actuatedJoints(model);
  // Validation (ideal) and test runs: metric forms, and the validation factor for the thesis's rank choice.
  say("reading the validation run " + o.validation);
  estimator::MetricAccumulator vm(model, model.phi, actuated);
  std::vector<ScoredSample> vsamples;
  // Logs read in part (--allow-partial): path -> damage report, said now and written into both tables' reports.
  std::map<std::string, std::string> partial;
  auto notePartial = [&](const std::string& path, const std::string& report) {
    if (report.empty() || partial.count(path)) return;
    partial[path] = report;
    say(path + ": damaged log, its readable part used: " + report);
  };
  std::string damage;
  if (!metricsFromRun(model, o.validation, o.stride, o.allow_partial, &damage, vm, error, &vsamples)) return false;
  notePartial(o.validation, damage);
  std::unique_ptr<estimator::MetricAccumulator> tm;
  if (!o.test.empty()) {
    say("reading the test run " + o.test);
    tm = std::make_unique<estimator::MetricAccumulator>(model, model.phi, actuated);
    if (!metricsFromRun(model, o.test, o.stride, o.allow_partial, &damage, *tm, error)) return false;
    notePartial(o.test, damage);
    if (!realisticFromRun(model, o.test, o.stride, o.realistic_cutoff_hz, o.allow_partial, *tm, error)) return false;
  }
  SourceOptions vo;
  vo.pipeline = LogPipeline::Truth;
  vo.allow_partial = o.allow_partial;
  estimator::AccumulatorOptions va;
  va.folds = 1;
  estimator::LsqAccumulator vacc(model, base, va);
  InputStats vst;
  if (!accumulateFile(o.validation, model, vo, vacc, vst, &err)) return fail(error, err);
  notePartial(o.validation, vst.damage_report);
  vacc.flush();
  const estimator::LsqFactor vfac = estimator::toStandard(vacc.mergedBase(), base.base_map);
  say("validation: " + std::to_string(vst.samples) + " samples (" + std::to_string(vm.samples()) +
      " scored, every " + std::to_string(o.stride) + "th)");

  std::vector<Row> rows;
  std::map<std::string, double> seconds;  ///< time spent per step (summed over the workers), reported at the end
  auto clock = [] { return std::chrono::steady_clock::now(); };
  auto since = [](std::chrono::steady_clock::time_point a) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
  };
  std::map<std::string, Eigen::VectorXd> first_prior;  ///< "pipeline|cutoff|range|method" -> estimate of prior 0
  // The random priors (the same for every pipeline and cutoff), written so that every row can be recomputed.
  std::vector<std::vector<Eigen::VectorXd>> priors(o.ranges.size());
  {
    std::ofstream pf(o.out_dir + "/priors.csv");
    pf.precision(17);
    pf << "range,prior";
    for (const std::string& n : model.paramNames()) pf << "," << n;
    pf << "\n";
    for (size_t g = 0; g < o.ranges.size(); ++g) {
      const PriorRange& range = o.ranges[g];
      for (int i = 0; i < o.priors; ++i) {
        std::mt19937_64 rng(o.seed * 1000003ull + static_cast<uint64_t>(i) * 7919ull +
                            static_cast<uint64_t>(range.value * 1e6) + (range.absolute ? 17ull : 0ull));
        priors[g].push_back(randomPrior(model, range, rng));
        pf << range.name << "," << i;
        for (int k = 0; k < priors[g].back().size(); ++k) pf << "," << priors[g].back()[k];
        pf << "\n";
      }
    }
  }
  // The training run's measured samples, read once per pipeline; every cutoff filters them anew.
  std::map<std::string, std::vector<estimator::MeasuredSample>> samples;
  for (const std::string& pipe : o.pipelines) {
    SourceOptions so;
    so.pipeline = pipe == "thesis" ? LogPipeline::Truth : LogPipeline::Sensors;
    so.allow_partial = o.allow_partial;
    InputStats st;
    const auto tr = clock();
    if (!readSamples(o.train, model, so, samples[pipe], st, &err)) return fail(error, err);
    notePartial(o.train, st.damage_report);
    seconds["reading the training run"] += since(tr);
  }
  // One job per (pipeline, cutoff), independent of the others: run by o.threads workers, merged in order.
  struct Job {
    std::string pipe;
    double cutoff = 0.0;
    std::vector<Row> rows;
    std::ostringstream sv, le;
    std::map<std::string, double> seconds;
    std::map<std::string, Eigen::VectorXd> first;
    std::string error;
  };
  std::vector<std::unique_ptr<Job>> jobs;
  for (const std::string& pipe : o.pipelines)
    for (double cutoff : o.cutoffs) {
      jobs.push_back(std::make_unique<Job>());
      jobs.back()->pipe = pipe;
      jobs.back()->cutoff = cutoff;
    }
  const int workers = std::max(1, std::min(o.threads, static_cast<int>(jobs.size())));
  std::mutex say_mutex;
  auto sayLocked = [&](const std::string& line) {
    std::lock_guard<std::mutex> lock(say_mutex);
    say(line);
  };
  auto runJob = [&](Job& job) {
    const std::string& pipe = job.pipe;
    const double cutoff = job.cutoff;
    auto& seconds = job.seconds;
    auto& sv = job.sv;
    auto& le = job.le;
    SourceOptions so;
    so.pipeline = pipe == "thesis" ? LogPipeline::Truth : LogPipeline::Sensors;
    so.allow_partial = o.allow_partial;
    so.dataset.cutoff_hz = cutoff;
    if (pipe == "sensors" && o.parallel_filter) so.dataset.filter = estimator::FilterMode::Parallel;
    so.dataset.orientation_from_legs = pipe == "sensors" && o.orientation_from_legs;
    so.dataset.orientation_cutoff_hz = o.orientation_cutoff_hz;
    if (pipe == "thesis") {  // thesis III-E: encoder noise on q, filtered, differentiated
      so.dataset.encoder_noise = 9e-6;
      so.dataset.derive = true;
      so.dataset.noise_seed = o.seed;
    }
    estimator::AccumulatorOptions ao;
    ao.folds = 5;
    ao.chunk = 2000;
    ao.threads = workers > 1 ? 1 : 2;  // the workers already share the cores
    estimator::LsqAccumulator train(model, base, ao);
    InputStats st;
    std::string jerr;
    const auto ta = clock();
    if (!accumulateSamples(samples.at(pipe), model, so, train, st, &jerr)) {
      job.error = o.train + ": " + jerr;
      return;
    }
    train.flush();
    seconds["training factor"] += since(ta);
    sayLocked(pipe + " pipeline, cutoff " + (cutoff > 0 ? fmt(cutoff) + " Hz" : std::string("none")) + ": " +
              std::to_string(st.samples) + " training samples");
    // The row-weighted factors (all folds, each fold left out) do not depend on the prior: once per data set.
    const auto tf0 = clock();
    const estimator::TrainingFactors plain = estimator::trainingFactors(train, model, Method::Ols);
    const estimator::TrainingFactors weighted = estimator::trainingFactors(train, model, Method::WlsRC);
    seconds["weighted factors"] += since(tf0);
    for (size_t g = 0; g < o.ranges.size(); ++g) {
      const PriorRange& range = o.ranges[g];
      estimator::FillOptions fill;
      fill.absolute_prior = range.absolute;
      for (int i = 0; i < o.priors; ++i) {
        const Eigen::VectorXd& prior = priors[g][static_cast<size_t>(i)];
        auto score = [&](const std::string& method, const Eigen::VectorXd& phi, int z) {
          Row r;
          r.pipeline = pipe;
          r.range = range.name;
          r.method = method;
          r.cutoff = cutoff;
          r.prior = i;
          r.z = z;
          r.inconsistent = countInconsistent(checkConsistency(model, phi));
          r.val = vm.evaluate(phi);
          if (tm) {
            r.test = tm->evaluate(phi);
            r.has_test = true;
          }
          job.rows.push_back(r);
          if (i == 0) job.first[pipe + "|" + fmt(cutoff) + "|" + range.name + "|" + method] = phi;
          if (method == "WLS-RC" || method == "WLS-RC-PC" || method == "OLS" || method == "Ref") {
            const Eigen::VectorXd e = estimator::linkEstimationErrorPercent(model, phi, model.phi);
            le << pipe << "," << cutoff << "," << range.name << "," << method << "," << i;
            for (int b = 0; b < model.nbodies; ++b) le << "," << e[b];
            le << "\n";
          }
        };
        score("Ref", prior, 0);
        estimator::ScaledProblem rc;
        int z_rc = 0;
        for (Method m : {Method::Ols, Method::WlsR, Method::WlsC, Method::WlsRC}) {
          const auto tp = clock();
          const bool row_scaled = m == Method::WlsR || m == Method::WlsRC;
          const estimator::ScaledProblem sp =
              estimator::prepare(row_scaled ? weighted.all : plain.all, model, prior, m, fill);
          const estimator::RankCurve curve = estimator::rankByValidation(sp, vfac);
          seconds["OLS/WLS-R/WLS-C/WLS-RC"] += since(tp);
          score(estimator::methodName(m), estimator::solveAtRank(sp, curve.best), curve.best);
          if (i == 0 && range.name == o.ranges.front().name) {
            for (int k = 0; k < sp.s.size(); ++k)
              sv << pipe << "," << cutoff << "," << estimator::methodName(m) << "," << k + 1 << "," << sp.s[k]
                 << "," << curve.best << "\n";
          }
          if (m == Method::WlsRC) {
            rc = sp;
            z_rc = curve.best;
          }
        }
        // The training-only rank choices (no ideal data), each scored: time-block cross-validation (minimum
        // and paired one-standard-error), GCV and the jackknife cap (docs/identification.md).
        std::pair<estimator::RankCurve, estimator::RankCurve> cv;  // one pass gives both cross-validation rules
        for (const char* rule : kTrainingRules) {
          auto tc = clock();
          const std::string r = rule;
          estimator::RankCurve c;
          if (r == "jackknife") {
            c = estimator::rankByJackknife(weighted, model, prior, range.value);
          } else if (r == "gcv") {
            c = estimator::rankByGcv(rc);
          } else {
            if (cv.first.score.empty()) cv = estimator::rankByCrossValidationBoth(weighted, train, model, prior, fill);
            c = r == "cv" ? cv.first : cv.second;
          }
          seconds[r == "jackknife" || r == "gcv" ? "WLS-RC " + r + " rank choice" : "WLS-RC cv rank choices"] += since(tc);
          score("WLS-RC (" + r + ")", estimator::solveAtRank(rc, c.best), c.best);
        }
        estimator::ConsistentOptions co;
        co.max_iterations = o.pc_iterations;
        const auto tpc = clock();
        const estimator::ConsistentResult pc = estimator::solveConsistentAtRank(model, rc, std::max(z_rc, 1),
                                                                                o.pc_nullspace, 1e-6, co);
        seconds["WLS-RC-PC"] += since(tpc);
        score("WLS-RC-PC", pc.phi, z_rc);
      }
      sayLocked(pipe + " pipeline, cutoff " + (cutoff > 0 ? fmt(cutoff) + " Hz" : std::string("none")) + ", prior " +
                range.name + ": " + std::to_string(o.priors) + " priors done");
    }
  };
  {
    std::atomic<size_t> next{0};
    auto worker = [&] {
      for (size_t k = next++; k < jobs.size(); k = next++) runJob(*jobs[k]);
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
  for (const std::string& n : model.body_names) le << "," << n;
  le << "\n";
  for (const auto& job : jobs) {
    if (!job->error.empty()) return fail(error, job->error);
    rows.insert(rows.end(), job->rows.begin(), job->rows.end());
    sv << job->sv.str();
    le << job->le.str();
    for (const auto& [k, v] : job->seconds) seconds[k] += v;
    first_prior.insert(job->first.begin(), job->first.end());
  }

  // Every estimate.
  {
    std::ofstream f(o.out_dir + "/results.csv");
    f.precision(12);
    f << "pipeline,cutoff_hz,range,prior,method,z,inconsistent_links,gen_force_rmse,torque_rmse,com_rmse_mm,"
         "momentum_rmse,estimation_error_pct,test_gen_force_rmse,test_torque_rmse,test_com_rmse_mm,"
         "test_momentum_rmse,test_realistic_torque_rmse\n";
    for (const Row& r : rows)
      f << r.pipeline << "," << r.cutoff << "," << r.range << "," << r.prior << "," << r.method << "," << r.z << ","
        << r.inconsistent << "," << r.val.generalized_force_rmse << "," << r.val.joint_torque_rmse << ","
        << r.val.com_position_rmse_mm << "," << r.val.com_momentum_rmse << "," << r.val.estimation_error_percent
        << "," << (r.has_test ? r.test.generalized_force_rmse : NAN) << ","
        << (r.has_test ? r.test.joint_torque_rmse : NAN) << "," << (r.has_test ? r.test.com_position_rmse_mm : NAN)
        << "," << (r.has_test ? r.test.com_momentum_rmse : NAN) << ","
        << (r.has_test ? r.test.realistic_torque_rmse : NAN) << "\n";
  }
  // Table C.1: means over the priors per (pipeline, range, method, cutoff).
  struct Agg {
    double sum[6] = {0, 0, 0, 0, 0, 0};
    double realistic = 0.0;  ///< test run, eq. 4.1
    int n = 0, consistent_priors = 0;
  };
  std::map<std::string, Agg> c1;
  std::vector<std::string> methods{"Ref", "OLS", "WLS-R", "WLS-C", "WLS-RC", "WLS-RC-PC"};
  for (const char* r : kTrainingRules) methods.push_back(std::string("WLS-RC (") + r + ")");
  auto key = [](const std::string& p, const std::string& r, const std::string& m, double c) {
    return p + "|" + r + "|" + m + "|" + fmt(c);
  };
  for (const Row& r : rows) {
    Agg& a = c1[key(r.pipeline, r.range, r.method, r.cutoff)];
    for (int k = 0; k < 6; ++k) a.sum[k] += metricOf(r, k);
    a.n += 1;
    a.consistent_priors += r.inconsistent == 0 ? 1 : 0;
    a.realistic += r.has_test ? r.test.realistic_torque_rmse : NAN;
  }
  std::string partialNote;  // the logs read in part, first in each report
  for (const auto& pr : partial) partialNote += "Read in part (--allow-partial): `" + pr.first + "`: " + pr.second + "\n\n";
  {
    std::ofstream f(o.out_dir + "/table_c1.csv"), md(o.out_dir + "/table_c1.md");
    f << "pipeline,range,method,cutoff_hz,gen_force_rmse,torque_rmse,com_rmse_mm,momentum_rmse,"
         "estimation_error_pct,singular_values,all_links_consistent_pct,test_realistic_torque_rmse\n";
    md << "# Table C.1 analogue: means over " << o.priors << " priors (validation run)\n\n" << partialNote
       << "| pipeline | prior | method | cutoff (Hz) | gen. force RMSE | torque RMSE (N m) | CoM RMSE (mm) | "
          "CoM mom. RMSE | est. error (%) | sing. values | consistent (%) | realistic torque RMSE, test (N m) |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& p : o.pipelines)
      for (const PriorRange& rg : o.ranges)
        for (const std::string& m : methods)
          for (double c : o.cutoffs) {
            const auto it = c1.find(key(p, rg.name, m, c));
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
  // Table II: per (pipeline, range, method) the best mean over the cutoffs, per metric (thesis V).
  {
    std::ofstream f(o.out_dir + "/table2.csv"), md(o.out_dir + "/table2.md");
    f << "pipeline,range,method,metric,value,best_cutoff_hz,thesis\n";
    md << "# Table II analogue: best mean over the cutoffs per metric (" << o.priors
       << " priors each), thesis value in brackets\n\n" << partialNote;
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
            // Metrics 0-4: the best cutoff for that metric (thesis V). The number of singular values is
            // reported at the cutoff where the generalized force RMSE is best.
            const int by = k < 5 ? k : 0;
            double best = NAN, best_c = NAN;
            for (double c : o.cutoffs) {
              const auto it = c1.find(key(p, rg.name, m, c));
              if (it == c1.end()) continue;
              const double v = it->second.sum[by] / it->second.n;
              if (std::isnan(best) || v < best) {
                best = v;
                best_c = c;
              }
            }
            if (k == 5 && !std::isnan(best_c)) {
              const Agg& a = c1.at(key(p, rg.name, m, best_c));
              best = a.sum[5] / a.n;
            }
            const auto tm_it = thesis.find(kMetricNames[k]);
            double th = NAN;
            if (tm_it != thesis.end()) {
              const auto v = tm_it->second.find(rg.name + "|" + m);
              if (v != tm_it->second.end()) th = v->second;
            }
            f << p << "," << rg.name << "," << m << "," << kMetricNames[k] << "," << best << "," << best_c << ","
              << th << "\n";
            md << " " << fmt(best) << (std::isnan(th) ? "" : " (" + fmt(th) + ")") << " |";
          }
          md << "\n";
        }
        md << "\n";
      }
  }
  // Time series of the thesis's Figs. 3-5 on the validation run: CoM position, joint torques (external
  // forces known) and centroidal momentum predicted by Ref and WLS-RC (prior 0 of the +-25 % range, or the
  // first range), first pipeline, at the cutoff with the best mean WLS-RC generalized force RMSE.
  {
    const std::string pipe = o.pipelines.front();
    std::string rname = o.ranges.front().name;
    for (const PriorRange& rg : o.ranges)
      if (rg.name == "25%") rname = rg.name;
    double best = INFINITY, best_c = o.cutoffs.front();
    for (double c : o.cutoffs) {
      const auto it = c1.find(key(pipe, rname, "WLS-RC", c));
      if (it != c1.end() && it->second.sum[0] / it->second.n < best) {
        best = it->second.sum[0] / it->second.n;
        best_c = c;
      }
    }
    const Eigen::VectorXd& ref = first_prior.at(pipe + "|" + fmt(best_c) + "|" + rname + "|Ref");
    const Eigen::VectorXd& rc = first_prior.at(pipe + "|" + fmt(best_c) + "|" + rname + "|WLS-RC");
    std::ofstream f(o.out_dir + "/series.csv");
    // Units and frames: docs/study.md (CoM world m; torques N m, external forces known; momentum about the
    // true CoM, world axes).
    f << "# " << pipe << " pipeline, prior " << rname << " #0, cutoff " << (best_c > 0 ? fmt(best_c) + " Hz" : "none")
      << "\nt";
    const char* who[] = {"true", "ref", "rc"};
    for (const char* w : who) f << ",com_x_" << w << ",com_y_" << w << ",com_z_" << w;
    for (int j : actuated)
      for (const char* w : who) f << ",tau_" << model.joint_names[j] << "_" << w;
    for (const char* w : who)
      for (const char* c : {"kx", "ky", "kz", "px", "py", "pz"}) f << ",mom_" << c << "_" << w;
    f << "\n";
    DynamicsData dyn(model);
    for (const ScoredSample& smp : vsamples) {
      const Eigen::Matrix3d R = smp.state.base_orientation.toRotationMatrix();
      const Eigen::VectorXd* phis[3] = {&model.phi, &ref, &rc};
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
      for (int j : actuated) {
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
  }
  std::string timing = "time spent:";
  for (const auto& [k, v] : seconds) timing += " " + k + " " + fmt(v) + " s;";
  say(timing);
  say("wrote " + o.out_dir + "/{results,table_c1,table2,singular_values,link_error,series}.csv and the Markdown tables");
  return true;
}

}  // namespace exoid::tools
