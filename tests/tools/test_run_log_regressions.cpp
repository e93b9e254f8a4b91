// Run-log inputs from fuzz_lcm_log (fuzz/, docs/testing.md). With LCM's own reader (lcm_eventlog_read_next_event)
// a data length of 0x7fffffff made it compute calloc(INT_MAX + 1), get nothing, and fread into a null pointer:
// `exoid export` died with SIGSEGV on a 35-byte file. The reader now frames events itself.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "exoid/intake/run_log.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

void put(std::vector<uint8_t>& v, uint64_t x, int bytes) {
  for (int s = 8 * (bytes - 1); s >= 0; s -= 8) v.push_back(static_cast<uint8_t>(x >> s));
}

// One lcm-logger event: sync word, event number, timestamp, channel length, data length, channel, data.
std::vector<uint8_t> event(const std::string& channel, const std::string& data, uint32_t datalen_field) {
  std::vector<uint8_t> e;
  put(e, 0xEDA1DA01u, 4);
  put(e, 0, 8);
  put(e, 0, 8);
  put(e, channel.size(), 4);
  put(e, datalen_field, 4);
  e.insert(e.end(), channel.begin(), channel.end());
  e.insert(e.end(), data.begin(), data.end());
  return e;
}

TEST(RunLogRegressions, DataLengthOfIntMaxIsDamageNotACrash) {
  test::TempDir dir("run_log_regressions");
  const std::string path = dir.file("int_max.lcmlog");
  std::vector<uint8_t> bytes = event("OTHER", "abc", 3);                // a good event (unknown channel)
  const std::vector<uint8_t> bad = event("EXO_STATE", "abc", 0x7fffffffu);  // its length field damaged
  bytes.insert(bytes.end(), bad.begin(), bad.end());
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), bytes.size());

  intake::RunLog log;
  std::string err;
  ASSERT_TRUE(intake::readRunLog(path, {}, log, &err)) << err;
  EXPECT_EQ(log.unknown_channel, 1);
  EXPECT_FALSE(log.intact());
  EXPECT_EQ(log.damage.readable_end, 28 + 5 + 3);  // header, channel, data of the good event
  EXPECT_EQ(log.damageReport().find('\n'), std::string::npos);

  // The whole CLI: an error exit naming the damage, not a signal.
  const auto r = test::runCommand(test::exoidBinary() + " export --log " + path + " --out " + dir.file("x.csv"),
                                  dir.path);
  EXPECT_NE(r.exit_code, -1) << "killed by a signal; stderr: " << r.err;
  EXPECT_NE(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace exoid
