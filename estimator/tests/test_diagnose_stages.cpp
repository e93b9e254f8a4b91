// The diagnosis's stages one by one (diagnose_stages.hpp), each against an independent dense computation on a short
// synthetic KUKA LWR4+ run (y = K phi + 2 N m s/rad of viscous friction on joint 3 + noise): the streamed factors
// against the stacked matrices, the fits against dense least squares, the fold test against per-fold refits, the
// selection rule on hand-made scores, Student's t against its closed forms.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "exoid/estimator/diagnose_stages.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "diagnosis_runs.hpp"
#include "kuka_model.hpp"

namespace exoid::estimator {
namespace {

using test::kuka;

using diagnosis_runs::Run;
using diagnosis_runs::segmentOf;

// 8 s at 100 Hz of three sines per joint; y = K phi + 2 v_3 + N(0, 0.05^2), and with coupling != 0 a moment on joint 2
// from joint 3's angle, y_2 += coupling q_3.
Run makeRun(const Model& model, uint64_t seed, double coupling = 0.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> f(0.1, 0.6), ph(0, 2 * M_PI), amp(0.1, 0.3);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<std::array<double, 9>> c(model.njoints);
  for (auto& cj : c)
    for (int h = 0; h < 3; ++h) cj[3 * h] = f(rng), cj[3 * h + 1] = ph(rng), cj[3 * h + 2] = amp(rng);
  Data data(model);
  Run run;
  for (int k = 0; k < 800; ++k) {
    const double t = 0.01 * k;
    State s = State::zero(model);
    for (int j = 0; j < model.njoints; ++j)
      for (int h = 0; h < 3; ++h) {
        const double w = 2 * M_PI * c[j][3 * h], a = c[j][3 * h + 2] / w, arg = w * t + c[j][3 * h + 1];
        s.q[j] += a * std::sin(arg), s.v[j] += a * w * std::cos(arg), s.a[j] -= a * w * w * std::sin(arg);
      }
    computeJointTorqueRegressor(model, data, s);
    Eigen::VectorXd y = data.K * model.phi;
    y[3] += 2.0 * s.v[3];
    y[2] += coupling * s.q[3];
    for (int r = 0; r < model.nv; ++r) y[r] += noise(rng);
    run.states.push_back(s), run.t.push_back(t), run.y.push_back(y);
  }
  return run;
}


// Stages up to the candidate columns on one training and one validation run.
struct Prepared {
  Run train = makeRun(kuka(), 11), val = makeRun(kuka(), 12);
  std::vector<Segment> tr, va;
  DiagnoseOptions opt;
  DiagnoseData data;
  DiagnosisResult out;
  explicit Prepared(bool two_angle = false, double coupling = 0.0) {
    const Model& model = kuka();
    if (coupling != 0.0) train = makeRun(model, 11, coupling), val = makeRun(model, 12, coupling);
    tr = {segmentOf(model, train, "train")}, va = {segmentOf(model, val, "val")};
    if (two_angle) opt.kinds.push_back(EffectKind::ElasticExpCoupled);
    opt.folds = 5;
    opt.chunk_seconds = 0.5;
    std::string err;
    declaredColumns(model, opt, tr, va, data, out);
    EXPECT_TRUE(trainingPass(model, opt, data, out, &err)) << err;
    EXPECT_TRUE(declaredFit(data, out, &err)) << err;
    profileCoulombWidths(data);
    profileElasticScales(opt, data);
    profileCoupledElasticShapes(opt, data);
    EXPECT_TRUE(declaredPrediction(model, data, out, &err)) << err;
    rowWeights(model, data);
    candidateSignals(model, opt, data, out);
  }
  long dense_rows() const { return static_cast<long>(train.states.size()) * kuka().nv; }
  // The stacked declared rows K_decl [n nv x m] and y of the training run.
  void dense(Eigen::MatrixXd& W, Eigen::VectorXd& y) const {
    const Model& model = kuka();
    Data d(model);
    const long n = static_cast<long>(train.states.size());
    W.resize(n * model.nv, data.m), y.resize(n * model.nv);
    for (long i = 0; i < n; ++i) {
      computeJointTorqueRegressor(model, d, train.states[i]);
      for (int r = 0; r < model.nv; ++r) {
        for (int c = 0; c < data.m; ++c) W(i * model.nv + r, c) = d.K(r, data.decl[c]);
        y[i * model.nv + r] = train.y[i][r];
      }
    }
  }
};

// The index of the candidate of this kind on this joint (-1: none), in the prepared data.
int candidateIndex(const DiagnoseData& data, EffectKind kind, int joint) {
  for (int c = 0; c < data.nc; ++c)
    if (data.cands[c].kind == kind && data.cands[c].joint == joint) return c;
  return -1;
}

TEST(DiagnoseStages, TriangularFactorKeepsTheGramOfTheStreamedRows) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  for (int rows : {3, 7, 300}) {  // fewer rows than columns, then several blocks of 64
    Eigen::MatrixXd A(rows, 7);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = g(rng);
    TriangularFactor f(7);
    for (int i = 0; i < rows; ++i) f.nextRow() = A.row(i);
    f.flush();
    EXPECT_LT((f.R().transpose() * f.R() - A.transpose() * A).norm(), 1e-10 * (A.transpose() * A).norm()) << rows;
    EXPECT_EQ(f.R().triangularView<Eigen::StrictlyLower>().toDenseMatrix().norm(), 0.0);
    EXPECT_LT((TriangularFactor::triangular(A).transpose() * TriangularFactor::triangular(A) - A.transpose() * A).norm(),
              1e-10 * (A.transpose() * A).norm());
  }
}

TEST(DiagnoseStages, DeclaredFitIsTheDenseLeastSquaresFitAndItsPrediction) {
  const Prepared p;
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  p.dense(W, y);
  ASSERT_EQ(p.out.train_samples, 800);
  ASSERT_EQ(p.out.validation_samples, 800);
  EXPECT_EQ(p.data.m + p.out.dropped_columns, p.data.md);
  const Eigen::VectorXd x = W.colPivHouseholderQr().solve(y);
  EXPECT_LT((p.data.x0 - x).norm(), 1e-8 * x.norm());
  const Eigen::VectorXd pred = W * x;
  const SegmentSignals& c = p.data.caches[0];
  for (long i : {0L, 399L, 799L})
    for (int r = 0; r < 7; ++r) EXPECT_NEAR(c.tau0(i, r), pred[i * 7 + r], 1e-8) << i << " " << r;
  // Row weights: the RMS of the declared residual per coordinate.
  for (int r = 0; r < 7; ++r) {
    double ss = 0.0;
    for (long i = 0; i < 800; ++i) ss += std::pow(y[i * 7 + r] - pred[i * 7 + r], 2);
    EXPECT_NEAR(p.data.sigma[r], std::sqrt(ss / 800), 1e-9) << r;
  }
  // v from K's friction column, a its central difference.
  EXPECT_NEAR(c.v(5, 2), p.train.states[5].v[2], 1e-12);
  EXPECT_NEAR(c.a(5, 2), (p.train.states[6].v[2] - p.train.states[4].v[2]) / 0.02, 1e-9);
}

TEST(DiagnoseStages, CandidateSignalsAndTheirColumns) {
  const Prepared p;
  // Every default kind on every joint (the arm's joints are actuated and measured); the biarticular spring once per
  // kinematic neighbour (a chain of 7 joints: 6 pairs, each in both directions); the opt-in two-angle exponential not.
  EXPECT_EQ(p.data.nc, (kEffectKinds - 2) * 7 + 12);
  EXPECT_EQ(p.data.P, p.data.m + p.data.nc + 1);  // no payload columns without a held model
  for (int r = 0; r < 7; ++r) EXPECT_EQ(p.data.active[r].back(), p.data.iy);
  for (const DiagnosisCandidate& cd : p.data.cands) {
    const double v = p.train.states[100].v[cd.joint], a = p.data.caches[0].a(100, cd.joint);
    const double x = p.train.states[100].q[cd.coupled >= 0 ? cd.coupled : cd.joint] - cd.center;
    if (cd.kind == EffectKind::ElasticCoupled) {
      EXPECT_EQ(std::abs(cd.coupled - cd.joint), 1);  // the arm's chain
    }
    const double tau = p.data.caches[0].tau(100, cd.coord), dtau = p.data.caches[0].dtau(100, cd.coord);
    const double expect = cd.kind == EffectKind::Viscous    ? v
                          : cd.kind == EffectKind::Offset   ? 1.0
                          : cd.kind == EffectKind::Armature ? a
                          : cd.kind == EffectKind::GainError ? tau  // fixed base: the sensor's part is all of y
                          : cd.kind == EffectKind::Delay    ? -dtau
                          : cd.kind == EffectKind::Coulomb  ? std::tanh(v / cd.width)
                          : cd.kind == EffectKind::Elastic || cd.kind == EffectKind::ElasticCoupled ? x
                          : cd.kind == EffectKind::ElasticExp ? cd.width * (std::exp(x / cd.width) - 1.0)
                                                            : std::tanh(v / cd.width) * std::exp(-std::pow(v / 0.1, 2));
    EXPECT_NEAR(candidateSignal(kuka(), p.opt, p.data, 0, 100, cd), expect, 1e-12) << effectKindName(cd.kind);
  }
  // The elastic kinds' center: the joint's mean training angle.
  for (int j = 0; j < 7; ++j) {
    double mean = 0.0;
    for (const State& s : p.train.states) mean += s.q[j];
    mean /= static_cast<double>(p.train.states.size());
    EXPECT_NEAR(p.data.center_of[static_cast<size_t>(j)], mean, 1e-12) << j;
  }
}

// The ElasticExp scale of each joint maximises, over the grid, the dense least-squares gain of the columns
// [s (exp((q - c) / s) - 1), q - c, 1] on the joint's row added to the declared columns: ||P_[W Z] y||^2 - ||P_W y||^2.
TEST(DiagnoseStages, ElasticScaleProfileMaximisesTheDenseGain) {
  const Prepared p;
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  p.dense(W, y);
  const long n = static_cast<long>(p.train.states.size());
  const auto explained = [&](const Eigen::MatrixXd& A) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    return (A * qr.solve(y)).squaredNorm();
  };
  const double base = explained(W);
  for (int j = 0; j < 7; ++j) {
    std::vector<double> gain;
    for (double sc : p.opt.elastic_scales) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(W.rows(), W.cols() + 3);
      A.leftCols(W.cols()) = W;
      for (long i = 0; i < n; ++i) {
        const double x = p.train.states[static_cast<size_t>(i)].q[j] - p.data.center_of[static_cast<size_t>(j)];
        A(i * 7 + j, W.cols()) = sc * std::expm1(x / sc), A(i * 7 + j, W.cols() + 1) = x, A(i * 7 + j, W.cols() + 2) = 1.0;
      }
      gain.push_back(explained(A) - base);
    }
    const double best = *std::max_element(gain.begin(), gain.end());
    const size_t chosen = static_cast<size_t>(
        std::find(p.opt.elastic_scales.begin(), p.opt.elastic_scales.end(), p.data.scale_of[static_cast<size_t>(j)]) -
        p.opt.elastic_scales.begin());
    ASSERT_LT(chosen, gain.size()) << j;
    EXPECT_GE(gain[chosen], best - 1e-6 * std::fabs(best)) << "joint " << j << ": scale " << p.data.scale_of[static_cast<size_t>(j)];
  }
}

