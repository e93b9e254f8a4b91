#pragma once
// The error convention of exoid's readers, loaders and stages: `bool f(..., std::string* error)` returns false
// with one line in *error (the caller may pass nullptr). `return fail(error, "...")` is that in one statement.
#include <string>

namespace exoid::common {

inline bool fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

}  // namespace exoid::common
