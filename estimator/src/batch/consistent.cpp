#include "exoid/estimator/batch/consistent.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace exoid::estimator {

QuadraticTarget consistentTarget(const Eigen::VectorXd& s, const Eigen::MatrixXd& V, const Eigen::VectorXd& d,
                                 const Eigen::VectorXd& h, const Eigen::VectorXd& offset,
                                 const Eigen::VectorXd& prior, int z, double nullspace_weight) {
  return consistentTarget(s, V, d, h, offset, prior, z, nullspace_weight, V, h);
}

QuadraticTarget consistentTarget(const Eigen::VectorXd& s, const Eigen::MatrixXd& V, const Eigen::VectorXd& d,
                                 const Eigen::VectorXd& h, const Eigen::VectorXd& offset,
                                 const Eigen::VectorXd& prior, int z, double nullspace_weight,
                                 const Eigen::MatrixXd& Q, const Eigen::VectorXd& fill) {
  const int p = static_cast<int>(V.rows());
  const int r = static_cast<int>(V.cols());
  z = std::clamp(z, 0, r);
  const Eigen::VectorXd hinv = h.cwiseInverse();
  const Eigen::MatrixXd Vz = V.leftCols(z);
  QuadraticTarget t;
  t.A.resize(z + p, p);
  t.b.resize(z + p);
  // Kept directions: S_z V_z^T H^-1 (phi - offset) = d_z.
  t.A.topRows(z) = s.head(z).asDiagonal() * Vz.transpose() * hinv.asDiagonal();
  t.b.head(z) = d.head(z) + t.A.topRows(z) * offset;
  // The rest, toward the prior in the fill's metric: (I - Q_z Q_z^T) D^-1 (phi - prior) = 0.
  const double w = std::sqrt(std::max(nullspace_weight, 0.0));
  const Eigen::MatrixXd Qz = Q.leftCols(z);
  const Eigen::MatrixXd Pn = Eigen::MatrixXd::Identity(p, p) - Qz * Qz.transpose();
  t.A.bottomRows(p) = w * Pn * fill.cwiseInverse().asDiagonal();
  t.b.tail(p) = t.A.bottomRows(p) * prior;
  return t;
}

namespace {

/// The body's pseudo-inertia with its eigenvalues raised to relative_floor times the largest.
Vector10d projectBody(const Vector10d& pb, double relative_floor, double floor_abs) {
  Eigen::Matrix4d J = pseudoInertia(pb);
  if (!J.allFinite()) J.setZero();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(J);
  Eigen::Vector4d l = es.eigenvalues();
  const double lmax = l.maxCoeff();
  if (!(lmax > 0.0)) return paramsFromPseudoInertia(floor_abs * Eigen::Matrix4d::Identity());
  for (int k = 0; k < 4; ++k) l[k] = std::max(l[k], relative_floor * lmax);
  return paramsFromPseudoInertia(es.eigenvectors() * l.asDiagonal() * es.eigenvectors().transpose());
}

}  // namespace

Eigen::VectorXd projectConsistent(const Model& model, const Eigen::VectorXd& phi, double relative_floor,
                                  double floor_abs) {
  Eigen::VectorXd out = phi;
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    const Vector10d pb = phi.segment<kParamsPerBody>(i);
    if (!checkConsistency(pb).consistent) out.segment<kParamsPerBody>(i) = projectBody(pb, relative_floor, floor_abs);
  }
  return out;
}

Eigen::VectorXd consistentCoordinates(const Model& model, const Eigen::VectorXd& phi, double relative_floor) {
  Eigen::VectorXd x = phi;
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    Vector10d theta;
    Vector10d pb = phi.segment<kParamsPerBody>(i);
    // Inconsistent (or, after round-off, on the boundary): raise the floor until the body is inside.
    for (double floor = relative_floor; !logCholeskyFromParams(pb, theta); floor *= 10.0)
      pb = projectBody(pb, std::min(floor, 1.0), 1e-9);
    x.segment<kParamsPerBody>(i) = theta;
  }
  return x;
}

Eigen::VectorXd paramsFromConsistentCoordinates(const Model& model, const Eigen::VectorXd& x) {
  Eigen::VectorXd phi = x;
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    phi.segment<kParamsPerBody>(i) = paramsFromLogCholesky(x.segment<kParamsPerBody>(i));
  }
  return phi;
}

Eigen::MatrixXd consistentJacobian(const Model& model, const Eigen::VectorXd& x) {
  const int p = static_cast<int>(x.size());
  Eigen::MatrixXd D = Eigen::MatrixXd::Identity(p, p);
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    D.block<kParamsPerBody, kParamsPerBody>(i, i) = logCholeskyJacobian(x.segment<kParamsPerBody>(i));
  }
  return D;
}