// The ElasticExpCoupled (scale, ratio) of each (joint, neighbour) pair maximises, over the grid, the dense
// least-squares gain of [s (exp(((q_j - c_j) + r (q_i - c_i)) / s) - 1), q_j - c_j, q_i - c_i, 1] on the joint's row
// beside the declared columns, computed here by residualising against W's thin QR (the stage accumulates normal-equation
// sums in pass A instead); each pair's candidate carries that shape and both centers.
TEST(DiagnoseStages, TwoAngleProfileMaximisesTheDenseGain) {
  const Prepared p(true);
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  p.dense(W, y);
  const long n = static_cast<long>(p.train.states.size());
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(W);
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(W.rows(), W.cols());
  const Eigen::VectorXd e = y - Q * (Q.transpose() * y);
  ASSERT_EQ(p.data.cprofile.size(), 12u);  // the arm's chain: 6 joints with two neighbours, 2 with one
  int candidates = 0;
  for (const DiagnosisCandidate& cd : p.data.cands) candidates += cd.kind == EffectKind::ElasticExpCoupled;
  EXPECT_EQ(candidates, 12);
  for (size_t k = 0; k < p.data.cprofile.size(); ++k) {
    const int j = p.data.cprofile[k].joint, c = p.data.cprofile[k].coupled;
    const double cj = p.data.center_of[static_cast<size_t>(j)], cc = p.data.center_of[static_cast<size_t>(c)];
    double best = -1.0, chosen = -1.0;
    for (double sc : p.opt.coupled_elastic_scales)
      for (double r : p.opt.coupled_elastic_ratios) {
        Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(W.rows(), 4);
        for (long i = 0; i < n; ++i) {
          const Eigen::VectorXd& q = p.train.states[static_cast<size_t>(i)].q;
          const double xj = q[j] - cj, xc = q[c] - cc;
          Z.row(i * 7 + j) << sc * std::expm1((xj + r * xc) / sc), xj, xc, 1.0;
        }
        Z -= Q * (Q.transpose() * Z);
        const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> zq(Z);
        const double gain = (Z * zq.solve(e)).squaredNorm();
        best = std::max(best, gain);
        if (sc == p.data.cscale_of[k] && r == p.data.cratio_of[k]) chosen = gain;
      }
    ASSERT_GE(chosen, 0.0) << "pair " << j << "-" << c << ": the chosen shape is not on the grid";
    EXPECT_GE(chosen, best - 1e-6 * best) << "pair " << j << "-" << c << ": scale " << p.data.cscale_of[k] << " ratio "
                                          << p.data.cratio_of[k];
    bool found = false;
    for (const DiagnosisCandidate& cd : p.data.cands)
      if (cd.kind == EffectKind::ElasticExpCoupled && cd.joint == j && cd.coupled == c) {
        found = true;
        EXPECT_EQ(cd.width, p.data.cscale_of[k]);
        EXPECT_EQ(cd.ratio, p.data.cratio_of[k]);
        EXPECT_EQ(cd.center, cj);
        EXPECT_EQ(cd.coupled_center, cc);
      }
    EXPECT_TRUE(found) << j << "-" << c;
  }
}

