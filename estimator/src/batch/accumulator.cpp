#include "exoid/estimator/batch/accumulator.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <thread>

#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::estimator {

std::vector<std::vector<int>> activeBaseColumns(const Model& model, const BaseParameters& base) {
  const int m = base.rank;
  Eigen::MatrixXd pattern = Eigen::MatrixXd::Zero(model.nv, m);
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(7);
  for (int k = 0; k < 8; ++k) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    for (int j = 0; j < m; ++j) pattern.col(j) += data.K.col(base.independent[j]).cwiseAbs();
  }
  std::vector<std::vector<int>> active(model.nv);
  for (int c = 0; c < model.nv; ++c)
    for (int j = 0; j < m; ++j)
      if (pattern(c, j) > 0.0) active[c].push_back(j);
  return active;
}

LsqAccumulator::LsqAccumulator(const Model& model, const BaseParameters& base, const AccumulatorOptions& options)
    : base_(base), opt_(options), nv_(model.nv), m_(base.rank) {
  opt_.folds = std::max(1, opt_.folds);
  opt_.block = std::max(1, opt_.block);
  opt_.chunk = std::max(1, opt_.chunk);
  active_ = activeBaseColumns(model, base_);
  factors_.resize(static_cast<size_t>(opt_.folds) * nv_);
  for (int f = 0; f < opt_.folds; ++f)
    for (int c = 0; c < nv_; ++c) {
      CoordinateFactor& cf = factors_[f * nv_ + c];
      cf.columns = active_[c];
      const int k = static_cast<int>(active_[c].size());
      cf.R_aug = Eigen::MatrixXd::Zero(k + 1, k + 1);
    }
  buffer_.resize(nv_);
  work_.resize(nv_);
  for (int c = 0; c < nv_; ++c) {
    const int k = static_cast<int>(active_[c].size());
    buffer_[c].resize(opt_.block, k + 1);
    work_[c].resize(k + 1 + opt_.block, k + 1);
  }
}

bool LsqAccumulator::add(const Eigen::Ref<const Eigen::MatrixXd>& K, const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (!K.allFinite() || !y.allFinite()) return false;
  const int fold = static_cast<int>((samples_ / opt_.chunk) % opt_.folds);
  if (buffered_ > 0 && fold != buffer_fold_) flush();
  buffer_fold_ = fold;
  for (int c = 0; c < nv_; ++c) {
    RowMatrix& b = buffer_[c];
    const std::vector<int>& cols = active_[c];
    const int k = static_cast<int>(cols.size());
    for (int j = 0; j < k; ++j) b(buffered_, j) = K(c, base_.independent[cols[j]]);
    b(buffered_, k) = y[c];
  }
  ++buffered_;
  ++samples_;
  if (buffered_ == opt_.block) flush();
  return true;
}

void LsqAccumulator::update(int c) {
  CoordinateFactor& f = factors_[buffer_fold_ * nv_ + c];
  const int k1 = static_cast<int>(f.R_aug.rows());
  Eigen::MatrixXd& w = work_[c];
  w.topRows(k1) = f.R_aug;
  w.middleRows(k1, buffered_) = buffer_[c].topRows(buffered_);
  triangularize(w.topRows(k1 + buffered_), f.R_aug);
  f.rows += buffered_;
}

void LsqAccumulator::flush() {
  if (buffered_ == 0) return;
  if (opt_.threads <= 1 || nv_ < 2) {
    for (int c = 0; c < nv_; ++c) update(c);
  } else {
    // Split the coordinates so that both halves cost about the same: cost ~ (rows) x (k+1)^2.
    std::vector<int> order(nv_);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return active_[a].size() > active_[b].size(); });
    std::vector<int> mine, theirs;
    double cost_mine = 0, cost_theirs = 0;
    for (int c : order) {
      const double k = active_[c].size() + 1.0;
      if (cost_mine <= cost_theirs) mine.push_back(c), cost_mine += k * k;
      else theirs.push_back(c), cost_theirs += k * k;
    }
    std::thread worker([&] { for (int c : theirs) update(c); });
    for (int c : mine) update(c);
    worker.join();
  }
  buffered_ = 0;
}

