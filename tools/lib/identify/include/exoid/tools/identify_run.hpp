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
#include "exoid/tools/identify_input.hpp"

namespace exoid::tools {

/// `exoid identify`'s options (its --help says what each does).
struct IdentifyRunOptions {
  std::vector<std::string> data, validate, only_links;
  std::string model_path, pipeline = "sensors", validate_pipeline, filter_mode = "inputs", method = "WLS-RC-PC",
                          rank = "jackknife", prior_path, effects_path;
  BaseSignals base_signals;  ///< sensors pipeline, floating base: where the base's motion comes from
  /// --hold: a URDF of the robot without what is to be identified (the empty exoskeleton's identification);
  /// --truth-model: the true system (simulated runs) for the added bodies' and the CoM's errors.
  std::string hold_path, truth_model_path;
  /// "all", "base" (SourceOptions::base_rows_only, training data only) or "" (default): "base" with --hold, else "all".
  std::string rows;
  /// "prior": the whole system's CoM height at the standing pose held at the prior's (SourceOptions::held_function);
  /// "data": identified; "" (default): "prior" with --hold, "data" otherwise.
  std::string com_height;
  bool rank_given = false;  ///< --rank was given (--only-links changes only the default)
  bool fixed_base = false, derive = false, skip_bad_rows = false, allow_partial = false;
  /// --no-processing-check: the jackknife rank rule without its processing term (processingAlternatives).
  bool no_processing_check = false;
  double cutoff_hz = 0.0, noise = 0.0, prior_perturb = 0.0, chunk_s = 2.0, prior_uncertainty = 0.25;
  uint64_t seed = 1, prior_seed = 1;
  int folds = 5, threads = 2;
};

/// --hold: what --model puts on one moving link beyond the held URDF (its fixed-joint links that the held URDF
/// lacks: a wearer's segments, a payload), all in the link's coordinates. The link is identified; this split
/// credits the change to the added bodies: identified = the link's estimate - held.
struct AddedBody {
  int body = -1;                    ///< the carrying link (Model body index)
  std::vector<std::string> frames;  ///< the added links on it (URDF names), --model's order
  Vector10d held = Vector10d::Zero();      ///< the held URDF's parameters of the link
  Vector10d prior = Vector10d::Zero();     ///< the added links' parameters in --model (the prior)
  Vector10d identified = Vector10d::Zero();
  Vector10d truth = Vector10d::Zero();     ///< --truth-model's added links (has_truth)
  bool has_truth = false;
  int excited = 0;                  ///< the link's parameters the data excited (neither left at the prior nor
                                    ///< weakly excited), of 10
};

/// The whole system's CoM over the validation logs' truth channel (EXO_TRUTH: the simulated robot with
/// everything on it, a moving trunk included), each model at the logged joint angles and base pose.
struct SystemComCheck {
  long samples = 0;
  double prior_rmse_m = -1.0, identified_rmse_m = -1.0, truth_model_rmse_m = -1.0;  ///< 3-D; < 0: not computed
  double prior_rmse_xy_m = -1.0, identified_rmse_xy_m = -1.0, truth_model_rmse_xy_m = -1.0;  ///< horizontal
  double identified_max_m = 0.0;
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
  std::vector<AddedBody> added;             ///< --hold: one per carrying link
  Model truth_model;                        ///< --truth-model (nbodies 0 without)
  SystemComCheck system_com;                ///< validation logs with a truth channel
  bool com_height_held = false;             ///< the system's CoM height was held at the prior's
  double com_height_m = 0.0;                ///< that height above the base origin (standing pose), when held
  /// The other processings of the training data the jackknife rank rule compared (processingAlternatives).
  std::vector<std::string> processing_checked;
};

/// Whether the training rows are the floating base's only (SourceOptions::base_rows_only): --rows base, or no --rows
/// with --hold on a floating base.
bool baseRowsOnly(const IdentifyRunOptions& options);

/// Prior from a CSV with columns name,value (every parameter named once; '#' comments, optional header).
bool readPrior(const std::string& path, const Model& model, Eigen::VectorXd& prior, std::string* error);

/// Runs the identification. Progress (per file: samples, skipped, damage read past) goes to stderr. False with
/// a one-line *error (run.damaged when a log was refused as damaged).
bool runIdentify(const IdentifyRunOptions& options, IdentifyRun& run, std::string* error);

}  // namespace exoid::tools
