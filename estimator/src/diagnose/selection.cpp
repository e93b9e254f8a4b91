// Forward selection of the diagnosis, its final fit and the Gauss-Newton reference (diagnose_stages.hpp,
// docs/diagnose.md).
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "exoid/estimator/diagnose_stages.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

namespace {
double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd x = a.array() - a.mean(), y = b.array() - b.mean();
  const double den = std::sqrt(x.squaredNorm() * y.squaredNorm());
  return den > 0 ? x.dot(y) / den : 0.0;
}

// The step's choice. The test decides whether a coordinate has an effect at all (some admissible candidate there
// significant at the Bonferroni level: the false-alarm rate); the held-out gain decides which kind it is, among that
// coordinate's admissible candidates significant on their own at alpha. (Requiring the kind itself to pass the test
// let a noisier fold pattern lose to a worse kind: viscous 10 N m s/rad on a hip, gain 1076 at p = 1.7e-4, was named
// Coulomb, gain 861 at p = 6e-5, with the level at 1.5e-4.) A refinement (Stribeck's column of Coulomb friction, the
// exponential spring of the linear one) is named only when it predicts the held-out data clearly better
// (refinement_margin) than the kind it refines on the same joint.
// A payload is its own test (Bonferroni level, usable like the others) and competes with the best effect by held-out
// gain. best: candidate index (-1: none), pbest: index into pevals (-1: none; when >= 0, best is -1).
struct StepChoice {
  int best = -1, pbest = -1;
  /// A coupling's source: the strongest usable candidate on the joint whose angle it reads, else the strongest there
  /// (-1: none, or not a coupling); and the choice. Indices into the step's evals.
  int source = -1;
  int best_eval = -1;
  double best_gain = 0.0;
  Finding best_finding;
  std::vector<char> coord_has_effect;
};
StepChoice chooseStep(const DiagnoseOptions& opt, const DiagnoseData& data, const std::vector<CandidateEval>& evals,
                      const std::vector<PayloadEval>& pevals, double level) {
  StepChoice ch;
  const auto usable = [&](const CandidateEval& ev) { return ev.admissible && ev.gain > 0 && ev.f.explained >= opt.min_explained; };
  ch.coord_has_effect.assign(static_cast<size_t>(data.nv), 0);
  for (const CandidateEval& ev : evals)
    if (usable(ev) && ev.f.p_value < level) ch.coord_has_effect[static_cast<size_t>(data.cands[ev.c].coord)] = 1;
  // A kind competes on an established coordinate when it is significant on its own at alpha (uncorrected: the
  // multiplicity is already paid by the coordinate's test).
  const auto competes = [&](const CandidateEval& ev) {
    return usable(ev) && ev.f.p_value < opt.alpha && ch.coord_has_effect[static_cast<size_t>(data.cands[ev.c].coord)];
  };
  for (const CandidateEval& ev : evals)
    if (competes(ev) && ev.gain > ch.best_gain) ch.best_gain = ev.gain, ch.best = ev.c, ch.best_finding = ev.f;
  // Down the chain of refinements (the two-angle exponential, the one-angle one, the linear spring), each step taken
  // when the kind refined comes within the margin of the one chosen so far.
  for (double chosen_gain = ch.best_gain; ch.best >= 0 && refinedKind(data.cands[ch.best].kind) != data.cands[ch.best].kind;) {
    const DiagnosisCandidate refinement = data.cands[ch.best];
    int coarser = -1;
    for (const CandidateEval& ev : evals)
      if (competes(ev) && data.cands[ev.c].kind == refinedKind(refinement.kind) && data.cands[ev.c].joint == refinement.joint &&
          ev.gain * (1.0 + opt.refinement_margin) >= chosen_gain && (coarser < 0 || ev.gain > evals[coarser].gain))
        coarser = static_cast<int>(&ev - evals.data());
    if (coarser < 0) break;
    ch.best = evals[coarser].c, ch.best_finding = evals[coarser].f, chosen_gain = evals[coarser].gain;
  }
  // Another family's strongest competitor on the chosen coordinate: named beside the choice when the folds do not
  // show the choice predicting better (the paired test of the fold gains' difference at alpha).
  if (ch.best >= 0) {
    const DiagnosisCandidate& chosen = data.cands[ch.best];
    const CandidateEval* best_eval = nullptr;
    const CandidateEval* rival = nullptr;
    for (const CandidateEval& ev : evals) {
      if (ev.c == ch.best) best_eval = &ev;
      const DiagnosisCandidate& cd = data.cands[ev.c];
      if (competes(ev) && cd.coord == chosen.coord && effectFamily(cd.kind) != effectFamily(chosen.kind) &&
          (!rival || ev.gain > rival->gain))
        rival = &ev;
      // A coupling's (joint j's moment on joint k's angle) source, the one selectStep names beside it where the
      // other joints' candidates take its significance: k's strongest usable candidate (an admissible value that
      // predicts), else k's strongest, whatever its test.
      if (!opt.hold_declared && isCoupled(chosen.kind) && cd.joint == chosen.coupled) {
        const CandidateEval* s = ch.source >= 0 ? &evals[static_cast<size_t>(ch.source)] : nullptr;
        if (!s || (usable(ev) && !usable(*s)) || (usable(ev) == usable(*s) && ev.gain > s->gain))
          ch.source = static_cast<int>(&ev - evals.data());
      }
    }
    if (best_eval && rival && best_eval->fold_gains.size() == opt.folds && rival->fold_gains.size() == opt.folds &&
        opt.folds > 1) {
      double mean = 0.0, t = 0.0, p = 1.0;
      pairedTest(best_eval->fold_gains - rival->fold_gains, opt.folds, mean, t, p);
      Finding& f = ch.best_finding;
      f.separation_p = p;
      f.alternative = rival->f.effect;
      f.alternative_std_error = rival->f.std_error;
      f.alternative_gain = best_eval->gain > 0 ? rival->gain / best_eval->gain : 0.0;
      f.ambiguous = p >= opt.alpha;
    }
    if (best_eval) ch.best_eval = static_cast<int>(best_eval - evals.data());
    if (!best_eval) ch.source = -1;
  }
  const auto pusable = [&](const PayloadEval& pe) { return pe.admissible && pe.gain > 0 && pe.f.explained >= opt.min_explained; };
  for (size_t k = 0; k < pevals.size(); ++k)
    if (pusable(pevals[k]) && pevals[k].f.p_value < level &&
        pevals[k].gain > std::max(ch.best >= 0 ? ch.best_gain : 0.0, ch.pbest >= 0 ? pevals[static_cast<size_t>(ch.pbest)].gain : 0.0))
      ch.pbest = static_cast<int>(k);
  if (ch.pbest >= 0) ch.best = -1;
  return ch;
}

