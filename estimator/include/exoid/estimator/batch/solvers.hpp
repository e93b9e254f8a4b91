#pragma once
// Batch least-squares solvers of the thesis (chapter 3, section III) on the streamed factors, never on the
// stacked W: every method reduces to the SVD of a small matrix with the same singular values and right
// singular vectors as the (scaled) W, because ||W phi - y||^2 = ||R phi - z||^2 + rss (lsq_factor.hpp).
//
//   OLS     eqs. (20)-(23): phi = V_e S_e^-1 U_e^T y + V_n V_n^T phi_prior  (nullspace toward the prior)
//   WLS-R   eqs. (29)-(32): rows of coordinate i scaled by 1 / sigma_i, sigma_i^2 = ||y_i - W_i phi_OLS||^2 /
//           (N - p); then as OLS (nullspace toward the prior)
//   WLS-C   eq. (27) with H = diag(|phi_prior|) and gamma = phi_prior: W~ = W H, y~ = y - W phi_prior,
//           phi = phi_prior + H phi~ (the directions not kept stay at the prior); zero prior entries get
//           the scale of their kind (see columnScale), a kind zero throughout the data's (priorUncertainty)
//   WLS-RC  both scalings
// Truncated SVD (III-D): only the z largest singular values of the scaled problem are used.
// Fill (the directions not kept): FillMetric::Scaled is the thesis's (eq. 23 for OLS / WLS-R, eq. 27's
// "stay at the prior" in the H^-1 metric for C); FillMetric::Prior (default) is the minimum deviation from the
// prior in the prior's own metric, phi = prior + P C^T (C P C^T)^-1 (c - C prior) with C phi = c the kept
// equations and P = diag(sigma^2) the prior's covariance (the Gaussian posterior mean given the kept
// directions). Both leave the kept directions' coefficients alpha_z unchanged.
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/lsq_factor.hpp"