// Held-out gains by dense refits, independently of the factor machinery: the declared rows weighted by 1 / sigma_r, the
// columns `given` [rows x g] added to the declared ones, then the candidate `cand` [rows]; fold of sample i =
// floor(t_i / 0.5) mod 5. d[f]: the held-out weighted SSE without the candidate minus with it. value: the candidate's
// coefficient fitted on all the rows.
Eigen::VectorXd denseHeldOutGains(const Prepared& p, const Eigen::MatrixXd& given, const Eigen::VectorXd& cand, double& value) {
  Eigen::MatrixXd W;
  Eigen::VectorXd y;
  p.dense(W, y);
  const long rows = W.rows();
  const int m = p.data.m, g = static_cast<int>(given.cols());
  Eigen::MatrixXd Wc(rows, m + g + 1);
  Eigen::VectorXd wy(rows);
  std::vector<int> fold(rows);
  for (long k = 0; k < rows; ++k) {
    const long i = k / 7;
    const double s = 1.0 / p.data.sigma[static_cast<int>(k % 7)];
    Wc.row(k).head(m) = s * W.row(k);
    Wc.row(k).segment(m, g) = s * given.row(k);
    Wc(k, m + g) = s * cand[k];
    wy[k] = s * y[k];
    fold[k] = static_cast<int>(static_cast<long>(p.train.t[i] / 0.5) % 5);
  }
  value = Wc.colPivHouseholderQr().solve(wy)[m + g];
  Eigen::VectorXd d(5);
  for (int f = 0; f < 5; ++f) {
    std::vector<long> in, out;
    for (long k = 0; k < rows; ++k) (fold[k] == f ? out : in).push_back(k);
    auto sub = [&](const std::vector<long>& idx, int cols) {
      Eigen::MatrixXd A(idx.size(), cols);
      for (size_t k = 0; k < idx.size(); ++k) A.row(k) = Wc.row(idx[k]).head(cols);
      return A;
    };
    auto vec = [&](const std::vector<long>& idx) {
      Eigen::VectorXd b(idx.size());
      for (size_t k = 0; k < idx.size(); ++k) b[k] = wy[idx[k]];
      return b;
    };
    const Eigen::VectorXd x0 = sub(in, m + g).colPivHouseholderQr().solve(vec(in));
    const Eigen::VectorXd x1 = sub(in, m + g + 1).colPivHouseholderQr().solve(vec(in));
    d[f] = (vec(out) - sub(out, m + g) * x0).squaredNorm() - (vec(out) - sub(out, m + g + 1) * x1).squaredNorm();
  }
  return d;
}

