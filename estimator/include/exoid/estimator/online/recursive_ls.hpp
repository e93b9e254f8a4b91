#pragma once
// Recursive weighted least squares on the structural base parameters (friction included), in information
// form, for the online estimator (docs/estimator.md). Equation numbers: seed thesis, chapter 3.
//
// Problem (thesis eq. 8 reduced to the base columns, II-E): per sample k, K_{B,k} x + e_k = y_k with
// x = B phi [m] the base parameters, K_{B,k} = K_k(:, independent) [nv x m] (W = W_B B), y_k [nv].
// Cost minimised after N samples, with row weights g_c (WLS-R, eqs. 24, 31-32: g_c = 1 / sigma_c) and the
// prior x0 with information Lambda0 (SPD, m x m) as the initial information:
//
//     J_N(x) = sum_k lambda^(N-k) sum_c g_c^2 (K_{B,k}[c,:] x - y_k[c])^2  +  (x - x0)^T Lambda0 (x - x0)
//
// (Ljung & Soederstroem 1983, "Theory and Practice of Recursive Identification", ch. 2: RLS = the exact
// minimiser of the regularised cost; lambda = 1 gives exactly the batch regularised least squares.)
// The minimiser solves the normal equations A x = b with
//     A = Lambda0 + D,  D = sum_c g_c^2 D_c,  D_c = sum_k lambda^(N-k) k_{c,k} k_{c,k}^T,
//     b = Lambda0 x0 + sum_c g_c^2 d_c,        d_c = sum_k lambda^(N-k) k_{c,k} y_k[c].
//
// Form chosen (issue 8 allows "information accumulation with a Cholesky solve at the publication rate"):
// - per sample, each coordinate c adds the rank-one term k k^T to its own dense D_c over only the base
//   columns its row can touch (structural zero pattern: an ankle row touches 12 columns, a base row 80), so
//   the per-sample cost is sum_c |active_c|^2 / 2 instead of nv m^2 (covariance form) — and no subtraction
//   ever happens, so D stays positive semidefinite by construction (the covariance update P - P k k^T P /
//   (1 + k^T P k) loses definiteness by cancellation; Bierman 1977, "Factorization Methods for Discrete
//   Sequential Estimation", ch. II);
// - at the publication rate, A is assembled (row weights applied then, so WLS-R weights may be re-estimated
//   from the per-coordinate residuals over the whole history exactly) and factored by Cholesky; A >= Lambda0
//   > 0 always, so the factorisation cannot fail on finite data.
// Forgetting (lambda < 1) is "stabilised" forgetting toward the prior (Kulhavy & Zarrop 1993, "On a general
// concept of forgetting", Int. J. Control 58(4); Milek & Kraus 1995): only the data part D decays, the prior
// information Lambda0 never does, so A >= Lambda0 and the covariance A^-1 <= Lambda0^-1 stays bounded however
// long the excitation stops (no windup), while directions the data keep exciting are tracked with memory
// 1 / (1 - lambda) samples. Forgetting costs nothing per sample: D_c is stored as D_c / s with a common scale
// s = lambda^N, renormalised when s becomes tiny.
//
// Real time: everything is allocated in makeRecursiveLs / RecursiveLsData's constructor; update, solve and
// feedforward allocate nothing and throw nothing.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

struct RecursiveLsOptions {
  double forgetting = 1.0;         ///< lambda in (0, 1]; 1: no forgetting (= batch regularised LS)
  std::vector<double> row_weight;  ///< [nv] g_c (WLS-R: 1 / sigma_c); empty: ones
};

/// What does not change while estimating (Pinocchio's Model role).
struct RecursiveLsModel {
  int nv = 0;  ///< rows per sample
  int p = 0;   ///< standard parameters (columns of K)
  int m = 0;   ///< base parameters
  std::vector<int> independent;              ///< [m] column of K kept for base parameter j
  std::vector<std::vector<int>> active;      ///< [nv] base parameters row c can touch (sorted)
  Eigen::VectorXd x0;                        ///< [m] prior base parameters (= base_map * prior phi)
  Eigen::MatrixXd prior_information;         ///< [m x m] Lambda0, symmetric positive definite
  Eigen::VectorXd prior_rhs;                 ///< [m] Lambda0 x0
  Eigen::VectorXd row_weight;                ///< [nv] g_c
  double forgetting = 1.0;                   ///< lambda
};

