// Per-sample work of the online estimator for the exoskeleton (issue 8 target: <= 20 us p99): regressor of
// the measured state, causal parallel filter, recursive update, regressor of the desired state and the
// feedforward prediction; plus the publication-rate solve and, for reference, the textbook covariance-form
// update (16 rows x m parameters) the information form replaces. Per-iteration times are measured with
// steady_clock (manual time) so that p50 / p99 / max can be reported as counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/estimator/online/row_filter.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "synthetic_sensors.hpp"

namespace {
using namespace exoid;
using namespace exoid::estimator;

struct Setup {
  Model model;
  BaseParameters base;
  RecursiveLsModel rm;
  std::vector<State> states;
  Setup() {
    std::string err;
    if (!buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) std::abort();
    base = computeBaseParameters(model);
    RecursiveLsOptions opt;
    opt.forgetting = 0.9995;
    if (!makeRecursiveLs(model, base, model.phi, diagonalPriorInformation(model, base, model.phi, 0.25), opt, rm, &err))
      std::abort();
    std::mt19937_64 rng(1);
    states.assign(1024, State::zero(model));
    for (State& s : states) randomState(model, rng, s);
  }
};
const Setup& setup() {
  static const Setup s;
  return s;
}

void reportPercentiles(benchmark::State& state, std::vector<double>& t) {
  std::sort(t.begin(), t.end());
  auto at = [&](double f) { return t[std::min(t.size() - 1, static_cast<size_t>(f * t.size()))] * 1e6; };
  state.counters["p50_us"] = at(0.50);
  state.counters["p99_us"] = at(0.99);
  state.counters["max_us"] = t.back() * 1e6;
}

void BM_OnlineSample(benchmark::State& state) {
  const Setup& s = setup();
  const Model& model = s.model;
  RecursiveLsData rd(s.rm);
  CausalRowFilter filter;
  filter.configure(s.rm, 30.0, 1000.0);
  Data measured(model), desired(model);
  Eigen::MatrixXd Kf = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Eigen::VectorXd y(model.nv), yf(model.nv), tau_ff(model.nv);
  std::vector<double> times;
  times.reserve(1 << 22);
  long k = 0;
  for (auto _ : state) {
    const State& st = s.states[k % s.states.size()];
    const State& sd = s.states[(k + 7) % s.states.size()];
    y.setConstant(1.0 + 1e-3 * (k % 13));
    const auto t0 = std::chrono::steady_clock::now();
    computeJointTorqueRegressor(model, measured, st);
    filter.filter(s.rm, measured.K, y, Kf, yf);
    updateRecursiveLs(s.rm, rd, k, Kf, yf);
    computeJointTorqueRegressor(model, desired, sd);
    predictRecursiveLs(s.rm, rd, desired.K, tau_ff);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(tau_ff.data());
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(dt);
    if (times.size() < times.capacity()) times.push_back(dt);
    ++k;
  }
  reportPercentiles(state, times);
}
BENCHMARK(BM_OnlineSample)->UseManualTime()->MinTime(2.0);

// The update alone (16 rows into the per-coordinate information over their structural columns).
void BM_OnlineUpdateOnly(benchmark::State& state) {
  const Setup& s = setup();
  RecursiveLsData rd(s.rm);
  Data data(s.model);
  computeJointTorqueRegressor(s.model, data, s.states[0]);
  Eigen::VectorXd y = Eigen::VectorXd::Ones(s.model.nv);
  long k = 0;
  for (auto _ : state) benchmark::DoNotOptimize(updateRecursiveLs(s.rm, rd, k++, data.K, y));
}
BENCHMARK(BM_OnlineUpdateOnly)->Unit(benchmark::kMicrosecond);

// Publication-rate solve: assemble A (m x m), Cholesky, solve; arg 1: plus A^-1 and sigma.
void BM_OnlineSolve(benchmark::State& state) {
  const Setup& s = setup();
  RecursiveLsData rd(s.rm);
  Data data(s.model);
  Eigen::VectorXd y = Eigen::VectorXd::Ones(s.model.nv);
  for (int k = 0; k < 200; ++k) {
    computeJointTorqueRegressor(s.model, data, s.states[k]);
    updateRecursiveLs(s.rm, rd, k, data.K, y);
  }
  for (auto _ : state) benchmark::DoNotOptimize(solveRecursiveLs(s.rm, rd, state.range(0) != 0));
}
BENCHMARK(BM_OnlineSolve)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Reference: textbook covariance-form RLS, one row at a time, dense m x m P (Ljung & Soederstroem 1983).
void BM_CovarianceFormReference(benchmark::State& state) {
  const Setup& s = setup();
  const int m = s.rm.m, nv = s.model.nv;
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(m, m), KB(nv, m);
  Data data(s.model);
  computeJointTorqueRegressor(s.model, data, s.states[0]);
  for (int j = 0; j < m; ++j) KB.col(j) = data.K.col(s.base.independent[j]);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(m), Pk(m);
  for (auto _ : state) {
    for (int c = 0; c < nv; ++c) {
      Pk.noalias() = P * KB.row(c).transpose();
      const double den = 1.0 + KB.row(c).dot(Pk);
      x += Pk * ((1.0 - KB.row(c).dot(x)) / den);
      P.noalias() -= (Pk / den) * Pk.transpose();
    }
    benchmark::DoNotOptimize(x.data());
  }
}
BENCHMARK(BM_CovarianceFormReference)->Unit(benchmark::kMicrosecond);

}  // namespace

