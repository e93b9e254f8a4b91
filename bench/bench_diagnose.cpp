// exoid_diagnose_bench: speed of `exoid diagnose` on a 62 s exoskeleton log (issue 9 target: < 10 s on the
// development machine; a benchmark, never a timed test). BM_DiagnoseLog runs the diagnosis library exactly as
// the command does with its defaults for a floating base (sensors pipeline, parallel filtering at 5 Hz, edges
// trimmed, every candidate kind), training on the log, without validation data and without the report/plots.
// The log: $EXOID_BENCH_LOG, else out/nominal/run.lcmlog (written by scripts/main.sh or `exoid experiment
// --scenario config/scenarios/nominal.yaml --out out/nominal`). Counters: samples, findings, peak_rss_MB.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdlib>
#include <filesystem>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"

namespace {
using namespace exoid;

void BM_DiagnoseLog(benchmark::State& state) {
  const char* env = std::getenv("EXOID_BENCH_LOG");
  const std::string log = env ? env : std::string(EXOID_SOURCE_DIR) + "/out/nominal/run.lcmlog";
  if (!std::filesystem::exists(log)) {
    state.SkipWithError(("no log at " + log + " (run scripts/main.sh or set EXOID_BENCH_LOG)").c_str());
    return;
  }
  Model model;
  std::string err;
  if (!buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) {
    state.SkipWithError(err.c_str());
    return;
  }
  tools::SourceOptions so;  // as `exoid diagnose --floating-base`
  so.dataset.cutoff_hz = 5.0;
  so.dataset.filter = estimator::FilterMode::Parallel;
  so.dataset.trim_edges = true;
  long samples = 0, findings = 0;
  for (auto _ : state) {
    estimator::Segment seg;
    seg.name = "run";
    seg.stream = [&](const estimator::DiagnosisRowSink& sink, std::string* e) {
      intake::InputStats st;
      return tools::streamFileRows(log, model, so, sink, st, e);
    };
    seg.stream_state = [&](const estimator::DiagnosisStateSink& sink, std::string* e) {  // q for the last stage
      intake::InputStats st;
      return tools::streamFileStateRows(log, model, so, sink, st, e);
    };
    estimator::DiagnosisResult res;
    if (!estimator::diagnose(model, {seg}, {}, estimator::DiagnoseOptions{}, res, &err)) {
      state.SkipWithError(err.c_str());
      return;
    }
    samples = res.train_samples;
    findings = static_cast<long>(res.findings.size());
  }
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["findings"] = static_cast<double>(findings);
  state.counters["peak_rss_MB"] = u.ru_maxrss / 1024.0;
}
BENCHMARK(BM_DiagnoseLog)->Iterations(1)->Repetitions(2)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
