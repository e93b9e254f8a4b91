// exoid_controller_bench: time of one BalanceController::tick() (state estimation, dynamics, QP build, ProxQP
// solve, torques) on a realistic state stream. The stream is recorded once from a closed loop against MuJoCo
// (config/exo.xml, realistic sensor noise, start-up latch then CoM moves) and replayed in order, so the QP is
// warm-started exactly as in operation. Reports median / p99 / max per tick (counters, microseconds), and the
// same for the QP solve alone and for the dynamics stage alone.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <vector>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/model/inertial.hpp"
#include "mujoco_exo.hpp"

namespace exoid::controller {
namespace {

struct Recording {
  Model model;
  ControllerConfig config;
  std::vector<RobotStateSample> samples;
  bool ok = false;
};

const Recording& recording() {
  static const Recording rec = [] {
    Recording r;
    std::string err;
    if (!testing::loadModel(r.model, &err) || !testing::loadConfig(r.config, &err)) {
      std::fprintf(stderr, "bench setup: %s\n", err.c_str());
      return r;
    }
    testing::MujocoExo sim;
    if (!sim.load(r.model, &err)) {
      std::fprintf(stderr, "bench setup: %s\n", err.c_str());
      return r;
    }
    BalanceController ctrl(r.model, r.config, 1);
    RobotStateSample s;
    sim.sizeState(s);
    JointCommandSample cmd, pending;
    ctrl.sizeCommand(cmd);
    ctrl.sizeCommand(pending);
    ControllerStatus st;
    const auto& t = r.config.trajectory;
    const long n = static_cast<long>((r.config.observer.latch_ticks * r.config.loop.period + t.initial_hold +
                                      3 * (t.move_duration + t.hold_duration)) / r.config.loop.period);
    r.samples.reserve(static_cast<size_t>(n));
    for (long k = 0; k < n; ++k) {
      sim.step1();
      sim.sample(s, k, testing::realisticNoise());
      sim.apply(pending);
      ctrl.tick(s, cmd, st);
      std::swap(pending, cmd);
      sim.step2();
      r.samples.push_back(s);
    }
    r.ok = st.fallbacks == 0 && sim.baseHeight() > 1.0;
    if (!r.ok) std::fprintf(stderr, "bench setup: the recording run fell back or fell\n");
    return r;
  }();
  return rec;
}

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

void BM_ControllerTick(benchmark::State& state) {
  const Recording& rec = recording();
  if (!rec.ok) {
    state.SkipWithError("recording failed");
    return;
  }
  // Argument 1: an online estimate in use at full weight (the model plus 1 kg on the base link, a correction on
  // every row), handed over every 10th tick as the estimator's 100 Hz (setEstimate's per-body consistency
  // checks cost ~10 us each time) and timed with the tick; the estimate's centroidal pass runs every tick.
  const bool with_estimate = state.range(0) == 1;
  ControllerConfig cfg = rec.config;
  cfg.estimate.blend_time = 0.0;
  EstimatorOutputSample est;
  est.valid = est.consistent = true;
  est.params = rec.model.phi;
  est.params.segment<kParamsPerBody>(rec.model.bodyParamIndex(0)) += paramsFromInertial(
      1.0, Eigen::Vector3d(-0.1, 0.0, 0.3), Eigen::Matrix3d::Identity(), 0.005 * Eigen::Matrix3d::Identity());
  est.tau_correction = Eigen::VectorXd::Constant(rec.model.nv, 0.1);
  est.tau_correction_stddev = Eigen::VectorXd::Zero(rec.model.nv);
  auto ctrl = std::make_unique<BalanceController>(rec.model, cfg, 1);
  JointCommandSample cmd;
  ctrl->sizeCommand(cmd);
  ControllerStatus st;
  std::vector<double> tick_us, qp_us;
  tick_us.reserve(1 << 20);
  qp_us.reserve(1 << 20);
  size_t i = 0;
  for (auto _ : state) {
    if (i == rec.samples.size()) {  // replay again from a fresh controller
      state.PauseTiming();
      ctrl = std::make_unique<BalanceController>(rec.model, cfg, 1);
      i = 0;
      state.ResumeTiming();
    }
    const auto t0 = std::chrono::steady_clock::now();
    if (with_estimate && i % 10 == 0) {
      est.tick = rec.samples[i].tick;
      ctrl->setEstimate(est);
    }
    ctrl->tick(rec.samples[i++], cmd, st);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(cmd.tau.data());
    if (tick_us.size() < tick_us.capacity()) {
      tick_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      qp_us.push_back(st.qp_solve_us);
    }
  }
  const double max_us = tick_us.empty() ? 0.0 : *std::max_element(tick_us.begin(), tick_us.end());
  state.counters["tick_p50_us"] = percentile(tick_us, 0.5);
  state.counters["tick_p99_us"] = percentile(tick_us, 0.99);
  state.counters["tick_max_us"] = max_us;
  state.counters["qp_p50_us"] = percentile(qp_us, 0.5);
  state.counters["qp_p99_us"] = percentile(qp_us, 0.99);
  state.counters["fallbacks"] = st.fallbacks;
  state.counters["estimate_weight"] = st.estimate.weight;
}
BENCHMARK(BM_ControllerTick)->Arg(0)->Arg(1)->ArgName("estimate")->Unit(benchmark::kMicrosecond)->MinTime(3.0);

void BM_DynamicsOnly(benchmark::State& state) {
  const Recording& rec = recording();
  if (!rec.ok) {
    state.SkipWithError("recording failed");
    return;
  }
  SoleFrame r, l;
  resolveSoleFrame(rec.model, rec.config.contact.right_sole_frame, r, nullptr);
  resolveSoleFrame(rec.model, rec.config.contact.left_sole_frame, l, nullptr);
  const std::array<SoleFrame, 2> soles{r, l};
  RobotDynamicsData data(rec.model);
  State s = State::zero(rec.model);
  s.base_position = Eigen::Vector3d(0.0, 0.0, 1.04);
  s.v.setConstant(0.1);
  s.base_omega = Eigen::Vector3d(0.01, 0.02, 0.0);
  for (auto _ : state) {
    computeRobotDynamics(rec.model, soles, data, s);
    benchmark::DoNotOptimize(data.h.data());
  }
}
BENCHMARK(BM_DynamicsOnly)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace exoid::controller

BENCHMARK_MAIN();
