#pragma once
// Strict YAML reading shared by the config and scenario loaders (yaml-cpp underneath).
// yaml-cpp keeps both pairs of a duplicated key in a map node and a lookup returns the first, so a second
// value would be silently ignored: checkNoDuplicateKeys refuses them at every nesting level. Numbers are
// parsed from the scalar's text by common::parseDouble/parseInt (whole token, finite, in range), not by
// yaml-cpp's stream conversion (which accepts .nan/.inf and refuses subnormals such as 1e-320).
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>

namespace exoid::common {

/// False with *error = "a.b[2].c: duplicate key (line 7; first on line 5)" for the first key that appears
/// twice in one map anywhere under `node` (paths as the loaders print them; lines 1-based).
bool checkNoDuplicateKeys(const YAML::Node& node, std::string* error);

/// A scalar as one finite number. On failure *why says what is wrong and quotes the value.
bool yamlNumber(const YAML::Node& node, double& out, std::string* why);

/// A scalar as one decimal integer in [lo, hi]. On failure *why says what is wrong and quotes the value.
bool yamlInteger(const YAML::Node& node, int64_t lo, int64_t hi, int64_t& out, std::string* why);

}  // namespace exoid::common
