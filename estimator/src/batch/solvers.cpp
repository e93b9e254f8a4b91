#include "exoid/estimator/batch/solvers.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace exoid::estimator {


const char* methodName(Method m) {
  switch (m) {
    case Method::Ols: return "OLS";
    case Method::WlsR: return "WLS-R";
    case Method::WlsC: return "WLS-C";
    case Method::WlsRC: return "WLS-RC";
  }
  return "?";
}

bool parseMethod(const std::string& name, Method& m) {
  for (Method x : {Method::Ols, Method::WlsR, Method::WlsC, Method::WlsRC})
    if (name == methodName(x)) return m = x, true;
  return false;
}

namespace {
bool rowScaled(Method m) { return m == Method::WlsR || m == Method::WlsRC; }
bool columnScaled(Method m) { return m == Method::WlsC || m == Method::WlsRC; }

// Kind of a standard parameter: 0 mass, 1 first moment, 2 inertia, 3 viscous, 4 Coulomb.
int kindOf(const Model& model, int i) {
  if (i >= model.nInertialParams()) return 3 + (i - model.nInertialParams()) % kParamsPerJoint;
  const int k = i % kParamsPerBody;
  return k == 0 ? 0 : k < 4 ? 1 : 2;
}

// Minimum-norm least-squares solution of R x = z (R square), numerical rank by relative tolerance.
Eigen::VectorXd pinvSolve(const Eigen::MatrixXd& R, const Eigen::VectorXd& z) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-12);
  return svd.solve(z);
}
}  // namespace

Eigen::VectorXd columnScale(const Model& model, const Eigen::VectorXd& prior, double floor_fraction) {
  const int p = static_cast<int>(prior.size());
  Eigen::VectorXd h = prior.cwiseAbs();
  for (int kind = 0; kind < 5; ++kind) {
    std::vector<double> v;
    double vmax = 0.0;
    for (int i = 0; i < p; ++i)
      if (kindOf(model, i) == kind) v.push_back(h[i]), vmax = std::max(vmax, h[i]);
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    const double floor = floor_fraction * vmax, median = v[v.size() / 2];
    // Nothing known of this kind (e.g. friction absent from a URDF): unit scale.
    const double fallback = vmax == 0.0 ? 1.0 : median > floor ? median : vmax;
    for (int i = 0; i < p; ++i)
      if (kindOf(model, i) == kind && !(h[i] > floor)) h[i] = fallback;
  }
  return h;
}

int ScaledProblem::numericalRank(double tolerance) const {
  int r = 0;
  while (r < s.size() && s[r] > tolerance * s[0]) ++r;
  return r;
}

Eigen::VectorXd priorScale(const Model& model, const Eigen::VectorXd& prior, const Eigen::VectorXd& h, bool absolute,
                           double floor_fraction) {
  Eigen::VectorXd d = h;
  for (int i = 0; i < model.nInertialParams(); ++i)
    d[i] = absolute ? 1.0 : std::max(std::abs(prior[i]), floor_fraction * h[i]);
  return d;
}

