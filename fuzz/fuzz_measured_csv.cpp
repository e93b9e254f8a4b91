// The measured-data CSV intake (intake::streamMeasuredCsv, what identify and diagnose read from a CSV) on
// arbitrary file contents, for the KUKA arm (fixed base) and the exoskeleton (floating base), with and without
// --skip-bad-rows. Properties: a failure is one line naming the file; accepted samples have the model's sizes,
// finite values and strictly increasing times; rows are counted once (samples + skipped <= lines); without
// skipping nothing is skipped, and a clean read (no skip needed) gives the same samples both ways.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "exoid/intake/measured_input.hpp"
#include "exoid/model/urdf.hpp"
#include "fuzz_samples.hpp"
#include "fuzz_support.hpp"

namespace {
exoid::Model g_models[2];
int g_feet[2][2];

void load(const std::string& path, bool floating, int k) {
  std::string error;
  if (!exoid::buildModelFromUrdfFile(path, floating, g_models[k], &error)) {
    std::fprintf(stderr, "fuzz_measured_csv: %s\n", error.c_str());
    std::abort();
  }
  g_feet[k][0] = floating ? g_models[k].bodyIndex("right_foot") : -1;
  g_feet[k][1] = floating ? g_models[k].bodyIndex("left_foot") : -1;
}
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  load(EXOID_DATA_DIR "/kuka_lwr4/kuka_lwr4.urdf", false, 0);
  load(EXOID_CONFIG_DIR "/exo.urdf", true, 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static exoid::fuzz::MemFile file;
  const std::string& path = file.write(data, size);
  const long lines = static_cast<long>(std::count(data, data + size, '\n')) + 1;
  for (int k = 0; k < 2; ++k) {
    const exoid::Model& model = g_models[k];
    exoid::intake::InputStats stats[2];
    bool ok[2];
    for (int skip = 0; skip < 2; ++skip) {
      double last_t = -INFINITY;
      long counted = 0;
      const exoid::intake::SampleSink sink = [&](const exoid::estimator::MeasuredSample& s, std::string*) {
        EXOID_FUZZ_CHECK(s.q.size() == model.njoints && s.tau.size() == model.njoints, "a sample has the model's sizes");
        EXOID_FUZZ_CHECK(exoid::fuzz::allValuesFinite(s), "a sample is finite");
        EXOID_FUZZ_CHECK(s.t > last_t, "times strictly increase");
        last_t = s.t;
        ++counted;
        return true;
      };
      std::string error;
      ok[skip] = exoid::intake::streamMeasuredCsv(path, model, g_feet[k], skip == 1, sink, stats[skip], &error);
      if (!ok[skip]) {
        exoid::fuzz::checkOneLine(error, "a rejected CSV gets a one-line error");
        EXOID_FUZZ_CHECK(error.find(path) != std::string::npos, "the error names the file");
      }
      EXOID_FUZZ_CHECK(counted == stats[skip].samples, "every sample handed on is counted");
      EXOID_FUZZ_CHECK(stats[skip].samples + stats[skip].skipped <= lines, "rows are counted once");
      EXOID_FUZZ_CHECK(stats[skip].skipped == 0 || !stats[skip].first_skip.empty(), "the first skip is named");
    }
    EXOID_FUZZ_CHECK(stats[0].skipped == 0, "without --skip-bad-rows nothing is skipped");
    if (ok[1] && stats[1].skipped == 0) EXOID_FUZZ_CHECK(ok[0] && stats[0].samples == stats[1].samples, "a clean file reads the same both ways");
  }
  return 0;
}
