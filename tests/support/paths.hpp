#pragma once
#include <string>

namespace exoid::test {
inline std::string configPath(const std::string& file) { return std::string(EXOID_CONFIG_DIR) + "/" + file; }
inline std::string sharedPath(const std::string& file) { return std::string(EXOID_SHARED_DIR) + "/" + file; }
}  // namespace exoid::test
