#pragma once
// Gradient-boosted regression trees (XGBoost 1.7, Debian's libxgboost-dev, C API): squared-error boosting of
// `rounds` trees of depth <= `depth`, shrinkage eta, row subsampling, histogram split finding; a nonparametric
// check of whether y depends on the features at all (no dictionary to choose). Fit and prediction in one call,
// so no XGBoost handle outlives it.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace exoid::estimator {

struct BoostedTreesOptions {
  int rounds = 30;           ///< trees
  int depth = 3;             ///< interactions of up to 3 features per tree
  double eta = 0.2;          ///< shrinkage per tree
  int max_bin = 32;          ///< histogram bins per feature (split candidates; XGBoost's default 256 costs 8x more)
  double subsample = 0.8;    ///< rows per tree (stochastic boosting)
  double min_child_weight = 20.0;  ///< rows per leaf at least (squared error: hessian 1 per row)
  int threads = 1;
  uint64_t seed = 1;
};

/// Fits y on X's rows `train` and predicts X's rows `predict` (prediction [predict.size()]). gain [X.cols()]
/// (optional): each feature's total split gain over the trees ("total_gain"), 0 for unused features.
/// False with *error (XGBoost's message) if XGBoost fails.
bool fitBoostedTrees(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const std::vector<long>& train,
                     const std::vector<long>& predict, const BoostedTreesOptions& options, Eigen::VectorXd& prediction,
                     Eigen::VectorXd* gain, std::string* error);

}  // namespace exoid::estimator
