#include "exoid/estimator/batch/lsq_factor.hpp"

#include <Eigen/QR>
#include <algorithm>

namespace exoid::estimator {

void triangularize(Eigen::Ref<Eigen::MatrixXd> work, Eigen::Ref<Eigen::MatrixXd> R) {
  const Eigen::Index n = R.cols(), k = std::min(work.rows(), n);
  Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(work);
  R.topRows(k) = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  R.bottomRows(n - k).setZero();
}

void TriangularFactor::reset(int n, int block) {
  n_ = n;
  block_ = block > 0 ? block : std::max(64, 2 * n);
  R_ = Eigen::MatrixXd::Zero(n, n);
  buf_.resize(0, 0);
  nbuf_ = 0;
}

Eigen::Ref<Eigen::RowVectorXd> TriangularFactor::nextRow() {
  if (buf_.rows() == 0) buf_ = RowMajor::Zero(block_, n_);
  if (nbuf_ == block_) flush();
  return buf_.row(nbuf_++);
}

void TriangularFactor::flush() {
  if (nbuf_ == 0) return;
  Eigen::MatrixXd stack(n_ + nbuf_, n_);
  stack << R_, buf_.topRows(nbuf_);
  triangularize(stack, R_);
  nbuf_ = 0;
}

Eigen::MatrixXd TriangularFactor::triangular(const Eigen::MatrixXd& stack) {
  Eigen::MatrixXd work = stack, R(stack.cols(), stack.cols());
  triangularize(work, R);
  return R;
}

}  // namespace exoid::estimator
