#pragma once
// Forward stepwise selection (greedy sparse least squares, the regression step of SINDy done by forward
// selection instead of thresholding): over a dictionary X [n x D] of candidate terms and a target y [n],
// the model y ~ b0 + sum_{d in S} b_d X_d with |S| = k grows one term at a time, each step adding the term
// that most reduces the residual sum of squares of the least-squares refit on the chosen terms:
//   S_{k+1} = S_k + argmax_d  c_{S+d}^T G_{S+d}^-1 c_{S+d},   G = Z^T Z, c = Z^T (y - mean y),
// Z the columns centred and scaled to unit standard deviation over the rows used (so the intercept is free and
// the selection does not depend on units). A term whose centred column lies in the span of the chosen ones
// (less than 1e-8 of its norm outside) is never added. Cost O(D k^3 + n D^2) for the Gram, n rows.
#include <Eigen/Core>
#include <vector>

namespace exoid::estimator {

/// One model of the path: the chosen terms (dictionary columns, in the order chosen) and the coefficients in
/// the dictionary's own units: prediction = intercept + sum_i coef[i] X(row, terms[i]).
struct SparseModel {
  std::vector<int> terms;
  Eigen::VectorXd coef;
  double intercept = 0.0;
  double predict(const Eigen::MatrixXd& X, long row) const;
};

/// The selection path on the rows `rows` of X, y: path[k] has k terms, k = 0 (intercept only) .. max_terms (fewer
/// when the dictionary runs out of independent terms). Constant columns are never chosen.
std::vector<SparseModel> forwardSelectionPath(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                                              const std::vector<long>& rows, int max_terms);

}  // namespace exoid::estimator
