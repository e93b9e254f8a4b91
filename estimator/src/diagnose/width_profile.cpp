// The signal-shape profiles of the diagnosis (diagnose_stages.hpp, docs/diagnose.md): each joint's Coulomb width and
// ElasticExp scale, chosen on the training data before the selection tests one candidate of each kind per joint.
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>

#include "exoid/estimator/diagnose_stages.hpp"

namespace exoid::estimator {

namespace {
// The declared (kept) columns' Gram A^T A = R1^T R1, R1 [mk x mk] the triangle of A_keep's QR (empty without kept
// columns).
Eigen::MatrixXd declaredGramFactor(const DiagnoseData& data) {
  const int mk = static_cast<int>(data.keep.size());
  return mk > 0 ? Eigen::MatrixXd(data.A_keep.householderQr().matrixQR().topRows(mk).triangularView<Eigen::Upper>())
                : Eigen::MatrixXd();
}

// Signals s of one joint row, from their training sums B = K_j^T s [md x n] and sy = s^T y_j [n], against the declared
// fit: Z [mk x n] with R1^T Z = B's kept rows, so that s_a^T P s_b = Z_a . Z_b (P the projection on the declared span),
// and se = s^T e = sy - B_keep^T x0 (e the declared fit's residual).
void offDeclaredSpan(const DiagnoseData& data, const Eigen::MatrixXd& R1, const Eigen::MatrixXd& B, const Eigen::VectorXd& sy,
                     Eigen::MatrixXd& Z, Eigen::VectorXd& se) {
  const int mk = static_cast<int>(data.keep.size()), n = static_cast<int>(B.cols());
  Eigen::MatrixXd Bk(mk, n);
  for (int a = 0; a < mk; ++a) Bk.row(a) = B.row(data.keep[a]);
  Z = mk > 0 ? Eigen::MatrixXd(R1.transpose().triangularView<Eigen::Lower>().solve(Bk)) : Eigen::MatrixXd::Zero(0, n);
  se = mk > 0 ? Eigen::VectorXd(sy - Bk.transpose() * data.x0) : sy;
}

// g^T M^+ g over the directions the Gram M resolves (a column inside the declared span has none of its own).
template <int N>
double resolvedGain(const Eigen::Matrix<double, N, N>& M, const Eigen::Matrix<double, N, 1>& g) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> es(M);
  const double top = es.eigenvalues().cwiseAbs().maxCoeff();
  double score = 0.0;
  for (int a = 0; a < N; ++a)
    if (es.eigenvalues()[a] > 1e-10 * top) score += std::pow(es.eigenvectors().col(a).dot(g), 2) / es.eigenvalues()[a];
  return score;
}
}  // namespace

// Per joint and dry-friction kind, the width whose signal s, together with the viscous signal v (on the joint's row),
// would remove the most of the declared fit's training residual e: the least-squares gain g^T M^-1 g of the two
// columns made orthogonal to the declared columns of every row (their Gram from the declared factor), M their Gram,
// g their products with e. e is orthogonal to the declared columns, so s_perp . e = s . e. With v beside it, a wide
// tanh gains nothing by imitating viscous friction: the width describes the dry part (alone, the KUKA's joints all
// took the grid's widest). Every width in one pass.
void profileCoulombWidths(DiagnoseData& data) {
  const int nw = data.nw, ns2 = 2 * nw;
  data.width_of.assign(static_cast<size_t>(2 * data.nj), data.widths[0]);  // the one width; with a grid, overwritten
  if (nw <= 1) return;
  const Eigen::MatrixXd R1 = declaredGramFactor(data);
  Eigen::MatrixXd Z;
  Eigen::VectorXd se;  // s^T e (v^T e last)
  for (int j = 0; j < data.nj; ++j) {
    const WidthProfileSums& pr = data.profile[static_cast<size_t>(j)];
    offDeclaredSpan(data, R1, pr.B, pr.cy, Z, se);
    const double vv = pr.cc[ns2] - Z.col(ns2).squaredNorm();
    for (int kind = 0; kind < 2; ++kind) {
      double best = -1.0;
      for (int w = 0; w < nw; ++w) {
        const int s = kind * nw + w;
        const double ss = pr.cc[s] - Z.col(s).squaredNorm(), sv = pr.cv[s] - Z.col(s).dot(Z.col(ns2));
        const double det = ss * vv - sv * sv;
        double score = 0.0;
        if (det > 1e-12 * ss * vv)  // [s v] gain: g^T M^-1 g
          score = (vv * se[s] * se[s] - 2.0 * sv * se[s] * se[ns2] + ss * se[ns2] * se[ns2]) / det;
        else if (ss > 1e-12 * pr.cc[s])
          score = se[s] * se[s] / ss;
        if (score > best) best = score, data.width_of[static_cast<size_t>(2 * j + kind)] = data.widths[w];
      }
    }
  }
}


