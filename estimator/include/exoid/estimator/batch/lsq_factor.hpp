#pragma once
// The compressed form of a linear least-squares problem, shared by every batch solver, the online estimator
// and the diagnosis: instead of the stacked W (rows x p) and y (rows), the triangular factor of an orthogonal
// factorisation W = Q R (R upper triangular, p x p), z = Q^T y (first p entries) and the residual sum of
// squares the factor cannot represent, so that for every x
//     ||W x - y||^2 = ||R x - z||^2 + rss.
// Factors of disjoint row sets merge exactly (QR of the stacked R's; the rss add), which is how data are
// streamed, split per generalized coordinate, per time block, or across logs.
#include <Eigen/Core>

namespace exoid::estimator {

struct LsqFactor {
  Eigen::MatrixXd R;  ///< p x p, upper triangular
  Eigen::VectorXd z;  ///< p, the first p entries of Q^T y
  double rss = 0.0;   ///< ||y||^2 - ||z||^2 >= 0: the part of y orthogonal to range(W)
  long rows = 0;      ///< number of rows (samples x coordinates) absorbed
};

}  // namespace exoid::estimator
