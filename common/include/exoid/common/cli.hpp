#pragma once
// Command-line conventions shared by every exoid binary, on CLI11: long options "--name VALUE" (or
// "--name=VALUE") and "--flag" switches, each given at most once; -h/--help prints the help generated from the
// option definitions on stdout and exits 0; anything else that is wrong (unknown option, stray argument,
// missing or bad value, value out of range) is one line "PROG: error: ..." on stderr and exit code 2.
// Numbers are checked by the strictNumber/strictInteger transformers (->transform(...)) (whole token, finite, in range; see
// strict_number.hpp), never by CLI11's own lenient conversion (it accepts "nan", "1e400", octal "010").
#include <CLI/CLI.hpp>
#include <cstdint>
#include <limits>
#include <string>

namespace exoid::common {

/// Applies the conventions above to `app` (help flag, option style, help layout). Call before adding options.
void configureCli(CLI::App& app);

/// Parses argv[0..argc) (argv[0] is the program name). Returns -1 when the program should go on, otherwise the
/// exit code to return at once: 0 after printing --help, 2 after printing a one-line error naming PROG.
int parseCli(CLI::App& app, int argc, const char* const* argv);

/// Transformer (use with ->transform: it rewrites the value CLI11 then converts) of a real-valued option: whole token, finite, lo <= value <= hi.
/// open: lo < value < hi instead.
CLI::Validator strictNumber(double lo = std::numeric_limits<double>::lowest(),
                            double hi = std::numeric_limits<double>::max(), bool open = false);

/// Transformer (->transform) of an integer option: decimal digits only, lo <= value <= hi.
CLI::Validator strictInteger(int64_t lo = std::numeric_limits<int64_t>::min(),
                             int64_t hi = std::numeric_limits<int64_t>::max());

/// Default path of a configuration file: config/FILE when it exists below the working directory (a checkout),
/// else FILE in `installed_dir` (the binary's compiled-in EXOID_CONFIG_DIR; nullptr: config/FILE).
std::string defaultConfigPath(const char* file, const char* installed_dir);

/// This process's executable (/proc/self/exe), e.g. to re-execute itself; `fallback` if unreadable.
std::string selfExecutablePath(const std::string& fallback);

/// Exit codes shared by the binaries (each binary's --help lists the ones it uses).
constexpr int kExitOk = 0;
constexpr int kExitRuntime = 1;
constexpr int kExitBadInput = 2;

}  // namespace exoid::common
