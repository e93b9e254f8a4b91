#include "exoid/tools/args.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace exoid::tools {

bool Args::parse(int argc, char** argv, int first, std::string* error) {
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) != 0) {
      if (error) *error = "unexpected argument '" + a + "'";
      return false;
    }
    a = a.substr(2);
    std::string value;
    const size_t eq = a.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) value = a.substr(eq + 1), a = a.substr(0, eq);
    if (flags_.count(a) && !inline_value) {
      set_.insert(a);
      continue;
    }
    if (!values_.count(a)) {
      if (error) *error = "unknown option '--" + a + "'";
      return false;
    }
    if (!inline_value) {
      if (i + 1 >= argc) {
        if (error) *error = "option '--" + a + "' needs a value";
        return false;
      }
      value = argv[++i];
    }
    values_[a] = value;
    set_.insert(a);
  }
  return true;
}

bool Args::getDouble(const std::string& name, double& out, std::string* error) const {
  const std::string& s = get(name);
  char* end = nullptr;
  errno = 0;
  out = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(out)) {
    if (error) *error = "option '--" + name + "': not a finite number ('" + s + "')";
    return false;
  }
  return true;
}

bool Args::getInt(const std::string& name, long& out, std::string* error) const {
  const std::string& s = get(name);
  char* end = nullptr;
  errno = 0;
  out = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno == ERANGE) {
    if (error) *error = "option '--" + name + "': not an integer ('" + s + "')";
    return false;
  }
  return true;
}

}  // namespace exoid::tools