// A candidate's column on the stacked rows (row r of sample i at i * 7 + r): its signal on its own joint's row.
Eigen::VectorXd denseColumn(const Prepared& p, const std::function<double(const State&)>& signal, int joint) {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(p.train.states.size()) * 7);
  for (size_t i = 0; i < p.train.states.size(); ++i) c[static_cast<Eigen::Index>(i) * 7 + joint] = signal(p.train.states[i]);
  return c;
}

// The declared columns of the current model: every declared one (the prepared data after foldFactors).
void declaredOnly(Prepared& p) {
  p.data.S.resize(p.data.m);
  for (int c = 0; c < p.data.m; ++c) p.data.S[c] = c;
  p.data.fcol.clear();
}

TEST(DiagnoseStages, ScreeningMatchesPerFoldDenseRefits) {
  Prepared p;
  std::string err;
  ASSERT_TRUE(foldFactors(kuka(), p.opt, p.data, &err)) << err;
  declaredOnly(p);
  p.data.pdone.assign(0, 0);
  p.data.excluded.assign(p.data.nc, 0);
  CurrentFits fits;
  currentFits(p.opt, p.data, fits);
  const std::vector<CandidateEval> evals = screenCandidates(kuka(), p.opt, p.data, fits, 0, p.out);
  // The viscous candidate on joint 3, independently.
  const int cv = candidateIndex(p.data, EffectKind::Viscous, 3);
  const CandidateEval* ev = nullptr;
  for (const CandidateEval& e : evals) ev = e.c == cv ? &e : ev;
  ASSERT_NE(ev, nullptr);
  double value = 0.0;
  const Eigen::VectorXd d =
      denseHeldOutGains(p, Eigen::MatrixXd(p.dense_rows(), 0), denseColumn(p, [](const State& s) { return s.v[3]; }, 3), value);
  EXPECT_NEAR(ev->f.effect.value, value, 1e-6);
  EXPECT_NEAR(ev->f.effect.value, 2.0, 0.1);
  const double mean = d.mean(), sd = std::sqrt((d.array() - mean).square().sum() / 4);
  EXPECT_NEAR(ev->gain, mean, 1e-6 * std::fabs(mean));
  EXPECT_NEAR(ev->f.t_stat, mean / (sd / std::sqrt(5.0)), 1e-6 * std::fabs(ev->f.t_stat));
  // The t-test (its statistic checked above) and the signed-rank test on the dense gains (ranks: exact), Bonferroni over
  // the two.
  EXPECT_DOUBLE_EQ(ev->f.p_value,
                   std::min(1.0, 2.0 * std::min(studentTUpperTail(ev->f.t_stat, 4), signedRankUpperTail(d))));
  // The same candidate tested with an offset on joint 0 in the model first (conditionalCandidateTest, selection's test of
  // a coupling given an effect on its angle's joint), against the dense refits with that column added; S restored.
  const int co = candidateIndex(p.data, EffectKind::Offset, 0);
  ASSERT_GE(co, 0);
  Eigen::VectorXd dc;
  const double pc = conditionalCandidateTest(p.opt, p.data, cv, {p.data.m + co}, dc);
  EXPECT_EQ(static_cast<int>(p.data.S.size()), p.data.m);
  const Eigen::VectorXd given = denseColumn(p, [](const State&) { return 1.0; }, 0);
  const Eigen::VectorXd dd = denseHeldOutGains(p, given, denseColumn(p, [](const State& s) { return s.v[3]; }, 3), value);
  ASSERT_EQ(dc.size(), 5);
  for (int f = 0; f < 5; ++f) EXPECT_NEAR(dc[f], dd[f], 1e-6 * std::fabs(dd[f])) << f;
  double m2 = 0, t2 = 0, p2 = 0;
  pairedTest(dd, 5, m2, t2, p2);
  EXPECT_NEAR(pc, p2, 1e-9);
}

TEST(DiagnoseStages, SelectStepTestsTheCoordinateThenPicksTheKindByGain) {
  Prepared p;
  p.data.S.clear();
  auto eval = [&](EffectKind kind, int joint, double gain, double pv) {
    CandidateEval e;
    e.c = candidateIndex(p.data, kind, joint);
    e.gain = gain, e.admissible = true, e.f.explained = 0.5, e.f.p_value = pv;
    e.f.effect = {kind, joint, 1.0, 0.0};
    return e;
  };
  // Level 0.01 / 3. Joint 2: Coulomb significant at the level, viscous at alpha only with the larger gain: viscous.
  std::vector<CandidateEval> ev = {eval(EffectKind::Coulomb, 2, 5.0, 1e-4), eval(EffectKind::Viscous, 2, 8.0, 5e-3),
                                   eval(EffectKind::Offset, 4, 50.0, 5e-3)};  // joint 4: not established
  EXPECT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
  ASSERT_EQ(p.out.findings.size(), 1u);
  EXPECT_EQ(p.out.findings[0].effect.kind, EffectKind::Viscous);
  EXPECT_EQ(p.out.findings[0].tested, 3);
  // Stribeck within the margin of Coulomb on the same joint: Coulomb is named.
  ev = {eval(EffectKind::Stribeck, 5, 10.5, 1e-5), eval(EffectKind::Coulomb, 5, 10.0, 1e-5)};
  EXPECT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
  EXPECT_EQ(p.out.findings.back().effect.kind, EffectKind::Coulomb);
  // Nothing significant at the Bonferroni level: stop.
  ev = {eval(EffectKind::Offset, 6, 10.0, 0.02)};
  EXPECT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Stop);
  EXPECT_EQ(p.out.findings.size(), 2u);
}