// The first step's scores of every tested candidate and payload (out.first_step, out.payload_first_step).
void recordFirstStep(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data,
                     const std::vector<CandidateEval>& evals, const std::vector<PayloadEval>& pevals,
                     const StepChoice& ch, double level, DiagnosisResult& out) {
  for (size_t k = 0; k < pevals.size(); ++k) {
    PayloadFinding pf = pevals[k].f;
    pf.status = static_cast<int>(k) == ch.pbest      ? "accepted"
                : !pevals[k].admissible             ? "inadmissible (mass <= 3 standard errors or CoM beyond the bound)"
                : pf.explained < opt.min_explained  ? "below min-explained"
                : pf.p_value >= level               ? "not significant"
                                                    : "significant (a larger one was taken first)";
    out.payload_first_step.push_back(pf);
  }
  for (const CandidateEval& ev : evals) {
    const DiagnosisCandidate& cd = data.cands[ev.c];
    CandidateScore sc;
    sc.effect = ev.f.effect;
    sc.explained = ev.f.explained;
    sc.p_value = ev.f.p_value;
    sc.separable = ev.separable;
    sc.std_error = ev.jackknife_se;
    Eigen::VectorXd res(out.train_samples), sig(out.train_samples);
    long at = 0;
    for (size_t s = 0; s < data.ntrain; ++s)
      for (long i = 0; i < data.caches[s].n; ++i, ++at) {
        res[at] = data.caches[s].y(i, cd.coord) - data.caches[s].tau0(i, cd.coord);
        sig[at] = candidateSignal(model, opt, data, s, i, cd);
      }
    sc.correlation = correlation(res, sig);
    sc.status = ev.c == ch.best                                             ? "accepted"
                : !ev.admissible                                            ? "inadmissible value"
                : ev.f.explained < opt.min_explained                        ? "below min-explained"
                : !ch.coord_has_effect[static_cast<size_t>(cd.coord)]       ? "not significant"
                : ev.f.p_value >= opt.alpha                                 ? "not significant"
                : ev.f.p_value >= level                                     ? "significant at alpha only (a larger one was taken)"
                                                                            : "significant (a larger one was taken first)";
    out.first_step.push_back(sc);
  }
}
}  // namespace