/// Builds the model: active sets from the structural pattern of the regressor over random states, prior
/// x0 = base.base_map * prior_phi [p], Lambda0 = prior_information [m x m] (SPD). Returns false with *error
/// on a size mismatch, a non-finite or non-positive-definite prior information, or lambda outside (0, 1].
bool makeRecursiveLs(const Model& model, const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                     const Eigen::MatrixXd& prior_information, const RecursiveLsOptions& options,
                     RecursiveLsModel& out, std::string* error);

/// Extra columns beyond the model's regressor (e.g. estimator::effectColumns of a `exoid diagnose` sidecar:
/// friction, offset, armature the rigid-body model lacks), appended as new estimated parameters with prior 0
/// and prior information 1 / prior_sigma[e]^2, uncorrelated with the rest. rows[e]: the one coordinate column e
/// touches. Afterwards m and p grow by rows.size(), and every K given to updateRecursiveLs /
/// predictRecursiveLs must be [K | E] with E [nv x rows.size()] in this order. Call before constructing
/// RecursiveLsData (and before saving a checkpoint: the structure includes the new columns). A model without
/// extra columns is unchanged. False with *error on a bad row, sigma or size.
bool addExtraColumns(RecursiveLsModel& model, const std::vector<int>& rows, const Eigen::VectorXd& prior_sigma,
                     std::string* error);

/// A diagonal prior information for a prior known to within +-relative of each parameter: the standard
/// parameters' scale h = columnScale(model, prior_phi) (the WLS-C scale, zero priors get their kind's
/// scale), sigma_std = relative * h, propagated to the base parameters, sigma_j^2 = sum_i B_ji^2 sigma_i^2;
/// Lambda0 = diag(1 / sigma_j^2). [m x m]
Eigen::MatrixXd diagonalPriorInformation(const Model& model, const BaseParameters& base,
                                         const Eigen::VectorXd& prior_phi, double relative);

enum class SampleStatus { Accepted, NonFinite, OutOfOrder, Duplicate };

/// The estimator's state and workspace (Pinocchio's Data role). Sized by the constructor.
struct RecursiveLsData {
  explicit RecursiveLsData(const RecursiveLsModel& model);

  // Accumulated data, per coordinate, stored divided by `scale` (true value = scale * stored).
  std::vector<Eigen::MatrixXd> D;  ///< [nv] |active_c|^2, upper triangle used
  std::vector<Eigen::VectorXd> d;  ///< [nv] |active_c|
  Eigen::VectorXd yy;              ///< [nv] sum lambda^(N-k) y_k[c]^2 / scale
  double scale = 1.0;              ///< s = lambda^N (renormalised)
  double effective_samples = 0.0;  ///< sum lambda^(N-k): memory length

  // Sample bookkeeping.
  long last_tick = 0;
  bool has_tick = false;
  long accepted = 0, rejected_nonfinite = 0, rejected_out_of_order = 0, rejected_duplicate = 0;
  long missing = 0;  ///< ticks skipped between accepted samples (accepted anyway)

  // Solution (valid after solveRecursiveLs).
  Eigen::MatrixXd A;                  ///< [m x m] information Lambda0 + D (upper triangle)
  Eigen::VectorXd b;                  ///< [m]
  Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt;  ///< Cholesky of A (reads the upper triangle)
  Eigen::VectorXd x;                  ///< [m] estimate (starts at x0)
  Eigen::MatrixXd covariance;         ///< [m x m] A^-1 (when asked for)
  Eigen::VectorXd sigma;              ///< [m] sqrt(diag A^-1) (when asked for)
  Eigen::VectorXd residual_rms;       ///< [nv] sqrt(weighted-free rss_c(x) / effective_samples) per coordinate
  long solves = 0;