LsqFactor LsqAccumulator::mergedBase(const std::vector<double>& row_weight, const std::vector<bool>& include) const {
  long total = 0;
  for (int f = 0; f < opt_.folds; ++f) {
    if (!include.empty() && !include[f]) continue;
    for (int c = 0; c < nv_; ++c) total += factors_[f * nv_ + c].R_aug.rows();
  }
  Eigen::MatrixXd stack = Eigen::MatrixXd::Zero(std::max<long>(total, m_ + 1), m_ + 1);
  long r = 0, rows = 0;
  for (int f = 0; f < opt_.folds; ++f) {
    if (!include.empty() && !include[f]) continue;
    for (int c = 0; c < nv_; ++c) {
      const CoordinateFactor& cf = factors_[f * nv_ + c];
      const double wgt = row_weight.empty() ? 1.0 : row_weight[c];
      const int k = static_cast<int>(cf.columns.size());
      for (int j = 0; j < k; ++j) stack.block(r, cf.columns[j], k + 1, 1) = wgt * cf.R_aug.col(j);
      stack.block(r, m_, k + 1, 1) = wgt * cf.R_aug.col(k);
      r += k + 1;
      rows += cf.rows;
    }
  }
  Eigen::MatrixXd Raug(m_ + 1, m_ + 1);
  triangularize(stack, Raug);
  LsqFactor out;
  out.R = Raug.topLeftCorner(m_, m_);
  out.z = Raug.col(m_).head(m_);
  out.rss = Raug(m_, m_) * Raug(m_, m_);
  out.rows = rows;
  return out;
}

double LsqAccumulator::residual(int c, const Eigen::VectorXd& x, int fold) const {
  double sum = 0.0;
  for (int f = 0; f < opt_.folds; ++f) {
    if (fold >= 0 && f != fold) continue;
    const CoordinateFactor& cf = factors_[f * nv_ + c];
    const int k = static_cast<int>(cf.columns.size());
    Eigen::VectorXd xc(k + 1);
    for (int j = 0; j < k; ++j) xc[j] = x[cf.columns[j]];
    xc[k] = -1.0;
    sum += (cf.R_aug.triangularView<Eigen::Upper>() * xc).squaredNorm();
  }
  return sum;
}

long LsqAccumulator::rows(int c, int fold) const {
  long n = 0;
  for (int f = 0; f < opt_.folds; ++f)
    if (fold < 0 || f == fold) n += factors_[f * nv_ + c].rows;
  return n;
}

LsqFactor toStandard(const LsqFactor& b, const Eigen::MatrixXd& base_map) {
  const int m = static_cast<int>(b.R.rows()), p = static_cast<int>(base_map.cols());
  Eigen::MatrixXd aug(std::max(m, p + 1), p + 1);
  aug.setZero();
  aug.topLeftCorner(m, p) = b.R.triangularView<Eigen::Upper>() * base_map;
  aug.block(0, p, m, 1) = b.z;
  Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(aug);
  LsqFactor out;
  const Eigen::MatrixXd Rf = qr.matrixQR().topRows(p + 1).triangularView<Eigen::Upper>();
  out.R = Rf.topLeftCorner(p, p);
  out.z = Rf.col(p).head(p);
  out.rss = b.rss + Rf(p, p) * Rf(p, p);
  out.rows = b.rows;
  return out;
}

LsqFactor mergeFactors(const std::vector<const LsqFactor*>& factors) {
  LsqFactor out;
  if (factors.empty()) return out;
  const int p = static_cast<int>(factors[0]->R.cols());
  Eigen::MatrixXd stack = Eigen::MatrixXd::Zero(std::max<long>(factors.size() * p, p + 1), p + 1);
  for (size_t i = 0; i < factors.size(); ++i) {
    stack.block(i * p, 0, p, p) = factors[i]->R;
    stack.block(i * p, p, p, 1) = factors[i]->z;
    out.rss += factors[i]->rss;
    out.rows += factors[i]->rows;
  }
  Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(stack);
  const Eigen::MatrixXd Rf = qr.matrixQR().topRows(p + 1).triangularView<Eigen::Upper>();
  out.R = Rf.topLeftCorner(p, p);
  out.z = Rf.col(p).head(p);
  out.rss += Rf(p, p) * Rf(p, p);
  return out;
}

}  // namespace exoid::estimator