// The choice is named with another family's strongest competitor on its coordinate when the paired test of their fold
// gains' difference does not show the choice better at alpha: a gain and a spring on a hip, nearly one signal.
TEST(DiagnoseStages, SelectStepNamesAnotherKindTheFoldsDoNotSeparate) {
  Prepared p;
  p.data.S.clear();
  auto eval = [&](EffectKind kind, int joint, std::vector<double> folds, double value) {
    CandidateEval e;
    e.c = candidateIndex(p.data, kind, joint);
    EXPECT_GE(e.c, 0) << effectKindName(kind) << " on joint " << joint;
    e.fold_gains = Eigen::Map<Eigen::VectorXd>(folds.data(), static_cast<Eigen::Index>(folds.size()));
    e.gain = e.fold_gains.mean(), e.admissible = true, e.f.explained = 0.5, e.f.p_value = 1e-6;
    e.f.effect = {kind, joint, value, 0.0};
    e.f.std_error = 0.01 * value;
    return e;
  };
  const std::vector<double> gain_folds = {10, 12, 9, 11, 10};
  // Joint 1: the spring's fold gains as large as the gain's, up and down: the gain is named, the spring beside it.
  std::vector<CandidateEval> ev = {eval(EffectKind::GainError, 1, gain_folds, -0.15),
                                   eval(EffectKind::Elastic, 1, {11, 9, 10, 10, 9.5}, 22.0),
                                   eval(EffectKind::Offset, 3, {10, 11, 9, 10, 10}, 1.0)};  // another joint: no rival
  ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
  const Finding& a = p.out.findings.back();
  EXPECT_EQ(a.effect.kind, EffectKind::GainError);
  EXPECT_TRUE(a.ambiguous);
  EXPECT_EQ(a.alternative.kind, EffectKind::Elastic);
  EXPECT_EQ(a.alternative.joint, 1);
  EXPECT_DOUBLE_EQ(a.alternative.value, 22.0);
  EXPECT_NEAR(a.alternative_gain, 9.9 / 10.4, 1e-12);
  // The difference's test by hand: d = (-1, 3, -1, 1, 0.5), mean 0.5, sd with 4 dof.
  const Eigen::VectorXd d = ev[0].fold_gains - ev[1].fold_gains;
  const double sd = std::sqrt((d.array() - 0.5).square().sum() / 4), t = 0.5 / (sd / std::sqrt(5.0));
  EXPECT_DOUBLE_EQ(a.separation_p, std::min(1.0, 2.0 * std::min(studentTUpperTail(t, 4), signedRankUpperTail(d))));
  EXPECT_GE(a.separation_p, p.opt.alpha);
  // The spring half as good in every fold: separated, named alone (the test's p kept for the record).
  p.data.S.clear();
  ev = {eval(EffectKind::GainError, 1, gain_folds, -0.15), eval(EffectKind::Elastic, 1, {5, 6, 4.5, 5.5, 5}, 22.0)};
  ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
  EXPECT_FALSE(p.out.findings.back().ambiguous);
  EXPECT_LT(p.out.findings.back().separation_p, p.opt.alpha);
  // Two shapes of one family (a linear and an exponential spring): not different explanations.
  p.data.S.clear();
  ev = {eval(EffectKind::ElasticExp, 2, gain_folds, 3.0), eval(EffectKind::Elastic, 2, {11, 9, 10, 10, 9.5}, 2.0)};
  ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
  EXPECT_FALSE(p.out.findings.back().ambiguous);
  EXPECT_EQ(p.out.findings.back().separation_p, 1.0);
  // The report names both.
  describeFindings(kuka(), p.opt, p.out);
  EXPECT_NE(p.out.findings[0].sentence.find("; or joint elasticity (linear spring) 22"), std::string::npos)
      << p.out.findings[0].sentence;
  EXPECT_EQ(p.out.findings[1].sentence.find("; or "), std::string::npos) << p.out.findings[1].sentence;
}

