// Is the residual the augmented model leaves predictable from the state? (residual_predictability.hpp)
#include "exoid/estimator/residual_predictability.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <numeric>

#include "exoid/common/format.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/sparse_regression.hpp"
#include "held_out_blocks.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

namespace {

// A column of a dictionary and the state variables it is a function of.
struct Column {
  std::string name;
  std::vector<std::string> vars;
  Eigen::VectorXd x;
};

using common::fmt;

// The state at the stage samples [N x nj]: q (zero when not given), v, a, the model torque tau, and per lag L
// v(t - L) and q(t) - q(t - L).
struct StateTable {
  bool has_q = false;
  Eigen::MatrixXd Q, V, A, T;
  std::vector<Eigen::MatrixXd> Vlag, Dq;
};

// The joint's dictionary (the sparse model's terms) and raw state features (the trees'), over the stage samples:
// residual_predictability.hpp lists the terms. Every column names the state variables it is a function of.
void stateDictionary(const Model& model, const StateTable& st, int j, const std::vector<int>& neighbours,
                     const PredictabilityOptions& o, std::vector<Column>& dict, std::vector<Column>& raw) {
  const long N = st.Q.rows();
  const int nl = static_cast<int>(o.lags.size());
  const bool has_q = st.has_q;
  const Eigen::MatrixXd &Q = st.Q, &V = st.V, &A = st.A, &T = st.T;
  const std::vector<Eigen::MatrixXd>& Vlag = st.Vlag;
  const std::vector<Eigen::MatrixXd>& Dq = st.Dq;
  const std::vector<std::string>& jn = model.joint_names;
  auto qn = [&](int i) { return "q_" + jn[i]; };
  auto vn = [&](int i) { return "v_" + jn[i]; };
  auto an = [&](int i) { return "a_" + jn[i]; };
  auto tn = [&](int i) { return "tau_" + jn[i]; };
  const double w0 = o.widths.empty() ? 0.03 : o.widths.front();
  // Dictionary (sparse model) and raw features (trees).
  auto add = [&](std::vector<Column>& to, std::string name, std::vector<std::string> vars,
                 const std::function<double(long)>& f) {
    Column c{std::move(name), std::move(vars), Eigen::VectorXd(N)};
    for (long k = 0; k < N; ++k) c.x[k] = f(k);
    to.push_back(std::move(c));
  };
  const std::string q = qn(j), v = vn(j), a = an(j), tau = tn(j);
  if (has_q) {
    add(dict, q, {q}, [&](long k) { return Q(k, j); });
    add(dict, "sin(" + q + ")", {q}, [&](long k) { return std::sin(Q(k, j)); });
    add(dict, "cos(" + q + ")", {q}, [&](long k) { return std::cos(Q(k, j)); });
  }
  add(dict, v, {v}, [&](long k) { return V(k, j); });
  add(dict, "|" + v + "|", {v}, [&](long k) { return std::fabs(V(k, j)); });
  add(dict, v + "|" + v + "|", {v}, [&](long k) { return V(k, j) * std::fabs(V(k, j)); });
  for (double w : o.widths) {
    const std::string th = "tanh(" + v + "/" + fmt("%g", w) + ")";
    add(dict, th, {v}, [&, w](long k) { return std::tanh(V(k, j) / w); });
    add(dict, tau + "*" + th, {tau, v}, [&, w](long k) { return T(k, j) * std::tanh(V(k, j) / w); });
    add(dict, "|" + tau + "|*" + th, {tau, v}, [&, w](long k) { return std::fabs(T(k, j)) * std::tanh(V(k, j) / w); });
  }
  add(dict, a, {a}, [&](long k) { return A(k, j); });
  add(dict, tau, {tau}, [&](long k) { return T(k, j); });
  const std::string th0 = "tanh(" + v + "/" + fmt("%g", w0) + ")";
  if (has_q) {
    add(dict, "sin(" + q + ")*" + th0, {q, v}, [&](long k) { return std::sin(Q(k, j)) * std::tanh(V(k, j) / w0); });
    add(dict, "cos(" + q + ")*" + th0, {q, v}, [&](long k) { return std::cos(Q(k, j)) * std::tanh(V(k, j) / w0); });
    add(dict, q + "*" + th0, {q, v}, [&](long k) { return Q(k, j) * std::tanh(V(k, j) / w0); });
    add(dict, q + "*" + v, {q, v}, [&](long k) { return Q(k, j) * V(k, j); });
  }
  for (int l = 0; l < nl; ++l) {
    const std::string L = fmt("%g s", o.lags[l]);
    const double rmsd = std::sqrt(Dq[l].col(j).squaredNorm() / N) + 1e-12;
    add(dict, v + "(t-" + L + ")", {v}, [&, l](long k) { return Vlag[l](k, j); });
    add(dict, q + "(t)-" + q + "(t-" + L + ")", {q}, [&, l](long k) { return Dq[l](k, j); });
    add(dict, "tanh((" + q + "(t)-" + q + "(t-" + L + "))/" + fmt("%.2g", 0.1 * rmsd) + ")", {q},
        [&, l, rmsd](long k) { return std::tanh(Dq[l](k, j) / (0.1 * rmsd)); });
    add(raw, v + "(t-" + L + ")", {v}, [&, l](long k) { return Vlag[l](k, j); });
    add(raw, q + "(t)-" + q + "(t-" + L + ")", {q}, [&, l](long k) { return Dq[l](k, j); });
  }
  for (int m : neighbours) {
    const std::string qm = qn(m), vm = vn(m), am = an(m);
    if (has_q) {
      add(dict, qm, {qm}, [&, m](long k) { return Q(k, m); });
      add(dict, "sin(" + qm + ")", {qm}, [&, m](long k) { return std::sin(Q(k, m)); });
      add(dict, "cos(" + qm + ")", {qm}, [&, m](long k) { return std::cos(Q(k, m)); });
      add(dict, "sin(" + q + "+" + qm + ")", {q, qm}, [&, m](long k) { return std::sin(Q(k, j) + Q(k, m)); });
      add(dict, "cos(" + q + "+" + qm + ")", {q, qm}, [&, m](long k) { return std::cos(Q(k, j) + Q(k, m)); });
    }
    add(dict, vm, {vm}, [&, m](long k) { return V(k, m); });
    add(dict, "tanh(" + vm + "/" + fmt("%g", w0) + ")", {vm}, [&, m](long k) { return std::tanh(V(k, m) / w0); });
    add(dict, am, {am}, [&, m](long k) { return A(k, m); });
    add(dict, v + "*" + vm, {v, vm}, [&, m](long k) { return V(k, j) * V(k, m); });
  }
  // Raw state for the trees.
  for (int m : [&] { std::vector<int> js{j}; js.insert(js.end(), neighbours.begin(), neighbours.end()); return js; }()) {
    if (has_q) add(raw, qn(m), {qn(m)}, [&, m](long k) { return Q(k, m); });
    add(raw, vn(m), {vn(m)}, [&, m](long k) { return V(k, m); });
    add(raw, an(m), {an(m)}, [&, m](long k) { return A(k, m); });
    add(raw, tn(m), {tn(m)}, [&, m](long k) { return T(k, m); });
  }
}

// The stage samples: every segment decimated to rate_hz, from max_lag after its start (the lagged terms need history).
// Segments in the order of their names, not as given: the folds are contiguous over the training samples and the
// trees subsample rows by index, so the same files in another order would otherwise give other figures.
struct StageSamples {
  long N = 0;
  std::vector<int> seg;                     // [N] series index
  std::vector<long> idx;                    // [N] sample index in its segment
  std::vector<bool> val;                    // [N] from a validation segment
  Eigen::VectorXd tt;                       // [N] time, s
  std::vector<double> seg_dt;               // [series] median sample interval (0: segment not used)
  std::vector<std::vector<long>> seg_rows;  // [series] its stage samples
};

StageSamples stageSamples(const std::vector<ResidualSeries>& series, const PredictabilityOptions& o, double max_lag) {
  StageSamples ss;
  ss.seg_dt.assign(series.size(), 0.0);
  std::vector<size_t> by_name(series.size());
  for (size_t s = 0; s < series.size(); ++s) by_name[s] = s;
  std::stable_sort(by_name.begin(), by_name.end(), [&](size_t a, size_t b) { return series[a].segment < series[b].segment; });
  for (const size_t s : by_name) {
    const ResidualSeries& rs = series[s];
    const long n = rs.t.size();
    if (n < 3) continue;
    std::vector<double> d(n - 1);
    for (long i = 0; i + 1 < n; ++i) d[i] = rs.t[i + 1] - rs.t[i];
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    const double dt = d[d.size() / 2];
    if (!(dt > 0.0)) continue;
    ss.seg_dt[s] = dt;
    const long step = std::max(1L, std::lround(1.0 / (o.rate_hz * dt)));
    for (long i = std::lround(max_lag / dt); i < n; i += step) ss.seg.push_back(static_cast<int>(s)), ss.idx.push_back(i);
  }
  ss.N = static_cast<long>(ss.seg.size());
  ss.tt.resize(ss.N);
  ss.val.resize(ss.N);
  ss.seg_rows.assign(series.size(), {});
  for (long k = 0; k < ss.N; ++k) {
    ss.tt[k] = series[ss.seg[k]].t[ss.idx[k]], ss.val[k] = series[ss.seg[k]].validation;
    ss.seg_rows[ss.seg[k]].push_back(k);
  }
  return ss;
}

// The state at the stage samples (StateTable) and the residual Rz [N x nj] there. Without q, q(t) - q(t - L) is the
// trapezoidal integral of v.
void stateAtSamples(const Model& model, const std::vector<ResidualSeries>& series, const PredictabilityOptions& o,
                    const StageSamples& ss, StateTable& st, Eigen::MatrixXd& Rz) {
  const long N = ss.N;
  const int nj = model.njoints, nl = static_cast<int>(o.lags.size());
  const bool has_q = st.has_q;
  st.Q.resize(N, nj), st.V.resize(N, nj), st.A.resize(N, nj), st.T.resize(N, nj);
  st.Vlag.assign(nl, Eigen::MatrixXd(N, nj)), st.Dq.assign(nl, Eigen::MatrixXd(N, nj));
  Rz.resize(N, nj);
  std::vector<Eigen::MatrixXd> cumv(series.size());  // integral of v (q up to a constant) when q is not given
  if (!has_q)
    for (size_t s = 0; s < series.size(); ++s) {
      const ResidualSeries& rs = series[s];
      cumv[s] = Eigen::MatrixXd::Zero(rs.t.size(), nj);
      for (long i = 1; i < rs.t.size(); ++i)
        cumv[s].row(i) = cumv[s].row(i - 1) + 0.5 * (rs.t[i] - rs.t[i - 1]) * (rs.v.row(i) + rs.v.row(i - 1));
    }
  for (long k = 0; k < N; ++k) {
    const ResidualSeries& rs = series[ss.seg[k]];
    const long i = ss.idx[k];
    for (int j = 0; j < nj; ++j) {
      const int r = model.jointRow(j);
      st.Q(k, j) = has_q ? rs.q(i, j) : 0.0;
      st.V(k, j) = rs.v(i, j), st.A(k, j) = rs.a(i, j), st.T(k, j) = rs.tau_model(i, r), Rz(k, j) = rs.after(i, r);
      for (int l = 0; l < nl; ++l) {
        const long il = std::max(0L, i - std::lround(o.lags[l] / ss.seg_dt[ss.seg[k]]));
        st.Vlag[l](k, j) = rs.v(il, j);
        st.Dq[l](k, j) = has_q ? rs.q(i, j) - rs.q(il, j) : cumv[ss.seg[k]](i, j) - cumv[ss.seg[k]](il, j);
      }
    }
  }
}

// One joint's training rows in time order per segment, cut into contiguous folds, and the fits over them.
struct FoldPlan {
  const StageSamples& ss;
  const PredictabilityOptions& o;
  std::vector<long> train_rows, val_rows;
  std::vector<int> fold;  // [N] -1: not a training row

