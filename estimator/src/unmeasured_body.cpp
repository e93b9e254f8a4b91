// Does an unmeasured body move on the base on a spring? (unmeasured_body.hpp)
#include "exoid/estimator/unmeasured_body.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "exoid/common/format.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "held_out_blocks.hpp"

namespace exoid::estimator {

void secondOrderResponse(const Eigen::VectorXd& t, const Eigen::VectorXd& u, double f_hz, double zeta,
                         Eigen::VectorXd& x, Eigen::VectorXd& dx) {
  const long n = t.size();
  x.resize(n), dx.resize(n);
  if (n == 0) return;
  const double w = 2.0 * M_PI * f_hz, w2 = w * w, zw2 = 2.0 * zeta * w;
  double p = u[0], v = 0.0;
  x[0] = p, dx[0] = v;
  for (long i = 1; i < n; ++i) {
    const double T = t[i] - t[i - 1];
    const int sub = std::max(1, static_cast<int>(std::ceil(T * w / 0.1)));
    const double h = T / sub, du = (u[i] - u[i - 1]) / sub;
    for (int k = 0; k < sub; ++k) {
      const double u0 = u[i - 1] + k * du, um = u0 + 0.5 * du, u1 = u0 + du;
      auto acc = [&](double pp, double vv, double uu) { return w2 * (uu - pp) - zw2 * vv; };
      const double k1p = v, k1v = acc(p, v, u0);
      const double k2p = v + 0.5 * h * k1v, k2v = acc(p + 0.5 * h * k1p, v + 0.5 * h * k1v, um);
      const double k3p = v + 0.5 * h * k2v, k3v = acc(p + 0.5 * h * k2p, v + 0.5 * h * k2v, um);
      const double k4p = v + h * k3v, k4v = acc(p + h * k3p, v + h * k3v, u1);
      p += h / 6.0 * (k1p + 2 * k2p + 2 * k3p + k4p);
      v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    x[i] = p, dx[i] = v;
  }
}

namespace {

constexpr double kNullDamping = 0.7;
constexpr double kGravity = 9.81;

using common::fmt;

// One plane: its two rows of K / y and the base-motion columns (ResidualSeries::base) that drive it; the sign of g in
// its gravity signature (n_y = L f_x - g J[f_x]; n_x = -L f_y + g J[f_y]).
struct PlaneDef {
  const char* name;
  int moment_row, force_row;  // base rows (0-2 moment, 3-5 force)
  int s_col, alpha_col;       // columns of ResidualSeries::base: [alpha_x, alpha_y, alpha_z, s_x, s_y, s_z]
  double gravity_sign;
};
constexpr PlaneDef kPlanes[2] = {{"sagittal", 1, 3, 3, 1, -1.0}, {"frontal", 0, 4, 4, 0, 1.0}};

// Least squares of each column of R on [Xn | Xe] over `rows` (Xe may have no columns); coefficients [(nn + ne) x k].
Eigen::MatrixXd fitRows(const Eigen::MatrixXd& Xn, const Eigen::MatrixXd& Xe, const Eigen::MatrixXd& R,
                        const std::vector<long>& rows) {
  Eigen::MatrixXd A(rows.size(), Xn.cols() + Xe.cols()), B(rows.size(), R.cols());
  for (size_t i = 0; i < rows.size(); ++i) {
    A.row(i) << Xn.row(rows[i]), Xe.row(rows[i]);
    B.row(i) = R.row(rows[i]);
  }
  return Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(A).solve(B);
}

// The prediction of [Xn | Xe] beta at row k.
Eigen::RowVectorXd predictRow(const Eigen::MatrixXd& Xn, const Eigen::MatrixXd& Xe, const Eigen::MatrixXd& beta, long k) {
  Eigen::RowVectorXd p = Xn.row(k) * beta.topRows(Xn.cols());
  if (Xe.cols() > 0) p += Xe.row(k) * beta.bottomRows(Xe.cols());
  return p;
}

double sseOn(const Eigen::MatrixXd& Xn, const Eigen::MatrixXd& Xe, const Eigen::MatrixXd& R, const Eigen::MatrixXd& beta,
             const std::vector<long>& rows) {
  double s = 0.0;
  for (long k : rows) s += (R.row(k) - predictRow(Xn, Xe, beta, k)).squaredNorm();
  return s;
}

// Columns scaled to unit RMS over the training rows (conditioning; the fits do not depend on it).
void normalise(Eigen::MatrixXd& X, const std::vector<long>& train_rows) {
  for (int c = 0; c < X.cols(); ++c) {
    double q = 0.0;
    for (long k : train_rows) q += X(k, c) * X(k, c);
    const double sc = std::sqrt(q / train_rows.size());
    if (sc > 0.0) X.col(c) /= sc;
  }
}

// The stage's samples (per usable segment, in the order of their names so that the order of the files does not change
// a figure: every `step`-th sample after the warm-up), the training folds and the held-out test shared by both
// signatures.
struct Stage {
  const UnmeasuredBodyOptions& o;
  long N = 0;
  std::vector<int> seg;
  std::vector<long> idx;
  std::vector<char> val;
  std::vector<double> tt;
  std::vector<std::vector<long>> seg_rows;  // [series]
  std::vector<size_t> used;                 // usable series, by name
  std::vector<long> train_rows, val_rows;
  std::vector<int> fold;

  Stage(const std::vector<ResidualSeries>& series, const UnmeasuredBodyOptions& options) : o(options) {
    for (size_t s = 0; s < series.size(); ++s) {
      const ResidualSeries& rs = series[s];
      if (!rs.held_base && rs.t.size() >= 3 && rs.base.rows() == rs.t.size() && rs.base.cols() == 6) used.push_back(s);
    }
    std::stable_sort(used.begin(), used.end(), [&](size_t a, size_t b) { return series[a].segment < series[b].segment; });
    seg_rows.assign(series.size(), {});
    for (size_t s : used) {
      const ResidualSeries& rs = series[s];
      const long n = rs.t.size();
      std::vector<double> d(n - 1);
      for (long i = 0; i + 1 < n; ++i) d[i] = rs.t[i + 1] - rs.t[i];
      std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
      const double dt = d[d.size() / 2];
      if (!(dt > 0.0)) continue;
      const long step = std::max(1L, std::lround(1.0 / (o.rate_hz * dt)));
      for (long i = 0; i < n; i += step)
        if (rs.t[i] - rs.t[0] >= o.warmup_seconds) {
          seg_rows[s].push_back(N++);
          seg.push_back(static_cast<int>(s)), idx.push_back(i), val.push_back(rs.validation), tt.push_back(rs.t[i]);
        }
    }
    for (long k = 0; k < N; ++k) (val[k] ? val_rows : train_rows).push_back(k);
    fold.assign(N, -1);
    for (size_t i = 0; i < train_rows.size(); ++i)
      fold[train_rows[i]] = static_cast<int>(i * o.folds / train_rows.size());
  }

  // Training rows outside fold f and outside block_seconds of it within its segment (the residual is correlated).
  std::vector<long> outside(int f) const { return trainingRowsOutside(train_rows, fold, seg, tt, {f}, o.block_seconds); }

  // Held-out predictions of the null Xn and of the best of the alternatives [Xn | Xe[g]] (the one with the smallest SSE on
  // the fitting rows) for the scaled targets Rs [N x k]: cross-fitted training folds (too few fitting rows, 10 per
  // column: no prediction, no skill claimed), validation from all training rows. Returns the alternative chosen on all
  // training rows and (beta_all) its coefficients there, the null's first.
  int predict(const Eigen::MatrixXd& Rs, const Eigen::MatrixXd& Xn, const std::vector<Eigen::MatrixXd>& Xe,
              Eigen::MatrixXd& Pn, Eigen::MatrixXd& Pa, Eigen::MatrixXd* beta_all) const {
    Pn = Eigen::MatrixXd::Zero(N, Rs.cols()), Pa = Pn;
    const Eigen::MatrixXd none(N, 0);
    auto run = [&](const std::vector<long>& fit, const std::vector<long>& target, Eigen::MatrixXd* beta_out) {
      int best = 0;
      double best_sse = INFINITY;
      Eigen::MatrixXd best_beta;
      for (size_t g = 0; g < Xe.size(); ++g) {
        const Eigen::MatrixXd beta = fitRows(Xn, Xe[g], Rs, fit);
        const double e = sseOn(Xn, Xe[g], Rs, beta, fit);
        if (e < best_sse) best_sse = e, best = static_cast<int>(g), best_beta = beta;
      }
      const Eigen::MatrixXd bn = fitRows(Xn, none, Rs, fit);
      for (long k : target) Pn.row(k) = Xn.row(k) * bn, Pa.row(k) = predictRow(Xn, Xe[best], best_beta, k);
      if (beta_out) *beta_out = best_beta;
      return best;
    };
    const size_t min_rows = 10 * static_cast<size_t>(Xn.cols() + Xe.front().cols());
    for (int f = 0; f < o.folds; ++f) {
      std::vector<long> te;
      for (long k : train_rows)
        if (fold[k] == f) te.push_back(k);
      const std::vector<long> tr = outside(f);
      if (te.empty() || tr.size() < min_rows) continue;
      run(tr, te, nullptr);
    }
    return run(train_rows, val_rows, beta_all);
  }

  // The held-out blocks (per segment, block_seconds; a last piece under half a block joins the one before) and the test
  // of the gain of Pa over Pn on the scaled targets Rs.
  BodyTest test(const Eigen::MatrixXd& Rs, const Eigen::MatrixXd& Pn, const Eigen::MatrixXd& Pa) const {
    std::vector<double> ssr, ssn, ssa;
    double v_r = 0, v_n = 0, v_a = 0;
    for (size_t s : used) {
      const std::vector<long>& rows = seg_rows[s];
      if (rows.empty()) continue;
      const double t0 = tt[rows.front()], span = tt[rows.back()] - t0;
      const int nb = std::max(1, static_cast<int>(std::floor(span / o.block_seconds + 0.5)));
      const size_t first = ssr.size();
      ssr.resize(first + nb, 0.0), ssn.resize(first + nb, 0.0), ssa.resize(first + nb, 0.0);
      for (long k : rows) {
        const int b = std::min(nb - 1, static_cast<int>((tt[k] - t0) / o.block_seconds));
        const double r2 = Rs.row(k).squaredNorm(), en = (Rs.row(k) - Pn.row(k)).squaredNorm(),
                     ea = (Rs.row(k) - Pa.row(k)).squaredNorm();
        ssr[first + b] += r2, ssn[first + b] += en, ssa[first + b] += ea;
        if (val[k]) v_r += r2, v_n += en, v_a += ea;
      }
    }
    const BlockTest bt = heldOutBlockTest(ssr, ssn, ssa);
    const double SR = std::accumulate(ssr.begin(), ssr.end(), 0.0);
    BodyTest r;
    r.blocks = static_cast<int>(ssr.size());
    r.gain = bt.share, r.se = bt.se, r.p = bt.p;
    r.share = SR > 0 ? 1.0 - std::accumulate(ssa.begin(), ssa.end(), 0.0) / SR : 0.0;
    r.null_share = SR > 0 ? 1.0 - std::accumulate(ssn.begin(), ssn.end(), 0.0) / SR : 0.0;
    r.validation_share = v_r > 0 ? 1.0 - v_a / v_r : 0.0, r.validation_gain = v_r > 0 ? (v_n - v_a) / v_r : 0.0;
    return r;
  }

  double trainRms(const Eigen::VectorXd& x) const {
    double q = 0.0;
    for (long k : train_rows) q += x[k] * x[k];
    return std::sqrt(q / std::max<size_t>(train_rows.size(), 1));
  }
};

// A signature's verdict (sets t.passed): significant at the level, a gain of at least min_share and admissible.
const char* judge(BodyTest& t, double level, double min_share, bool admissible) {
  t.passed = false;
  if (!(t.p < level)) return "not significant";
  if (t.gain < min_share) return "below min-share";
  if (!admissible) return "wrong sign";
  t.passed = true;
  return "an unmeasured body";
}

}  // namespace

bool unmeasuredBodyResponse(const Model& model, const std::vector<ResidualSeries>& series, double alpha, double min_share,
                            const UnmeasuredBodyOptions& o, UnmeasuredBodyResult& out, std::string* error) {
  out = UnmeasuredBodyResult{};
  auto fail = [&](const std::string& m) {
    if (error) *error = "unmeasured body: " + m;
    return false;
  };
  if (!o.enabled || !model.floating_base) return true;
  if (o.frequencies_hz.empty() || o.damping_ratios.empty() || !(o.rate_hz > 0.0) || !(o.block_seconds > 0.0) ||
      o.folds < 3 || !(o.warmup_seconds >= 0.0) || !(o.null_frequency_hz > 0.0) || !(o.leak_hz > 0.0))
    return fail("the grid, rate, block length, leak and folds (>= 3) must be positive");
  for (double f : o.frequencies_hz)
    if (!(f > o.leak_hz) || f >= o.null_frequency_hz)
      return fail("every natural frequency must be between the leak and the null's frequency");
  for (double z : o.damping_ratios)
    if (!(z > 0.0)) return fail("every damping ratio must be positive");

  const Stage st(series, o);
  if (st.train_rows.size() < 50) return true;  // nothing to test: too little base-row data
  out.ran = true;
  out.level = alpha / 4.0;
  const long N = st.N;
  const int ng = static_cast<int>(o.frequencies_hz.size() * o.damping_ratios.size());
  const std::vector<std::string> names = model.coordinateNames();
  out.series.resize(st.used.size());
  for (size_t i = 0; i < st.used.size(); ++i) {
    const ResidualSeries& rs = series[st.used[i]];
    UnmeasuredBodyResult::Series& os = out.series[i];
    os.segment = rs.segment, os.validation = rs.validation;
    const std::vector<long>& rows = st.seg_rows[st.used[i]];
    os.t.resize(rows.size());
    for (size_t k = 0; k < rows.size(); ++k) os.t[k] = st.tt[rows[k]];
    os.residual = os.body = os.null = Eigen::MatrixXd::Zero(rows.size(), 4);
  }

  for (int pl = 0; pl < 2; ++pl) {
    const PlaneDef& P = kPlanes[pl];
    // Per segment at its own rate, then at the stage samples: the two rows' residual R [N x 2]; the gravity signature's
    // high-passed rows H [N x 2] and J[f] [N]; the driven null [N x 7] = F, F', F'' of s and alpha, 1; the driven body
    // per grid point [N x 4] = G, G' of s and alpha.
    Eigen::MatrixXd R(N, 2), H(N, 2), Xn(N, 7);
    Eigen::VectorXd Jf(N);
    std::vector<Eigen::MatrixXd> Xb(ng, Eigen::MatrixXd(N, 4));
    Eigen::VectorXd x, dx;
    const double w0 = 2 * M_PI * o.leak_hz, wf = 2 * M_PI * o.null_frequency_hz;
    for (size_t s : st.used) {
      const ResidualSeries& rs = series[s];
      const std::vector<long>& rows = st.seg_rows[s];
      if (rows.empty()) continue;
      for (int c = 0; c < 2; ++c) {
        const Eigen::VectorXd r = rs.after.col(c == 0 ? P.moment_row : P.force_row);
        // s^2 / (s + w0)^2 = 1 - G - (2 / w0) s G and 1 / (s + w0)^2 = G / w0^2, G = w0^2 / (s + w0)^2 (damping 1)
        secondOrderResponse(rs.t, r, o.leak_hz, 1.0, x, dx);
        for (long k : rows) {
          const long i = st.idx[k];
          R(k, c) = r[i], H(k, c) = r[i] - x[i] - 2.0 / w0 * dx[i];
          if (c == 1) Jf[k] = x[i] / (w0 * w0);
        }
      }
      for (int in = 0; in < 2; ++in) {
        const Eigen::VectorXd u = rs.base.col(in == 0 ? P.s_col : P.alpha_col);
        secondOrderResponse(rs.t, u, o.null_frequency_hz, kNullDamping, x, dx);
        for (long k : rows) {
          const long i = st.idx[k];
          Xn(k, 3 * in) = x[i], Xn(k, 3 * in + 1) = dx[i], Xn(k, 3 * in + 2) = wf * wf * (u[i] - x[i]) - 2 * kNullDamping * wf * dx[i];
        }
        int g = 0;
        for (double f : o.frequencies_hz)
          for (double z : o.damping_ratios) {
            secondOrderResponse(rs.t, u, f, z, x, dx);
            for (long k : rows) Xb[g](k, 2 * in) = x[st.idx[k]], Xb[g](k, 2 * in + 1) = dx[st.idx[k]];
            ++g;
          }
      }
      for (long k : rows) Xn(k, 6) = 1.0;
    }
    UnmeasuredBodyPlane up;
    up.plane = P.name, up.moment_row = names[P.moment_row], up.force_row = names[P.force_row];
    const Eigen::Vector2d scale(st.trainRms(R.col(0)), st.trainRms(R.col(1)));
    if (!(scale.minCoeff() > 0.0)) {
      up.verdict = "not significant";
      out.planes.push_back(up);
      continue;
    }
    {  // every held-out row's RMS (training and validation)
      double m = 0.0, f = 0.0;
      for (long k = 0; k < N; ++k) m += R(k, 0) * R(k, 0), f += R(k, 1) * R(k, 1);
      up.moment_rms = std::sqrt(m / N), up.force_rms = std::sqrt(f / N);
    }

    // 1. The gravity signature: the first-moment excursion J[f] from the moment row, [n, f, 1] against [f, 1] (high-passed
    // rows). This way round, not n from J[f]: J[f] doubly integrates the force row's noise at low frequency, which as a
    // regressor would bias b toward 0 (errors in variables), while as the target it only adds scatter; the moment row
    // carries g p, well above its noise wherever the body moves.
    {
      const double js = st.trainRms(Jf);
      Eigen::MatrixXd Gn(N, 2);
      Gn << H.col(1), Eigen::VectorXd::Ones(N);
      const Eigen::MatrixXd Js = Jf / (js > 0.0 ? js : 1.0);
      Eigen::MatrixXd Pn, Pa, beta;
      st.predict(Js, Gn, {H.col(0)}, Pn, Pa, &beta);  // beta: f, 1, n
      up.gravity = st.test(Js, Pn, Pa);
      // J[f] = (z f - n) / g (sagittal), (n + z f) / g (frontal): the coefficient of n is 1 / (sign g)
      const double bn = beta(2, 0) * js, bf = beta(0, 0) * js;
      up.gravity_ratio = bn * P.gravity_sign * kGravity;
      up.lever = bn != 0.0 ? P.gravity_sign * bf / bn : 0.0;  // z of n_y = z f_x, n_x = -z f_y: the mass's height
      up.first_moment_rms = js;
    }
    // 2. The driven response on both rows (scaled by their training RMS).
    {
      const Eigen::MatrixXd Rs = R * scale.cwiseInverse().asDiagonal();
      normalise(Xn, st.train_rows);
      for (Eigen::MatrixXd& X : Xb) normalise(X, st.train_rows);
      Eigen::MatrixXd Pn, Pb;
      const int g_all = st.predict(Rs, Xn, Xb, Pn, Pb, nullptr);
      up.frequency_hz = o.frequencies_hz[g_all / o.damping_ratios.size()];
      up.damping_ratio = o.damping_ratios[g_all % o.damping_ratios.size()];
      up.driven = st.test(Rs, Pn, Pb);
      double m_r = 0, m_b = 0, f_r = 0, f_b = 0;
      for (long k = 0; k < N; ++k) {
        m_r += Rs(k, 0) * Rs(k, 0), m_b += std::pow(Rs(k, 0) - Pb(k, 0), 2);
        f_r += Rs(k, 1) * Rs(k, 1), f_b += std::pow(Rs(k, 1) - Pb(k, 1), 2);
      }
      up.moment_share = m_r > 0 ? 1.0 - m_b / m_r : 0.0, up.force_share = f_r > 0 ? 1.0 - f_b / f_r : 0.0;
      for (size_t i = 0; i < st.used.size(); ++i) {
        const std::vector<long>& rows = st.seg_rows[st.used[i]];
        for (size_t k = 0; k < rows.size(); ++k)
          for (int c = 0; c < 2; ++c) {
            out.series[i].residual(k, 2 * pl + c) = R(rows[k], c);
            out.series[i].body(k, 2 * pl + c) = scale[c] * Pb(rows[k], c);
            out.series[i].null(k, 2 * pl + c) = scale[c] * Pn(rows[k], c);
          }
      }
    }

    const std::string gravity_verdict = judge(up.gravity, out.level, min_share, up.gravity_ratio > 0.0),
                      driven_verdict = judge(up.driven, out.level, min_share, true);
    up.found = up.gravity.passed || up.driven.passed;
    up.verdict = up.found ? "an unmeasured body"
                          : "gravity signature: " + gravity_verdict + "; driven response: " + driven_verdict;
    if (up.found) {
      std::string why;
      if (up.gravity.passed)
        why += "the double integral of the force row, a moving mass's first moment (" + fmt("%.2g", up.first_moment_rms) +
               " kg m RMS), is in the moment row times " + fmt("%.2f", up.gravity_ratio) + " g, as gravity puts it there (at " +
               fmt("%.2f", up.lever) + " m above the base; the moment row predicts " + fmt("%.0f", 100 * up.gravity.gain) +
               " % of its held-out variance beyond the force row alone, p = " + fmt("%.2g", up.gravity.p) + ")";
      if (up.driven.passed)
        why += std::string(why.empty() ? "" : "; ") + "a resonance near " + fmt("%.2g", up.frequency_hz) +
               " Hz (damping ratio " + fmt("%.2g", up.damping_ratio) + "), driven by the base's own motion, predicts " +
               fmt("%.0f", 100 * up.driven.share) + " % of these rows' held-out residual, a rigid null " +
               fmt("%.0f", 100 * up.driven.null_share) + " % (p = " + fmt("%.2g", up.driven.p) + ")";
      up.sentence = "an unmeasured body moves on the base (" + up.plane + " plane: " + up.moment_row + " " +
                    fmt("%.3g", up.moment_rms) + " N m, " + up.force_row + " " + fmt("%.3g", up.force_rms) +
                    " N RMS): " + why + "; no joint effect acts on these rows";
    }
    out.planes.push_back(up);
  }
  return true;
}

}  // namespace exoid::estimator
