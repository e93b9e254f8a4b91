// The command-line conventions every exoid binary shares (exoid_common/cli.hpp): help, one-line errors,
// exit codes, strict numeric options.
#include <gtest/gtest.h>

#include "exoid/common/cli.hpp"

namespace exoid::common {
namespace {

struct Parsed {
  int code = -1;
  std::string out, err;
  double gain = 1.5;
  int64_t count = 3;
  std::string file;
  bool quiet = false;
};

Parsed parse(std::vector<std::string> args) {
  Parsed p;
  CLI::App app{"A test program.", "prog"};
  configureCli(app);
  app.add_option("--gain", p.gain, "a gain")->transform(strictNumber(0.0, 10.0));
  app.add_option("--count", p.count, "a count")->transform(strictInteger(1, 1000));
  app.add_option("--file", p.file, "a file");
  app.add_flag("--quiet", p.quiet, "no output");
  args.insert(args.begin(), "prog");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  p.code = parseCli(app, static_cast<int>(argv.size()), argv.data());
  p.out = testing::internal::GetCapturedStdout();
  p.err = testing::internal::GetCapturedStderr();
  return p;
}

void expectError(const std::vector<std::string>& args, const std::string& needle) {
  const Parsed p = parse(args);
  EXPECT_EQ(p.code, kExitBadInput) << args.front();
  EXPECT_EQ(p.err.rfind("prog: error: ", 0), 0u) << p.err;
  EXPECT_NE(p.err.find(needle), std::string::npos) << p.err;
  EXPECT_EQ(std::count(p.err.begin(), p.err.end(), '\n'), 1) << "one line: " << p.err;
  EXPECT_TRUE(p.out.empty()) << p.out;
}

TEST(Cli, ValuesBothSpellingsAndDefaults) {
  Parsed p = parse({"--gain", "2.5", "--count=010", "--file", "x.yaml", "--quiet"});
  EXPECT_EQ(p.code, -1) << p.err;
  EXPECT_EQ(p.gain, 2.5);
  EXPECT_EQ(p.count, 10);  // decimal: CLI11 alone would read octal 8
  EXPECT_EQ(p.file, "x.yaml");
  EXPECT_TRUE(p.quiet);
  p = parse({});
  EXPECT_EQ(p.code, -1);
  EXPECT_EQ(p.gain, 1.5);
  EXPECT_EQ(p.count, 3);
  p = parse({"--gain", "1e-320"});
  EXPECT_EQ(p.code, -1) << p.err;
  EXPECT_GT(p.gain, 0.0);
}

TEST(Cli, HelpIsGeneratedFromTheDefinitions) {
  for (const char* flag : {"--help", "-h"}) {
    const Parsed p = parse({flag});
    EXPECT_EQ(p.code, kExitOk);
    EXPECT_TRUE(p.err.empty());
    for (const char* s : {"usage: prog", "A test program.", "--gain", "a gain", "NUMBER in [0, 10]", "--count",
                          "INTEGER in [1, 1000]", "--quiet", "--help"})
      EXPECT_NE(p.out.find(s), std::string::npos) << s << "\n" << p.out;
  }
  EXPECT_EQ(parse({"--count", "5", "--help"}).code, kExitOk);
}

TEST(Cli, OneLineErrors) {
  expectError({"--bogus", "1"}, "unknown option '--bogus'");
  expectError({"--bogus=1"}, "unknown option '--bogus'");
  expectError({"stray"}, "unexpected argument 'stray'");
  expectError({"--gain"}, "--gain");
  expectError({"--gain", "nan"}, "--gain: 'nan': not finite");
  expectError({"--gain", "13,5"}, "--gain: '13,5': not a number");
  expectError({"--gain", "1e400"}, "too large");
  expectError({"--gain", "11"}, "out of range, expected in [0, 10]");
  expectError({"--count", "1.5"}, "--count: '1.5': not an integer");
  expectError({"--count", "0"}, "expected an integer in [1, 1000]");
  expectError({"--count", "99999999999999999999"}, "integer too large");
  expectError({"--count", "2", "--count", "3"}, "--count");
}

}  // namespace
}  // namespace exoid::common
