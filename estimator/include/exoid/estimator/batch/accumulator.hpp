#pragma once
// Streaming orthogonal factorisation of the identification problem W phi = y (thesis eq. 8) without ever
// holding W or y: rows arrive sample by sample (K [nv x p], y [nv]); each generalized coordinate c keeps
// its own factor of [W_c y_c] restricted to the columns its rows can touch (structural sparsity: a joint
// row only sees the bodies below that joint), updated by a Householder QR of [R_c; block of rows] every
// `block` samples. Columns are first reduced to the structural base parameters (W = W_base * base_map,
// thesis II-E), so a floating-base exoskeleton factors ~100 columns instead of 130.
// Time blocks: samples are dealt in contiguous chunks of `chunk` samples to `folds` folds (chunk i -> fold
// i mod folds), each with its own per-coordinate factors, for time-block cross-validation.
// Memory: folds x nv factors of at most (m+1)^2 plus one block buffer per coordinate, independent of the
// number of samples.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/lsq_factor.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

struct AccumulatorOptions {
  int block = 256;   ///< samples buffered per coordinate before a QR update
  int folds = 5;     ///< time-block folds (1: no cross-validation)
  int chunk = 2000;  ///< samples per contiguous time chunk (2 s at 1 kHz)
  int threads = 2;   ///< QR updates of the coordinates split over this many threads
};

/// Factor of one coordinate (and fold) in the reduced column space: R_aug [(k+1) x (k+1)] upper triangular
/// The structural zero pattern of the base columns per generalized coordinate: for each of the model.nv rows of
/// K, the indices j in [0, base.rank) of the base columns (base.independent[j]) that row can be non-zero in,
/// from |K| summed over 8 random states (a structural zero is zero in every state). The batch accumulator and
/// the online estimator update only these columns of each row.
std::vector<std::vector<int>> activeBaseColumns(const Model& model, const BaseParameters& base);

/// with the factor of the active columns (top-left k x k), z (last column) and sqrt(rss) (bottom-right).
struct CoordinateFactor {
  std::vector<int> columns;  ///< [k] indices into the base-parameter columns (sorted)
  Eigen::MatrixXd R_aug;
  long rows = 0;
};

class LsqAccumulator {
 public:
  /// nv rows per sample, p = model.nparams() columns in K. base: structural base parameters of the model
  /// (columns kept: base.independent; the map back: base.base_map). Allocates everything here.
  LsqAccumulator(const Model& model, const BaseParameters& base, const AccumulatorOptions& options = {});

  /// One sample: K [nv x p] (columns of Model::phi), y [nv]. Rows with a non-finite entry are rejected
  /// (false). Allocation-free except for the QR workspace every `block` samples.
  bool add(const Eigen::Ref<const Eigen::MatrixXd>& K, const Eigen::Ref<const Eigen::VectorXd>& y);
  /// Flushes the buffers (call before reading the factors; add may continue afterwards).
  void flush();

  int coordinates() const { return nv_; }
  int folds() const { return opt_.folds; }
  int baseColumns() const { return m_; }
  long samples() const { return samples_; }
  const BaseParameters& base() const { return base_; }
  /// Factor of coordinate c in fold f (flushed).
  const CoordinateFactor& factor(int fold, int c) const { return factors_[fold * nv_ + c]; }

  /// Merged factor in base-parameter space (m x m, x = phi_base): sum over the folds with include[f] (all
  /// when empty) and the coordinates, row c scaled by row_weight[c] (1 when empty).
  LsqFactor mergedBase(const std::vector<double>& row_weight = {}, const std::vector<bool>& include = {}) const;
  /// Residual sum of squares of coordinate c, fold f (all folds when f < 0) at base parameters x [m].
  double residual(int c, const Eigen::VectorXd& x_base, int fold = -1) const;
  long rows(int c, int fold = -1) const;

 private:
  void update(int slot);
  BaseParameters base_;
  AccumulatorOptions opt_;
  int nv_ = 0, m_ = 0;
  std::vector<std::vector<int>> active_;  ///< [nv] active base columns per coordinate
  std::vector<CoordinateFactor> factors_;  ///< [folds x nv]
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  std::vector<RowMatrix> buffer_;          ///< [nv] block x (k+1) rows waiting (row-major: filled row by row)
  std::vector<Eigen::MatrixXd> work_;      ///< [nv] QR workspace (k+1+block) x (k+1)
  int buffered_ = 0, buffer_fold_ = 0;
  long samples_ = 0;
};

/// The factor in standard-parameter space p: ||W phi - y||^2 = ||R phi - z||^2 + rss with R = R_base *
/// base_map padded to p x p upper triangular (QR of the m x p product).
LsqFactor toStandard(const LsqFactor& base_factor, const Eigen::MatrixXd& base_map);

/// Merges factors of disjoint row sets exactly (QR of the stacked R's; rss add).
LsqFactor mergeFactors(const std::vector<const LsqFactor*>& factors);

}  // namespace exoid::estimator
