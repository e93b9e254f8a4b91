#pragma once
// WLS-RC-PC: a physically consistent estimate by construction (issue 7 item 3; the thesis's estimates were
// not consistent, Appendix D). Every body's parameters are written in log-Cholesky coordinates theta_b
// (exoid/model/inertial.hpp: every theta is a body with a positive definite pseudo-inertia, every such body
// has one theta), other parameters (friction) stay linear, and Levenberg-Marquardt minimises
//     F(x) = ||A phi(x) - b||^2 + gamma ||x - x_prior||^2,      x = [theta_0 .. theta_(nb-1), friction]
// without constraints: each iterate is consistent, none can leave the set. The steps are Newton steps
// (Gauss-Newton plus the curvature of theta -> phi weighted by the residual, which matters because the
// residual at a constrained minimiser is not small) with Levenberg damping and a trust region of one unit
// per log-Cholesky coordinate.
// The quadratic target ||A phi - b||^2 is the WLS-RC fit in its own metric (consistentTarget below): the
// scaled, truncated least-squares cost of the z kept directions (thesis eqs. 24-32 and III-D), plus a weak
// pull toward the prior in the directions the truncated fit does not use (the unexcited ones). When the
// WLS-RC estimate is itself consistent it is the minimiser of the target (up to the gamma term).
// In phi the target is convex and the map theta -> phi is a diffeomorphism onto the consistent set, so with
// gamma = 0 every stationary point is the global constrained minimum; gamma > 0 (tiny) keeps the minimiser
// away from the boundary (where theta diverges) and fixes directions A leaves free.
#include <Eigen/Core>
#include <vector>

#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// A quadratic target ||A phi - b||^2 with A [k x p], b [k].
struct QuadraticTarget {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
};

/// The WLS-RC fit in its own metric, from the SVD of its scaled problem G W H = U S V^T (thesis eq. 27:
/// phi = H x + offset): kept directions V_z (the z largest singular values s_z, d_z = U_z^T y~):
///     ||S_z V_z^T H^-1 (phi - offset) - d_z||^2 + nullspace_weight ||(I - V_z V_z^T) H^-1 (phi - prior)||^2.
/// s [r], V [p x r] (orthonormal columns), d [r], h [p] column scale (> 0), offset [p] (the prior for column
/// scaling, 0 without), prior [p]; z clamped to [0, r]. nullspace_weight is absolute (e.g. 1e-2 s_z^2).
QuadraticTarget consistentTarget(const Eigen::VectorXd& s, const Eigen::MatrixXd& V, const Eigen::VectorXd& d,
                                 const Eigen::VectorXd& h, const Eigen::VectorXd& offset,
                                 const Eigen::VectorXd& prior, int z, double nullspace_weight);
/// The same with the unused directions pulled toward the prior in the fill's metric (solvers.hpp,
/// ScaledProblem::Q and fill): nullspace_weight ||(I - Q_z Q_z^T) D^-1 (phi - prior)||^2, D = diag(fill), whose
/// minimiser together with the kept equations is solveAtRank's estimate. Q = V, fill = h gives the above.
QuadraticTarget consistentTarget(const Eigen::VectorXd& s, const Eigen::MatrixXd& V, const Eigen::VectorXd& d,
                                 const Eigen::VectorXd& h, const Eigen::VectorXd& offset,
                                 const Eigen::VectorXd& prior, int z, double nullspace_weight,
                                 const Eigen::MatrixXd& Q, const Eigen::VectorXd& fill);

struct ConsistentOptions {
  double prior_weight = 0.0;  ///< gamma: weight of ||x - x_prior||^2 in log-Cholesky coordinates (absolute)
  int max_iterations = 500;
  double tolerance = 1e-12;   ///< stop after 5 steps in a row lowering F by less than this (relative), or
                              ///< a step below this relative to |x|
  double max_step = 1.0;      ///< largest change of any coordinate per step (log-Cholesky: a factor e)
  /// Inconsistent bodies of a start or prior are projected onto the consistent set by raising the
  /// pseudo-inertia's eigenvalues to at least eigenvalue_floor times its largest (relative).
  double eigenvalue_floor = 1e-6;
};

struct ConsistentResult {
  Eigen::VectorXd phi;    ///< [p] estimate; every body consistent
  Eigen::VectorXd x;      ///< [p] its coordinates (log-Cholesky per body, then the linear parameters)
  double target_cost = 0.0;   ///< ||A phi - b||^2 at the estimate
  double start_cost = 0.0;    ///< ||A phi - b||^2 at the (projected) start
  int iterations = 0;
  bool converged = false;
  std::vector<LinkConsistency> consistency;  ///< [nbodies] verdict of the estimate
};

/// Projects each inconsistent body of phi [p] onto the consistent set (eigenvalues of its pseudo-inertia
/// raised to the floor, relative to its largest eigenvalue; a body with no positive eigenvalue gets
/// floor_abs times the identity pseudo-inertia). Consistent bodies and the other parameters are unchanged.
Eigen::VectorXd projectConsistent(const Model& model, const Eigen::VectorXd& phi, double relative_floor = 1e-6,
                                  double floor_abs = 1e-9);

/// Log-Cholesky coordinates x [p] of phi [p] (bodies projected first if inconsistent) and back.
Eigen::VectorXd consistentCoordinates(const Model& model, const Eigen::VectorXd& phi, double relative_floor = 1e-6);
Eigen::VectorXd paramsFromConsistentCoordinates(const Model& model, const Eigen::VectorXd& x);

/// Jacobian d phi / d x [p x p] at x (block diagonal: 10 x 10 per body, identity for the other parameters).
Eigen::MatrixXd consistentJacobian(const Model& model, const Eigen::VectorXd& x);

/// Minimises ||A phi - b||^2 + gamma ||x - x_prior||^2 over consistent phi by Levenberg-Marquardt from start
/// (its inconsistent bodies start at the prior's, projected if the prior's is inconsistent too). A final
/// minimiser on the boundary (singular pseudo-inertia, approached with theta diverging) has its smallest
/// pseudo-inertia eigenvalues lifted to 1e-10 of the largest so that the verdict survives round-off. prior: [p], its log-Cholesky coordinates anchor the gamma term.
ConsistentResult solveConsistent(const Model& model, const QuadraticTarget& target, const Eigen::VectorXd& prior,
                                 const Eigen::VectorXd& start, const ConsistentOptions& options = {});

/// WLS-RC-PC on a prepared problem (solvers.hpp; WLS-RC for the thesis's scaling, any method works): the
/// target of its rank-z fit (consistentTarget with nullspace_weight = nullspace_rel * s_z^2), started at
/// that fit (solveAtRank), gamma = prior_rel * s_z^2. The unused directions are pulled toward the prior in the
/// fill's metric (ScaledProblem::Q, fill); nullspace_rel = 3e-2 keeps the estimation error at WLS-RC's
/// (docs/study.md measures 1e-3 to 1).
ConsistentResult solveConsistentAtRank(const Model& model, const ScaledProblem& problem, int z,
                                       double nullspace_rel = 3e-2, double prior_rel = 1e-6,
                                       ConsistentOptions options = {});

}  // namespace exoid::estimator