// A coupling (joint 2's moment on joint 3's angle) is tested again with every single-joint candidate on the other joints
// in the model (whatever their own tests; the step's evals hold candidates on joints 3 and 4): named with joint 3's
// strongest usable candidate where the coupling's held-out gain is then not significant, named alone where it is.
// The step's evals are set by hand; the conditional test runs on the data.
TEST(DiagnoseStages, SelectStepTestsACouplingGivenAnEffectOnItsAnglesJoint) {
  for (const double coupling : {0.0, 3.0}) {  // the data: no coupling (a coupling found would be a stand-in), a real one
    SCOPED_TRACE(coupling);
    Prepared p(false, coupling);
    p.opt.folds = 10;  // with 5 the two tests cannot go below p ~ 0.01 on gains that vary as these do
    p.opt.chunk_seconds = 0.25;
    std::string err;
    ASSERT_TRUE(foldFactors(kuka(), p.opt, p.data, &err)) << err;
    int cc = -1;
    for (int c = 0; c < p.data.nc; ++c)
      if (p.data.cands[c].kind == EffectKind::ElasticCoupled && p.data.cands[c].joint == 2 && p.data.cands[c].coupled == 3)
        cc = c;
    ASSERT_GE(cc, 0);
    const int offset3 = candidateIndex(p.data, EffectKind::Offset, 3), offset4 = candidateIndex(p.data, EffectKind::Offset, 4);
    const int viscous2 = candidateIndex(p.data, EffectKind::Viscous, 2);
    ASSERT_GE(offset3, 0);
    ASSERT_GE(offset4, 0);
    ASSERT_GE(viscous2, 0);
    auto eval = [&](int c, std::vector<double> folds, double p_value) {
      CandidateEval e;
      e.c = c;
      e.fold_gains = Eigen::Map<Eigen::VectorXd>(folds.data(), static_cast<Eigen::Index>(folds.size()));
      e.gain = e.fold_gains.mean(), e.admissible = true, e.f.explained = 0.3, e.f.p_value = p_value;
      e.f.effect = candidateEffect(p.data.cands[c], 1.5);
      e.f.std_error = 0.01;
      return e;
    };
    const std::vector<double> steady = {10, 12, 9, 11, 10, 10, 12, 9, 11, 10}, uneven = {60, -5, 45, 2, 50, 60, -5, 45, 2, 50};
    // The coupling established (p 1e-6 against the level 0.01 / 2), joint 3's offset credible at alpha (5e-3).
    declaredOnly(p);
    std::vector<CandidateEval> ev = {eval(cc, steady, 1e-6), eval(offset3, uneven, 5e-3)};
    ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
    Finding a = p.out.findings.back();
    EXPECT_EQ(a.effect.kind, EffectKind::ElasticCoupled);
    // The conditional test by hand (selectStep left data.S with the coupling appended: the declared ones again).
    declaredOnly(p);
    Eigen::VectorXd d;
    const double pc = conditionalCandidateTest(p.opt, p.data, cc, {p.data.m + offset3}, d);
    if (coupling == 0.0) {
      EXPECT_GE(pc, p.opt.alpha);
      EXPECT_TRUE(a.ambiguous);
      EXPECT_EQ(a.alternative.kind, EffectKind::Offset);
      EXPECT_EQ(a.alternative.joint, 3);
      EXPECT_DOUBLE_EQ(a.separation_p, pc);
      EXPECT_NEAR(a.alternative_gain, 30.4 / 10.4, 1e-12);
      p.out.findings.back() = a;
      describeFindings(kuka(), p.opt, p.out);
      const std::string& sentence = p.out.findings.back().sentence;
      EXPECT_NE(sentence.find("; or constant torque offset"), std::string::npos) << sentence;
      EXPECT_NE(sentence.find(" on " + kuka().joint_names[3] + " (its strongest candidate), which the identified link "
                              "parameters carry into this joint's row: with the other joints' candidates in the model "
                              "this one's held-out gain is not significant"),
                std::string::npos) << sentence;
      // Two candidates on joint 3 (an offset and viscous friction, independent columns): both in the model for the
      // test, the stronger usable one named; an inadmissible one (here the offset) is in the model but not named, and
      // neither is its test (p 0.5) a condition.
      const int viscous3 = candidateIndex(p.data, EffectKind::Viscous, 3);
      ASSERT_GE(viscous3, 0);
      // selectStep on these evals; its p against the conditional test given `second` after the offset on joint 3, and
      // the alternative named: joint 3's offset.
      const auto givenOffsetAnd = [&](const std::vector<CandidateEval>& evals, int second) {
        declaredOnly(p);
        ASSERT_EQ(selectStep(kuka(), p.opt, p.data, evals, {}, 1, p.out), StepOutcome::Effect);
        declaredOnly(p);
        EXPECT_DOUBLE_EQ(p.out.findings.back().separation_p,
                         conditionalCandidateTest(p.opt, p.data, cc, {p.data.m + offset3, p.data.m + second}, d));
        EXPECT_EQ(p.out.findings.back().alternative.kind, EffectKind::Offset);
        EXPECT_EQ(p.out.findings.back().alternative.joint, 3);
      };
      givenOffsetAnd({eval(cc, steady, 1e-6), eval(viscous3, steady, 0.5), eval(offset3, uneven, 5e-3)}, viscous3);
      declaredOnly(p);
      ev = {eval(cc, steady, 1e-6), eval(viscous3, steady, 0.5), eval(offset3, uneven, 5e-3)};
      ev[2].admissible = false;
      ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
      EXPECT_TRUE(p.out.findings.back().ambiguous);
      EXPECT_EQ(p.out.findings.back().alternative.kind, EffectKind::Viscous);
      // A candidate on a joint the coupling does not read (joint 4's offset) is in the model for the test too, after
      // the stronger one on joint 3; the one named is still joint 3's.
      givenOffsetAnd({eval(cc, steady, 1e-6), eval(offset4, steady, 0.5), eval(offset3, uneven, 5e-3)}, offset4);
    } else {  // 3 N m/rad on q_3 (0.1-0.3 rad): the coupling keeps its own gain with the offset in
      EXPECT_LT(pc, 1e-3) << d.transpose();
      EXPECT_GT(d.minCoeff(), 0.0) << d.transpose();
      EXPECT_FALSE(a.ambiguous);
    }
    // No candidate on the joint the coupling reads (only joint 4's: nothing to name), the declared model held, and a
    // choice that is not a coupling: no conditional test, no alternative.
    declaredOnly(p);
    ev = {eval(cc, steady, 1e-6), eval(offset4, uneven, 5e-3)};
    ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
    EXPECT_FALSE(p.out.findings.back().ambiguous);
    declaredOnly(p);
    p.opt.hold_declared = true;
    ev = {eval(cc, steady, 1e-6), eval(offset3, uneven, 5e-3)};
    ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
    EXPECT_FALSE(p.out.findings.back().ambiguous);
    p.opt.hold_declared = false;
    declaredOnly(p);
    ev = {eval(viscous2, steady, 1e-6), eval(offset3, uneven, 5e-3)};
    ASSERT_EQ(selectStep(kuka(), p.opt, p.data, ev, {}, 1, p.out), StepOutcome::Effect);
    EXPECT_FALSE(p.out.findings.back().ambiguous);
  }
}

