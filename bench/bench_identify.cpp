// exoid_identify_bench: speed and memory of the batch identification (Google Benchmark; targets in
// docs/identification.md, never in timed tests).
//  - BM_IdentifyLog: everything `exoid identify` does on a logged run, from reading the LCM log to the
//    WLS-RC solution with the rank chosen by time-block cross-validation. The log: $EXOID_BENCH_LOG, else
//    out/nominal/run.lcmlog (written by scripts/main.sh). Arg = how many times the log is streamed (1: 62 s,
//    10: 620 s of data); counter peak_rss_MB is the process's peak resident set so far.
//  - BM_StreamingQr: the factorization alone, 62 200 exoskeleton samples (16 x 130 each) from a pool of
//    random states, per thread count.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdlib>
#include <filesystem>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"

namespace {
using namespace exoid;

const Model& exo() {
  static Model m = [] {
    Model model;
    std::string err;
    if (!buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) std::abort();
    return model;
  }();
  return m;
}

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

std::string benchLog() {
  if (const char* p = std::getenv("EXOID_BENCH_LOG")) return p;
  return std::string(EXOID_SOURCE_DIR) + "/out/nominal/run.lcmlog";
}

void BM_IdentifyLog(benchmark::State& state) {
  const std::string log = benchLog();
  if (!std::filesystem::exists(log)) {
    state.SkipWithError(("no log at " + log + " (run scripts/main.sh or set EXOID_BENCH_LOG)").c_str());
    return;
  }
  const Model& model = exo();
  long samples = 0;
  for (auto _ : state) {
    const BaseParameters base = computeBaseParameters(model);
    estimator::AccumulatorOptions ao;
    estimator::LsqAccumulator acc(model, base, ao);
    tools::SourceOptions so;  // sensors pipeline, no filter, base orientation fused and rate from the legs
    so.dataset.orientation_from_legs = true;  // (exoid identify's defaults)
    so.fit_sole_tilt = true;
    so.dataset.base_rate_from_legs = true;
    so.dataset.base_acceleration_from_legs = true;
    for (int i = 0; i < state.range(0); ++i) {
      intake::InputStats st;
      std::string err;
      if (!tools::accumulateFile(log, model, so, acc, st, &err)) {
        state.SkipWithError(err.c_str());
        return;
      }
    }
    acc.flush();
    estimator::IdentifyOptions io;
    estimator::IdentifyResult r;
    std::string err;
    if (!estimator::identify(acc, model, model.phi, io, nullptr, r, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    samples = acc.samples();
    benchmark::DoNotOptimize(r.phi.data());
  }
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["peak_rss_MB"] = peakRssMb();
}
BENCHMARK(BM_IdentifyLog)->Arg(1)->Arg(10)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_StreamingQr(benchmark::State& state) {
  const Model& model = exo();
  const BaseParameters base = computeBaseParameters(model);
  std::vector<Eigen::MatrixXd> K;
  std::vector<Eigen::VectorXd> y;
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(1);
  for (int i = 0; i < 500; ++i) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    K.push_back(data.K);
    y.push_back(data.K * model.phi);
  }
  for (auto _ : state) {
    estimator::AccumulatorOptions ao;
    ao.threads = static_cast<int>(state.range(0));
    estimator::LsqAccumulator acc(model, base, ao);
    for (int i = 0; i < 62200; ++i) acc.add(K[i % K.size()], y[i % y.size()]);
    acc.flush();
    const estimator::ScaledProblem sp = estimator::scaleProblem(acc, model, model.phi, estimator::Method::WlsRC);
    benchmark::DoNotOptimize(estimator::solveAtRank(sp, sp.numericalRank()).data());
  }
}
BENCHMARK(BM_StreamingQr)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
