#pragma once
// Where the soles stand on their plates, from the data (`exoid identify --sole-on-plate fit`).
//
// The legs place a floating base from its soles: p_b = p_sole - R_wb p_sole^b(q), p_sole = the plate's reported
// origin + the declared offset (DatasetOptions::Foothold::world), averaged over the feet. If both soles stand a further
// c (lab axes) from where they are declared, every base position is off by c and each base moment row by
// -R^T (c x f), f the plates' total force: y(c) = y(0) + dY c, dY [nv x 2] for c's x and y. A difference between the
// feet cancels in the average; the common part is what moves the identified CoM (docs/identification.md "Where the
// soles stand").
//
// A rigid model can take the static part of c x f (the weight) as a first moment of the base link, but not the dynamic
// part c x sum_i m_i a_i, where the links accelerate differently from the base; the joint rows pin the links. So c is
// fitted jointly with the base parameters, by weighted least squares on every row:
//   [K_b  -dY] [phi_b; c] = y(0)      K_b [nv x m] the base-parameter columns (BaseParameters::independent)
// per coordinate normal equations (m + 2)^2, so any row weights can be applied at the end: first unweighted, then each
// coordinate weighted by 1 / its residual variance (WLS-R, thesis eq. 27). Standard error: delete-one-fold jackknife
// over contiguous time folds (the residuals are correlated in time; the formula's sigma^2 (X^T W X)^-1 is not).
// Memory: folds x nv x (m + 2)^2 doubles (5 x 16 x 82^2: 4.3 MB for the exoskeleton).
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// One `--sole-on-plate` value, SIDE:X,Y[,Z] (SIDE right or left; the sole frame's origin minus the plate's reported
/// sensor origin, lab axes, m; Z default 0; each within +-1 m), into out[0] (right) or out[1] (left). False with a
/// message quoting the value and saying what is wrong. `exoid identify`, `diagnose`, `study` and `exo_estimator`.
bool parseSoleOnPlate(const std::string& spec, std::array<Eigen::Vector3d, 2>& out, std::string* error);

/// The fitted common offset of the soles on their plates (lab x, y), and what it changes.
struct SolePlacement {
  bool fitted = false;
  /// When not fitted: e.g. "fewer than 1000 samples", "not determined by these data"; empty when there was nothing
  /// to fit (every sample records the base's position: the soles place nothing).
  std::string why_not;
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();          ///< m: add to both soles' declared placement
  Eigen::Vector2d standard_error = Eigen::Vector2d::Zero();  ///< m, jackknife over the time folds
  /// Share of the offset's columns that the base parameters' columns cannot take (weighted, 0..1): how much of the
  /// data's information on c is its own; near 0 the offset is a first moment to these data.
  Eigen::Vector2d separable = Eigen::Vector2d::Zero();
  double weighted_rms_without = 0.0;  ///< the WLS fit's residual RMS without the offset (weighted units)
  double weighted_rms_with = 0.0;     ///< ... and with it
  long samples = 0;
};

/// One line for a report: "fitted: x +10.02 mm (+- 0.02), y +0.00 mm (+- 0.00)", or "not fitted (why)".
std::string describeSolePlacement(const SolePlacement& placement);

/// Accumulates the rows of one run (or several: one common offset) and fits the offset at finish().
class SolePlacementFit {
 public:
  /// base: the model's structural base parameters; folds >= 2 contiguous time folds of `chunk` samples dealt in turn.
  SolePlacementFit(const Model& model, const BaseParameters& base, int folds = 5, int chunk = 2000);
  /// One sample's rows: K [nv x p] at y(0) [nv], dY [nv x 2] = y's change per metre of the common offset in x and y.
  /// Non-finite rows are skipped (returns false).
  bool add(const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::MatrixXd& dY);
  /// Fits the offset (flushes the buffered rows first).
  SolePlacement finish();

 private:
  int nv_, m_, folds_, chunk_;
  std::vector<int> independent_;
  std::vector<Eigen::MatrixXd> G_;  ///< [folds x nv] (m+2) x (m+2): X^T X of the coordinate's rows, X = [K_b, -dY]
  std::vector<Eigen::VectorXd> b_;  ///< [folds x nv] X^T y
  std::vector<double> yy_;          ///< [folds x nv] y^T y
  std::vector<long> rows_;          ///< [folds x nv]
  long samples_ = 0;
  static constexpr int kBlock = 128;  ///< rows buffered per coordinate before a rank-k update (SYRK)
  std::vector<Eigen::MatrixXd> buf_;  ///< [nv] kBlock x (m + 3): [x, y] rows waiting
  std::vector<int> buffered_;         ///< [nv]
  std::vector<int> buf_slot_;         ///< [nv] the fold slot the buffered rows belong to
  void flush(int r);
  void flushAll();
};

}  // namespace exoid::estimator