TEST(DiagnoseStages, SummariesAreTheResidualsRms) {
  const Model& model = kuka();
  Prepared p;
  p.opt.folds = 10;  // with 5, t over 4 degrees of freedom cannot pass 0.01 / 49 candidates
  p.opt.chunk_seconds = 0.25;
  std::string err;
  ASSERT_TRUE(foldFactors(model, p.opt, p.data, &err)) << err;
  p.data.S.resize(p.data.m);
  for (int c = 0; c < p.data.m; ++c) p.data.S[c] = c;
  p.data.pdone.clear();
  ASSERT_FALSE(selectEffects(model, p.opt, p.data, p.out));
  finalFit(p.opt, p.data, p.out);
  ASSERT_FALSE(p.out.findings.empty());
  EXPECT_EQ(p.out.findings[0].effect.kind, EffectKind::Viscous);
  EXPECT_EQ(p.out.findings[0].effect.joint, 3);
  ASSERT_TRUE(residualSeries(model, p.opt, p.data, p.out, &err)) << err;
  p.out.has_validation = true;
  summarizeCoordinates(model, p.opt, p.data, p.out);
  const ResidualSeries& v = p.out.series[1];
  ASSERT_TRUE(v.validation);
  for (int r = 0; r < 7; ++r) {
    EXPECT_NEAR(p.out.coordinates[r].rms_before, std::sqrt(v.before.col(r).squaredNorm() / 800), 1e-12);
    EXPECT_NEAR(p.out.coordinates[r].rms_after, std::sqrt(v.after.col(r).squaredNorm() / 800), 1e-12);
  }
  // Joint 3 after: the 2 N m s/rad are gone down to the noise; before they were not.
  EXPECT_LT(p.out.coordinates[3].rms_after, 0.06);
  EXPECT_GT(p.out.coordinates[3].rms_before, 0.1);
}

// The floating base's motion that the unmeasured-body stage reads off K (declaredPrediction -> ResidualSeries::base)
// against the states it came from: alpha and s = a_b - R^T g, with a rotating base (omega x (I omega) must not leak in).
TEST(DiagnoseStages, DeclaredPredictionReadsTheFloatingBasesMotionOffK) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  diagnosis_runs::Run run;
  Data d(model);
  for (int k = 0; k < 120; ++k) {
    State s = State::zero(model);
    s.base_orientation = Eigen::Quaterniond(Eigen::Vector4d(g(rng), g(rng), g(rng), g(rng)).normalized());
    s.base_omega = Eigen::Vector3d(g(rng), g(rng), g(rng));
    s.base_domega = Eigen::Vector3d(g(rng), g(rng), g(rng));
    s.base_acceleration = Eigen::Vector3d(g(rng), g(rng), g(rng));
    for (int j = 0; j < model.njoints; ++j) s.q[j] = 0.3 * g(rng), s.v[j] = g(rng), s.a[j] = g(rng);
    computeJointTorqueRegressor(model, d, s);
    run.states.push_back(s), run.t.push_back(0.01 * k), run.y.push_back(d.K * model.phi + 0.1 * Eigen::VectorXd::Random(model.nv));
  }
  const std::vector<Segment> tr = {segmentOf(model, run, "train")};
  DiagnoseOptions opt;
  DiagnoseData data;
  DiagnosisResult out;
  declaredColumns(model, opt, tr, {}, data, out);
  ASSERT_TRUE(trainingPass(model, opt, data, out, &err)) << err;
  ASSERT_TRUE(declaredFit(data, out, &err)) << err;
  ASSERT_TRUE(declaredPrediction(model, data, out, &err)) << err;
  const Eigen::MatrixXd& base = data.caches[0].base;
  ASSERT_EQ(base.rows(), 120);
  ASSERT_EQ(base.cols(), 6);
  for (int k = 0; k < 120; ++k) {
    const State& s = run.states[k];
    const Eigen::Vector3d sf = s.base_acceleration - s.base_orientation.toRotationMatrix().transpose() * model.gravity;
    EXPECT_LT((base.row(k).head<3>().transpose() - s.base_domega).norm(), 1e-12) << k;
    EXPECT_LT((base.row(k).tail<3>().transpose() - sf).norm(), 1e-12) << k;
  }
}

TEST(StudentT, BoostTailMatchesClosedForms) {
  for (double t : {-3.0, -0.5, 0.0, 0.7, 2.0, 9.0, 40.0}) {
    EXPECT_NEAR(studentTUpperTail(t, 1), 0.5 - std::atan(t) / M_PI, 1e-14);                    // Cauchy
    EXPECT_NEAR(studentTUpperTail(t, 2), 0.5 * (1 - t / std::sqrt(t * t + 2)), 1e-14);        // dof 2
    const double x = t / std::sqrt(t * t + 4);                                              // dof 4
    const double p4 = 0.5 - 0.5 * x * (1.5 - 0.5 * x * x);
    EXPECT_NEAR(studentTUpperTail(t, 4), p4, 1e-13 + 1e-12 * p4) << t;
  }
  EXPECT_EQ(studentTUpperTail(INFINITY, 5), 0.0);
  EXPECT_EQ(studentTUpperTail(-INFINITY, 5), 1.0);
  EXPECT_EQ(studentTUpperTail(std::nan(""), 5), 1.0);
}

}  // namespace
}  // namespace exoid::estimator

