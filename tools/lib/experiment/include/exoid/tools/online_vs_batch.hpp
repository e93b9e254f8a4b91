#pragma once
// Online vs batch on one run's log (exoid experiment's summary, docs/estimator.md): the live exo_estimator's
// final estimate against a batch WLS-RC (truncated SVD, jackknife rank; sensors pipeline, inputs filtered at
// 30 Hz) on the same log, and the held-out joint-torque RMSE of each when both learn from the first
// `train_fraction` of the run and are judged on the rest (the online side replayed in-process by the same
// OnlineEstimator code and options over the logged sensor messages).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/model/model.hpp"
#include "exoid/intake/run_log.hpp"

namespace exoid::tools {

struct OnlineVsBatch {
  bool computed = false;
  std::string error;                 ///< why not (no estimate file, too few samples, ...)
  bool live_read = false;            ///< the live estimator's final estimate was read
  long logged_ticks = 0;             ///< ticks with the state and both plates in the log
  int64_t split_tick = 0;            ///< training: ticks < split_tick, held out: the rest
  int batch_rank = 0, base_params = 0;  ///< batch WLS-RC's z of m
  double heldout_rmse_online = 0.0;  ///< N m, joint rows, online estimate after the training part
  double heldout_rmse_batch = 0.0;   ///< N m, batch WLS-RC on the training part
  double heldout_rmse_prior = 0.0;   ///< N m, the prior
  double param_diff_live_batch = 0.0;   ///< |B (phi_live - phi_batch)| / |B phi_batch|, whole run
  double param_diff_live_batch_sigma = 0.0;   ///< RMS over base parameters of |x_live - x_batch| / prior sigma_j
  double param_diff_live_replay = -1.0;    ///< |B phi_live - x_replay| / |x_replay|: the live consistent phi's misfit
                                           ///< against the replay's base estimate, plus what the live process lost
  double param_diff_live_replay_sigma = -1.0;  ///< the same in prior sigmas (RMS)
  double param_diff_replay_batch_sigma = -1.0; ///< replay (all logged samples) vs batch, prior sigmas (RMS)
  /// With a diagnose sidecar in the options (exo_estimator --effects): heldout_rmse_online is the estimate with
  /// its effect columns, judged on held-out rows from which the effects at the estimated values were subtracted
  /// (and gains divided out: estimator::EffectCorrector); this is the same replay without the sidecar (-1: none).
  double heldout_rmse_online_rigid = -1.0;
  std::vector<std::string> effect_names;  ///< "joint kind" per effect column
  std::vector<double> effect_values;      ///< the online estimate of each after the training part
};

/// publish_every: exo_estimator's publication step (the replay publishes alike). live_csv: exo_estimator --final output (name,prior,estimate,stddev); "" or unreadable: the live figures are
/// left out (live_read false) and the rest is still computed.
OnlineVsBatch compareOnlineBatch(const Model& model, const intake::RunLog& log, const Eigen::VectorXd& prior,
                                 const estimator::OnlineEstimatorOptions& options, int publish_every,
                                 const std::string& live_csv, double train_fraction = 0.75);

/// summary.json with an "estimator" object added (the comparison, or {"ran": false}).
std::string summaryJsonWithEstimator(const std::string& summary_json, bool ran, const OnlineVsBatch& c);
/// Markdown rows for the summary table ("" when the estimator did not run).
std::string onlineVsBatchTable(bool ran, const OnlineVsBatch& c);

}  // namespace exoid::tools
