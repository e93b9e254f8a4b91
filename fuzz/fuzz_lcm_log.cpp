// LCM event-log reader (intake::readRunLog, what `exoid export` reads) on arbitrary file contents.
// Properties: a failure is one line; every event read is accounted for exactly once (decoded into a
// sample, rejected, or on an unknown channel); the damage figures lie inside the file and the damage
// report is one line.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "exoid/model/urdf.hpp"
#include "exoid/intake/run_log.hpp"
#include "fuzz_support.hpp"

namespace {
std::vector<std::string> g_joints;
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  exoid::Model model;
  std::string error;
  if (!exoid::buildModelFromUrdfFile(EXOID_CONFIG_DIR "/exo.urdf", true, model, &error)) {
    std::fprintf(stderr, "fuzz_lcm_log: %s\n", error.c_str());
    std::abort();
  }
  g_joints = model.joint_names;
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static exoid::fuzz::MemFile file;
  exoid::intake::RunLog log;
  std::string error;
  if (!exoid::intake::readRunLog(file.write(data, size), g_joints, log, &error)) {
    exoid::fuzz::checkOneLine(error, "a rejected log gets a one-line error");
    return 0;
  }
  long events = 0;
  for (const auto& [channel, count] : log.events) events += count;
  const long taken = static_cast<long>(log.states.size() + log.plates[0].size() + log.plates[1].size() +
                                       log.truth.size() + log.commands.size() + log.status.size() +
                                       log.estimates.size());
  EXOID_FUZZ_CHECK(events == taken + log.rejected + log.unknown_channel, "every event is accounted for once");
  EXOID_FUZZ_CHECK(log.rejected == 0 || !log.first_rejection.empty(), "the first rejection is named");
  EXOID_FUZZ_CHECK(log.damage.file_bytes == static_cast<int64_t>(size), "the file size is reported");
  EXOID_FUZZ_CHECK(log.damage.readable_end > 0 && log.damage.readable_end <= log.damage.file_bytes, "the readable part is in the file");
  EXOID_FUZZ_CHECK(log.damage.corrupt_bytes >= 0 && log.damage.corrupt_bytes <= log.damage.file_bytes, "damaged bytes are in the file");
  EXOID_FUZZ_CHECK((log.damage.corrupt_events > 0) == (log.damage.first_corrupt_offset >= 0), "the first damage is located");
  if (log.intact())
    EXOID_FUZZ_CHECK(log.damageReport().empty(), "an intact log has no damage report");
  else
    exoid::fuzz::checkOneLine(log.damageReport(), "the damage report is one line");
  return 0;
}
