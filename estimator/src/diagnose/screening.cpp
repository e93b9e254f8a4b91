// Screening of the diagnosis's candidates against the current model (diagnose_stages.hpp, docs/diagnose.md).
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "exoid/estimator/diagnose_stages.hpp"

namespace exoid::estimator {

namespace {
// Held-out weighted SSE of coordinate r in fold f at xP [P] (xP[iy] = -1): ||R_{f,r} xP(active_r)||^2.
double heldOutSse(const DiagnoseData& data, int f, int r, const Eigen::VectorXd& xP) {
  const std::vector<int>& act = data.active[r];
  Eigen::VectorXd xa(act.size());
  for (size_t k = 0; k < act.size(); ++k) xa[k] = xP[act[k]];
  return (data.fc[f * data.nv + r].R() * xa).squaredNorm();
}

// R^-1 B for an upper-triangular R that may be empty (no column in the model yet).
Eigen::MatrixXd upperSolve(const Eigen::MatrixXd& R, const Eigen::MatrixXd& B) {
  if (R.rows() == 0) return Eigen::MatrixXd::Zero(0, B.cols());
  return R.triangularView<Eigen::Upper>().solve(B);
}

// Candidate c with its training estimate beta, refitted without each fold f (value bfold[f]) and scored on it: the
// pooled held-out reduction d[f] and, on the candidate's own coordinate, num / den (the explained fraction).
void heldOutCandidate(const DiagnoseData& data, const CurrentFits& fits, int F, int c, Eigen::VectorXd& d,
                      Eigen::VectorXd& bfold, double& explained) {
  const int m = data.m, ns = fits.ns, coord = data.cands[c].coord;
  double num = 0.0, den = 0.0;
  for (int f = 0; f < F; ++f) {
    const Eigen::VectorXd colf = data.Rtrain[f].col(m + c);
    const Eigen::VectorXd wf = fits.Rs[f].triangularView<Eigen::Upper>().solve(fits.Q[f].transpose() * colf);
    const Eigen::VectorXd rcf = colf - fits.A[f] * wf;
    const double nf = rcf.squaredNorm();
    const double bf = nf > 0 ? rcf.dot(fits.ry[f]) / nf : 0.0;
    bfold[f] = bf;
    Eigen::VectorXd xP = Eigen::VectorXd::Zero(data.P);
    for (int k = 0; k < ns; ++k) xP[data.S[k]] = fits.xs[f][k] - bf * wf[k];
    xP[m + c] = bf;
    xP[data.iy] = -1.0;
    d[f] = 0.0;
    for (int r = 0; r < data.nv; ++r) {
      const double sn = heldOutSse(data, f, r, xP);
      d[f] += fits.sse_now(f, r) - sn;
      if (r == coord) num += fits.sse_now(f, r) - sn, den += fits.sse_now(f, r);
    }
  }
  explained = den > 0 ? num / den : 0.0;
}
}  // namespace

// One-sided tests over the F folds that the held-out reductions d [F] lie above 0: the paired t-test, t = mean / (sd /
// sqrt F), sd with F - 1, and Wilcoxon's signed-rank test, p = 2 min(p_t, p_W) (Bonferroni over the two). The t-test
// alone loses an effect whose gain comes unevenly: an exponential spring's residual lies in the few chunks where the
// joint is far out, and a two-angle one that explained all of its joint's held-out residual, with every fold's gain
// positive (13 to 2720), had p_t = 0.008 (the fold-gain spread taken as noise); p_W = 1e-6. The signed-rank test uses
// signs and ranks only, so one fold's large gain does not decide it either way.
void pairedTest(const Eigen::VectorXd& d, int F, double& mean, double& t_stat, double& p_value) {
  mean = d.mean();
  const double sd = std::sqrt((d.array() - mean).square().sum() / (F - 1));
  t_stat = sd > 0 ? mean / (sd / std::sqrt(static_cast<double>(F))) : (mean > 0 ? INFINITY : 0.0);
  p_value = std::min(1.0, 2.0 * std::min(studentTUpperTail(t_stat, F - 1), signedRankUpperTail(d)));
}

void currentFits(const DiagnoseOptions& opt, const DiagnoseData& data, CurrentFits& fits) {
  const int F = opt.folds, P = data.P, ns = fits.ns = static_cast<int>(data.S.size());
  fits.Q.assign(F + 1, {}), fits.Rs.assign(F + 1, {}), fits.A.assign(F + 1, {});
  fits.xs.assign(F + 1, {}), fits.ry.assign(F + 1, {});
  for (int f = 0; f <= F; ++f) {
    fits.A[f].resize(P, ns);
    for (int k = 0; k < ns; ++k) fits.A[f].col(k) = data.Rtrain[f].col(data.S[k]);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(fits.A[f]);
    fits.Q[f] = qr.householderQ() * Eigen::MatrixXd::Identity(P, ns);
    fits.Rs[f] = qr.matrixQR().topRows(ns).triangularView<Eigen::Upper>();
    const Eigen::VectorXd b = data.Rtrain[f].col(data.iy);
    fits.xs[f] = fits.Rs[f].triangularView<Eigen::Upper>().solve(fits.Q[f].transpose() * b);
    fits.ry[f] = b - fits.A[f] * fits.xs[f];
  }
  fits.sse_now.resize(F, data.nv);
  for (int f = 0; f < F; ++f) {
    Eigen::VectorXd xP = Eigen::VectorXd::Zero(P);
    for (int k = 0; k < ns; ++k) xP[data.S[k]] = fits.xs[f][k];
    xP[data.iy] = -1.0;
    for (int r = 0; r < data.nv; ++r) fits.sse_now(f, r) = heldOutSse(data, f, r, xP);
  }
  fits.dof_res = static_cast<double>(data.total_rows - ns - 1);
}

std::vector<CandidateEval> screenCandidates(const Model&, const DiagnoseOptions& opt, DiagnoseData& data,
                                            const CurrentFits& fits, int step, DiagnosisResult& out) {
  const int F = opt.folds, m = data.m;
  std::vector<CandidateEval> evals;
  for (int c = 0; c < data.nc; ++c) {
    if (data.excluded[c] || std::find(data.S.begin(), data.S.end(), m + c) != data.S.end()) continue;
    const DiagnosisCandidate& cd = data.cands[c];
    // Training-all estimate and separability.
    const Eigen::VectorXd col = data.Rtrain[F].col(m + c);
    const Eigen::VectorXd w = fits.Rs[F].triangularView<Eigen::Upper>().solve(fits.Q[F].transpose() * col);
    const Eigen::VectorXd rc = col - fits.A[F] * w;
    const double nrc = rc.squaredNorm();
    if (col.squaredNorm() == 0.0 || !(nrc > 1e-6 * col.squaredNorm())) {
      data.excluded[c] = 1;
      if (step == 0) {
        CandidateScore sc;
        sc.effect = candidateEffect(cd, 0.0);
        sc.separable = col.squaredNorm() > 0.0 ? nrc / col.squaredNorm() : 0.0;
        sc.std_error = INFINITY;
        sc.status = "not separable from the declared model";
        out.first_step.push_back(sc);
      }
      continue;
    }
    const double beta = rc.dot(fits.ry[F]) / nrc;
    const double sse_all = fits.ry[F].squaredNorm() - beta * beta * nrc;
    Eigen::VectorXd d(F), bfold(F);
    CandidateEval ev;
    heldOutCandidate(data, fits, F, c, d, bfold, ev.f.explained);
    ev.c = c;
    pairedTest(d, F, ev.gain, ev.f.t_stat, ev.f.p_value);
    ev.fold_gains = d;
    ev.admissible = admissibleValue(cd.kind, beta);
    ev.separable = nrc / col.squaredNorm();
    // Delete-one-fold jackknife of the value: the time-block folds keep the residual's correlation (filtered data: the
    // white-noise error below is ~10x optimistic at 5 Hz) out of it.
    ev.jackknife_se = std::sqrt((F - 1.0) / F * (bfold.array() - bfold.mean()).square().sum());
    ev.f.effect = candidateEffect(cd, beta);
    ev.f.std_error = std::sqrt(std::max(sse_all, 0.0) / std::max(fits.dof_res, 1.0) / nrc);
    if (std::getenv("EXOID_DIAGNOSE_DEBUG"))
      std::fprintf(stderr, "step %d %s j%d beta %.4g gain %.4g t %.4g p %.3g expl %.3f\n", step, effectKindName(cd.kind),
                   cd.joint, beta, ev.gain, ev.f.t_stat, ev.f.p_value, ev.f.explained);
    evals.push_back(ev);
  }
  return evals;
}

double conditionalCandidateTest(const DiagnoseOptions& opt, DiagnoseData& data, int c, const std::vector<int>& given,
                                Eigen::VectorXd& d) {
  const int F = opt.folds;
  const size_t ns = data.S.size();
  data.S.insert(data.S.end(), given.begin(), given.end());
  CurrentFits fits;
  currentFits(opt, data, fits);
  Eigen::VectorXd bfold(F);
  double explained = 0.0, mean = 0.0, t = 0.0, p = 1.0;
  d.resize(F);
  heldOutCandidate(data, fits, F, c, d, bfold, explained);
  data.S.resize(ns);
  pairedTest(d, F, mean, t, p);
  return p;
}

namespace {
// Payload l refitted without each fold f (values bfold.col(f): m, m c) and scored on it (as heldOutCandidate, the
// explained fraction over the rows that see the link).
void heldOutPayload(const DiagnoseData& data, const CurrentFits& fits, int F, int l, Eigen::VectorXd& d,
                    Eigen::MatrixXd& bfold, double& explained) {
  const int c0 = data.pc0 + 4 * l, ns = fits.ns;
  double num = 0.0, den = 0.0;
  for (int f = 0; f < F; ++f) {
    const Eigen::MatrixXd Cf = data.Rtrain[f].middleCols(c0, 4);
    const Eigen::MatrixXd Wf = upperSolve(fits.Rs[f], fits.Q[f].transpose() * Cf);
    const Eigen::MatrixXd Rcf = Cf - fits.A[f] * Wf;
    const Eigen::Vector4d bf = (Rcf.transpose() * Rcf).ldlt().solve(Rcf.transpose() * fits.ry[f]);
    bfold.col(f) = bf;
    Eigen::VectorXd xP = Eigen::VectorXd::Zero(data.P);
    const Eigen::VectorXd xsf = fits.xs[f] - Wf * bf;
    for (int k = 0; k < ns; ++k) xP[data.S[k]] = xsf[k];
    xP.segment<4>(c0) = bf;
    xP[data.iy] = -1.0;
    d[f] = 0.0;
    for (int r = 0; r < data.nv; ++r) {
      const double sn = heldOutSse(data, f, r, xP);
      d[f] += fits.sse_now(f, r) - sn;
      if (data.ptouch[r][l]) num += fits.sse_now(f, r) - sn, den += fits.sse_now(f, r);
    }
  }
  explained = den > 0 ? num / den : 0.0;
}

// Separable share of payload l's 4 columns C: the smallest |Rc x|^2 / |C x|^2 over the directions x (C = U S V^T,
// x = V S^-1 z), Rc = C minus its projection on the current columns. False when the columns move no measured row.
bool payloadSeparable(const DiagnoseData& data, const CurrentFits& fits, int F, int l, Eigen::MatrixXd& Rc,
                      double& separable) {
  const Eigen::MatrixXd C = data.Rtrain[F].middleCols(data.pc0 + 4 * l, 4);
  const Eigen::Vector4d cn = C.colwise().norm().transpose();
  const Eigen::MatrixXd Wc = upperSolve(fits.Rs[F], fits.Q[F].transpose() * C);
  Rc = C - fits.A[F] * Wc;
  Eigen::JacobiSVD<Eigen::MatrixXd> svc(C, Eigen::ComputeThinV);
  const Eigen::VectorXd sc = svc.singularValues();
  const bool moves = cn.minCoeff() > 0.0 && sc[3] > 1e-7 * sc[0];
  if (moves) {
    const Eigen::MatrixXd M = Rc * svc.matrixV() * sc.cwiseInverse().asDiagonal();
    const double smin = Eigen::JacobiSVD<Eigen::MatrixXd>(M).singularValues()[3];
    separable = smin * smin;
  }
  return moves;
}
}  // namespace

std::vector<PayloadEval> screenPayloads(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data,
                                        const CurrentFits& fits, int step, DiagnosisResult& out) {
  const int F = opt.folds;
  std::vector<PayloadEval> pevals;
  for (int l = 0; l < data.npl; ++l) {
    if (data.pdone[static_cast<size_t>(l)]) continue;
    PayloadFinding pf;
    pf.link = data.plinks[l];
    Eigen::MatrixXd Rc;
    const bool moves = payloadSeparable(data, fits, F, l, Rc, pf.separable);
    if (!moves || !(pf.separable > opt.payload_min_separable)) {
      data.pdone[static_cast<size_t>(l)] = 1;
      if (step == 0) {
        pf.status = !moves ? "not identifiable (its mass or first moment moves no measured row)"
                           : "not separable from the declared model";
        out.payload_first_step.push_back(pf);
      }
      continue;
    }
    const Eigen::Vector4d beta = (Rc.transpose() * Rc).ldlt().solve(Rc.transpose() * fits.ry[F]);
    Eigen::VectorXd d(F);
    Eigen::MatrixXd bfold(4, F);
    heldOutPayload(data, fits, F, l, d, bfold, pf.explained);
    double mean = 0.0;
    pairedTest(d, F, mean, pf.t_stat, pf.p_value);
    pf.mass = beta[0];
    pf.com = beta.tail<3>() / beta[0];
    // Delete-one-fold jackknife of the mass and the CoM (as the single candidates' std_error).
    Eigen::MatrixXd jk(4, F);
    for (int f = 0; f < F; ++f) jk(0, f) = bfold(0, f), jk.col(f).tail<3>() = bfold.col(f).tail<3>() / bfold(0, f);
    const Eigen::VectorXd jmean = jk.rowwise().mean();
    const Eigen::VectorXd jse = ((F - 1.0) / F * (jk.colwise() - jmean).array().square().rowwise().sum()).sqrt();
    pf.mass_se = jse[0];
    pf.com_se = jse.tail<3>();
    if (std::getenv("EXOID_DIAGNOSE_DEBUG"))
      std::fprintf(stderr, "step %d payload %s m %.4g c %.3g %.3g %.3g gain %.4g p %.3g expl %.3f sep %.3g\n", step,
                   model.body_names[pf.link].c_str(), pf.mass, pf.com[0], pf.com[1], pf.com[2], mean, pf.p_value,
                   pf.explained, pf.separable);
    // Admissible: a positive mass determined by the data (above 3 jackknife standard errors: a body whose mass the rows
    // cannot pin is model error fitted by 4 free columns) with its CoM within the bound.
    pevals.push_back({l, mean, pf.mass > 3.0 * pf.mass_se && pf.com.norm() <= opt.payload_com_bound, pf});
  }
  return pevals;
}

}  // namespace exoid::estimator
