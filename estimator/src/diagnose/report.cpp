// The diagnosis's residuals, summaries and sentences (diagnose_stages.hpp, docs/diagnose.md).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "exoid/estimator/diagnose_stages.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

namespace {
// Streams segment s once more (with q when it has stream_state) and fills rs.after: y minus the augmented model.
bool augmentedResidual(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data, size_t s,
                       ResidualSeries& rs, std::string* error) {
  const int nv = data.nv, m = data.m, nj = data.nj;
  const SegmentSignals& cache = data.caches[s];
  const Eigen::VectorXd& xa = data.xa;
  std::vector<DiagnosisCandidate> chosen;
  std::vector<int> chosen_pos, payload_pos, payload_param;  // positions in S (and xa); the payloads' columns of K
  for (size_t i = 0; i < data.fcol.size(); ++i)
    chosen.push_back(data.cands[data.fcol[i] - m]), chosen_pos.push_back(columnPosition(data.S, data.fcol[i]));
  for (size_t i = 0; i < data.pcol.size(); ++i)
    for (int k = 0; k < 4; ++k) {
      const int c = data.pcol[i] + k;
      payload_pos.push_back(columnPosition(data.S, c));
      payload_param.push_back(payloadParameter(model, data, c));
    }
  long i = 0;
  const DiagnosisRowSink row = [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
    if (i >= cache.n) return;
    for (int r = 0; r < nv; ++r) {
      double pr = 0.0;
      for (int c = 0; c < m; ++c) pr += K(r, data.decl[c]) * xa[c];
      rs.after(i, r) = y[r] - pr;
    }
    for (size_t e = 0; e < chosen.size(); ++e)
      rs.after(i, chosen[e].coord) -= xa[chosen_pos[e]] * candidateSignal(model, opt, data, s, i, chosen[e]);
    for (size_t e = 0; e < payload_pos.size(); ++e)
      for (int r = 0; r < nv; ++r) rs.after(i, r) -= K(r, payload_param[e]) * xa[payload_pos[e]];
    ++i;
  };
  const Segment& seg = data.segment(s);
  // With Segment::stream_state the same rows come with q (for the last stage's dictionary).
  if (seg.stream_state) rs.q.resize(cache.n, nj);
  const bool ok = seg.stream_state ? seg.stream_state(
                                         [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                             const Eigen::VectorXd& ts, const Eigen::VectorXd& q) {
                                           if (i < cache.n && q.size() == nj) rs.q.row(i) = q.transpose();
                                           row(t, K, y, ts);
                                         },
                                         error)
                                   : seg.stream(row, error);
  if (!ok) return false;
  if (i != cache.n) return common::fail(error, seg.name + ": the data changed between two reads");
  return true;
}

double lag1(const Eigen::VectorXd& r) {
  if (r.size() < 3) return 0.0;
  const Eigen::VectorXd c = r.array() - r.mean();
  const double den = c.squaredNorm();
  return den > 0 ? c.head(c.size() - 1).dot(c.tail(c.size() - 1)) / den : 0.0;
}

std::string formatValue(EffectKind k, double value, double se) {
  char buf[160];
  if (k == EffectKind::GainError)
    std::snprintf(buf, sizeof buf, "%+.2f %% (+- %.2f)", 100.0 * value, 100.0 * se);
  else if (k == EffectKind::Delay)
    std::snprintf(buf, sizeof buf, "%+.2f ms (+- %.2f)", 1e3 * value, 1e3 * se);
  else
    std::snprintf(buf, sizeof buf, "%.3g %s (+- %.2g)", value, effectUnit(k), se);
  return buf;
}
}  // namespace

bool residualSeries(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out,
                    std::string* error) {
  for (size_t s = 0; s < data.caches.size(); ++s) {
    const SegmentSignals& cache = data.caches[s];
    ResidualSeries rs;
    rs.segment = data.segment(s).name;
    rs.validation = s >= data.ntrain;
    rs.t = Eigen::Map<const Eigen::VectorXd>(cache.t.data(), cache.n);
    rs.before = cache.y - cache.tau0;
    rs.after.resize(cache.n, data.nv);
    rs.v = cache.v;
    rs.a = cache.a;
    rs.tau_model = cache.tau;
    rs.base = cache.base;
    rs.held_base = data.segment(s).held_base;
    if (!augmentedResidual(model, opt, data, s, rs, error)) return false;
    out.series.push_back(std::move(rs));
  }
  return true;
}