StepOutcome selectStep(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data,
                       const std::vector<CandidateEval>& evals, const std::vector<PayloadEval>& pevals, int step,
                       DiagnosisResult& out) {
  const int tested = static_cast<int>(evals.size() + pevals.size());
  const double level = opt.alpha / std::max(tested, 1);  // Bonferroni over the step's candidates
  const StepChoice ch = chooseStep(opt, data, evals, pevals, level);
  if (step == 0) recordFirstStep(model, opt, data, evals, pevals, ch, level, out);
  if (ch.pbest >= 0) {
    const PayloadEval& pe = pevals[static_cast<size_t>(ch.pbest)];
    data.pdone[static_cast<size_t>(pe.l)] = 1;
    for (int k = 0; k < 4; ++k) data.S.push_back(data.pc0 + 4 * pe.l + k);
    data.pcol.push_back(data.pc0 + 4 * pe.l);
    out.payloads.push_back(pe.f);
    out.payloads.back().tested = tested;
    out.payloads.back().status = "accepted";
    // The gain and delay signals: about the model with the payload (relinearise), then select on.
    return data.measurement_cands ? StepOutcome::PayloadRelinearise : StepOutcome::Payload;
  }
  if (ch.best < 0) return StepOutcome::Stop;
  Finding f = ch.best_finding;
  // A coupling (joint j's moment on joint k's angle) tested again with every single-joint candidate on every other
  // joint in the model: whatever the library can say about the other rows. The declared model's link parameters are
  // fitted to every joint's rows, so what an effect elsewhere leaves in its rows moves them, and through them j's
  // prediction, as a function of the angles: the coupling's own signal. Where the coupling's held-out gain is no
  // longer significant at alpha with those candidates in, the data do not say which is there; the report names the
  // coupling and k's strongest candidate (the likeliest source: the coupling reads k's angle).
  // Seen on wearers' calibration swings: the person's hip flexion spring, which no one candidate spans over 0-1.3 rad,
  // put a 0.7-1.4 N m/rad "coupling" on the hip ab/adduction (p ~1e-5), where the person has no moment, and held at
  // the true rigid model the diagnosis names nothing there. With only k's candidates in, 3 of 5 such couplings lost
  // their significance; one that kept p 6e-4 (a hip whose flexion also takes reflex bursts) did so with k's rows
  // left out of the fit altogether, so it reaches j's row through the other joints' rows too. With every other
  // joint's candidates in it has p 0.064. A coupling that is the person's own (an ankle's moment on the knee's
  // angle, a knee's on the ankle's or the hip's) keeps p <= 2.8e-4 on every shipped wearer, KUKA's two <= 1.2e-5
  // (docs/diagnose.md "Selection" step 4).
  if (ch.source >= 0) {
    // Every other joint's single-joint candidates, strongest first, each taken when it is not (nearly) a combination
    // of the model's columns and the ones taken before it: at least 1 % of its norm^2 outside their span on all the
    // training rows (near-collinear columns would make the refits' triangular solves ill-conditioned; what they would
    // add is in the span already).
    const int F = opt.folds, j = data.cands[ch.best].joint;
    std::vector<int> order;
    for (size_t e = 0; e < evals.size(); ++e) {
      const DiagnosisCandidate& cd = data.cands[evals[e].c];
      if (cd.joint != j && cd.coupled < 0) order.push_back(static_cast<int>(e));
    }
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return evals[a].gain > evals[b].gain; });
    std::vector<int> given;
    for (int k : order) {
      const int col = data.m + evals[static_cast<size_t>(k)].c;
      Eigen::MatrixXd A(data.Rtrain[F].rows(), static_cast<Eigen::Index>(data.S.size() + given.size()));
      Eigen::Index at = 0;
      for (int s : data.S) A.col(at++) = data.Rtrain[F].col(s);
      for (int s : given) A.col(at++) = data.Rtrain[F].col(s);
      const Eigen::VectorXd x = data.Rtrain[F].col(col);
      const Eigen::VectorXd r = x - A * A.colPivHouseholderQr().solve(x);
      if (r.squaredNorm() > 0.01 * x.squaredNorm()) given.push_back(col);
    }
    const CandidateEval& source = evals[static_cast<size_t>(ch.source)];
    Eigen::VectorXd d;
    const double p = given.empty() ? 0.0 : conditionalCandidateTest(opt, data, ch.best, given, d);
    if (std::getenv("EXOID_DIAGNOSE_DEBUG") && !given.empty())
      std::fprintf(stderr,
                   "step %d coupling j%d on j%d given %zu of %zu single-joint candidates on the other joints "
                   "(named %s on j%d): gain %.4g p %.3g\n",
                   step, j, data.cands[ch.best].coupled, given.size(), order.size(),
                   effectKindName(source.f.effect.kind), source.f.effect.joint, d.mean(), p);
    if (!given.empty() && p >= opt.alpha) {
      const CandidateEval& chosen = evals[static_cast<size_t>(ch.best_eval)];
      f.ambiguous = true;
      f.alternative = source.f.effect;
      f.alternative_std_error = source.f.std_error;
      f.alternative_gain = chosen.gain > 0 ? source.gain / chosen.gain : 0.0;
      f.separation_p = p;
    }
  }
  f.tested = tested;
  data.S.push_back(data.m + ch.best);
  data.fcol.push_back(data.m + ch.best);
  out.findings.push_back(f);
  return StepOutcome::Effect;
}

