#include "exoid/common/yaml.hpp"

#include <cctype>
#include <map>

#include "exoid/common/strict_number.hpp"

namespace exoid::common {

namespace {
bool walk(const YAML::Node& node, const std::string& path, std::string* error) {
  if (node.IsSequence()) {
    for (size_t i = 0; i < node.size(); ++i)
      if (!walk(node[i], path + "[" + std::to_string(i) + "]", error)) return false;
  } else if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) continue;  // complex keys: the loaders refuse them
      const std::string& key = kv.first.Scalar();
      const std::string child = path.empty() ? key : path + "." + key;
      const int line = kv.first.Mark().line + 1;
      const auto [it, inserted] = first_line.emplace(key, line);
      if (!inserted) {
        if (error)
          *error = child + ": duplicate key (line " + std::to_string(line) + "; first on line " +
                   std::to_string(it->second) + ")";
        return false;
      }
      if (!walk(kv.second, child, error)) return false;
    }
  }
  return true;
}
}  // namespace

bool checkNoDuplicateKeys(const YAML::Node& node, std::string* error) { return walk(node, "", error); }

bool yamlNumber(const YAML::Node& node, double& out, std::string* why) {
  if (!node.IsScalar()) {
    if (why) *why = "expected a number";
    return false;
  }
  std::string reason;
  if (parseDouble(node.Scalar(), out, &reason)) return true;
  // YAML's own spellings of the non-finite values (core schema: .nan, .inf, -.inf in three capitalisations).
  std::string lower = node.Scalar();
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (lower == ".nan" || lower == ".inf" || lower == "+.inf" || lower == "-.inf") reason = "not finite";
  if (why) *why = "expected a finite number, got " + quoteValue(node.Scalar()) + " (" + reason + ")";
  return false;
}

bool yamlInteger(const YAML::Node& node, int64_t lo, int64_t hi, int64_t& out, std::string* why) {
  if (!node.IsScalar()) {
    if (why) *why = "expected an integer";
    return false;
  }
  std::string reason;
  if (parseInt(node.Scalar(), lo, hi, out, &reason)) return true;
  if (why) *why = "expected an integer, got " + quoteValue(node.Scalar()) + " (" + reason + ")";
  return false;
}

}  // namespace exoid::common