  FoldPlan(const StageSamples& samples, const PredictabilityOptions& options, const std::vector<bool>& usable)
      : ss(samples), o(options), fold(samples.N, -1) {
    for (long k = 0; k < ss.N; ++k)
      if (usable[k]) (ss.val[k] ? val_rows : train_rows).push_back(k);
    for (size_t i = 0; i < train_rows.size(); ++i) fold[train_rows[i]] = static_cast<int>(i * o.folds / train_rows.size());
  }
  // Training rows outside the folds in `folds` and outside block_seconds of them within their segment.
  std::vector<long> trainingOutside(const std::vector<int>& folds) const {
    return trainingRowsOutside(train_rows, fold, ss.seg, ss.tt, folds, o.block_seconds);
  }
  std::vector<long> foldRows(int f) const {
    std::vector<long> rows;
    for (long k : train_rows)
      if (fold[k] == f) rows.push_back(k);
    return rows;
  }
  // Sparse model size by cross-validation over the folds in `among` (SSE summed per size).
  int chooseSize(const Eigen::MatrixXd& X, const Eigen::VectorXd& r, const std::vector<int>& among,
                 const std::vector<int>& also_held) const {
    std::vector<double> sse(o.max_terms + 1, 0.0);
    for (int g : among) {
      std::vector<int> held = also_held;
      held.push_back(g);
      const std::vector<long> tr = trainingOutside(held), te = foldRows(g);
      if (tr.size() < 20 || te.empty()) continue;
      const std::vector<SparseModel> path = forwardSelectionPath(X, r, tr, o.max_terms);
      for (int s = 0; s <= o.max_terms; ++s) {
        const SparseModel& m = path[std::min<size_t>(s, path.size() - 1)];
        for (long k : te) sse[s] += std::pow(r[k] - m.predict(X, k), 2);
      }
    }
    return static_cast<int>(std::min_element(sse.begin(), sse.end()) - sse.begin());
  }
};

// Joint j's predictions: cross-fitted on the training rows (each fold from the others, its size chosen on them), then
// the final models on all training rows for the validation rows (sparse model sm, the trees' feature gains).
bool predictJoint(const Eigen::MatrixXd& X, const Eigen::MatrixXd& F, const Eigen::VectorXd& r, const FoldPlan& plan,
                  const PredictabilityOptions& o, int j, Eigen::MatrixXd& Psp, Eigen::MatrixXd& Ptr, SparseModel& sm,
                  Eigen::VectorXd& gain, std::string* error) {
  std::string err;
  const int nf = o.folds;
  for (int f = 0; f < nf; ++f) {
    const std::vector<long> tr = plan.trainingOutside({f}), te = plan.foldRows(f);
    if (te.empty()) continue;
    if (tr.size() < 20) {  // too little data outside the guard: predict zero (no skill claimed)
      for (long k : te) Psp(k, j) = Ptr(k, j) = 0.0;
      continue;
    }
    std::vector<int> others;
    for (int g = 0; g < nf; ++g)
      if (g != f) others.push_back(g);
    const std::vector<SparseModel> path = forwardSelectionPath(X, r, tr, plan.chooseSize(X, r, others, {f}));
    for (long k : te) Psp(k, j) = path.back().predict(X, k);
    if (o.trees) {
      Eigen::VectorXd pred;
      if (!fitBoostedTrees(F, r, tr, te, o.tree, pred, nullptr, &err))
        return common::fail(error, "residual predictability: " + err);
      for (size_t i = 0; i < te.size(); ++i) Ptr(te[i], j) = pred[static_cast<Eigen::Index>(i)];
    }
  }
  std::vector<int> all(nf);
  std::iota(all.begin(), all.end(), 0);
  sm = forwardSelectionPath(X, r, plan.train_rows, plan.chooseSize(X, r, all, {})).back();
  for (long k : plan.val_rows) Psp(k, j) = sm.predict(X, k);
  gain = Eigen::VectorXd::Zero(F.cols());
  if (o.trees) {
    Eigen::VectorXd pred;
    if (!fitBoostedTrees(F, r, plan.train_rows, plan.val_rows, o.tree, pred, &gain, &err))
      return common::fail(error, "residual predictability: " + err);
    for (size_t i = 0; i < plan.val_rows.size(); ++i) Ptr(plan.val_rows[i], j) = pred[static_cast<Eigen::Index>(i)];
  }
  return true;
}

// Held-out blocks of joint j: per segment, block_seconds of the stage samples (a last piece under half a block joins the
// one before); per block the residual's and each method's error sums of squares. Fills jp.blocks, rms, validation_*.
struct BlockSums {
  std::vector<double> ssr, sse_s, sse_t;
  double sr = 0.0;
  long nr = 0;
};
BlockSums heldOutBlocks(const std::vector<ResidualSeries>& series, const StageSamples& ss, const std::vector<bool>& usable,
                        const Eigen::MatrixXd& Psp, const Eigen::MatrixXd& Ptr, const Eigen::VectorXd& r,
                        const PredictabilityOptions& o, int j, JointPredictability& jp) {
  BlockSums b;
  std::vector<double> vr(3, 0.0);
  long nvr = 0;
  for (size_t s = 0; s < series.size(); ++s) {
    std::vector<long> rows;
    for (long k : ss.seg_rows[s])
      if (usable[k] && !std::isnan(Psp(k, j))) rows.push_back(k);
    if (rows.empty()) continue;
    const double t0 = ss.tt[rows.front()], span = ss.tt[rows.back()] - t0;
    const int nb_seg = std::max(1, static_cast<int>(std::floor(span / o.block_seconds + 0.5)));
    const size_t first = b.ssr.size();
    b.ssr.resize(first + nb_seg, 0.0), b.sse_s.resize(first + nb_seg, 0.0), b.sse_t.resize(first + nb_seg, 0.0);
    for (long k : rows) {
      const int bl = std::min(nb_seg - 1, static_cast<int>((ss.tt[k] - t0) / o.block_seconds));
      const double e_s = r[k] - Psp(k, j), e_t = o.trees ? r[k] - Ptr(k, j) : r[k];
      b.ssr[first + bl] += r[k] * r[k], b.sse_s[first + bl] += e_s * e_s, b.sse_t[first + bl] += e_t * e_t;
      b.sr += r[k] * r[k], ++b.nr;
      if (series[s].validation) vr[0] += r[k] * r[k], vr[1] += e_s * e_s, vr[2] += e_t * e_t, ++nvr;
    }
  }
  jp.blocks = static_cast<int>(b.ssr.size());
  jp.rms = std::sqrt(b.sr / std::max(b.nr, 1L));
  if (nvr > 0) {
    jp.validation_rms = std::sqrt(vr[0] / nvr);
    if (vr[0] > 0) jp.validation_share_sparse = 1 - vr[1] / vr[0], jp.validation_share_trees = o.trees ? 1 - vr[2] / vr[0] : 0.0;
  }
  return b;
}

// The verdict before the size floor: each method's block test; predictable when one passes the level with at least
// min_share; the reported method is the larger significant share (else the larger share). True: the trees.
bool judgeMethods(const BlockSums& b, const PredictabilityOptions& o, double level, double min_share,
                  JointPredictability& jp) {
  const BlockTest bs = heldOutBlockTest(b.ssr, b.ssr, b.sse_s), bt = o.trees ? heldOutBlockTest(b.ssr, b.ssr, b.sse_t) : BlockTest{};
  jp.share_sparse = bs.share, jp.se_sparse = bs.se, jp.p_sparse = bs.p;
  jp.share_trees = bt.share, jp.se_trees = bt.se, jp.p_trees = bt.p;
  const bool sig_s = bs.p < level && bs.share >= min_share, sig_t = o.trees && bt.p < level && bt.share >= min_share;
  jp.predictable = sig_s || sig_t;  // the size floor is applied once the pooled RMS is known
  const bool use_trees = o.trees && ((sig_t && (!sig_s || bt.share > bs.share)) || (!jp.predictable && bt.share > bs.share));
  jp.method = use_trees ? "trees" : "sparse";
  const BlockTest& m = use_trees ? bt : bs;
  jp.share = m.share, jp.se = m.se, jp.p = m.p;
  return use_trees;
}

// The sparse model's terms with their weights (squared standardized coefficients, normalised), and the state variables
// the reported method depends on (the trees' feature gains, or the terms' weights split over their variables).
void explainJoint(const std::vector<Column>& dict, const std::vector<Column>& raw, const SparseModel& sm,
                  const std::vector<long>& train_rows, bool use_trees, const Eigen::VectorXd& gain, JointPredictability& jp) {
  double tw = 0.0;
  for (size_t i = 0; i < sm.terms.size(); ++i) {
    const Eigen::VectorXd& x = dict[sm.terms[i]].x;
    double m = 0.0, s2 = 0.0;
    for (long k : train_rows) m += x[k];
    m /= static_cast<double>(train_rows.size());
    for (long k : train_rows) s2 += (x[k] - m) * (x[k] - m);
    const double w = std::pow(sm.coef[static_cast<Eigen::Index>(i)], 2) * s2 / static_cast<double>(train_rows.size());
    jp.terms.push_back({dict[sm.terms[i]].name, sm.coef[static_cast<Eigen::Index>(i)], w});
    tw += w;
  }
  for (PredictabilityTerm& t : jp.terms) t.weight = tw > 0 ? t.weight / tw : 0.0;
  std::sort(jp.terms.begin(), jp.terms.end(), [](const auto& x, const auto& y) { return x.weight > y.weight; });
  std::map<std::string, double> vw;
  if (use_trees) {
    const double g = gain.sum();
    for (size_t c = 0; c < raw.size(); ++c)
      if (g > 0) vw[raw[c].vars.front()] += gain[static_cast<Eigen::Index>(c)] / g;
  } else {
    for (size_t i = 0; i < sm.terms.size(); ++i) {
      const Column& c = dict[sm.terms[i]];
      double w = 0.0;
      for (const PredictabilityTerm& t : jp.terms)
        if (t.name == c.name) w = t.weight;
      for (const std::string& var : c.vars) vw[var] += w / c.vars.size();
    }
  }
  for (const auto& [name, w] : vw)
    if (w > 0.05) jp.variables.push_back({name, w});
  std::sort(jp.variables.begin(), jp.variables.end(), [](const auto& x, const auto& y) { return x.second > y.second; });
  jp.predictable_rms = std::sqrt(std::max(jp.share, 0.0)) * jp.rms;
}

std::string predictableSentence(const std::string& joint, const JointPredictability& jp, bool use_trees, double level) {
  std::string vars;
  for (size_t i = 0; i < jp.variables.size() && i < 4; ++i)
    vars += (i == 0 ? "" : i + 1 == std::min<size_t>(jp.variables.size(), 4) ? " and " : ", ") + jp.variables[i].first;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "an effect the model lacks on %s: %.0f %% (+- %.0f) of the remaining held-out residual (RMS %.3g N m) "
                "is predictable from the state (%s; p = %.2g, level %.2g); depends on %s",
                joint.c_str(), 100 * jp.share, 100 * jp.se, jp.rms, use_trees ? "gradient-boosted trees" : "sparse regression",
                jp.p, level, vars.empty() ? "(no single variable)" : vars.c_str());
  return buf;
}

