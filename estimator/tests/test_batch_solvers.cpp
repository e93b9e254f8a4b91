// The batch machinery against independent dense computations on the stacked problem:
//  - the streamed per-coordinate, per-fold QR equals the QR of the stacked W (normal matrix, z, rss) for any
//    block size, fold count and thread count;
//  - every solver (OLS, WLS-R, WLS-C, WLS-RC) at every truncation rank equals the thesis's formulas
//    (eqs. 20-23, 27, 29-32) evaluated with a dense SVD of the stacked, scaled 130-column W;
//  - a held function (HeldFunction, eliminated from the rows) gives the equality-constrained least-squares fit of a
//    dense nullspace solve, the function held exactly;
//  - a set of directions kept (orderDirections) equals the dense minimum-deviation solve of its equations, and the
//    jackknife leaves at the prior a direction that another processing of the same data moves.
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::estimator {
namespace {

struct Problem {
  Model model;
  BaseParameters base;
  Eigen::MatrixXd W;  // stacked [N nv x p]
  Eigen::VectorXd y;
  int nv = 0, N = 0;
};

// N random states of the exoskeleton; y = W phi_true + noise whose level differs per coordinate (so WLS-R
// has something to weight).
Problem makeProblem(int N, uint64_t seed) {
  Problem pb;
  std::string err;
  EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, pb.model, &err)) << err;
  pb.base = computeBaseParameters(pb.model);
  const Model& m = pb.model;
  pb.nv = m.nv;
  pb.N = N;
  pb.W.resize(N * m.nv, m.nparams());
  pb.y.resize(N * m.nv);
  Data data(m);
  State s = State::zero(m);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Eigen::VectorXd phi = m.phi;
  for (int j = 0; j < m.njoints; ++j) phi[m.frictionParamIndex(j)] = 0.3, phi[m.frictionParamIndex(j) + 1] = 0.5;
  for (int i = 0; i < N; ++i) {
    randomState(m, rng, s);
    s.a *= 0.1;  // gentler, so that coordinates differ in scale
    computeJointTorqueRegressor(m, data, s);
    pb.W.middleRows(i * m.nv, m.nv) = data.K;
    for (int c = 0; c < m.nv; ++c) pb.y[i * m.nv + c] = data.K.row(c).dot(phi) + 0.05 * (1 + c % 4) * noise(rng);
  }
  return pb;
}

LsqAccumulator accumulate(const Problem& pb, const AccumulatorOptions& o) {
  LsqAccumulator acc(pb.model, pb.base, o);
  for (int i = 0; i < pb.N; ++i)
    EXPECT_TRUE(acc.add(pb.W.middleRows(i * pb.nv, pb.nv), pb.y.segment(i * pb.nv, pb.nv)));
  acc.flush();
  return acc;
}

TEST(BatchAccumulator, StreamingQrEqualsTheStackedSolve) {
  const Problem pb = makeProblem(900, 1);
  const int m = pb.base.rank;
  Eigen::MatrixXd Wb(pb.W.rows(), m);
  for (int j = 0; j < m; ++j) Wb.col(j) = pb.W.col(pb.base.independent[j]);
  // Independent: normal matrix, W^T y, the least-squares solution and its residual from the stacked matrix.
  const Eigen::MatrixXd G = Wb.transpose() * Wb;
  const Eigen::VectorXd g = Wb.transpose() * pb.y;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> dense(Wb);
  const Eigen::VectorXd x_dense = dense.solve(pb.y);
  const double rss_dense = (Wb * x_dense - pb.y).squaredNorm();
  for (const AccumulatorOptions o : {AccumulatorOptions{256, 5, 100, 2}, AccumulatorOptions{7, 1, 2000, 1},
                                     AccumulatorOptions{1000, 3, 37, 2}}) {
    const LsqAccumulator acc = accumulate(pb, o);
    const LsqFactor f = acc.mergedBase();
    EXPECT_EQ(f.rows, static_cast<long>(pb.W.rows()));
    const Eigen::MatrixXd Rt = f.R.triangularView<Eigen::Upper>();
    EXPECT_LT((Rt.transpose() * Rt - G).norm() / G.norm(), 1e-13);
    EXPECT_LT((Rt.transpose() * f.z - g).norm() / g.norm(), 1e-13);
    const Eigen::VectorXd x = Rt.triangularView<Eigen::Upper>().solve(f.z);
    EXPECT_LT((x - x_dense).norm() / x_dense.norm(), 1e-9);
    EXPECT_NEAR(f.rss, rss_dense, 1e-9 * rss_dense);
    // Per-coordinate residuals from the factors equal the stacked ones.
    for (int c = 0; c < pb.nv; ++c) {
      double r = 0.0;
      for (int i = 0; i < pb.N; ++i) r += std::pow(Wb.row(i * pb.nv + c).dot(x_dense) - pb.y[i * pb.nv + c], 2);
      EXPECT_NEAR(acc.residual(c, x_dense), r, 1e-9 * r) << c;
    }
    // The standard-parameter factor: ||W phi - y||^2 = ||R phi - z||^2 + rss for any phi.
    const LsqFactor sf = toStandard(f, pb.base.base_map);
    const Eigen::VectorXd phi = pb.model.phi * 1.1;
    const double lhs = (pb.W * phi - pb.y).squaredNorm();
    EXPECT_NEAR((sf.R.triangularView<Eigen::Upper>() * phi - sf.z).squaredNorm() + sf.rss, lhs, 1e-10 * lhs);
  }
}

