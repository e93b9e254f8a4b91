// The whole log intake (intake::streamRunLog: the one reader, the tick assembly and the measured samples,
// what identify, diagnose and study read) on arbitrary file contents, both pipelines, refusing and allowing a
// partial log. Properties: a failure is one line; a log is refused as damaged exactly when its damage report
// is not empty, and that read hands on the same samples as the --allow-partial one; every sample handed on is
// counted, has the model's sizes and finite values, two contacts on the feet, and comes in tick order (never
// two of one tick: the counts of samples and skips add up to at most the ticks seen).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "exoid/intake/measured_input.hpp"
#include "exoid/model/urdf.hpp"
#include "fuzz_samples.hpp"
#include "fuzz_support.hpp"

namespace {
exoid::Model g_model;
int g_feet[2];
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  std::string error;
  if (!exoid::buildModelFromUrdfFile(EXOID_CONFIG_DIR "/exo.urdf", true, g_model, &error)) {
    std::fprintf(stderr, "fuzz_log_samples: %s\n", error.c_str());
    std::abort();
  }
  g_feet[0] = g_model.bodyIndex("right_foot");
  g_feet[1] = g_model.bodyIndex("left_foot");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static exoid::fuzz::MemFile file;
  const std::string& path = file.write(data, size);
  for (const auto pipeline : {exoid::intake::LogPipeline::Sensors, exoid::intake::LogPipeline::Truth}) {
    long counted[2] = {0, 0};
    exoid::intake::InputStats stats[2];
    bool ok[2];
    for (int allow = 0; allow < 2; ++allow) {
      const exoid::intake::SampleSink sink = [&](const exoid::estimator::MeasuredSample& s, std::string*) {
        EXOID_FUZZ_CHECK(s.q.size() == g_model.njoints && s.tau.size() == g_model.njoints, "a sample has the model's sizes");
        EXOID_FUZZ_CHECK(exoid::fuzz::allValuesFinite(s), "a sample is finite");
        EXOID_FUZZ_CHECK(s.ncontacts == 2 && s.contact[0].body == g_feet[0] && s.contact[1].body == g_feet[1],
                         "a sample's contacts are the feet");
        ++counted[allow];
        return true;
      };
      std::string error;
      ok[allow] = exoid::intake::streamRunLog(path, g_model, pipeline, g_feet, allow == 1, sink, stats[allow], &error);
      if (!ok[allow]) exoid::fuzz::checkOneLine(error, "a rejected log gets a one-line error");
      EXOID_FUZZ_CHECK(counted[allow] == stats[allow].samples, "every sample handed on is counted");
      if (!stats[allow].damage_report.empty()) exoid::fuzz::checkOneLine(stats[allow].damage_report, "the damage report is one line");
    }
    EXOID_FUZZ_CHECK(stats[0].refused_damaged == (!stats[0].damage_report.empty()), "refused as damaged iff damaged");
    EXOID_FUZZ_CHECK(!stats[1].refused_damaged, "--allow-partial never refuses for damage");
    EXOID_FUZZ_CHECK(!stats[0].refused_damaged || !ok[0], "a refused log is a failed read");
    EXOID_FUZZ_CHECK(stats[0].samples == stats[1].samples && stats[0].skipped == stats[1].skipped,
                     "refusing and allowing read the same samples");
    EXOID_FUZZ_CHECK(stats[1].damage.events >= 0 && stats[1].damage.readable_end <= static_cast<int64_t>(size),
                     "the readable part is in the file");
  }
  return 0;
}