// The plot series: every segment's stage samples with the residual and both methods' predictions.
void plotSeries(const std::vector<ResidualSeries>& series, const StageSamples& ss, const Eigen::MatrixXd& Rz,
                const Eigen::MatrixXd& Psp, const Eigen::MatrixXd& Ptr, int nj, PredictabilityResult& out) {
  for (size_t s = 0; s < series.size(); ++s) {
    PredictabilityResult::Series ps;
    ps.segment = series[s].segment;
    ps.validation = series[s].validation;
    const long n = static_cast<long>(ss.seg_rows[s].size());
    ps.t.resize(n), ps.residual.resize(n, nj), ps.sparse.resize(n, nj), ps.trees.resize(n, nj);
    for (long i = 0; i < n; ++i) {
      const long k = ss.seg_rows[s][i];
      ps.t[i] = ss.tt[k];
      ps.residual.row(i) = Rz.row(k), ps.sparse.row(i) = Psp.row(k), ps.trees.row(i) = Ptr.row(k);
    }
    out.series.push_back(std::move(ps));
  }
}

}  // namespace

std::vector<std::vector<int>> kinematicNeighbours(const Model& model) {
  std::vector<std::vector<int>> nb(model.njoints);
  for (int j = 0; j < model.njoints; ++j) {
    const int pb = model.parent[model.joint_body[j]];
    if (pb >= 0 && model.jointOfBody(pb) >= 0) {
      const int pj = model.jointOfBody(pb);
      nb[j].push_back(pj), nb[pj].push_back(j);
    }
  }
  return nb;
}