TEST(BatchAccumulator, RejectsNonFiniteRows) {
  const Problem pb = makeProblem(3, 2);
  LsqAccumulator acc(pb.model, pb.base);
  Eigen::MatrixXd K = pb.W.topRows(pb.nv);
  K(3, 4) = std::nan("");
  EXPECT_FALSE(acc.add(K, pb.y.head(pb.nv)));
  EXPECT_EQ(acc.samples(), 0);
}

// The column scale of WLS-C from the stacked problem: columnScale, except a kind whose prior is zero throughout
// (friction absent from the prior), which takes the data's scale sqrt(sum_c ||G_c y_c||^2 / sum_c ||G_c W_c e_j||^2)
// over the coordinates c its column reaches (priorUncertainty's unknown prior).
Eigen::VectorXd denseColumnScale(const Problem& pb, const Eigen::VectorXd& prior, const Eigen::VectorXd& wrow) {
  Eigen::VectorXd h = columnScale(pb.model, prior);
  const int ni = pb.model.nInertialParams(), p = pb.model.nparams();
  for (int kind = 0; kind < 2; ++kind) {
    bool stated = false;
    for (int i = ni + kind; i < p; i += 2) stated = stated || prior[i] != 0.0;
    if (stated) continue;
    for (int i = ni + kind; i < p; i += 2) {
      Eigen::VectorXd col2 = Eigen::VectorXd::Zero(pb.nv), y2 = Eigen::VectorXd::Zero(pb.nv);
      for (int r = 0; r < pb.N; ++r)
        for (int c = 0; c < pb.nv; ++c) {
          const int row = r * pb.nv + c;
          col2[c] += std::pow(wrow[row] * pb.W(row, i), 2), y2[c] += std::pow(wrow[row] * pb.y[row], 2);
        }
      double a = 0.0, b = 0.0;
      for (int c = 0; c < pb.nv; ++c)
        if (col2[c] > 1e-24 * col2.maxCoeff()) a += y2[c], b += col2[c];
      if (b > 0.0) h[i] = std::sqrt(a / b);
    }
  }
  return h;
}