// The whole per-sample path of exo_estimator's loop (OnlineEstimator): the state and both plates of a tick in,
// tick assembly, input checks, central differences, leg-kinematics base position, regressor, measured
// generalized forces, causal filter of K and y, update. Publications are not part of it (below). Arg 0: the
// default row weighting (wls-r-corr: the innovation against the full-information fit too), 1: wls-r.
void BM_EstimatorTick(benchmark::State& state) {
  const Setup& s = setup();
  const Model& model = s.model;
  OnlineEstimatorOptions opt;
  if (state.range(0) == 1) opt.row_weighting = RowWeighting::WlsR;
  OnlineEstimator est(model, s.base, model.phi, opt);
  std::vector<estimator::testing::SensorTick> ticks(1000, estimator::testing::makeSensorTick(model));
  std::mt19937_64 rng(1);
  for (size_t i = 0; i < ticks.size(); ++i) estimator::testing::fillSensorTick(model, static_cast<long>(i), 0.3, 1.0, rng, ticks[i]);
  std::vector<double> times;
  times.reserve(1 << 22);
  long k = 0;
  for (auto _ : state) {
    estimator::testing::SensorTick& t = ticks[static_cast<size_t>(k) % ticks.size()];
    t.state.tick = t.plate[0].tick = t.plate[1].tick = k;
    const auto t0 = std::chrono::steady_clock::now();
    est.addState(t.state);
    est.addPlate(t.plate[0]);
    est.addPlate(t.plate[1]);
    const auto t1 = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(dt);
    if (times.size() < times.capacity()) times.push_back(dt);
    ++k;
  }
  reportPercentiles(state, times);
}
BENCHMARK(BM_EstimatorTick)->Arg(0)->Arg(1)->UseManualTime()->MinTime(2.0);

// One publication of the loop (solve, standard parameters, consistency, excitation, tau_ff); arg 0: forgetting
// none (the covariance every 10th publication, as exo_estimator runs; the default row weighting solves twice),
// 1: selective (fixed weights; plus its block step every 100 samples), 2: forgetting none with wls-r (one solve).
// Each iteration folds 10 ticks first (not timed).
void BM_EstimatorPublish(benchmark::State& state) {
  const Setup& s = setup();
  const Model& model = s.model;
  OnlineEstimatorOptions opt;
  opt.forgetting = state.range(0) == 1 ? Forgetting::Selective : Forgetting::None;
  if (state.range(0) == 2) opt.row_weighting = RowWeighting::WlsR;
  OnlineEstimator est(model, s.base, model.phi, opt);
  EstimatorOutputSample out;
  est.sizeOutput(out);
  estimator::testing::SensorTick t = estimator::testing::makeSensorTick(model);
  std::mt19937_64 rng(1);
  long k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (int i = 0; i < 10; ++i, ++k) {
      estimator::testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
      est.addState(t.state);
      est.addPlate(t.plate[0]);
      est.addPlate(t.plate[1]);
    }
    state.ResumeTiming();
    est.fillOutput(out);
  }
  benchmark::DoNotOptimize(out.tau_correction.data());
}
BENCHMARK(BM_EstimatorPublish)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
