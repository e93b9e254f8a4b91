#pragma once
// One number formatted for a report's sentence (printf format with one double conversion, e.g. "%.3g").
#include <cstdio>
#include <string>

namespace exoid::common {

inline std::string fmt(const char* format, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

}  // namespace exoid::common