// The thesis's formulas on the stacked, scaled W (all 130 columns, dense SVD).
std::vector<Eigen::VectorXd> denseSolve(const Problem& pb, Method method, const Eigen::VectorXd& prior,
                                        const std::vector<int>& ranks, Eigen::VectorXd* singular) {
  const int p = pb.model.nparams(), nv = pb.nv;
  Eigen::VectorXd wrow = Eigen::VectorXd::Ones(pb.W.rows());
  if (method == Method::WlsR || method == Method::WlsRC) {
    // Eq. (30) with the OLS solution (minimum norm; the residual does not depend on the nullspace).
    Eigen::BDCSVD<Eigen::MatrixXd> svd(pb.W, Eigen::ComputeThinU | Eigen::ComputeThinV);
    svd.setThreshold(1e-10);
    const Eigen::VectorXd e = pb.W * svd.solve(pb.y) - pb.y;
    for (int c = 0; c < nv; ++c) {
      double r2 = 0.0;
      for (int i = 0; i < pb.N; ++i) r2 += e[i * nv + c] * e[i * nv + c];
      const double sigma = std::sqrt(r2 / (pb.N - p));
      for (int i = 0; i < pb.N; ++i) wrow[i * nv + c] = 1.0 / sigma;  // eqs. (31)-(32)
    }
  }
  const bool C = method == Method::WlsC || method == Method::WlsRC;
  const Eigen::VectorXd h = C ? denseColumnScale(pb, prior, wrow) : Eigen::VectorXd::Ones(p);
  const Eigen::VectorXd gamma = C ? prior : Eigen::VectorXd::Zero(p);
  const Eigen::MatrixXd A = wrow.asDiagonal() * pb.W * h.asDiagonal();
  const Eigen::VectorXd yt = wrow.asDiagonal() * (pb.y - pb.W * gamma);
  Eigen::BDCSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  *singular = svd.singularValues();
  std::vector<Eigen::VectorXd> out;
  for (int z : ranks) {
    const Eigen::MatrixXd U = svd.matrixU().leftCols(z), V = svd.matrixV().leftCols(z);
    const Eigen::VectorXd alpha = (U.transpose() * yt).cwiseQuotient(svd.singularValues().head(z));  // eq. (20)
    if (C) {
      out.push_back(gamma + h.cwiseProduct(V * alpha));
    } else {
      // Eqs. (21)-(23): V_n spans the directions not used.
      const Eigen::MatrixXd Vn = svd.matrixV().rightCols(p - z);
      out.push_back(V * alpha + Vn * (Vn.transpose() * prior));
    }
  }
  return out;
}

TEST(BatchSolvers, EveryMethodAtEveryRankEqualsTheDenseSvdOfTheStackedProblem) {
  const Problem pb = makeProblem(400, 3);
  const LsqAccumulator acc = accumulate(pb, {64, 4, 50, 2});
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  Eigen::VectorXd prior = pb.model.phi;
  for (int i = 0; i < prior.size(); ++i) prior[i] *= 1.0 + u(rng);
  const int m = pb.base.rank;
  for (Method method : {Method::Ols, Method::WlsR, Method::WlsC, Method::WlsRC}) {
    FillOptions thesis_fill;
    thesis_fill.metric = FillMetric::Scaled;  // the thesis's fill: eq. 23 (OLS, WLS-R), eq. 27 (C)
    const ScaledProblem sp = scaleProblem(acc, pb.model, prior, method, {}, thesis_fill);
    const ScaledProblem spp = scaleProblem(acc, pb.model, prior, method);  // the default: the prior's own metric
    ASSERT_EQ(sp.s.size(), m);
    Eigen::VectorXd s_dense;
    const std::vector<int> ranks = {1, 10, 40, 77, m};
    const std::vector<Eigen::VectorXd> dense = denseSolve(pb, method, prior, ranks, &s_dense);
    // Same singular values as the scaled 130-column W: the m nonzero ones, then (structurally) zeros.
    EXPECT_LT((sp.s - s_dense.head(m)).norm() / s_dense[0], 1e-11) << methodName(method);
    std::printf("%s: s_1 %.3e, s_m/s_1 %.3e, s_(m+1)/s_1 %.3e\n", methodName(method), sp.s[0], sp.s[m - 1] / sp.s[0], s_dense[m] / s_dense[0]);
    EXPECT_LT(s_dense[m] / s_dense[0], 1e-12) << methodName(method);
    for (size_t k = 0; k < ranks.size(); ++k) {
      const int z = ranks[k];
      const Eigen::VectorXd a = solveAtRank(sp, z), b = dense[k];
      EXPECT_LT((a - b).norm() / b.norm(), 1e-8) << methodName(method) << " z " << z;
      // Prior fill: the same kept equations C phi = C b (C = V_z^T H^-1 from the dense SVD; any estimate of
      // the thesis's formulas satisfies them), and among those the point closest to the prior in the metric
      // P^-1, P = diag(sigma^2): phi = prior + P C^T (C P C^T)^-1 C (b - prior), evaluated densely.
      const bool C = method == Method::WlsC || method == Method::WlsRC;
      Eigen::VectorXd wrow = Eigen::VectorXd::Ones(pb.W.rows());
      for (int i = 0; i < pb.N; ++i)
        for (int c = 0; c < pb.nv; ++c) wrow[i * pb.nv + c] = sp.row_weight[c];
      const Eigen::VectorXd h = C ? denseColumnScale(pb, prior, wrow) : Eigen::VectorXd::Ones(prior.size());
      const Eigen::VectorXd sigma = priorScale(pb.model, prior, h);
      Eigen::BDCSVD<Eigen::MatrixXd> svd(wrow.asDiagonal() * pb.W * h.asDiagonal(), Eigen::ComputeThinV);
      const Eigen::MatrixXd Cz = svd.matrixV().leftCols(z).transpose() * h.cwiseInverse().asDiagonal();
      const Eigen::MatrixXd P = sigma.cwiseAbs2().asDiagonal();
      const Eigen::VectorXd want = prior + P * Cz.transpose() * (Cz * P * Cz.transpose()).ldlt().solve(Cz * (b - prior));
      EXPECT_LT((solveAtRank(spp, z) - want).norm() / want.norm(), 1e-8) << methodName(method) << " prior fill, z " << z;
    }
  }
}

