#pragma once
// The compressed form of a linear least-squares problem, shared by every batch solver (LsqAccumulator's
// merged factors, the solvers, the validation factor): instead of the stacked W (rows x p) and y (rows), the triangular factor of an orthogonal
// factorisation W = Q R (R upper triangular, p x p), z = Q^T y (first p entries) and the residual sum of
// squares the factor cannot represent, so that for every x
//     ||W x - y||^2 = ||R x - z||^2 + rss.
// Factors of disjoint row sets merge exactly (QR of the stacked R's; the rss add), which is how data are
// streamed, split per generalized coordinate, per time block, or across logs.
// The one streaming update behind every such factor, LsqAccumulator's per-coordinate factors and the diagnosis's
// per-(fold, coordinate) factors alike: triangularize (a Householder QR of the stacked [R; rows]) and
// TriangularFactor (rows filled one by one, folded in every `block` rows). The online estimator keeps a
// recursive form instead (online/recursive_ls.hpp).
#include <Eigen/Core>

namespace exoid::estimator {

struct LsqFactor {
  Eigen::MatrixXd R;  ///< p x p, upper triangular
  Eigen::VectorXd z;  ///< p, the first p entries of Q^T y
  double rss = 0.0;   ///< ||y||^2 - ||z||^2 >= 0: the part of y orthogonal to range(W)
  long rows = 0;      ///< number of rows (samples x coordinates) absorbed
};

/// Upper-triangular R [n x n] (n = work.cols()) of a Householder QR of `work` [rows x n], computed in place (work is
/// overwritten): ||work x||^2 = ||R x||^2 for every x. Fewer rows than columns: R's last n - rows rows are zero.
void triangularize(Eigen::Ref<Eigen::MatrixXd> work, Eigen::Ref<Eigen::MatrixXd> R);

/// Upper-triangular factor R [n x n] of rows streamed one by one: ||A x||^2 = ||R x||^2 for every x, A the rows so
/// far. Rows wait in a block of `block` rows (default max(64, 2 n)); each full block is folded in by triangularize
/// of [R; block] ((n + block) x n), so memory is O(n (n + block)) whatever the number of rows.
class TriangularFactor {
 public:
  explicit TriangularFactor(int n = 0, int block = 0) { reset(n, block); }
  /// Empties the factor: n columns, rows folded in every `block` (<= 0: max(64, 2 n)).
  void reset(int n, int block);
  /// The next row to fill (n entries), counted as added at once.
  Eigen::Ref<Eigen::RowVectorXd> nextRow();
  /// Folds the waiting rows in (call before reading R; rows may be added afterwards).
  void flush();
  const Eigen::MatrixXd& R() const { return R_; }
  /// R of a whole stack [rows x n] at once (triangularize on a copy).
  static Eigen::MatrixXd triangular(const Eigen::MatrixXd& stack);

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  int n_ = 0, block_ = 64, nbuf_ = 0;
  Eigen::MatrixXd R_;
  RowMajor buf_;
};

}  // namespace exoid::estimator
