#include "exoid/estimator/sole_placement.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string_view>

#include "exoid/common/strict_number.hpp"

namespace exoid::estimator {

bool parseSoleOnPlate(const std::string& spec, std::array<Eigen::Vector3d, 2>& out, std::string* error) {
  const auto bad = [&](const std::string& why) {
    if (error) *error = "--sole-on-plate " + common::quoteValue(spec) + ": " + why;
    return false;
  };
  const size_t colon = spec.find(':');
  if (colon == std::string::npos) return bad("expected SIDE:X,Y[,Z] (e.g. right:0.01,-0.005)");
  const std::string side = spec.substr(0, colon);
  if (side != "right" && side != "left") return bad("the side must be right or left, got '" + side + "'");
  std::vector<double> v;
  std::string rest = spec.substr(colon + 1);
  for (size_t at = 0; at <= rest.size();) {
    const size_t comma = std::min(rest.find(',', at), rest.size());
    double x = 0.0;
    std::string why;
    if (!common::parseDouble(std::string_view(rest).substr(at, comma - at), -1.0, 1.0, x, &why))
      return bad("coordinate " + std::to_string(v.size() + 1) + ": " + why + " (m)");
    v.push_back(x);
    at = comma + 1;
  }
  if (v.size() != 2 && v.size() != 3) return bad("expected 2 or 3 coordinates, got " + std::to_string(v.size()));
  out[side == "right" ? 0 : 1] = Eigen::Vector3d(v[0], v[1], v.size() == 3 ? v[2] : 0.0);
  return true;
}

std::string describeSolePlacement(const SolePlacement& p) {
  if (!p.fitted) return "not fitted (" + p.why_not + ")";
  char s[160];
  std::snprintf(s, sizeof s, "fitted: x %+.2f mm (+- %.2f), y %+.2f mm (+- %.2f)", 1e3 * p.offset.x(),
                1e3 * p.standard_error.x(), 1e3 * p.offset.y(), 1e3 * p.standard_error.y());
  return s;
}

SolePlacementFit::SolePlacementFit(const Model& model, const BaseParameters& base, int folds, int chunk)
    : nv_(model.nv), m_(base.rank), folds_(std::max(folds, 2)), chunk_(std::max(chunk, 1)),
      independent_(base.independent) {
  const int n = m_ + 2, slots = folds_ * nv_;
  G_.assign(static_cast<size_t>(slots), Eigen::MatrixXd::Zero(n, n));
  b_.assign(static_cast<size_t>(slots), Eigen::VectorXd::Zero(n));
  yy_.assign(static_cast<size_t>(slots), 0.0);
  rows_.assign(static_cast<size_t>(slots), 0);
  buf_.assign(static_cast<size_t>(nv_), Eigen::MatrixXd::Zero(kBlock, n + 1));
  buffered_.assign(static_cast<size_t>(nv_), 0);
  buf_slot_.assign(static_cast<size_t>(nv_), 0);
}

void SolePlacementFit::flush(int r) {
  const size_t ri = static_cast<size_t>(r);
  const int k = buffered_[ri], n = m_ + 2;
  if (k == 0) return;
  const size_t s = static_cast<size_t>(buf_slot_[ri]);
  const auto X = buf_[ri].topLeftCorner(k, n);
  const auto y = buf_[ri].block(0, n, k, 1);
  G_[s].selfadjointView<Eigen::Lower>().rankUpdate(X.transpose());
  b_[s].noalias() += X.transpose() * y;
  yy_[s] += y.squaredNorm();
  rows_[s] += k;
  buffered_[ri] = 0;
}

void SolePlacementFit::flushAll() {
  for (int r = 0; r < nv_; ++r) flush(r);
}

bool SolePlacementFit::add(const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::MatrixXd& dY) {
  const int fold = static_cast<int>((samples_ / chunk_) % folds_);
  ++samples_;
  bool all = true;
  for (int r = 0; r < nv_; ++r) {
    const size_t ri = static_cast<size_t>(r);
    if (buffered_[ri] > 0 && buf_slot_[ri] != fold * nv_ + r) flush(r);  // a new fold: its own slot
    buf_slot_[ri] = fold * nv_ + r;
    auto row = buf_[ri].row(buffered_[ri]);
    for (int j = 0; j < m_; ++j) row[j] = K(r, independent_[static_cast<size_t>(j)]);
    row[m_] = -dY(r, 0);
    row[m_ + 1] = -dY(r, 1);
    row[m_ + 2] = y[r];
    if (!row.allFinite()) {
      all = false;
      continue;  // overwritten by the next row
    }
    if (++buffered_[ri] == kBlock) flush(r);
  }
  return all;
}

namespace {

struct Normal {
  Eigen::MatrixXd G;  // full symmetric
  Eigen::VectorXd b;
  double yy = 0.0;
  long rows = 0;
};

// Minimum-norm solution on columns scaled to a unit diagonal (a column no row touched stays 0); k leading columns.
Eigen::VectorXd solve(const Normal& ne, int k) {
  const Eigen::MatrixXd G = ne.G.topLeftCorner(k, k);
  Eigen::VectorXd d(k);
  for (int i = 0; i < k; ++i) d[i] = G(i, i) > 0.0 ? 1.0 / std::sqrt(G(i, i)) : 0.0;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(d.asDiagonal() * G * d.asDiagonal());
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double cut = 1e-10 * std::max(l.maxCoeff(), 0.0);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(k);
  for (int i = 0; i < k; ++i)
    if (l[i] > cut) inv[i] = 1.0 / l[i];
  const Eigen::MatrixXd& V = eig.eigenvectors();
  return d.asDiagonal() * (V * (inv.asDiagonal() * (V.transpose() * (d.asDiagonal() * ne.b.head(k)))));
}

double rss(const Normal& ne, const Eigen::VectorXd& x) {
  const int k = static_cast<int>(x.size());
  return ne.yy - 2.0 * x.dot(ne.b.head(k)) + x.dot(ne.G.topLeftCorner(k, k) * x);
}

}  // namespace

SolePlacement SolePlacementFit::finish() {
  flushAll();
  SolePlacement out;
  out.samples = samples_;
  const int n = m_ + 2;
  if (samples_ < 1000) {
    out.why_not = "fewer than 1000 samples";
    return out;
  }
  // Per coordinate over all folds, and each fold's share (for the jackknife).
  auto full = [&](size_t s) {
    Normal ne;
    ne.G = G_[s].selfadjointView<Eigen::Lower>();
    ne.b = b_[s];
    ne.yy = yy_[s];
    ne.rows = rows_[s];
    return ne;
  };
  std::vector<Normal> coord(static_cast<size_t>(nv_));
  for (int r = 0; r < nv_; ++r) {
    Normal& c = coord[static_cast<size_t>(r)];
    c.G = Eigen::MatrixXd::Zero(n, n), c.b = Eigen::VectorXd::Zero(n);
    for (int f = 0; f < folds_; ++f) {
      const Normal p = full(static_cast<size_t>(f * nv_ + r));
      c.G += p.G, c.b += p.b, c.yy += p.yy, c.rows += p.rows;
    }
  }
  auto combine = [&](const std::vector<double>& w, int leave_out) {
    Normal ne;
    ne.G = Eigen::MatrixXd::Zero(n, n), ne.b = Eigen::VectorXd::Zero(n);
    for (int r = 0; r < nv_; ++r) {
      const double wr = w[static_cast<size_t>(r)];
      if (wr <= 0.0) continue;
      const Normal& c = coord[static_cast<size_t>(r)];
      Normal part = c;
      if (leave_out >= 0) {
        const Normal p = full(static_cast<size_t>(leave_out * nv_ + r));
        part.G -= p.G, part.b -= p.b, part.yy -= p.yy, part.rows -= p.rows;
      }
      ne.G += wr * part.G, ne.b += wr * part.b, ne.yy += wr * part.yy, ne.rows += part.rows;
    }
    return ne;
  };
  // Unweighted first, then each coordinate weighted by 1 / its residual variance there.
  std::vector<double> w(static_cast<size_t>(nv_), 0.0);
  for (int r = 0; r < nv_; ++r) w[static_cast<size_t>(r)] = coord[static_cast<size_t>(r)].rows > 0 ? 1.0 : 0.0;
  const Eigen::VectorXd x0 = solve(combine(w, -1), n);
  double mean_var = 0.0;
  int used = 0;
  for (int r = 0; r < nv_; ++r) {
    const Normal& c = coord[static_cast<size_t>(r)];
    if (c.rows == 0) continue;
    w[static_cast<size_t>(r)] = std::max(rss(c, x0), 0.0) / static_cast<double>(c.rows);
    mean_var += w[static_cast<size_t>(r)], ++used;
  }
  if (used == 0) {
    out.why_not = "no rows";
    return out;
  }
  mean_var /= used;
  for (int r = 0; r < nv_; ++r)
    if (coord[static_cast<size_t>(r)].rows > 0)
      w[static_cast<size_t>(r)] = 1.0 / std::max(w[static_cast<size_t>(r)], 1e-12 * mean_var);
  const Normal all = combine(w, -1);
  const Eigen::VectorXd x = solve(all, n), xb = solve(all, m_);
  out.weighted_rms_with = std::sqrt(std::max(rss(all, x), 0.0) / static_cast<double>(all.rows));
  out.weighted_rms_without = std::sqrt(std::max(rss(all, xb), 0.0) / static_cast<double>(all.rows));
  // How much of each offset column the base columns cannot take: its Schur complement over its own diagonal.
  const Eigen::MatrixXd Gpp = all.G.topLeftCorner(m_, m_), Gpc = all.G.topRightCorner(m_, 2);
  Normal gp;
  gp.G = Gpp;
  for (int j = 0; j < 2; ++j) {
    gp.b = Gpc.col(j);
    const double gcc = all.G(m_ + j, m_ + j);
    out.separable[j] = gcc > 0.0 ? (gcc - Gpc.col(j).dot(solve(gp, m_))) / gcc : 0.0;
  }
  out.offset = x.tail<2>();
  // Jackknife over the folds.
  std::vector<Eigen::Vector2d> cs;
  for (int f = 0; f < folds_; ++f) {
    long fold_rows = 0;
    for (int r = 0; r < nv_; ++r) fold_rows += rows_[static_cast<size_t>(f * nv_ + r)];
    if (fold_rows > 0) cs.push_back(solve(combine(w, f), n).tail<2>());
  }
  if (cs.size() >= 2) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero(), var = Eigen::Vector2d::Zero();
    for (const auto& c : cs) mean += c / static_cast<double>(cs.size());
    for (const auto& c : cs) var += (c - mean).cwiseAbs2();
    out.standard_error = (var * (static_cast<double>(cs.size()) - 1.0) / static_cast<double>(cs.size())).cwiseSqrt();
  }
  if (!out.offset.allFinite() || !out.standard_error.allFinite()) {
    out.why_not = "the fit is not finite";
    return out;
  }
  if (out.separable.minCoeff() < 1e-6) {
    out.why_not = "not determined by these data (the offset is a first moment of the base link to them)";
    return out;
  }
  if (cs.size() < 2) {
    out.why_not = "fewer than two time folds";
    return out;
  }
  out.fitted = true;
  return out;
}

}  // namespace exoid::estimator