TEST(BatchSolvers, RankChoiceCurvesAreConsistentWithTheirDefinitions) {
  const Problem pb = makeProblem(600, 4), val = makeProblem(300, 8);
  const LsqAccumulator acc = accumulate(pb, {64, 4, 50, 2});
  const LsqAccumulator vacc = accumulate(val, {64, 1, 50, 2});
  Eigen::VectorXd prior = pb.model.phi * 1.2;
  const ScaledProblem sp = scaleProblem(acc, pb.model, prior, Method::WlsRC);
  const LsqFactor vf = toStandard(vacc.mergedBase(), val.base.base_map);
  const RankCurve vc = rankByValidation(sp, vf);
  for (int z : {0, 5, 50, vc.best}) {
    const Eigen::VectorXd phi = solveAtRank(sp, z);
    const double direct = std::sqrt((val.W * phi - val.y).squaredNorm() / val.W.rows());
    EXPECT_NEAR(vc.score[z], direct, 1e-9 * direct);
  }
  for (double s : vc.score) EXPECT_GE(s, vc.score[vc.best]);
  // GCV from the factors equals rows * RSS / (rows - z)^2 with the weighted stacked residual.
  const RankCurve g = rankByGcv(sp);
  Eigen::VectorXd wrow(pb.W.rows());
  for (int i = 0; i < pb.N; ++i)
    for (int c = 0; c < pb.nv; ++c) wrow[i * pb.nv + c] = sp.row_weight[c];
  for (int z : {3, 60}) {
    const double r = (wrow.asDiagonal() * (pb.W * solveAtRank(sp, z) - pb.y)).squaredNorm();
    const double n = static_cast<double>(pb.W.rows());
    EXPECT_NEAR(g.score[z], n * r / ((n - z) * (n - z)), 1e-8 * g.score[z]);
  }
  // Cross-validation: noise-free data of a well-excited problem keep (nearly) every direction.
  const RankCurve cv = rankByCrossValidation(acc, pb.model, prior, Method::WlsRC);
  EXPECT_EQ(static_cast<int>(cv.score.size()), sp.s.size() + 1);
  EXPECT_GT(cv.best, 0);
}