WeightedFactor weightedFactor(const LsqAccumulator& acc, const Model& model, bool row_scaled,
                              const std::vector<bool>& include) {
  const int nv = acc.coordinates(), p = model.nparams();
  WeightedFactor wf;
  wf.row_weight.assign(nv, 1.0);
  if (row_scaled) {
    // Eqs. (29)-(30): sigma_i from the OLS residual of coordinate i (the residual does not depend on the
    // nullspace, so the minimum-norm base solution gives it).
    const LsqFactor ols = acc.mergedBase({}, include);
    const Eigen::VectorXd x = pinvSolve(ols.R, ols.z);
    std::vector<double> sigma(nv);
    double y2 = 0.0, maxsig = 0.0;
    long rows_all = 0;
    for (int c = 0; c < nv; ++c) {
      long n = 0;
      for (int f = 0; f < acc.folds(); ++f)
        if (include.empty() || include[f]) n += acc.rows(c, f);
      double r2 = 0.0;
      for (int f = 0; f < acc.folds(); ++f)
        if (include.empty() || include[f]) {
          r2 += acc.residual(c, x, f);
          y2 += acc.residual(c, Eigen::VectorXd::Zero(acc.baseColumns()), f);
        }
      rows_all += n;
      sigma[c] = std::sqrt(r2 / std::max<long>(1, n - p));
      maxsig = std::max(maxsig, sigma[c]);
    }
    // Exact data leave sigma ~ round-off: floor at 1e-10 of the RMS of y so that weights stay finite.
    const double floor = std::max(1e-10 * std::sqrt(y2 / std::max<long>(1, rows_all)), 1e-6 * maxsig);
    for (int c = 0; c < nv; ++c) wf.row_weight[c] = sigma[c] > 0.0 || floor > 0.0 ? 1.0 / std::max(sigma[c], floor) : 1.0;
  }
  // Per coordinate: ||G_c y_c||^2 and each standard column's ||G_c W_c e_j||^2 = ||R_c B_(cols, j)||^2 (the
  // augmented factor's last row holds only sqrt(rss)).
  const Eigen::MatrixXd& B = acc.base().base_map;
  wf.coordinate_y2 = Eigen::VectorXd::Zero(nv);
  wf.coordinate_col2 = Eigen::MatrixXd::Zero(nv, p);
  for (int c = 0; c < nv; ++c)
    for (int f = 0; f < acc.folds(); ++f) {
      if (!(include.empty() || include[f])) continue;
      const CoordinateFactor& cf = acc.factor(f, c);
      const int k = static_cast<int>(cf.columns.size());
      Eigen::MatrixXd Bc(k, p);
      for (int j = 0; j < k; ++j) Bc.row(j) = B.row(cf.columns[j]);
      const double g2 = wf.row_weight[c] * wf.row_weight[c];
      wf.coordinate_col2.row(c) += g2 * (cf.R_aug.topLeftCorner(k, k).triangularView<Eigen::Upper>() * Bc).colwise().squaredNorm();
      wf.coordinate_y2[c] += g2 * acc.residual(c, Eigen::VectorXd::Zero(acc.baseColumns()), f);
    }
  const LsqFactor f = acc.mergedBase(wf.row_weight, include);
  wf.rows = f.rows;
  wf.Rf = f.R.triangularView<Eigen::Upper>() * acc.base().base_map;  // m x p, same singular values and V as G W
  wf.z = f.z;
  wf.rss = f.rss;
  return wf;
}

TrainingFactors trainingFactors(const LsqAccumulator& acc, const Model& model, Method method) {
  TrainingFactors t;
  t.method = method;
  t.all = weightedFactor(acc, model, rowScaled(method));
  const int K = acc.folds();
  t.without.resize(K);
  t.fold_rows.assign(K, 0);
  for (int k = 0; k < K; ++k) {
    for (int c = 0; c < acc.coordinates(); ++c) t.fold_rows[k] += acc.rows(c, k);
    if (t.fold_rows[k] == 0 || K < 2) continue;  // an empty fold (or nothing would be left)
    std::vector<bool> include(K, true);
    include[k] = false;
    t.without[k] = weightedFactor(acc, model, rowScaled(method), include);
  }
  return t;
}

namespace {

/// The fill for the problem's direction order: kept equations v_i^T H^-1 (phi - gamma) = alpha_i; phi = prior + D u
/// with u the minimum-norm solution of (D H^-1 V_z)^T u = r_z, r = alpha - V^T H^-1 (prior - gamma). With
/// M = D H^-1 V = Q R (Householder), u = Q_z R_z^-T r_z: R^T is lower triangular, so w = R^-T r serves every z at once.
void prepareFill(ScaledProblem& sp) {
  const int r = static_cast<int>(sp.s.size()), p = static_cast<int>(sp.V.rows());
  Eigen::VectorXd alpha = Eigen::VectorXd::Zero(r);
  for (int i = 0; i < r; ++i)
    if (sp.s[i] > 0.0) alpha[i] = sp.d[i] / sp.s[i];
  const Eigen::VectorXd rv = alpha - sp.V.transpose() * (sp.prior - sp.gamma).cwiseQuotient(sp.h);
  const Eigen::MatrixXd M = sp.fill.cwiseQuotient(sp.h).asDiagonal() * sp.V;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(M);
  sp.Q = qr.householderQ() * Eigen::MatrixXd::Identity(p, r);
  const Eigen::MatrixXd Rq = qr.matrixQR().topRows(r).triangularView<Eigen::Upper>();
  sp.w = Rq.transpose().triangularView<Eigen::Lower>().solve(rv);
}

}  // namespace

ScaledProblem scaleProblem(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior, Method method,
                      const std::vector<bool>& include, const FillOptions& fill) {
  return scaleProblem(weightedFactor(acc, model, rowScaled(method), include), model, prior, method, fill);
}