void profileElasticScales(const DiagnoseOptions& opt, DiagnoseData& data) {
  const int nj = data.nj, ne = static_cast<int>(opt.elastic_scales.size());
  data.center_of.assign(static_cast<size_t>(nj), 0.0);
  data.scale_of.assign(static_cast<size_t>(nj), ne > 0 ? opt.elastic_scales[0] : 0.0);
  if (!data.has_q || data.eprofile.empty()) return;
  const Eigen::MatrixXd R1 = declaredGramFactor(data);
  Eigen::MatrixXd Z;
  Eigen::VectorXd ze;  // z^T e
  for (int j = 0; j < nj; ++j) {
    const ElasticProfileSums& pr = data.eprofile[static_cast<size_t>(j)];
    if (pr.n == 0) continue;
    data.center_of[static_cast<size_t>(j)] = pr.qsum / static_cast<double>(pr.n);
    offDeclaredSpan(data, R1, pr.B, pr.zy, Z, ze);
    // The Gram of z off the declared span.
    const Eigen::MatrixXd M = Eigen::MatrixXd(pr.G.selfadjointView<Eigen::Lower>()) - Z.transpose() * Z;
    double best = -1.0;
    for (int k = 0; k < ne; ++k) {
      const int idx[3] = {k, ne, ne + 1};
      Eigen::Matrix3d Ms;
      Eigen::Vector3d g;
      for (int a = 0; a < 3; ++a) {
        g[a] = ze[idx[a]];
        for (int b = 0; b < 3; ++b) Ms(a, b) = M(idx[a], idx[b]);
      }
      const double score = resolvedGain(Ms, g);
      if (std::isfinite(score) && score > best) best = score, data.scale_of[static_cast<size_t>(j)] = opt.elastic_scales[k];
    }
  }
}

void profileCoupledElasticShapes(const DiagnoseOptions& opt, DiagnoseData& data) {
  const size_t np = data.cprofile.size();
  const int ns = static_cast<int>(opt.coupled_elastic_scales.size()), nr = static_cast<int>(opt.coupled_elastic_ratios.size());
  const int ng = ns * nr;
  data.cscale_of.assign(np, ns > 0 ? opt.coupled_elastic_scales[0] : 0.0);
  data.cratio_of.assign(np, nr > 0 ? opt.coupled_elastic_ratios[0] : 0.0);
  if (np == 0) return;
  const Eigen::MatrixXd R1 = declaredGramFactor(data);
  Eigen::MatrixXd Z;
  Eigen::VectorXd ze;  // z^T e
  for (size_t k = 0; k < np; ++k) {
    const CoupledElasticProfileSums& pr = data.cprofile[k];
    offDeclaredSpan(data, R1, pr.B, pr.zy, Z, ze);
    // The three linear signals' block of the Gram off the declared span: the same for every grid signal.
    Eigen::Matrix3d L;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) L(a, b) = pr.G(ng + a, 1 + b) - Z.col(ng + a).dot(Z.col(ng + b));
    double best = -1.0;
    for (int g = 0; g < ng; ++g) {
      Eigen::Matrix4d Ms;
      Eigen::Vector4d gv;
      Ms.bottomRightCorner<3, 3>() = L;
      Ms(0, 0) = pr.G(g, 0) - Z.col(g).squaredNorm();
      for (int b = 0; b < 3; ++b) Ms(0, 1 + b) = Ms(1 + b, 0) = pr.G(g, 1 + b) - Z.col(g).dot(Z.col(ng + b));
      gv[0] = ze[g];
      for (int b = 0; b < 3; ++b) gv[1 + b] = ze[ng + b];
      const double score = resolvedGain(Ms, gv);
      if (std::isfinite(score) && score > best)
        best = score, data.cscale_of[k] = opt.coupled_elastic_scales[g / nr], data.cratio_of[k] = opt.coupled_elastic_ratios[g % nr];
    }
  }
}

}  // namespace exoid::estimator
