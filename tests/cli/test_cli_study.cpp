// `exoid study` input handling: a missing or unreadable run, bad lists and unknown ranges exit 2 with one
// line naming the problem; --help documents the protocol. (The study's numbers come from the library's
// tested parts: metrics, solvers, WLS-RC-PC; a full study needs recorded runs, docs/study.md.)
#include <gtest/gtest.h>

#include <fstream>

#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

TEST(StudyCli, HelpDocumentsTheProtocol) {
  test::TempDir dir("study_help");
  const test::CommandResult r = test::runCommand(test::exoidBinary() + " study --help", dir.path);
  EXPECT_EQ(r.exit_code, 0);
  for (const char* s : {"--train", "--validation", "--test", "--priors", "--cutoffs", "WLS-RC-PC", "Table II"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

TEST(StudyCli, BadInputExitsTwoWithOneLine) {
  test::TempDir dir("study_bad");
  const std::string junk = dir.file("junk.lcmlog");
  std::ofstream(junk) << "not an lcm log";
  const std::string out = dir.file("out");
  const std::string base = test::exoidBinary() + " study --out " + out;
  struct Case {
    std::string args, expect;
  } cases[] = {
      {" --train " + dir.file("missing.lcmlog") + " --validation " + junk, "missing.lcmlog"},
      {" --train " + junk + " --validation " + junk, "junk.lcmlog"},
      {" --train " + junk + " --validation " + junk + " --cutoffs 30,abc", "--cutoffs"},
      {" --train " + junk + " --validation " + junk + " --cutoffs 600", "--cutoffs"},
      {" --train " + junk + " --validation " + junk + " --ranges 50%", "50%"},
      {" --train " + junk + " --validation " + junk + " --pipelines thesis,magic", "magic"},
      {" --validation " + junk, "--train"},
  };
  for (const Case& c : cases) {
    const test::CommandResult r = test::runCommand(base + c.args, dir.path);
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    // Progress lines may precede it; the error itself is one line.
    const size_t e = r.err.find("exoid study: error: ");
    ASSERT_NE(e, std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n', e), r.err.size() - 1) << r.err;
  }
}

}  // namespace
}  // namespace exoid