bool residualPredictability(const Model& model, const std::vector<ResidualSeries>& series, double alpha, double min_share,
                            double pooled_rms, const PredictabilityOptions& o, PredictabilityResult& out,
                            std::string* error) {
  out = PredictabilityResult{};
  const int nj = model.njoints;
  if (nj == 0 || series.empty() || !o.enabled) return true;
  if (!(o.rate_hz > 0.0) || !(o.block_seconds > 0.0) || o.folds < 3) {
    if (error) *error = "residual predictability: rate_hz and block_seconds must be positive and folds >= 3";
    return false;
  }
  StateTable st;
  st.has_q = true;
  for (const ResidualSeries& rs : series) st.has_q = st.has_q && rs.q.rows() == rs.t.size() && rs.q.cols() == nj;
  const StageSamples ss = stageSamples(series, o, o.lags.empty() ? 0.0 : *std::max_element(o.lags.begin(), o.lags.end()));
  const long N = ss.N;
  if (N == 0) return true;
  Eigen::MatrixXd Rz;
  stateAtSamples(model, series, o, ss, st, Rz);
  const std::vector<std::vector<int>> nb = kinematicNeighbours(model);
  // Joints tested: those with data (a held-base segment's unmeasured rows are not).
  std::vector<int> tested;
  std::vector<std::vector<bool>> usable(nj, std::vector<bool>(N, true));
  for (int j = 0; j < nj; ++j) {
    long ntr = 0;
    for (long k = 0; k < N; ++k) {
      usable[j][k] = !series[ss.seg[k]].held_base || heldBaseRowMeasured(model, model.jointRow(j));
      if (usable[j][k] && !ss.val[k]) ++ntr;
    }
    if (ntr >= 10L * o.folds) tested.push_back(j);
  }
  out.ran = true;
  out.has_q = st.has_q;
  out.tests = static_cast<int>(tested.size()) * (o.trees ? 2 : 1);
  out.level = out.tests > 0 ? alpha / out.tests : alpha;
  Eigen::MatrixXd Psp = Eigen::MatrixXd::Constant(N, nj, std::nan("")), Ptr = Psp;
  double pooled_ss = 0.0;
  long pooled_n = 0;
  for (int j : tested) {
    std::vector<Column> dict, raw;
    stateDictionary(model, st, j, nb[j], o, dict, raw);
    Eigen::MatrixXd X(N, static_cast<Eigen::Index>(dict.size())), F(N, static_cast<Eigen::Index>(raw.size()));
    for (size_t c = 0; c < dict.size(); ++c) X.col(c) = dict[c].x;
    for (size_t c = 0; c < raw.size(); ++c) F.col(c) = raw[c].x;
    const Eigen::VectorXd r = Rz.col(j);
    const FoldPlan plan(ss, o, usable[j]);
    SparseModel sm;
    Eigen::VectorXd gain;
    if (!predictJoint(X, F, r, plan, o, j, Psp, Ptr, sm, gain, error)) return false;
    JointPredictability jp;
    jp.joint = j;
    const BlockSums b = heldOutBlocks(series, ss, usable[j], Psp, Ptr, r, o, j, jp);
    const bool use_trees = judgeMethods(b, o, out.level, min_share, jp);
    explainJoint(dict, raw, sm, plan.train_rows, use_trees, gain, jp);
    pooled_ss += b.sr, pooled_n += b.nr;
    if (jp.predictable) jp.sentence = predictableSentence(model.joint_names[j], jp, use_trees, out.level);
    out.joints.push_back(std::move(jp));
  }
  // The relevance floor: a significant predictable part below min_rms_fraction of the pooled held-out RMS is not named.
  out.pooled_rms = pooled_rms > 0.0 ? pooled_rms : std::sqrt(pooled_ss / std::max(pooled_n, 1L));
  for (JointPredictability& jp : out.joints) {
    const bool significant = jp.predictable;
    jp.predictable = significant && jp.predictable_rms >= o.min_rms_fraction * out.pooled_rms;
    jp.verdict = jp.predictable ? "predictable" : significant ? "significant but small" : "not significant";
    if (!jp.predictable) jp.sentence.clear();
  }
  plotSeries(series, ss, Rz, Psp, Ptr, nj, out);
  return true;
}

}  // namespace exoid::estimator