void summarizeCoordinates(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data,
                          DiagnosisResult& out) {
  // The residuals of coordinate r over the validation (val) or training segments, before or after, measured rows only.
  auto stack = [&](bool val, bool after, int r) {
    long n = 0;
    for (size_t s = 0; s < out.series.size(); ++s)
      if (out.series[s].validation == val && !data.unmeasured(model, s, r)) n += out.series[s].t.size();
    Eigen::VectorXd v(n);
    long at = 0;
    for (size_t s = 0; s < out.series.size(); ++s) {
      const ResidualSeries& rs = out.series[s];
      if (rs.validation == val && !data.unmeasured(model, s, r))
        v.segment(at, rs.t.size()) = after ? rs.after.col(r) : rs.before.col(r), at += rs.t.size();
    }
    return v;
  };
  const bool held = out.has_validation;  // held-out = the validation segments when given
  double pb = 0, pa = 0, tb = 0, ta = 0;
  long nh = 0, nt = 0;
  const auto rms = [](const Eigen::VectorXd& x) { return std::sqrt(x.squaredNorm() / std::max<Eigen::Index>(x.size(), 1)); };
  for (int r = 0; r < data.nv; ++r) {
    CoordinateSummary cs;
    cs.name = out.coordinate_names[r];
    cs.joint = model.floating_base ? r - 6 : r;
    const Eigen::VectorXd hb = stack(held, false, r), ha = stack(held, true, r);
    const Eigen::VectorXd trb = stack(false, false, r), tra = stack(false, true, r);
    cs.rms_before = rms(hb), cs.rms_after = rms(ha), cs.train_rms_before = rms(trb), cs.train_rms_after = rms(tra);
    pb += hb.squaredNorm(), pa += ha.squaredNorm(), nh += hb.size();
    tb += trb.squaredNorm(), ta += tra.squaredNorm(), nt += trb.size();
    if (opt.torque_noise > 0) {
      cs.noise_floor = opt.torque_noise;
    } else if (hb.size() > 2) {
      const Eigen::VectorXd dd = hb.tail(hb.size() - 1) - hb.head(hb.size() - 1);
      cs.noise_floor = std::sqrt(dd.squaredNorm() / dd.size() / 2.0);
    }
    cs.lag1_before = lag1(hb);
    cs.lag1_after = lag1(ha);
    for (const CandidateScore& sc : out.first_step)
      if (model.jointRow(sc.effect.joint) == r && std::fabs(sc.correlation) > std::fabs(cs.best_correlation))
        cs.best_correlation = sc.correlation, cs.best_candidate = sc.effect;
    out.coordinates.push_back(cs);
  }
  out.pooled_before = std::sqrt(pb / std::max(nh, 1L));
  out.pooled_after = std::sqrt(pa / std::max(nh, 1L));
  out.train_pooled_before = std::sqrt(tb / std::max(nt, 1L));
  out.train_pooled_after = std::sqrt(ta / std::max(nt, 1L));
}