  // Workspace.
  Eigen::VectorXd row, row2;  ///< [max |active_c|] gathered row, product
};

/// Absorbs one sample: tick (strictly increasing sample index), K [nv x p] standard regressor, y [nv].
/// Non-finite entries, a tick not after the last accepted one (out of order) or equal to it (duplicate)
/// are rejected and counted; the state is then untouched. Allocation-free.
SampleStatus updateRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, long tick,
                               const Eigen::Ref<const Eigen::MatrixXd>& K, const Eigen::Ref<const Eigen::VectorXd>& y);

/// Assembles A and b, factors A (Cholesky) and solves for x; with `uncertainty` also A^-1 and sigma (m^3);
/// fills the per-coordinate residual RMS. Returns false (x unchanged) only if A is not positive definite,
/// which finite data cannot cause. Allocation-free.
/// carried_information [m x m] (symmetric, full) and carried_rhs [m], when given, are added to A and b: the
/// information an estimator carries from earlier blocks (selective forgetting, online_estimator.hpp).
bool solveRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, bool uncertainty,
                      const Eigen::MatrixXd* carried_information = nullptr,
                      const Eigen::VectorXd* carried_rhs = nullptr);

/// Empties the accumulated sums (D_c, d_c, yy; scale 1, effective samples 0) and keeps the tick, the counters
/// and the last solution: the start of a new block. Allocation-free.
void clearRecursiveLsSums(const RecursiveLsModel& model, RecursiveLsData& data);

/// Keeps the fraction kappa in (0, 1] of the accumulated data (information, rhs, residual sums, effective
/// samples), the prior untouched: a one-off forgetting step ("covariance resetting" toward the prior, Goodwin &
/// Sin 1984, sec. 3.3), e.g. when the robot is known to have changed. O(1): the common scale. Allocation-free.
void discountRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, double kappa);

/// The data information the sums hold, sum_c g_c^2 s D_c, scattered into the upper triangle of D [m x m]
/// (overwritten), and the rhs sum_c g_c^2 s d_c into d [m]. Allocation-free.
void recursiveLsInformation(const RecursiveLsModel& model, const RecursiveLsData& data, Eigen::MatrixXd& D,
                            Eigen::VectorXd& d);

/// tau = K_B x: the generalized forces the current estimate predicts for the regressor K [nv x p] (e.g. of
/// the desired motion: the feedforward torque). tau [nv]. Allocation-free.
void predictRecursiveLs(const RecursiveLsModel& model, const RecursiveLsData& data,
                        const Eigen::Ref<const Eigen::MatrixXd>& K, Eigen::Ref<Eigen::VectorXd> tau);
/// The same for any estimate x [m] (e.g. another solve of the same sums). Allocation-free.
void predictRecursiveLs(const RecursiveLsModel& model, const Eigen::VectorXd& x,
                        const Eigen::Ref<const Eigen::MatrixXd>& K, Eigen::Ref<Eigen::VectorXd> tau);

/// Checkpoint for a restarted estimator: writes the accumulated state (D_c, d_c, yy, scale, effective samples,
/// tick and counters) with the model's structure (nv, m, active sets, forgetting, prior, row weights) to
/// `path` (binary, native endianness; written to path + ".tmp", then renamed, so a crash never leaves half a
/// file). Not real-time (file I/O): call it off the per-sample path.
/// `extra`: values of the caller's own state stored with it (loadRecursiveLs returns them).
bool saveRecursiveLs(const RecursiveLsModel& model, const RecursiveLsData& data, const std::string& path,
                     std::string* error, const std::vector<double>& extra = {});
/// Restores a checkpoint written for the same model structure; on any mismatch or a damaged file returns
/// false with *error naming the file and what differs, and leaves data untouched. Call solveRecursiveLs after.
/// extra (when not null) receives the values saved with it (empty when none were).
bool loadRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, const std::string& path,
                     std::string* error, std::vector<double>* extra = nullptr);

}  // namespace exoid::estimator