namespace exoid::estimator {

enum class Method { Ols, WlsR, WlsC, WlsRC };
const char* methodName(Method m);  ///< "OLS", "WLS-R", "WLS-C", "WLS-RC"
bool parseMethod(const std::string& name, Method& m);

/// Column scale of WLS-C: |phi_prior_i|, and where that is below floor_fraction of the largest |prior|
/// of the same kind (mass, first moment, inertia, friction), that kind's median |prior| (a zero prior
/// product of inertia must not pin its parameter). [p]
Eigen::VectorXd columnScale(const Model& model, const Eigen::VectorXd& prior, double floor_fraction = 1e-3);

/// The prior's standard deviation per parameter (up to one common factor) for FillMetric::Prior: inertial
/// parameters |prior_i| (a relative prior), floored at floor_fraction of the column scale h_i (so a zero prior
/// entry is not pinned); friction (which a URDF does not carry) h_i. absolute: a prior within +-a of the
/// truth in every inertial parameter, sigma_i = 1 (friction h_i).
Eigen::VectorXd priorScale(const Model& model, const Eigen::VectorXd& prior, const Eigen::VectorXd& h,
                           bool absolute = false, double floor_fraction = 1e-2);

enum class FillMetric { Scaled, Prior };
struct FillOptions {
  FillMetric metric = FillMetric::Prior;
  bool absolute_prior = false;  ///< priorScale's absolute variant (chapter 4's +-0.125 priors)
};

/// The row-weighted training factor of one row weighting (it does not depend on the prior: the WLS-R
/// weights come from the OLS residual): ||G (W phi - y)||^2 = ||Rf phi - z||^2 + rss, Rf [m x p].
struct WeightedFactor {
  std::vector<double> row_weight;  ///< [nv] 1 / sigma_i with R, ones without
  Eigen::MatrixXd Rf;              ///< [m x p] R_base * base_map
  Eigen::VectorXd z;               ///< [m]
  double rss = 0.0;
  long rows = 0;
  Eigen::VectorXd coordinate_y2;    ///< [nv] ||G_c y_c||^2 per generalized coordinate c
  Eigen::MatrixXd coordinate_col2;  ///< [nv x p] ||G_c W_c e_j||^2: standard parameter j's column in coordinate c
};
WeightedFactor weightedFactor(const LsqAccumulator& acc, const Model& model, bool row_scaled,
                              const std::vector<bool>& include = {});
/// A method's training factors, all folds and each fold left out (the rank rules' input); built once per
/// data set and reused for every prior.
struct TrainingFactors {
  Method method = Method::Ols;
  WeightedFactor all;
  std::vector<WeightedFactor> without;  ///< [folds] every fold but k (rows = 0: fold k was empty)
  std::vector<long> fold_rows;          ///< [folds] rows of fold k
};
TrainingFactors trainingFactors(const LsqAccumulator& acc, const Model& model, Method method);

/// A method's problem reduced to its SVD: the scaled problem's singular values s (descending), right
/// singular vectors V [p x r] (r = m base parameters), d = U^T y~ [r], plus what maps back to phi.
struct ScaledProblem {
  Method method = Method::Ols;
  Eigen::VectorXd s;          ///< [r] singular values of G W H, descending
  Eigen::MatrixXd V;          ///< [p x r]
  Eigen::VectorXd d;          ///< [r]
  Eigen::VectorXd h;          ///< [p] column scale (ones without C): columnScale, a kind the prior leaves at 0
                              ///< throughout scaled by the data (priorUncertainty's sigma)
  Eigen::VectorXd gamma;      ///< [p] offset (prior with C, zero without)
  Eigen::VectorXd prior;      ///< [p]
  Eigen::VectorXd fill;       ///< [p] prior scale sigma of the fill metric (h for FillMetric::Scaled)
  Eigen::MatrixXd Q;          ///< [p x r] QR of M = diag(fill) H^-1 V: Q
  Eigen::VectorXd w;          ///< [r] R^-T (alpha - V^T H^-1 (prior - gamma)); phi_z = prior + fill .* Q_z w_z
  std::vector<double> row_weight;  ///< [nv] 1 / sigma_i with R, ones without
  Eigen::MatrixXd Rw;         ///< [m x p] row-weighted factor: ||G (W phi - y)||^2 = ||Rw phi - zw||^2 + rss_w
  Eigen::VectorXd zw;         ///< [m]
  double rss_w = 0.0;
  long rows = 0;
  /// ||G (W phi - y)||^2 from the factor.
  double weightedRss(const Eigen::VectorXd& phi) const { return (Rw * phi - zw).squaredNorm() + rss_w; }
  int numericalRank(double tolerance = 1e-10) const;  ///< s_i > tolerance * s_1
};

/// Builds the scaled problem from the training folds (include: all when empty).
ScaledProblem scaleProblem(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior, Method method,
                      const std::vector<bool>& include = {}, const FillOptions& fill = {});
/// The same from a weighted factor of the method's row weighting (no pass over the accumulator).
ScaledProblem scaleProblem(const WeightedFactor& factor, const Model& model, const Eigen::VectorXd& prior, Method method,
                      const FillOptions& fill = {});

/// Standard parameters [p] using the z largest singular values (z clamped to [0, r]); the directions not
/// used are filled from the prior (OLS, WLS-R: eq. 23 with V_n = the unused columns of V; C: gamma), so
/// z = 0 returns the prior.
Eigen::VectorXd solveAtRank(const ScaledProblem& problem, int z);

/// Generalized-force RMSE of phi on a factor (p-space): sqrt((||R phi - z||^2 + rss) / rows).
double rmse(const LsqFactor& standard_factor, const Eigen::VectorXd& phi);

/// Error of the estimate against held-out data for every rank z = 1..r.
struct RankCurve {
  std::vector<double> score;  ///< [r + 1] score per z (index z; score[0] = the prior)
  int best = 0;               ///< chosen z
  std::string rule;           ///< how it was chosen
  /// [r] the directions (indices into ScaledProblem::s) in the order the rule keeps them, when it keeps a set
  /// rather than the z largest: solve on orderDirections(problem, order) at rank best. Empty: singular-value order.
  std::vector<int> order;
  /// Directions the rule left at the prior only because the same data processed another way moved them (the
  /// jackknife's processing term; indices into s).
  std::vector<int> processing_sensitive;
};

/// The problem with its directions in `order` (a permutation of 0..r-1; empty: sp itself), the fill prepared for
/// it, so that solveAtRank(result, z) keeps the first z of order and fills the rest from the prior; s is permuted
/// with V and d (no longer descending).
ScaledProblem orderDirections(const ScaledProblem& sp, const std::vector<int>& order);

/// (a) The thesis's choice: validation generalized-force RMSE (needs a separate, ideal run).
RankCurve rankByValidation(const ScaledProblem& problem, const LsqFactor& validation);
/// (b1) Training data only: time-block cross-validation over the accumulator's folds (each fold predicted
/// by the method trained on the others, the same weighting procedure); score = RMSE over the folds.
/// Minimum: best = argmin. OneStandardError: the smallest z whose paired excess MSE over the minimum
/// (per fold, then mean over folds) is within one standard error.
enum class CvRule { Minimum, OneStandardError };
RankCurve rankByCrossValidation(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior,
                                Method method, CvRule rule = CvRule::Minimum, const FillOptions& fill = {});
RankCurve rankByCrossValidation(const TrainingFactors& factors, const LsqAccumulator& acc, const Model& model,
                                const Eigen::VectorXd& prior, CvRule rule = CvRule::Minimum, const FillOptions& fill = {});
/// Both rules (minimum, paired 1-SE) from one cross-validation pass.
std::pair<RankCurve, RankCurve> rankByCrossValidationBoth(const TrainingFactors& factors, const LsqAccumulator& acc,
                                                          const Model& model, const Eigen::VectorXd& prior,
                                                          const FillOptions& fill = {});
/// (b3) Training data only, the default of `exoid identify`: the set of directions of least expected error. The
/// jackknife over the time-block folds gives the variance var_i of each scaled coordinate alpha_i = v_i^T H^-1 (phi -
/// gamma) of the full-rank estimate (it sees the real, time-correlated noise, unlike sigma^2 / s_i^2 of eq. 34); the
/// prior's variance along the same direction is pv_i = ||diag(sigma / h) v_i||^2 with sigma = priorUncertainty (a
/// stated prior within +-prior_uncertainty, an unknown kind scaled by the data). A systematic error of the data
/// processing (differentiated encoders, a filter's lag, an estimated orientation) is the same in every time block,
/// so the jackknife cannot see it; what can is the estimate's move when the same data are processed another way:
/// with `processing` (the training data's weighted factors under other processing, e.g. half the cutoff, filtering
/// the inputs instead of parallel filtering, the IMU's orientation) b_i = max_k (alpha_i - alpha_i^(k))^2, else 0.
/// A kept direction costs var_i + b_i, a dropped one (left at the prior) pv_i, each weighted by s_i^2, its share of
/// the training forces:
///   risk(S) = sum_{i in S} s_i^2 (var_i + b_i) + sum_{i not in S} s_i^2 pv_i.
/// With `processing`, S = {i : var_i + b_i < pv_i}, the least risk over every set: order = S (by singular value) then
/// the rest, best = |S|, score[z] = the risk of the first z of order. Without it, the least risk over the prefixes
/// S = {1..z} (order empty, score[z] = risk({1..z})): the jackknife alone underestimates the weak directions' error,
/// which a systematic one dominates, and the singular-value order guards against keeping them out of turn (on the
/// exoskeleton's sensor runs the least-risk set without b was 1.5-3.7x worse than the prefix; docs/identification.md).
/// With every prior entry stated and h = |prior| (pv_i = prior_uncertainty^2 / 3) a direction pays for itself where
/// the former cap (std_i <= prior_uncertainty / sqrt(3)) kept it. Meaningful with column scaling.
RankCurve rankByJackknife(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior, Method method,
                          double prior_uncertainty, const std::vector<const LsqAccumulator*>& processing = {});
RankCurve rankByJackknife(const TrainingFactors& factors, const Model& model, const Eigen::VectorXd& prior,
                          double prior_uncertainty, const std::vector<WeightedFactor>& processing = {});
/// Per-parameter prior standard deviation sigma [p] of the jackknife rule: a meaningful prior (a kind of
/// parameter with some nonzero prior entry: the URDF's inertials) is within +-relative of the truth, uniform,
/// sigma_j = relative h_j / sqrt(3) with h the column scale (|prior_j|, or its kind's median where that is ~0);
/// a kind whose prior is zero throughout (friction without a friction prior) is unknown: sigma_j = ||G y_Cj|| /
/// ||G W_Cj,j|| over the coordinates C_j that parameter j acts on (a joint's friction: that joint's torque), the
/// value that alone would explain all the forces it can reach.
Eigen::VectorXd priorUncertainty(const Model& model, const Eigen::VectorXd& prior, const WeightedFactor& all,
                                 double relative);
/// (b2) Training data only: generalized cross-validation, GCV(z) = rows * RSS(z) / (rows - z)^2 with the
/// weighted training residual RSS(z).
RankCurve rankByGcv(const ScaledProblem& problem);

}  // namespace exoid::estimator
