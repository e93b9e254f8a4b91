#pragma once
// Positional numbers of the bench programs, parsed strictly (common/strict_number.hpp): a bad one is refused with
// the program, the argument's name and the reason, never read as 0 as atof/atoi would.
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "exoid/common/strict_number.hpp"

namespace exoid::bench {

inline bool numberArg(const char* prog, const char* name, std::string_view text, double lo, double hi, double& out) {
  std::string why;
  if (common::parseDouble(text, lo, hi, out, &why)) return true;
  std::fprintf(stderr, "%s: %s %s: %s\n", prog, name, common::quoteValue(text).c_str(), why.c_str());
  return false;
}

inline bool integerArg(const char* prog, const char* name, std::string_view text, int lo, int hi, int& out) {
  std::string why;
  int64_t v = 0;
  if (!common::parseInt(text, lo, hi, v, &why)) {
    std::fprintf(stderr, "%s: %s %s: %s\n", prog, name, common::quoteValue(text).c_str(), why.c_str());
    return false;
  }
  out = static_cast<int>(v);
  return true;
}

}  // namespace exoid::bench
