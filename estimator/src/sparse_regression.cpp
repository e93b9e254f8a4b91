// Forward stepwise selection (sparse_regression.hpp).
#include "exoid/estimator/sparse_regression.hpp"

#include <Eigen/Cholesky>
#include <cmath>

namespace exoid::estimator {

double SparseModel::predict(const Eigen::MatrixXd& X, long row) const {
  double p = intercept;
  for (size_t i = 0; i < terms.size(); ++i) p += coef[static_cast<Eigen::Index>(i)] * X(row, terms[i]);
  return p;
}

std::vector<SparseModel> forwardSelectionPath(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                                              const std::vector<long>& rows, int max_terms) {
  const long n = static_cast<long>(rows.size());
  const int D = static_cast<int>(X.cols());
  std::vector<SparseModel> path;
  if (n == 0) return path;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(D), scale = Eigen::VectorXd::Zero(D);
  double ymean = 0.0;
  for (long r : rows) mean += X.row(r).transpose(), ymean += y[r];
  mean /= static_cast<double>(n), ymean /= static_cast<double>(n);
  Eigen::MatrixXd Z(n, D);
  Eigen::VectorXd yc(n);
  for (long i = 0; i < n; ++i) Z.row(i) = X.row(rows[i]) - mean.transpose(), yc[i] = y[rows[i]] - ymean;
  for (int d = 0; d < D; ++d) {
    scale[d] = std::sqrt(Z.col(d).squaredNorm() / static_cast<double>(n));
    if (scale[d] > 1e-12 * (1.0 + std::fabs(mean[d]))) Z.col(d) /= scale[d];
    else scale[d] = 0.0, Z.col(d).setZero();  // constant: never chosen
  }
  const Eigen::MatrixXd G = Z.transpose() * Z;
  const Eigen::VectorXd c = Z.transpose() * yc;

  auto model = [&](const std::vector<int>& S, const Eigen::VectorXd& beta) {
    SparseModel m;
    m.terms = S;
    m.coef.resize(static_cast<Eigen::Index>(S.size()));
    m.intercept = ymean;
    for (size_t i = 0; i < S.size(); ++i) {
      m.coef[static_cast<Eigen::Index>(i)] = beta[static_cast<Eigen::Index>(i)] / scale[S[i]];
      m.intercept -= m.coef[static_cast<Eigen::Index>(i)] * mean[S[i]];
    }
    return m;
  };
  std::vector<int> S;
  path.push_back(model(S, Eigen::VectorXd()));
  std::vector<bool> used(D, false);
  for (int k = 0; k < max_terms; ++k) {
    const int m = static_cast<int>(S.size());
    Eigen::MatrixXd Gs(m, m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) Gs(i, j) = G(S[i], S[j]);
    const Eigen::LLT<Eigen::MatrixXd> llt(Gs);
    int best = -1;
    double best_gain = 0.0;
    Eigen::VectorXd best_beta;
    for (int d = 0; d < D; ++d) {
      if (used[d] || scale[d] == 0.0) continue;
      Eigen::VectorXd g(m);
      for (int i = 0; i < m; ++i) g[i] = G(S[i], d);
      const Eigen::VectorXd h = m ? Eigen::VectorXd(llt.solve(g)) : Eigen::VectorXd();
      const double schur = G(d, d) - (m ? g.dot(h) : 0.0);  // squared norm of the part of Z_d outside span(Z_S)
      if (!(schur > 1e-8 * G(d, d))) continue;
      Eigen::VectorXd cs(m);
      for (int i = 0; i < m; ++i) cs[i] = c[S[i]];
      // Block elimination: the new term's coefficient and the RSS reduction it adds.
      const double resid_c = c[d] - (m ? h.dot(cs) : 0.0);
      const double gain = resid_c * resid_c / schur;
      if (gain > best_gain) {
        best_gain = gain, best = d;
        const double bd = resid_c / schur;
        best_beta.resize(m + 1);
        if (m) best_beta.head(m) = llt.solve(cs) - h * bd;
        best_beta[m] = bd;
      }
    }
    if (best < 0) break;
    used[best] = true;
    S.push_back(best);
    path.push_back(model(S, best_beta));
  }
  return path;
}

}  // namespace exoid::estimator
