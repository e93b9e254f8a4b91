// exoid_bench: per-call cost of the model algorithms on the exoskeleton (16 generalized forces x 130
// parameters). Run: build/bin/exoid_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdio>
#include <random>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace {

using namespace exoid;

struct Fixture {
  Model model;
  std::vector<State> states;
  Fixture() {
    std::string err;
    if (!buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) {
      std::fprintf(stderr, "%s\n", err.c_str());
      std::exit(2);
    }
    std::mt19937_64 rng(1);
    for (int i = 0; i < 64; ++i) {
      State s = State::zero(model);
      randomState(model, rng, s);
      states.push_back(s);
    }
  }
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

void BM_JointTorqueRegressor_Exo16x130(benchmark::State& st) {
  const Fixture& f = fixture();
  Data data(f.model);
  size_t i = 0;
  for (auto _ : st) {
    computeJointTorqueRegressor(f.model, data, f.states[i++ & 63]);
    benchmark::DoNotOptimize(data.K.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_JointTorqueRegressor_Exo16x130);

void BM_Rnea_Exo(benchmark::State& st) {
  const Fixture& f = fixture();
  DynamicsData dyn(f.model);
  size_t i = 0;
  for (auto _ : st) {
    rnea(f.model, dyn, f.states[i++ & 63]);
    benchmark::DoNotOptimize(dyn.tau.data());
  }
}
BENCHMARK(BM_Rnea_Exo);

void BM_Crba_Exo(benchmark::State& st) {
  const Fixture& f = fixture();
  DynamicsData dyn(f.model);
  size_t i = 0;
  for (auto _ : st) {
    crba(f.model, dyn, f.states[i++ & 63]);
    benchmark::DoNotOptimize(dyn.M.data());
  }
}
BENCHMARK(BM_Crba_Exo);

}  // namespace

BENCHMARK_MAIN();