bool selectEffects(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out) {
  data.excluded.assign(static_cast<size_t>(data.nc), 0);
  for (int step = data.steps_done; data.selecting && step < opt.max_effects; ++step) {
    data.steps_done = step + 1;
    CurrentFits fits;
    currentFits(opt, data, fits);
    const std::vector<CandidateEval> evals = screenCandidates(model, opt, data, fits, step, out);
    const std::vector<PayloadEval> pevals = screenPayloads(model, opt, data, fits, step, out);
    const StepOutcome o = selectStep(model, opt, data, evals, pevals, step, out);
    if (o == StepOutcome::PayloadRelinearise) return true;
    if (o == StepOutcome::Stop) break;
  }
  return false;
}

int columnPosition(const std::vector<int>& S, int col) {
  return static_cast<int>(std::find(S.begin(), S.end(), col) - S.begin());
}

void finalFit(const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out) {
  const int F = opt.folds, nv = data.nv, P = data.P, iy = data.iy;
  std::vector<std::pair<int, int>> w;
  for (int f = 0; f < F; ++f)
    for (int r = 0; r < nv; ++r) w.push_back({f, r});
  const Eigen::MatrixXd Ru = mergeFoldFactors(data, w, true);
  const int ns = static_cast<int>(data.S.size());
  Eigen::MatrixXd Au(P, ns), Aw(P, ns);
  for (int k = 0; k < ns; ++k) Au.col(k) = Ru.col(data.S[k]), Aw.col(k) = data.Rtrain[F].col(data.S[k]);
  data.xa = Au.householderQr().solve(Ru.col(iy));
  if (ns == 0) return;  // (a held declared model and nothing found)
  const Eigen::VectorXd& xa = data.xa;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(Aw);
  const Eigen::MatrixXd Rw = qr.matrixQR().topRows(ns).triangularView<Eigen::Upper>();
  const Eigen::VectorXd xw = Rw.triangularView<Eigen::Upper>().solve(
      (qr.householderQ() * Eigen::MatrixXd::Identity(P, ns)).transpose() * data.Rtrain[F].col(iy));
  const double s2 = (data.Rtrain[F].col(iy) - Aw * xw).squaredNorm() / std::max<double>(data.total_rows - ns, 1);
  const Eigen::MatrixXd Rinv = Rw.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(ns, ns));
  for (size_t i = 0; i < out.payloads.size(); ++i) {  // final values; the jackknife errors stay the selection's
    const int c = data.pcol[i], k = columnPosition(data.S, c);
    out.payloads[i].mass = xa[k];
    out.payloads[i].com =
        Eigen::Vector3d(xa[columnPosition(data.S, c + 1)], xa[columnPosition(data.S, c + 2)], xa[columnPosition(data.S, c + 3)]) / xa[k];
    // Admissibility is decided at selection; a final refit that leaves it says the data do not pin the CoM (a load on
    // a foot flat on its plate: its height moves no torque).
    const bool ok = xa[k] > 0.0 && out.payloads[i].com.norm() <= opt.payload_com_bound;
    out.payloads[i].status = ok ? "accepted" : "accepted; the final refit puts its CoM beyond the bound: not determined";
  }
  for (size_t i = 0; i < out.findings.size(); ++i) {
    const int k = columnPosition(data.S, data.fcol[i]);
    out.findings[i].effect.value = xa[k];
    out.findings[i].std_error = std::sqrt(s2 * Rinv.row(k).squaredNorm());
  }
}