namespace {

struct Evaluation {
  Eigen::VectorXd phi, r;
  double data = 0.0, total = 0.0;
};

Evaluation evaluate(const Model& model, const QuadraticTarget& t, const Eigen::VectorXd& x,
                    const Eigen::VectorXd& x_prior, double gamma) {
  Evaluation e;
  e.phi = paramsFromConsistentCoordinates(model, x);
  e.r = t.A * e.phi - t.b;
  e.data = e.r.squaredNorm();
  e.total = e.data + gamma * (x - x_prior).squaredNorm();
  if (!std::isfinite(e.total)) e.total = std::numeric_limits<double>::infinity();
  return e;
}

/// The start in log-Cholesky coordinates. Inconsistent bodies of the start begin at the prior's (projected)
/// body: a projection of an impossible body (negative mass) can be arbitrarily far from anything the data support.
Eigen::VectorXd startCoordinates(const Model& model, const Eigen::VectorXd& start, const Eigen::VectorXd& x_prior,
                                 double eigenvalue_floor) {
  Eigen::VectorXd x = consistentCoordinates(model, start, eigenvalue_floor);
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    if (!checkConsistency(Vector10d(start.segment<kParamsPerBody>(i))).consistent)
      x.segment<kParamsPerBody>(i) = x_prior.segment<kParamsPerBody>(i);
  }
  return x;
}

/// Newton model of F(x) = ||A phi(x) - b||^2 + gamma ||x - x_prior||^2 around x (halved): H [p x p], g [p].
/// Gauss-Newton with J_F = [A D; sqrt(gamma) I], D = dphi/dx per body, plus the curvature of x -> phi:
/// the residual at a constrained minimiser is not small (the fit wants an inconsistent body), and without
/// sum_k w_k d2 phi_k / dx2 (w = A^T r) the iteration crawls along the boundary. That term per body, by central
/// differences of the exact Jacobian.
void newtonModel(const Model& model, const QuadraticTarget& target, const Eigen::VectorXd& x,
                 const Eigen::VectorXd& x_prior, double gamma, const Evaluation& cur, Eigen::MatrixXd& AD,
                 Eigen::MatrixXd& H, Eigen::VectorXd& g) {
  AD = target.A;
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    AD.middleCols<kParamsPerBody>(i) = target.A.middleCols<kParamsPerBody>(i) *
                                       logCholeskyJacobian(x.segment<kParamsPerBody>(i));
  }
  // The Gauss-Newton matrix (AD)^T AD, symmetric: its lower triangle by a rank update (half a general product's work),
  // mirrored.
  H.setZero();
  H.selfadjointView<Eigen::Lower>().rankUpdate(AD.transpose());
  H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
  H.diagonal().array() += gamma;
  const Eigen::VectorXd w = target.A.transpose() * cur.r;  // dF/dphi / 2
  g.noalias() = AD.transpose() * cur.r;
  g += gamma * (x - x_prior);
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    const Vector10d wb = w.segment<kParamsPerBody>(i);
    Matrix10d S;
    const double hstep = 1e-6;
    for (int j = 0; j < kParamsPerBody; ++j) {
      Vector10d tp = x.segment<kParamsPerBody>(i), tm = tp;
      tp[j] += hstep;
      tm[j] -= hstep;
      S.col(j) = (logCholeskyJacobian(tp) - logCholeskyJacobian(tm)).transpose() * wb / (2.0 * hstep);
    }
    H.block<kParamsPerBody, kParamsPerBody>(i, i) += 0.5 * (S + S.transpose());
  }
}

/// The Levenberg-Marquardt iteration's state between steps.
struct LmState {
  Eigen::VectorXd x;  ///< log-Cholesky coordinates
  Evaluation cur;     ///< F and phi at x
  double lambda = 1e-3;
  int flat = 0;  ///< consecutive accepted steps that lowered F by less than tolerance (relative)
};