namespace exoid::estimator {
namespace {

// A source of n samples (K [3 x 4], y, tau [3], q [2] drawn from the seed; identical every pass) that counts its
// passes, fails its next pass when asked, and can offer stream_state.
struct CountingSource {
  int n = 50, passes = 0;
  bool fail_next = false;
  static void sample(int k, Eigen::MatrixXd& K, Eigen::VectorXd& y, Eigen::VectorXd& tau, Eigen::VectorXd& q) {
    std::mt19937_64 rng(1000 + k);
    std::normal_distribution<double> g;
    K.resize(3, 4), y.resize(3), tau.resize(3), q.resize(2);
    for (Eigen::Index i = 0; i < K.size(); ++i) K.data()[i] = g(rng);
    for (Eigen::Index i = 0; i < 3; ++i) y[i] = g(rng), tau[i] = g(rng);
    for (Eigen::Index i = 0; i < 2; ++i) q[i] = g(rng);
  }
  bool run(const DiagnosisStateSink& sink, std::string* error) {
    ++passes;
    Eigen::MatrixXd K;
    Eigen::VectorXd y, tau, q;
    for (int k = 0; k < n; ++k) {
      if (fail_next && k == n / 2) {
        fail_next = false;
        *error = "damaged";
        return false;
      }
      sample(k, K, y, tau, q);
      sink(0.001 * k, K, y, tau, q);
    }
    return true;
  }
  Segment segment(bool with_state) {
    Segment s;
    s.name = "counting";
    s.stream = [this](const DiagnosisRowSink& sink, std::string* e) {
      return run([&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau,
                     const Eigen::VectorXd&) { sink(t, K, y, tau); },
                 e);
    };
    if (with_state) s.stream_state = [this](const DiagnosisStateSink& sink, std::string* e) { return run(sink, e); };
    return s;
  }
};

// Every row a pass gives, bit for bit against the source's own sample k, and how many.
int checkPass(const Segment& s, bool state, std::string* error, bool* ok) {
  int k = 0;
  Eigen::MatrixXd K;
  Eigen::VectorXd y, tau, q;
  const auto same = [&](double t, const Eigen::MatrixXd& Kp, const Eigen::VectorXd& yp, const Eigen::VectorXd& taup) {
    CountingSource::sample(k, K, y, tau, q);
    EXPECT_EQ(t, 0.001 * k);
    EXPECT_TRUE(Kp == K && yp == y && taup == tau) << "row " << k;
  };
  *ok = state ? s.stream_state(
                    [&](double t, const Eigen::MatrixXd& Kp, const Eigen::VectorXd& yp, const Eigen::VectorXd& taup,
                        const Eigen::VectorXd& qp) {
                      same(t, Kp, yp, taup);
                      EXPECT_TRUE(qp == q) << "row " << k;
                      ++k;
                    },
                    error)
              : s.stream([&](double t, const Eigen::MatrixXd& Kp, const Eigen::VectorXd& yp,
                             const Eigen::VectorXd& taup) { same(t, Kp, yp, taup), ++k; },
                         error);
  return k;
}

// keptInMemory: the source is read once and every later pass (rows, or rows with q) is its rows bit for bit; over the
// budget, after a failed pass and without a budget the source is read at every pass, and the memory is given back.
TEST(KeptInMemory, ReadsTheSourceOnceAndReplaysItsRowsBitForBit) {
  const size_t sample_bytes = sizeof(double) * (1 + 12 + 3 + 3 + 2);  // t, K, y, tau, q
  const size_t row_bytes = sizeof(double) * (1 + 12 + 3 + 3);         // a segment without stream_state: no q
  bool ok = false;
  std::string err;
  {
    CountingSource src;
    auto memory = std::make_shared<RowMemory>();
    memory->budget_bytes = 1 << 30;
    const Segment s = keptInMemory(src.segment(true), memory);
    EXPECT_EQ(s.name, "counting");
    ASSERT_TRUE(s.stream_state);
    EXPECT_EQ(checkPass(s, false, &err, &ok), src.n);  // the first pass reads through stream_state: q kept too
    EXPECT_TRUE(ok);
    for (int pass = 0; pass < 3; ++pass) {
      EXPECT_EQ(checkPass(s, pass % 2 == 0, &err, &ok), src.n);
      EXPECT_TRUE(ok);
    }
    EXPECT_EQ(src.passes, 1);
    EXPECT_GE(memory->used_bytes, src.n * sample_bytes);
  }
  {  // a budget below one block of samples: never kept, every pass from the source, nothing held
    CountingSource src;
    auto memory = std::make_shared<RowMemory>();
    memory->budget_bytes = 1024 * row_bytes - 1;
    const Segment s = keptInMemory(src.segment(false), memory);
    EXPECT_FALSE(s.stream_state);
    for (int pass = 0; pass < 3; ++pass) EXPECT_EQ(checkPass(s, false, &err, &ok), src.n);
    EXPECT_EQ(src.passes, 3);
    EXPECT_EQ(memory->used_bytes, 0u);
  }
  {  // a failed first pass keeps nothing and says why; the next pass reads the source again and is kept
    CountingSource src;
    src.fail_next = true;
    auto memory = std::make_shared<RowMemory>();
    memory->budget_bytes = 1 << 30;
    const Segment s = keptInMemory(src.segment(true), memory);
    EXPECT_EQ(checkPass(s, true, &err, &ok), src.n / 2);
    EXPECT_FALSE(ok);
    EXPECT_EQ(err, "damaged");
    EXPECT_EQ(memory->used_bytes, 0u);
    for (int pass = 0; pass < 2; ++pass) {
      EXPECT_EQ(checkPass(s, true, &err, &ok), src.n);
      EXPECT_TRUE(ok);
    }
    EXPECT_EQ(src.passes, 2);
  }
  {  // two segments sharing a budget of one block: the first is kept, the second read at every pass; the memory is
     // given back when the segments go
    CountingSource a, b;
    auto memory = std::make_shared<RowMemory>();
    memory->budget_bytes = 1024 * sample_bytes + 1;
    {
      const Segment sa = keptInMemory(a.segment(true), memory), sb = keptInMemory(b.segment(true), memory);
      for (int pass = 0; pass < 2; ++pass) {
        EXPECT_EQ(checkPass(sa, true, &err, &ok), a.n);
        EXPECT_EQ(checkPass(sb, true, &err, &ok), b.n);
      }
      EXPECT_EQ(a.passes, 1);
      EXPECT_EQ(b.passes, 2);
      EXPECT_EQ(memory->used_bytes, 1024 * sample_bytes);
    }
    EXPECT_EQ(memory->used_bytes, 0u);
  }
  for (const auto& none : {std::make_shared<RowMemory>(), std::shared_ptr<RowMemory>()}) {  // no memory: the source
    CountingSource src;
    const Segment s = keptInMemory(src.segment(true), none);
    for (int pass = 0; pass < 2; ++pass) EXPECT_EQ(checkPass(s, true, &err, &ok), src.n);
    EXPECT_EQ(src.passes, 2);
  }
}

}  // namespace
}  // namespace exoid::estimator
