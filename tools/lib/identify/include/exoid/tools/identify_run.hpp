#pragma once
// One batch identification from data files (`exoid identify`, docs/identification.md): the model and its prior
// (URDF, --prior CSV, --prior-perturb, --only-links holding the other links at the prior), the training (and
// validation) files streamed into LsqAccumulators through the dataset pipeline, estimator::identify on them.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/intake/measured_input.hpp"
#include "exoid/model/model.hpp"

namespace exoid::tools {

/// `exoid identify`'s options (its --help says what each does).
struct IdentifyRunOptions {
  std::vector<std::string> data, validate, only_links;
  std::string model_path, pipeline = "sensors", validate_pipeline, filter_mode = "inputs", method = "WLS-RC-PC",
                          rank = "jackknife", prior_path, effects_path, orientation = "fused";
  bool rank_given = false;  ///< --rank was given (--only-links changes only the default)
  bool fixed_base = false, derive = false, skip_bad_rows = false, allow_partial = false;
  double cutoff_hz = 0.0, noise = 0.0, prior_perturb = 0.0, chunk_s = 2.0, orientation_cutoff_hz = 5.0,
         prior_uncertainty = 0.25;
  uint64_t seed = 1, prior_seed = 1;
  int folds = 5, threads = 2;
};

/// What an identification found, with what it was computed from.
struct IdentifyRun {
  Model model;
  BaseParameters base;
  Eigen::VectorXd prior;                    ///< [nparams]
  estimator::IdentifyOptions options;       ///< the method and rank rule resolved
  estimator::IdentifyResult result;
  std::vector<std::pair<std::string, intake::InputStats>> inputs;  ///< per training / validation file
  long training_samples = 0;
  double read_s = 0.0, solve_s = 0.0;       ///< read + filter + factor, solve + rank choice (wall)
  bool damaged = false;                     ///< failed on a damaged log (the command's exit 3)
};

/// Prior from a CSV with columns name,value (every parameter named once; '#' comments, optional header).
bool readPrior(const std::string& path, const Model& model, Eigen::VectorXd& prior, std::string* error);

/// Runs the identification. Progress (per file: samples, skipped, damage read past) goes to stderr. False with
/// a one-line *error (run.damaged when a log was refused as damaged).
bool runIdentify(const IdentifyRunOptions& options, IdentifyRun& run, std::string* error);

}  // namespace exoid::tools
