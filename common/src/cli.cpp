#include "exoid/common/cli.hpp"

#include <unistd.h>

#include <cstdio>
#include <fstream>

#include "exoid/common/strict_number.hpp"

namespace exoid::common {

namespace {
/// Help layout: usage, description, options (each with its value's constraint, default, required), footer.
class Formatter : public CLI::Formatter {
 public:
  Formatter() { column_width(27); }
  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override {
    std::string out = make_usage(app, name);
    if (!app->get_description().empty()) out += "\n" + app->get_description() + "\n";
    out += make_groups(app, mode);
    if (!app->get_footer().empty()) out += "\n" + app->get_footer() + "\n";
    return out;
  }
  std::string make_usage(const CLI::App* app, std::string name) const override {
    return "usage: " + name + (app->get_options().size() > 1 ? " [options]" : "") + "\n";
  }
  std::string make_option_opts(const CLI::Option* opt) const override {
    if (opt->get_type_size() == 0) return {};
    const std::string type = opt->get_type_name();
    return " " + type.substr(0, type.find(':'));
  }
  std::string make_option_desc(const CLI::Option* opt) const override {
    std::string extra;
    auto add = [&](const std::string& s) { extra += (extra.empty() ? "" : "; ") + s; };
    if (opt->get_required()) add("required");
    if (opt->get_type_size() != 0) {
      const std::string type = opt->get_type_name();
      if (type.find(':') != std::string::npos) add(type.substr(type.find(':') + 1));
      if (!opt->get_default_str().empty()) add("default " + opt->get_default_str());
    }
    return opt->get_description() + (extra.empty() ? "" : " [" + extra + "]");
  }
};
}  // namespace

void configureCli(CLI::App& app) {
  app.formatter(std::make_shared<Formatter>());
  app.set_help_flag("-h,--help", "print this help and exit 0");
  app.option_defaults()->always_capture_default()->multi_option_policy(CLI::MultiOptionPolicy::Throw);
  app.allow_extras(false);
  app.positionals_at_end(false);
}

int parseCli(CLI::App& app, int argc, const char* const* argv) {
  std::string prog = app.get_name();
  try {
    app.parse(argc, argv);
    return -1;
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::fputs(app.help("", CLI::AppFormatMode::All).c_str(), stdout);
    return kExitOk;
  } catch (const CLI::ParseError& e) {
    // An unknown option or stray argument is named first (CLI11 checks required options before extras, and its
    // own text lists every leftover); otherwise CLI11's message, on one line.
    const std::vector<std::string> left = app.remaining();
    if (left.empty()) {
      std::string what = e.what();
      // "--x: 1 required T:NUMBER in [a, b] missing" says less than this:
      if (dynamic_cast<const CLI::ArgumentMismatch*>(&e) && what.find(" missing") != std::string::npos &&
          what.find(':') != std::string::npos)
        what = what.substr(0, what.find(':')) + ": missing value";
      else if (dynamic_cast<const CLI::ArgumentMismatch*>(&e) && what.find("At Most") != std::string::npos &&
               what.find(':') != std::string::npos)
        what = what.substr(0, what.find(':')) + ": given more than once";
      for (char& c : what)
        if (c == '\n') c = ' ';
      std::fprintf(stderr, "%s: error: %s (see --help)\n", prog.c_str(), what.c_str());
      return kExitBadInput;
    }
    const std::string& first = left.front();
    const bool option = first.size() > 1 && first[0] == '-';
    std::fprintf(stderr, "%s: error: %s '%s' (see --help)\n", prog.c_str(),
                 option ? "unknown option" : "unexpected argument", first.substr(0, first.find('=')).c_str());
    return kExitBadInput;
  }
}

CLI::Validator strictNumber(double lo, double hi, bool open) {
  std::string desc = "NUMBER";
  if (lo != std::numeric_limits<double>::lowest() || hi != std::numeric_limits<double>::max()) {
    char buf[96];
    if (hi == std::numeric_limits<double>::max())
      std::snprintf(buf, sizeof buf, open ? " > %g" : " >= %g", lo);
    else if (lo == std::numeric_limits<double>::lowest())
      std::snprintf(buf, sizeof buf, open ? " < %g" : " <= %g", hi);
    else
      std::snprintf(buf, sizeof buf, open ? " in (%g, %g)" : " in [%g, %g]", lo, hi);
    desc += buf;
  }
  return CLI::Validator(
      [lo, hi, open, desc](std::string& s) -> std::string {
        double v = 0.0;
        std::string why;
        if (!parseDouble(s, open ? std::numeric_limits<double>::lowest() : lo,
                         open ? std::numeric_limits<double>::max() : hi, v, &why))
          return quoteValue(s) + ": " + why;
        if (open && (v <= lo || v >= hi)) return quoteValue(s) + ": out of range, expected" + desc.substr(6);
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.17g", v);  // what CLI11 converts next: exact and never hex/octal
        s = buf;
        return {};
      },
      desc, "strict number");
}

CLI::Validator strictInteger(int64_t lo, int64_t hi) {
  std::string desc = "INTEGER";
  if (lo != std::numeric_limits<int64_t>::min() && hi != std::numeric_limits<int64_t>::max())
    desc += " in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  else if (lo != std::numeric_limits<int64_t>::min())
    desc += " >= " + std::to_string(lo);
  else if (hi != std::numeric_limits<int64_t>::max())
    desc += " <= " + std::to_string(hi);
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        int64_t v = 0;
        std::string why;
        if (!parseInt(s, lo, hi, v, &why)) return quoteValue(s) + ": " + why;
        s = std::to_string(v);  // CLI11 converts with base 0: "010" would otherwise become 8
        return {};
      },
      desc, "strict integer");
}

std::string defaultConfigPath(const char* file, const char* installed_dir) {
  const std::string local = std::string("config/") + file;
  if (std::ifstream(local).good() || installed_dir == nullptr) return local;
  return std::string(installed_dir) + "/" + file;
}

std::string selfExecutablePath(const std::string& fallback) {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return fallback;
  buf[n] = '\0';
  return buf;
}

}  // namespace exoid::common
