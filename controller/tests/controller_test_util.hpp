#pragma once
// Shared helpers of the controller tests and benchmark: model and config loading.
#include <Eigen/Core>
#include <string>

#include "exoid/controller/config.hpp"
#include "exoid/model/model.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::controller::testing {

inline std::string configPath(const std::string& file) { return std::string(EXOID_CONFIG_DIR) + "/" + file; }

inline bool loadModel(Model& model, std::string* error) {
  return buildModelFromUrdfFile(configPath("exo.urdf"), true, model, error);
}

inline bool loadConfig(ControllerConfig& config, std::string* error) {
  return loadControllerConfig(configPath("controller.yaml"), config, error);
}

}  // namespace exoid::controller::testing