ScaledProblem scaleProblem(const WeightedFactor& f, const Model& model, const Eigen::VectorXd& prior, Method method,
                      const FillOptions& fill) {
  const int p = model.nparams();
  ScaledProblem sp;
  sp.method = method;
  sp.prior = prior;
  sp.row_weight = f.row_weight;
  sp.rows = f.rows;
  sp.h = columnScaled(method) ? columnScale(model, prior) : Eigen::VectorXd::Ones(p);
  if (columnScaled(method) && f.coordinate_y2.size() > 0) {
    // A kind the prior leaves at zero throughout has no scale of its own: the data's (priorUncertainty at
    // relative sqrt(3), i.e. sigma_j itself), so that its scaled coordinates are commensurate with the stated ones.
    const Eigen::VectorXd u = priorUncertainty(model, prior, f, std::sqrt(3.0));
    for (int i = 0; i < p; ++i)
      if (u[i] > 0.0) sp.h[i] = u[i];  // the stated kinds' entries equal columnScale's
  }
  sp.gamma = columnScaled(method) ? prior : Eigen::VectorXd::Zero(p);
  const Eigen::VectorXd zt = f.z - f.Rf * sp.gamma;
  const Eigen::MatrixXd A = f.Rf * sp.h.asDiagonal();
  Eigen::BDCSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  sp.s = svd.singularValues();
  sp.V = svd.matrixV();
  sp.d = svd.matrixU().transpose() * zt;
  sp.Rw = f.Rf;
  sp.zw = f.z;
  sp.rss_w = f.rss;
  sp.fill = fill.metric == FillMetric::Scaled ? sp.h : priorScale(model, prior, sp.h, fill.absolute_prior);
  prepareFill(sp);
  return sp;
}

ScaledProblem orderDirections(const ScaledProblem& in, const std::vector<int>& order) {
  if (order.empty()) return in;
  ScaledProblem sp = in;
  for (size_t k = 0; k < order.size(); ++k) {
    const int i = order[k];
    sp.s[k] = in.s[i];
    sp.V.col(k) = in.V.col(i);
    sp.d[k] = in.d[i];
  }
  prepareFill(sp);
  return sp;
}

Eigen::VectorXd solveAtRank(const ScaledProblem& sp, int z) {
  z = std::clamp(z, 0, static_cast<int>(sp.s.size()));
  while (z > 0 && !(sp.s[z - 1] > 0.0)) --z;
  // Scaled fill: phi = gamma + H V_z S_z^-1 d_z with C (eq. 27), phi = V_z alpha_z + V_n V_n^T phi_prior
  // without (eqs. 21-23); Prior fill: the P-metric minimum deviation. Both are prior + D Q_z w_z (prepare).
  return sp.prior + sp.fill.cwiseProduct(sp.Q.leftCols(z) * sp.w.head(z));
}

double rmse(const LsqFactor& f, const Eigen::VectorXd& phi) {
  const double sse = (f.R.triangularView<Eigen::Upper>() * phi - f.z).squaredNorm() + f.rss;
  return std::sqrt(sse / std::max<long>(1, f.rows));
}

RankCurve rankByValidation(const ScaledProblem& sp, const LsqFactor& validation) {
  RankCurve c;
  c.rule = "validation generalized-force RMSE (thesis IV-B)";
  const int r = static_cast<int>(sp.s.size());
  c.score.resize(r + 1);
  for (int z = 0; z <= r; ++z) c.score[z] = rmse(validation, solveAtRank(sp, z));
  c.best = static_cast<int>(std::min_element(c.score.begin(), c.score.end()) - c.score.begin());
  return c;
}

RankCurve rankByCrossValidation(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior,
                                Method method, CvRule rule, const FillOptions& fill) {
  return rankByCrossValidation(trainingFactors(acc, model, method), acc, model, prior, rule, fill);
}

RankCurve rankByCrossValidation(const TrainingFactors& tf, const LsqAccumulator& acc, const Model& model,
                                const Eigen::VectorXd& prior, CvRule rule, const FillOptions& fill) {
  const std::pair<RankCurve, RankCurve> both = rankByCrossValidationBoth(tf, acc, model, prior, fill);
  return rule == CvRule::Minimum ? both.first : both.second;
}

