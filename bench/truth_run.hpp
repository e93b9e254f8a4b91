#pragma once
// The evaluation tools' common start (exoid_noise_budget, exoid_com_budget): the exoskeleton model of config/ and a
// run log of `exoid experiment` aligned tick by tick with its ground truth (EXO_TRUTH). Errors go to stderr.
#include <cstdio>
#include <string>
#include <vector>

#include "exoid/estimator/dataset.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/intake/run_log.hpp"

namespace exoid::bench {

struct TruthRun {
  Model model;                                  ///< config/exo.urdf (or the URDF given), floating base
  intake::RunLog log;                            ///< the messages (the ticks point into it)
  std::vector<estimator::AlignedTick> ticks;    ///< ticks with a state, both plates and the truth
};

/// Loads the model (urdf: nullptr = config/exo.urdf) and the log; false (message on stderr) when either is
/// unreadable or no tick has everything.
inline bool loadTruthRun(const char* log_path, TruthRun& run, const char* urdf = nullptr) {
  std::string err;
  const std::string model_path = urdf ? std::string(urdf) : std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  if (!buildModelFromUrdfFile(model_path, true, run.model, &err) ||
      !intake::readRunLog(log_path, run.model.joint_names, run.log, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    return false;
  }
  estimator::TickNeeds needs;
  needs.truth = true;
  long skipped = 0;
  run.ticks = estimator::alignByTick(run.log.states, run.log.plates[0], run.log.plates[1], run.log.truth, needs, &skipped);
  if (run.ticks.empty()) {
    std::fprintf(stderr, "%s: no tick with state, plates and truth\n", log_path);
    return false;
  }
  return true;
}

}  // namespace exoid::bench