// A rule that keeps a set of directions rather than the z largest (the jackknife's): orderDirections puts them first,
// and solveAtRank then keeps exactly those and fills the rest from the prior. Independent: the kept equations
// v_i^T H^-1 (phi - gamma) = d_i / s_i for i in S, and the minimum deviation from the prior in the fill's metric,
// phi = prior + D (A D)^+ (b - A prior) with A = V_S^T H^-1, D = diag(fill), by a complete orthogonal decomposition.
TEST(BatchSolvers, OrderedDirectionsKeepExactlyTheChosenSet) {
  const Problem pb = makeProblem(600, 5);
  const LsqAccumulator acc = accumulate(pb, {64, 5, 50, 2});
  const Eigen::VectorXd prior = pb.model.phi * 1.2;
  const ScaledProblem sp = scaleProblem(acc, pb.model, prior, Method::WlsRC);
  const int r = static_cast<int>(sp.s.size());
  std::vector<int> kept, order;
  for (int i = 0; i < 12; ++i) kept.push_back(i);
  for (int i : {20, 35, r - 3}) kept.push_back(i);
  order = kept;
  for (int i = 0; i < r; ++i)
    if (std::find(kept.begin(), kept.end(), i) == kept.end()) order.push_back(i);
  const int z = static_cast<int>(kept.size());
  const Eigen::VectorXd phi = solveAtRank(orderDirections(sp, order), z);
  const int p = pb.model.nparams();
  Eigen::MatrixXd A(z, p);
  Eigen::VectorXd b(z);
  for (int k = 0; k < z; ++k) {
    const int i = kept[k];
    A.row(k) = sp.V.col(i).cwiseQuotient(sp.h).transpose();
    b[k] = sp.d[i] / sp.s[i] + A.row(k).dot(sp.gamma);
  }
  const Eigen::MatrixXd AD = A * sp.fill.asDiagonal();
  const Eigen::VectorXd dense = prior + sp.fill.cwiseProduct(AD.completeOrthogonalDecomposition().solve(b - A * prior));
  EXPECT_LT((A * phi - b).norm(), 1e-9 * b.norm());
  EXPECT_LT((phi - dense).cwiseQuotient(sp.h).norm(), 1e-8 * dense.cwiseQuotient(sp.h).norm());
  // Not the prefix of the same size: the set differs.
  EXPECT_GT((solveAtRank(sp, z) - phi).cwiseQuotient(sp.h).norm(), 1e-3 * dense.cwiseQuotient(sp.h).norm());
  // The singular-value order itself changes nothing.
  std::vector<int> identity(r);
  for (int i = 0; i < r; ++i) identity[i] = i;
  EXPECT_LT((solveAtRank(orderDirections(sp, identity), 40) - solveAtRank(sp, 40)).norm(), 1e-12 * prior.norm());
}

// The jackknife's processing term: training data processed another way that moves the estimate along one kept
// direction by twice the prior's standard deviation there (y + W H v_k c, the same data otherwise, so every other
// coordinate stays) leave exactly that direction at the prior, named as processing-sensitive; every other
// direction keeps its verdict, and the kept set has the least risk of the curve.
TEST(BatchSolvers, TheJackknifeLeavesAtThePriorADirectionTheProcessingMoves) {
  const Problem pb = makeProblem(600, 6);
  const Model& m = pb.model;
  const LsqAccumulator acc = accumulate(pb, {64, 5, 50, 2});
  Eigen::VectorXd prior = m.phi * 1.2;
  for (int j = 0; j < m.njoints; ++j) prior[m.frictionParamIndex(j)] = 0.36, prior[m.frictionParamIndex(j) + 1] = 0.6;
  const TrainingFactors tf = trainingFactors(acc, m, Method::WlsRC);
  // Processed the same way (b = 0): the least-risk set of the variances alone, nothing processing-sensitive.
  const RankCurve plain = rankByJackknife(tf, m, prior, 0.25, {tf.all});
  ASSERT_GT(plain.best, 10);
  EXPECT_TRUE(plain.processing_sensitive.empty());
  const std::vector<int> kept(plain.order.begin(), plain.order.begin() + plain.best);
  // Without processing alternatives the rule keeps a prefix (order empty).
  EXPECT_TRUE(rankByJackknife(tf, m, prior, 0.25).order.empty());
  const int k = kept[kept.size() / 2];
  const ScaledProblem sp = scaleProblem(tf.all, m, prior, Method::WlsRC);
  const Eigen::VectorXd sh = priorUncertainty(m, prior, tf.all, 0.25).cwiseQuotient(sp.h);
  const double c = 2.0 * sh.cwiseProduct(sp.V.col(k)).norm();  // twice the prior's standard deviation along v_k
  Problem moved = pb;
  moved.y += pb.W * sp.h.cwiseProduct(sp.V.col(k)) * c;
  const LsqAccumulator alt = accumulate(moved, {64, 5, 50, 2});
  const RankCurve checked = rankByJackknife(tf, m, prior, 0.25, {weightedFactor(alt, m, true)});
  ASSERT_EQ(checked.processing_sensitive, std::vector<int>{k});
  std::vector<int> expect = kept;
  expect.erase(std::find(expect.begin(), expect.end(), k));
  EXPECT_EQ(std::vector<int>(checked.order.begin(), checked.order.begin() + checked.best), expect);
  EXPECT_EQ(checked.best, plain.best - 1);
  for (double score : checked.score) EXPECT_GE(score, checked.score[checked.best]);
  for (double score : plain.score) EXPECT_GE(score, plain.score[plain.best]);
  // The same through identify(): that set kept, the rest filled from the prior.
  IdentifyOptions o;
  o.rank_rule = RankRule::Jackknife;
  IdentifyResult r;
  std::string err;
  ASSERT_TRUE(identify(acc, m, prior, o, nullptr, r, &err, {&alt})) << err;
  EXPECT_EQ(r.rank, checked.best);
  const Eigen::VectorXd expect_phi = solveAtRank(orderDirections(sp, checked.order), checked.best);
  EXPECT_LT((r.phi - expect_phi).cwiseQuotient(sp.h).norm(), 1e-9 * expect_phi.cwiseQuotient(sp.h).norm());
}

