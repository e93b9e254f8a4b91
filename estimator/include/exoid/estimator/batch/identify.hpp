#pragma once
// One identification from streamed factors: the chosen method, rank rule and the verdicts a user needs to
// trust (or distrust) the estimate: singular values, chosen z and condition number, the parameters the data
// did not excite (left at the prior), per-link physical consistency, and training / validation RMSE.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

enum class RankRule {
  Full,             ///< numerical rank of the scaled problem (s_i > 1e-10 s_1)
  Fixed,            ///< IdentifyOptions::rank
  Validation,       ///< (a) validation generalized-force RMSE (needs validation data)
  CrossValidation,  ///< (b) time-block cross-validation on the training data, minimum
  CrossValidation1Se,  ///< (b) the same, paired one-standard-error rule
  Gcv,              ///< (b) generalized cross-validation on the training data
  Jackknife,        ///< (b) least expected error: each direction's jackknife variance against the prior's
};
const char* rankRuleName(RankRule r);  ///< "full", "fixed", "validation", "cv", "cv-1se", "gcv", "jackknife"
bool parseRankRule(const std::string& name, RankRule& r);
/// "OLS", ..., "WLS-RC", and the method's name with "-PC" when made physically consistent ("WLS-RC-PC").
std::string methodLabel(Method m, bool physically_consistent);

/// One linear function of the parameters held at a value, c^T phi = value with c_j = 1, that the caller has
/// eliminated from the data through parameter j: every row's K became K - K_j c^T (column j zero, so j must be
/// held in the base parameters) and y became y - K_j value (tools::SourceOptions::held_function). c must be an
/// identifiable function (in the regressor's row space, c orthogonal to its nullspace): then the eliminated rows have
/// the structural base parameters of the model with j held, which the accumulator's column reduction assumes.
/// `BatchIdentify.AHeldFunctionGivesTheEqualityConstrainedLeastSquaresFit` checks the fit against a dense
/// equality-constrained solve.
struct HeldFunction {
  int j = -1;          ///< < 0: none
  Eigen::VectorXd c;   ///< [p]
  double value = 0.0;
  /// phi_j = value - sum_(k != j) c_k phi_k.
  void apply(Eigen::VectorXd& phi) const { phi[j] = value - (c.dot(phi) - c[j] * phi[j]); }
};

struct IdentifyOptions {
  Method method = Method::WlsRC;
  /// WLS-RC-PC (consistent.hpp): the method's rank-z fit made physically consistent (every link's
  /// pseudo-inertia positive definite) by solveConsistentAtRank; the method's estimate is returned unchanged
  /// when it is consistent already.
  bool physically_consistent = false;
  int consistent_iterations = 500;  ///< Newton iterations of WLS-RC-PC
  RankRule rank_rule = RankRule::Jackknife;
  int rank = -1;                  ///< for RankRule::Fixed
  double prior_uncertainty = 0.25;  ///< for RankRule::Jackknife: the prior's stated kinds within +-this
                                    ///< (relative) of the truth; a kind it leaves at 0 is unknown (priorUncertainty)
  double excitation_threshold = 0.1;  ///< a parameter whose unit direction has less than this norm in the
                                      ///< kept right singular vectors is reported as weakly excited
  /// Held-out / training RMSE above this says the validation data differ from the training data (a load, a
  /// tool, another robot state): noise and an adequate model give ~1 (docs/identification.md, "Output").
  double data_differ_ratio = 2.0;
  /// A held function (e.g. the system's CoM height, `exoid identify --com-height prior`): the estimate's phi_j is
  /// set from it; with WLS-RC-PC a body it makes inconsistent gets the least isotropic lift of its second moments
  /// (masses and first moments, hence the function, unchanged).
  HeldFunction held_function;
};

/// Physical consistency of one body's 10 parameters (about the body origin): the pseudo-inertia
/// J = [0.5 tr(I) 1 - I, m c; (m c)^T, m] is positive definite (mass > 0 and the inertia about the CoM
/// satisfies the triangle inequalities strictly).
struct LinkVerdict {
  std::string name;
  double mass = 0.0;
  double min_eigenvalue = 0.0;  ///< smallest eigenvalue of J (kg m^2)
  bool consistent = false;
};
LinkVerdict checkLink(const std::string& name, const Eigen::Ref<const Eigen::Matrix<double, 10, 1>>& phi10);

struct IdentifyResult {
  Method method = Method::WlsRC;
  bool physically_consistent = false;  ///< WLS-RC-PC was applied
  int consistent_iterations = 0;       ///< its Newton iterations (0: the fit was consistent already)
  RankRule rank_rule = RankRule::Full;
  Eigen::VectorXd phi;         ///< [p] standard parameters (inertial per body, then fv, fc per joint)
  Eigen::VectorXd phi_base;    ///< [m] structural base parameters base_map * phi
  Eigen::VectorXd prior;       ///< [p]
  Eigen::VectorXd singular_values;  ///< [m] of the scaled training problem
  int rank = 0;                ///< z used
  int numerical_rank = 0;      ///< s_i > 1e-10 s_1
  double condition = 0.0;      ///< largest / smallest kept singular value (s_1 / s_z for a prefix)
  RankCurve curve;             ///< the rank rule's score per z (empty for Full / Fixed)
  std::vector<int> unexcited;  ///< standard parameters whose estimate is the prior's value (|phi_i - prior_i| <=
                               ///< 1e-9 of the prior's scale): nothing in the data or the fill moved them
  std::vector<LinkVerdict> links;
  std::vector<double> row_weight;  ///< [nv] WLS-R weights (ones without R)
  long training_rows = 0;
  double training_rmse = 0.0;      ///< unweighted generalized-force RMSE on the training data
  double training_y_rms = 0.0;     ///< RMS of the training y (scale for training_rmse)
  double validation_rmse = -1.0;   ///< pooled, when validation data were given (< 0 otherwise)
  std::vector<double> validation_rmse_per_coordinate;  ///< [nv]
  double prior_validation_rmse = -1.0;  ///< the prior's (Ref)
  /// Parameters the kept directions barely reach (norm of the unit direction in span(V_z) below
  /// excitation_threshold) that moved all the same, through the fill's correlation with the kept ones.
  std::vector<int> weakly_excited;
  double heldout_ratio = -1.0;  ///< validation_rmse / training_rmse (< 0 without validation data)
  bool data_differ = false;     ///< heldout_ratio > IdentifyOptions::data_differ_ratio
};

/// Identifies from the training accumulator. validation may be null (then RankRule::Validation fails).
/// processing: the same training data processed other ways (tools::processingAlternatives: half the cutoff,
/// filtering the inputs instead of parallel filtering, the IMU's orientation), for RankRule::Jackknife's processing
/// term (rankByJackknife); may be empty. False with *error when the data cannot support an estimate (no rows, fewer
/// rows than base parameters, nothing excited) or the options are inconsistent.
bool identify(const LsqAccumulator& train, const Model& model, const Eigen::VectorXd& prior,
              const IdentifyOptions& options, const LsqAccumulator* validation, IdentifyResult& out,
              std::string* error, const std::vector<const LsqAccumulator*>& processing = {});

}  // namespace exoid::estimator