void describeFindings(const Model& model, const DiagnoseOptions& opt, DiagnosisResult& out) {
  // Payload candidates without a held declared model: the identified link parameters absorb any payload exactly (its 4
  // columns are columns of K, inside the declared base parameters' span), so they are not tested.
  for (int b = 0; opt.payload && !opt.hold_declared && b < model.nbodies; ++b) {
    PayloadFinding pf;
    pf.link = b;
    pf.status = "not separable: absorbed by the identified link parameters (hold them: --declared-model)";
    out.payload_first_step.push_back(pf);
  }
  for (PayloadFinding& pf : out.payloads) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s carries a payload of %.3g kg (+- %.2g) at CoM (%.4f, %.4f, %.4f) m (+- %.2g, %.2g, %.2g) in the link "
                  "frame, explains %.0f %% of the residual of the rows it moves (held-out folds; p = %.2g, %d tested)%s",
                  model.body_names[pf.link].c_str(), pf.mass, pf.mass_se, pf.com[0], pf.com[1], pf.com[2], pf.com_se[0],
                  pf.com_se[1], pf.com_se[2], 100.0 * pf.explained, pf.p_value, pf.tested,
                  pf.status == "accepted" ? "" : "; its CoM is not determined by these data (the final refit leaves the bound)");
    pf.sentence = buf;
  }
  for (Finding& f : out.findings) {
    char buf[640];
    char width[256] = "";
    if (f.effect.width > 0.0 && isDryFriction(f.effect.kind))
      std::snprintf(width, sizeof width, ", tanh width %g rad/s", f.effect.width);
    if (f.effect.kind == EffectKind::ElasticCoupled) {
      std::snprintf(width, sizeof width, " per rad of %s (about its mean angle %.3f rad)",
                    model.joint_names[f.effect.coupled].c_str(), f.effect.center);
    } else if (f.effect.kind == EffectKind::ElasticExpCoupled) {
      std::snprintf(width, sizeof width,
                    " at the mean angles, stiffening toward %s q with scale %g rad, the exponent moved by %+.3g rad per rad of "
                    "%s (about its mean angle %.3f rad; its own %.3f rad)",
                    f.effect.width > 0 ? "+" : "-", std::fabs(f.effect.width), f.effect.ratio,
                    model.joint_names[f.effect.coupled].c_str(), f.effect.coupled_center, f.effect.center);
    } else if (isElastic(f.effect.kind)) {
      // k (q - q0) = k (q - c) + k (c - q0): the rest angle comes from an offset found on the same joint, if any, and
      // the joint's stiffness at c, k the sum of its own springs' values (the linear and the exponential ones all have
      // slope 1 in q_j at c).
      const Finding* offset = nullptr;
      double k = 0.0;
      for (const Finding& g : out.findings) {
        if (g.effect.joint != f.effect.joint) continue;
        if (g.effect.kind == EffectKind::Offset) offset = &g;
        if (g.effect.kind == EffectKind::Elastic || g.effect.kind == EffectKind::ElasticExp ||
            g.effect.kind == EffectKind::ElasticExpCoupled)
          k += g.effect.value;
      }
      char scale[64] = "";
      if (f.effect.kind == EffectKind::ElasticExp)
        std::snprintf(scale, sizeof scale, ", stiffening toward %s q with scale %g rad", f.effect.width > 0 ? "+" : "-",
                      std::fabs(f.effect.width));
      if (offset && k > 0)
        std::snprintf(width, sizeof width, " at the mean angle %.3f rad%s (rest angle %.3f rad: the offset found over the "
                      "joint's stiffness %.3g N m/rad)", f.effect.center, scale, f.effect.center - offset->effect.value / k, k);
      else
        std::snprintf(width, sizeof width, " at the mean angle %.3f rad%s (rest angle: not separable from an offset here)",
                      f.effect.center, scale);
    }
    std::snprintf(buf, sizeof buf, "%s: %s %s%s, explains %.0f %% of its residual (held-out folds; p = %.2g, %d tested)",
                  model.joint_names[f.effect.joint].c_str(), effectKindWords(f.effect.kind),
                  formatValue(f.effect.kind, f.effect.value, f.std_error).c_str(), width, 100.0 * f.explained,
                  f.p_value, f.tested);
    f.sentence = buf;
    if (f.ambiguous) {
      const Effect& a = f.alternative;
      char of[128] = "";
      if (isCoupled(a.kind)) std::snprintf(of, sizeof of, " on %s's angle", model.joint_names[a.coupled].c_str());
      if (a.joint != f.effect.joint)  // a coupling given the other joints' candidates (selection.cpp)
        std::snprintf(buf, sizeof buf, "; or %s %s on %s%s (its strongest candidate), which the identified link "
                      "parameters carry into this joint's row: with the other joints' candidates in the model this "
                      "one's held-out gain is not significant (p = %.2g; that candidate's own held-out gain %.0f %% "
                      "of this one's)",
                      effectKindWords(a.kind),
                      formatValue(a.kind, a.value, f.alternative_std_error).c_str(), model.joint_names[a.joint].c_str(),
                      of, f.separation_p, 100.0 * f.alternative_gain);
      else
        std::snprintf(buf, sizeof buf, "; or %s %s%s: the data do not tell the two apart (its held-out gain %.0f %% of "
                      "this one's, p = %.2g that this one predicts better)", effectKindWords(a.kind),
                      formatValue(a.kind, a.value, f.alternative_std_error).c_str(), of, 100.0 * f.alternative_gain,
                      f.separation_p);
      f.sentence += buf;
    }
  }
}

}  // namespace exoid::estimator
