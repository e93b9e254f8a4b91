#pragma once
// The last stage of the diagnosis (docs/diagnose.md "Is the remaining residual predictable?"): after the candidate
// effects are in the model, is what remains of each joint's residual r_j predictable from the robot's state at all?
// An effect the candidate library lacks (hysteresis, position- or load-dependent friction, backlash) is a function
// of the state and its recent history; noise, however correlated in time, is not.
//
// Per joint j, on the samples decimated to rate_hz:
//   - a dictionary Theta_j [n x D] of the state of j and of its kinematic neighbours (parent and child joints):
//     q, v, a; sin q, cos q; |v|, v|v|, tanh(v / w); products (sin q, cos q, q, the model torque) x tanh(v / w),
//     q v, v_j v_k, sin/cos(q_j + q_k); lagged terms v(t - L) and q(t) - q(t - L) for the lags L (hysteresis and
//     backlash time scales). Never the lagged residual: that would "predict" any autocorrelated residual and say
//     nothing about the state;
//   - a sparse model (forward selection over Theta_j, the number of terms chosen by cross-validation over
//     contiguous training folds, nested inside each outer fold) and gradient-boosted trees (XGBoost) on the raw
//     state variables;
//   - held-out predictions: the training data are cut into `folds` contiguous folds; each is predicted by models
//     fitted on the other folds minus a guard of block_seconds on each side (the residual is correlated over
//     seconds: a neighbouring sample would leak it); the validation segments by models fitted on all training data;
//   - held-out blocks of block_seconds: gain g_b = sum_b r^2 - sum_b (r - r_hat)^2; the predictable share
//     1 - SSE(r - r_hat) / SSE(r) over all held-out blocks, its delete-one-block jackknife standard error, and the
//     one-sided t-test of mean(g_b) > 0 (blocks - 1 degrees of freedom), at level alpha / (joints x methods)
//     (Bonferroni, the family-wise false-alarm rate of the candidates' test).
// A joint is reported when a method passes the test, predicts at least min_share of its held-out residual, and that
// part is at least min_rms_fraction of the pooled held-out RMS (a relevance floor, not a test): "an
// effect the model lacks on <joint>: s % of the remaining held-out residual is predictable from the state; depends
// on <variables>" -- never a candidate's name.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/boosted_trees.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// Kinematic neighbours of each joint [njoints]: the joint of its parent body and the joints of its children.
std::vector<std::vector<int>> kinematicNeighbours(const Model& model);

struct ResidualSeries;

struct PredictabilityOptions {
  bool enabled = true;
  double rate_hz = 25.0;        ///< samples decimated to this rate (the residual of interest is slow; fits stay cheap)
  double block_seconds = 5.0;   ///< held-out test blocks and the guard around a held-out fold (>> the correlation time
                                ///< of noise the test must not mistake for state dependence)
  int folds = 5;                ///< contiguous training folds (cross-fitting, and the sparse model's size)
  int max_terms = 6;            ///< terms of the sparse model at most
  std::vector<double> lags = {0.1, 0.3, 1.0};  ///< s: v(t - L), q(t) - q(t - L)
  std::vector<double> widths = {0.01, 0.1};    ///< rad/s: tanh(v / w)
  bool trees = true;            ///< also the gradient-boosted trees
  /// A joint is named only when its predictable part, sqrt(share) x its held-out RMS, is at least this fraction of the
  /// diagnosis' pooled held-out RMS (PredictabilityResult::pooled_rms): a smaller part is no model error worth a
  /// sentence (a relevance floor, not a test). Seen on the clean simulated exoskeleton runs (docs/diagnose.md): the
  /// passive ankles' in/eversion residuals are 35-63 % predictable (p down to 1e-5), 0.006-0.009 N m, 8-12 % of the
  /// pooled 0.079 N m: real (the sensor pipeline is not exact) but negligible.
  double min_rms_fraction = 0.2;
  BoostedTreesOptions tree;
};

/// One term of a joint's sparse model.
struct PredictabilityTerm {
  std::string name;        ///< e.g. "sin(q_lwr_4_joint)*tanh(v_lwr_4_joint/0.01)"
  double coefficient = 0.0;
  double weight = 0.0;     ///< share of the model's fitted variance (training) attributed to the term
};

/// The stage's figures for one joint, on held-out data (cross-fitted training blocks and validation segments).
struct JointPredictability {
  int joint = -1;
  double rms = 0.0;          ///< RMS of the remaining residual (held-out samples of the stage)
  double validation_rms = 0.0;  ///< on the validation segments only (0 without)
  int blocks = 0;            ///< held-out blocks
  double share_sparse = 0.0, se_sparse = 0.0, p_sparse = 1.0;  ///< predictable share, jackknife SE, p (one-sided)
  double share_trees = 0.0, se_trees = 0.0, p_trees = 1.0;
  double validation_share_sparse = 0.0, validation_share_trees = 0.0;  ///< the same shares on validation only
  bool predictable = false;  ///< a method passed the Bonferroni level with at least min_share, and large enough
  double predictable_rms = 0.0;  ///< N m: sqrt(max(share, 0)) x rms, the size of the predictable part
  std::string verdict;       ///< "predictable", "significant but small" (below min_rms_fraction), "not significant"
  std::string method;        ///< the reported method ("sparse" or "trees"; the larger significant share), else ""
  double share = 0.0, se = 0.0, p = 1.0;  ///< the reported method's figures (the larger share when none passed)
  std::vector<PredictabilityTerm> terms;  ///< the sparse model fitted on all training data
  /// State variables ("q_<joint>", "v_<joint>", "a_<joint>", "tau_<joint>" for the model torque) with their weight:
  /// the reported method's (sparse: its terms' weights, a product shared among its factors; trees: total split
  /// gain share), largest first, those above 5 %.
  std::vector<std::pair<std::string, double>> variables;
  std::string sentence;      ///< the finding in words (empty when not predictable)
};

struct PredictabilityResult {
  bool ran = false;
  double level = 0.0;        ///< the per-test p-value threshold alpha / tests
  double pooled_rms = 0.0;   ///< N m: the pooled held-out RMS the size floor refers to (argument, else the joints')
  int tests = 0;
  bool has_q = false;        ///< joint positions reached the stage (else no q-only terms)
  std::vector<JointPredictability> joints;  ///< one per joint with data
  /// Held-out samples per segment for plots: t, residual and both predictions [n x njoints].
  struct Series {
    std::string segment;
    bool validation = false;
    Eigen::VectorXd t;
    Eigen::MatrixXd residual, sparse, trees;
  };
  std::vector<Series> series;
};

/// The stage on the diagnosis' per-sample residuals `after` (ResidualSeries: t, after, v, a, tau_model, q when
/// present, held_base), training series first. alpha, min_share: DiagnoseOptions::alpha, min_explained; pooled_rms:
/// the diagnosis' pooled held-out RMS after augmentation over every coordinate (<= 0: the tested joints' own).
bool residualPredictability(const Model& model, const std::vector<ResidualSeries>& series, double alpha, double min_share,
                            double pooled_rms, const PredictabilityOptions& options, PredictabilityResult& out,
                            std::string* error);

}  // namespace exoid::estimator