std::pair<RankCurve, RankCurve> rankByCrossValidationBoth(const TrainingFactors& tf, const LsqAccumulator& acc,
                                                          const Model& model, const Eigen::VectorXd& prior,
                                                          const FillOptions& fill) {
  RankCurve c;
  c.rule = "time-block cross-validation, minimum";
  const int K = acc.folds(), nv = acc.coordinates(), m = acc.baseColumns();
  const Eigen::MatrixXd& B = acc.base().base_map;
  int r = m;
  std::vector<std::vector<double>> mse(K);  // [fold][z]
  for (int k = 0; k < K && K > 1; ++k) {
    const long n = tf.fold_rows[k];
    if (n == 0) continue;  // an empty fold
    const ScaledProblem sp = scaleProblem(tf.without[k], model, prior, tf.method, fill);
    r = std::min(r, static_cast<int>(sp.s.size()));
    for (int z = 0; z <= static_cast<int>(sp.s.size()); ++z) {
      const Eigen::VectorXd xb = B * solveAtRank(sp, z);
      double sse = 0.0;
      for (int cc = 0; cc < nv; ++cc) sse += acc.residual(cc, xb, k);
      mse[k].push_back(sse / n);
    }
  }
  c.score.assign(r + 1, 0.0);
  int used = 0;
  for (int k = 0; k < K; ++k)
    if (!mse[k].empty()) ++used;
  if (used == 0) {
    RankCurve se = c;
    se.rule = "time-block cross-validation, paired 1-SE";
    return {c, se};
  }
  for (int z = 0; z <= r; ++z) {
    double mean = 0.0;
    for (int k = 0; k < K; ++k)
      if (!mse[k].empty()) mean += mse[k][z];
    c.score[z] = std::sqrt(mean / used);
  }
  const int zmin = static_cast<int>(std::min_element(c.score.begin(), c.score.end()) - c.score.begin());
  c.best = zmin;
  RankCurve se = c;
  se.rule = "time-block cross-validation, paired 1-SE";
  if (used > 1) {
    // The folds' error levels differ (motion and noise differ between time blocks), but for one fold the
    // comparison of two ranks is paired: judge z by the mean and standard error over folds of
    // MSE_k(z) - MSE_k(zmin), and take the smallest z not significantly worse.
    for (int z = 0; z < zmin; ++z) {
      double mean = 0.0, sq = 0.0;
      for (int k = 0; k < K; ++k)
        if (!mse[k].empty()) mean += mse[k][z] - mse[k][zmin];
      mean /= used;
      for (int k = 0; k < K; ++k)
        if (!mse[k].empty()) sq += std::pow(mse[k][z] - mse[k][zmin] - mean, 2);
      if (mean <= std::sqrt(sq / (used - 1) / used)) {
        se.best = z;
        break;
      }
    }
  }
  return {c, se};
}

RankCurve rankByJackknife(const LsqAccumulator& acc, const Model& model, const Eigen::VectorXd& prior, Method method,
                          double prior_uncertainty, const std::vector<const LsqAccumulator*>& processing) {
  std::vector<WeightedFactor> alt;
  for (const LsqAccumulator* a : processing) alt.push_back(weightedFactor(*a, model, rowScaled(method)));
  return rankByJackknife(trainingFactors(acc, model, method), model, prior, prior_uncertainty, alt);
}

Eigen::VectorXd priorUncertainty(const Model& model, const Eigen::VectorXd& prior, const WeightedFactor& all,
                                 double relative) {
  const int p = static_cast<int>(prior.size());
  const Eigen::VectorXd h = columnScale(model, prior);
  Eigen::VectorXd sigma = (relative / std::sqrt(3.0)) * h;
  // A kind whose prior is zero throughout (friction: a URDF has none) is unknown, not "0 +- 25 %": its scale is
  // the value that alone would explain all the measured forces, ||G y|| / ||G W_j||.
  bool known[5] = {false, false, false, false, false};
  for (int i = 0; i < p; ++i)
    if (prior[i] != 0.0) known[kindOf(model, i)] = true;
  for (int i = 0; i < p; ++i) {
    if (known[kindOf(model, i)]) continue;
    const double cmax = all.coordinate_col2.col(i).maxCoeff();
    double y2 = 0.0, c2 = 0.0;
    for (int c = 0; c < all.coordinate_col2.rows(); ++c)
      if (all.coordinate_col2(c, i) > 1e-24 * cmax) y2 += all.coordinate_y2[c], c2 += all.coordinate_col2(c, i);
    sigma[i] = c2 > 0.0 ? std::sqrt(y2 / c2) : 0.0;  // a column the data never touch: no direction contains it
  }
  return sigma;
}