/// One Levenberg-Marquardt step on the Newton model (H, g): raises the damping until a step lowers F within
/// the trust region. False when no damping gives a descent (x stationary to working precision); `converged`
/// when the accepted step was flat (5 in a row), small or reached F = 0.
bool levenbergMarquardtStep(const Model& model, const QuadraticTarget& target, const Eigen::VectorXd& x_prior,
                            double gamma, const ConsistentOptions& opt, const Eigen::MatrixXd& H,
                            const Eigen::VectorXd& g, LmState& st, bool& converged) {
  const double dscale = std::max(H.diagonal().maxCoeff(), 1e-300);
  while (st.lambda < 1e16) {
    Eigen::MatrixXd Hd = H;
    // Levenberg's damping (lambda I): it shortens the flat directions most, which the trust region needs.
    Hd.diagonal().array() += st.lambda * dscale;
    const Eigen::LLT<Eigen::MatrixXd> llt(Hd);
    if (llt.info() != Eigen::Success) {  // the Newton model is not convex here: damp more
      st.lambda *= 4.0;
      continue;
    }
    const Eigen::VectorXd step = llt.solve(-g);
    // Trust region in log-Cholesky coordinates: at most a factor e per step. A long Gauss-Newton step
    // can otherwise jump to a far log-coordinate where the map is flat (e^d ~ 0) and stall there.
    const double big = step.cwiseAbs().maxCoeff();
    if (!(big <= opt.max_step)) {
      st.lambda *= 4.0;
      continue;
    }
    const Eigen::VectorXd x_new = st.x + step;
    Evaluation next = evaluate(model, target, x_new, x_prior, gamma);
    if (next.total < st.cur.total) {
      const double decrease = st.cur.total - next.total;
      const bool small_step = step.norm() <= opt.tolerance * (st.x.norm() + opt.tolerance);
      st.flat = decrease <= opt.tolerance * st.cur.total ? st.flat + 1 : 0;
      st.x = x_new;
      st.cur = std::move(next);
      st.lambda = std::max(st.lambda / 3.0, 1e-15);
      // One flat step can be a heavily damped one on a plateau of the exponential map: ask for several.
      if (st.flat >= 5 || small_step || st.cur.total == 0.0) converged = true;
      return true;
    }
    st.lambda *= 4.0;
  }
  return false;
}

/// A minimiser on the boundary of the consistent set (singular pseudo-inertia) is approached with theta
/// diverging; keep the verdict robust to round-off by lifting eigenvalues below 1e-10 of the largest.
void liftBoundaryBodies(const Model& model, Eigen::VectorXd& phi) {
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    const Eigen::Vector4d l =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudoInertia(phi.segment<kParamsPerBody>(i)),
                                                       Eigen::EigenvaluesOnly)
            .eigenvalues();
    if (!(l.minCoeff() > 1e-10 * l.maxCoeff()))
      phi.segment<kParamsPerBody>(i) = projectBody(phi.segment<kParamsPerBody>(i), 1e-10, 1e-12);
  }
}

}  // namespace

ConsistentResult solveConsistent(const Model& model, const QuadraticTarget& target, const Eigen::VectorXd& prior,
                                 const Eigen::VectorXd& start, const ConsistentOptions& opt) {
  const int p = model.nparams();
  const double gamma = std::max(opt.prior_weight, 0.0);
  const Eigen::VectorXd x_prior = consistentCoordinates(model, prior, opt.eigenvalue_floor);
  LmState st;
  st.x = startCoordinates(model, start, x_prior, opt.eigenvalue_floor);
  st.cur = evaluate(model, target, st.x, x_prior, gamma);
  ConsistentResult res;
  res.start_cost = st.cur.data;
  Eigen::MatrixXd AD(target.A.rows(), p), H(p, p);
  Eigen::VectorXd g(p);
  for (int it = 0; it < opt.max_iterations && !res.converged; ++it) {
    res.iterations = it + 1;
    newtonModel(model, target, st.x, x_prior, gamma, st.cur, AD, H, g);
    if (st.cur.total == 0.0 || g.norm() <= 1e-300) {
      res.converged = true;
      break;
    }
    if (!levenbergMarquardtStep(model, target, x_prior, gamma, opt, H, g, st, res.converged)) {
      res.converged = true;  // no descent at any damping: x is stationary to working precision
      break;
    }
  }
  res.x = st.x;
  res.phi = st.cur.phi;
  liftBoundaryBodies(model, res.phi);
  res.target_cost = (target.A * res.phi - target.b).squaredNorm();
  res.consistency = checkConsistency(model, res.phi);
  return res;
}

ConsistentResult solveConsistentAtRank(const Model& model, const ScaledProblem& sp, int z, double nullspace_rel,
                                       double prior_rel, ConsistentOptions options) {
  z = std::clamp(z, 1, static_cast<int>(sp.s.size()));
  const double sz2 = sp.s[z - 1] * sp.s[z - 1];
  const QuadraticTarget t =
      consistentTarget(sp.s, sp.V, sp.d, sp.h, sp.gamma, sp.prior, z, nullspace_rel * sz2, sp.Q, sp.fill);
  options.prior_weight = prior_rel * sz2;
  return solveConsistent(model, t, sp.prior, solveAtRank(sp, z), options);
}

}  // namespace exoid::estimator