// The system's vertical first moment at q = 0 held 0.5 kg m away from the truth's (`exoid identify --com-height
// prior`'s function), eliminated through the base link's h_z as tools::SourceOptions::held_function does it row by row
// (here on the stacked W): OLS at full rank with the held function predicts what the dense equality-constrained
// least-squares solution predicts (min ||W phi - y|| s.t. c^T phi = v, by the nullspace of c^T), and c^T phi = v.
TEST(BatchIdentify, AHeldFunctionGivesTheEqualityConstrainedLeastSquaresFit) {
  const Problem pb = makeProblem(600, 3);
  const Model& m = pb.model;
  HeldFunction h;
  h.j = m.bodyParamIndex(0) + 3;
  Data kin(m);
  forwardKinematics(m, kin, State::zero(m));
  h.c = Eigen::VectorXd::Zero(m.nparams());
  for (int b = 0; b < m.nbodies; ++b) {
    h.c[m.bodyParamIndex(b)] = kin.p[b].z();
    h.c.segment<3>(m.bodyParamIndex(b) + 1) = kin.R[b].row(2).transpose();
  }
  ASSERT_EQ(h.c[h.j], 1.0);
  h.value = h.c.dot(m.phi) + 0.5;
  // The elimination: W - W_j c^T, y - W_j v; parameter j held in the base parameters.
  Problem el = pb;
  el.y -= pb.W.col(h.j) * h.value;
  el.W -= pb.W.col(h.j) * h.c.transpose();
  BaseParameterOptions bo;
  bo.held.assign(static_cast<size_t>(m.nparams()), false);
  bo.held[static_cast<size_t>(h.j)] = true;
  el.base = computeBaseParameters(m, bo);
  const LsqAccumulator acc = accumulate(el, AccumulatorOptions{256, 5, 100, 2});
  IdentifyOptions o;
  o.method = Method::Ols;
  o.rank_rule = RankRule::Full;
  o.held_function = h;
  IdentifyResult r;
  std::string err;
  ASSERT_TRUE(identify(acc, m, m.phi, o, nullptr, r, &err)) << err;
  // Independent: phi = phi_p + N z with c^T phi_p = v and N a basis of null(c^T) (a full QR of c); z the minimum-norm
  // solution (W N has W's structural nullspace: a pivoted QR's basic solution is huge there and loses c^T phi to
  // rounding).
  const int p = m.nparams();
  const Eigen::VectorXd phi_p = h.c * (h.value / h.c.squaredNorm());
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(h.c);
  const Eigen::MatrixXd N = (qr.householderQ() * Eigen::MatrixXd::Identity(p, p)).rightCols(p - 1);
  const Eigen::VectorXd z = (pb.W * N).completeOrthogonalDecomposition().solve(pb.y - pb.W * phi_p);
  const Eigen::VectorXd phi_kkt = phi_p + N * z;
  EXPECT_NEAR(h.c.dot(phi_kkt), h.value, 1e-9 * std::abs(h.value));
  const Eigen::VectorXd pred_kkt = pb.W * phi_kkt, pred = pb.W * r.phi;
  std::printf("held function: predictions against the dense constrained solution, relative %.2e\n",
              (pred - pred_kkt).norm() / pred_kkt.norm());
  EXPECT_LT((pred - pred_kkt).norm(), 1e-8 * pred_kkt.norm());
  EXPECT_NEAR(h.c.dot(r.phi), h.value, 1e-12 * std::abs(h.value));
  // The constraint is active: the unconstrained fit's function is far from v.
  const Eigen::VectorXd phi_free = pb.W.colPivHouseholderQr().solve(pb.y);
  EXPECT_GT(std::abs(h.c.dot(phi_free) - h.value), 0.3);
}

}  // namespace
}  // namespace exoid::estimator