bool relinearise(const Model& model, DiagnoseData& data, std::string* error) {
  const int nv = data.nv, m = data.m;
  const Eigen::VectorXd xr = data.xa.head(m);
  std::vector<int> ppos, pparam;  // positions in xa of the payloads' columns, their columns of K
  for (size_t i = 0; i < data.pcol.size(); ++i)
    for (int k = 0; k < 4; ++k) {
      ppos.push_back(columnPosition(data.S, data.pcol[i] + k));
      pparam.push_back(payloadParameter(model, data, data.pcol[i] + k));
    }
  for (size_t s = 0; s < data.caches.size(); ++s) {
    SegmentSignals& cache = data.caches[s];
    long i = 0;
    const bool ok = data.segment(s).stream(
        [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd&, const Eigen::VectorXd&) {
          if (i >= cache.n) return;
          for (int r = 0; r < nv; ++r) {
            double pr = 0.0;
            for (int c = 0; c < m; ++c) pr += K(r, data.decl[c]) * xr[c];
            for (size_t e = 0; e < ppos.size(); ++e) pr += K(r, pparam[e]) * data.xa[ppos[e]];
            cache.tau(i, r) = pr;
          }
          ++i;
        },
        error);
    if (!ok) return false;
    if (i != cache.n) return common::fail(error, data.segment(s).name + ": the data changed between two reads");
    cache.dtau = centralDifference(cache.t, cache.tau);
  }
  return true;
}

}  // namespace exoid::estimator