RankCurve rankByJackknife(const TrainingFactors& tf, const Model& model, const Eigen::VectorXd& prior,
                          double prior_uncertainty, const std::vector<WeightedFactor>& processing) {
  RankCurve c;
  c.rule = processing.empty() ? "jackknife over time blocks: the directions of least risk, data variance against the "
                                "prior's per direction"
                              : "jackknife over time blocks and the processing: the directions of least risk, data "
                                "variance and processing sensitivity against the prior's variance per direction";
  const ScaledProblem all = scaleProblem(tf.all, model, prior, tf.method);
  const int r = all.numericalRank(), K = static_cast<int>(tf.without.size());
  // Coordinates along the full problem's right singular vectors, in its scaled units (at full rank the fill does
  // not change them).
  auto coordinates = [&](const ScaledProblem& sp) -> Eigen::VectorXd {
    return all.V.leftCols(r).transpose() * (solveAtRank(sp, sp.numericalRank()) - all.gamma).cwiseQuotient(all.h);
  };
  std::vector<Eigen::VectorXd> a;
  for (int k = 0; k < K; ++k) {
    if (tf.fold_rows[k] == 0 || tf.without[k].rows == 0) continue;  // an empty fold
    a.push_back(coordinates(scaleProblem(tf.without[k], model, prior, tf.method)));
  }
  c.score.assign(r + 1, 0.0);
  c.best = 0;
  const int used = static_cast<int>(a.size());
  if (used < 2) return c;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(r), var = Eigen::VectorXd::Zero(r);
  for (const auto& x : a) mean += x / used;
  for (const auto& x : a) var += (x - mean).cwiseAbs2();
  var *= (used - 1.0) / used;
  // The processing's share: how far each coordinate moves when the same data are processed another way.
  Eigen::VectorXd bias = Eigen::VectorXd::Zero(r);
  if (!processing.empty()) {
    const Eigen::VectorXd full = coordinates(all);
    for (const WeightedFactor& f : processing)
      if (f.rows > 0) bias = bias.cwiseMax((full - coordinates(scaleProblem(f, model, prior, tf.method))).cwiseAbs2());
  }
  // The prior's variance of each scaled coordinate alpha_i = v_i^T H^-1 (phi - gamma): ||diag(sigma / h) v_i||^2.
  const Eigen::VectorXd sh = priorUncertainty(model, prior, tf.all, prior_uncertainty).cwiseQuotient(all.h);
  Eigen::VectorXd prior_var(r);
  for (int i = 0; i < r; ++i) prior_var[i] = sh.cwiseProduct(all.V.col(i)).squaredNorm();
  // Expected squared error on data like the training data: a kept direction costs its variance and processing
  // sensitivity, a dropped one (left at the prior) the prior's, each weighted by s_i^2 (its share of the forces).
  double risk = 0.0;
  for (int i = 0; i < r; ++i) risk += all.s[i] * all.s[i] * prior_var[i];
  c.score[0] = risk;
  if (processing.empty()) {
    // Without a measure of the processing's error the jackknife underestimates the weak directions' error (it cannot
    // see a systematic one), and the singular-value order guards against it: the least risk over prefixes.
    double best = risk;
    for (int z = 1; z <= r; ++z) {
      risk += all.s[z - 1] * all.s[z - 1] * (var[z - 1] - prior_var[z - 1]);
      c.score[z] = risk;
      if (risk < best) best = risk, c.best = z;
    }
    return c;
  }
  // With it, the least risk over every set: each direction that costs less kept than dropped.
  std::vector<int> dropped;
  for (int i = 0; i < r; ++i) {
    const bool keep = var[i] + bias[i] < prior_var[i];
    (keep ? c.order : dropped).push_back(i);
    if (!keep && var[i] < prior_var[i]) c.processing_sensitive.push_back(i);
  }
  c.best = static_cast<int>(c.order.size());
  c.order.insert(c.order.end(), dropped.begin(), dropped.end());
  for (int i = r; i < static_cast<int>(all.s.size()); ++i) c.order.push_back(i);  // numerically zero: never kept
  for (int z = 1; z <= r; ++z) {
    const int i = c.order[z - 1];
    risk += all.s[i] * all.s[i] * (var[i] + bias[i] - prior_var[i]);
    c.score[z] = risk;
  }
  return c;
}

RankCurve rankByGcv(const ScaledProblem& sp) {
  RankCurve c;
  c.rule = "generalized cross-validation";
  const int r = static_cast<int>(sp.s.size());
  c.score.resize(r + 1);
  const double n = static_cast<double>(sp.rows);
  for (int z = 0; z <= r; ++z) {
    const double rss = sp.weightedRss(solveAtRank(sp, z));
    c.score[z] = n > z ? n * rss / ((n - z) * (n - z)) : INFINITY;
  }
  c.best = static_cast<int>(std::min_element(c.score.begin(), c.score.end()) - c.score.begin());
  return c;
}

}  // namespace exoid::estimator
