#pragma once
// Solver-agnostic dense QP and the solver interface. The control law only sees QpProblem / QpResult; a
// concrete solver (ProxQpSolver) lives behind QpSolver and its types never appear in these headers.
//
//   minimise 1/2 x^T H x + g^T x   subject to   A x = b,   l <= C x <= u   (l, u may be +-infinity).
#include <Eigen/Core>
#include <memory>

#include "exoid/status_samples.hpp"

namespace exoid::controller {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct QpDimensions {
  int n = 0;     ///< variables
  int n_eq = 0;  ///< equality rows
  int n_in = 0;  ///< two-sided inequality rows
};

/// A dense QP, sized once (resize) and refilled every tick.
struct QpProblem {
  RowMatrixXd H, A, C;
  Eigen::VectorXd g, b, l, u;

  void resize(const QpDimensions& dims);
  QpDimensions dimensions() const {
    return {static_cast<int>(g.size()), static_cast<int>(b.size()), static_cast<int>(l.size())};
  }
};

struct QpResult {
  QpStatus status = QpStatus::NotRun;
  int iterations = 0;
  double solve_us = 0.0;          ///< wall time of the solve, microseconds
  Eigen::VectorXd x;              ///< [n] primal solution (valid when status == Solved)
  double primal_residual = 0.0;   ///< max(|A x - b|_inf, inequality violation) reported by the solver
  double dual_residual = 0.0;     ///< |H x + g + A^T y + C^T z|_inf reported by the solver

  void resize(const QpDimensions& dims) { x = Eigen::VectorXd::Zero(dims.n); }
};

/// Interface of a QP solver usable inside the 1 kHz tick: setup() may allocate; solve() must not allocate,
/// throw or block, and keeps whatever warm start the solver supports.
class QpSolver {
 public:
  virtual ~QpSolver() = default;
  /// Allocates for problems of these dimensions. Returns false if the solver cannot.
  virtual bool setup(const QpDimensions& dims) = 0;
  /// Solves `problem` (same dimensions as setup). Fills result.status/iterations/solve_us/x.
  virtual void solve(const QpProblem& problem, QpResult& result) = 0;
  /// Drops the warm start (after a failure or a discontinuity).
  virtual void resetWarmStart() = 0;
  virtual const char* name() const = 0;
};

struct QpSolverSettings {
  double eps_abs = 0.0;    ///< absolute residual tolerance
  int max_iterations = 0;  ///< iteration cap
};

/// ProxQP (proxsuite, dense backend), preallocated and warm-started from the previous solution.
/// Allocation-free solves: the vectors are written straight into the solver's preallocated model and only
/// the row-major matrices go through QP::update() (update() would .eval() the vectors into temporaries).
std::unique_ptr<QpSolver> makeProxQpSolver(const QpSolverSettings& settings);

}  // namespace exoid::controller
