#pragma once
// Strict numbers in an MJCF file, checked on the raw XML before MuJoCo compiles it: MuJoCo 2.2 accepts "inf"
// and "nan" (printing a warning on stdout) in numeric attributes; exoid refuses them with one line.
#include <string>

namespace exoid::sim {

/// Every numeric attribute MuJoCo reads (positions, orientations, inertias, sizes, ranges, gains, solver and
/// contact parameters, options) must be whitespace-separated whole finite numbers (common::parseDouble).
/// False with *err = "<file>: body 'thigh' <inertial mass='nan'> (line 14): not finite"; unreadable or
/// malformed XML is left to MuJoCo, whose message names the file too.
bool checkMjcfNumbers(const std::string& path, std::string* err);

}  // namespace exoid::sim
