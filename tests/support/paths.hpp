#pragma once
#include <string>

namespace exoid::test {
inline std::string configPath(const std::string& file) { return std::string(EXOID_CONFIG_DIR) + "/" + file; }
/// A file under data/ (measured data sets shipped with the repository, e.g. "kuka_lwr4/kuka_lwr4.urdf").
inline std::string dataPath(const std::string& file) { return std::string(EXOID_DATA_DIR) + "/" + file; }
}  // namespace exoid::test
