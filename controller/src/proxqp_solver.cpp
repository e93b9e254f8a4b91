#include "exoid/controller/proxqp_solver.hpp"

#include <chrono>
#include <cmath>
#include <proxsuite/proxqp/dense/dense.hpp>

namespace exoid::controller {

namespace pq = proxsuite::proxqp;

void QpProblem::resize(const QpDimensions& d) {
  H = RowMatrixXd::Zero(d.n, d.n);
  A = RowMatrixXd::Zero(d.n_eq, d.n);
  C = RowMatrixXd::Zero(d.n_in, d.n);
  g = Eigen::VectorXd::Zero(d.n);
  b = Eigen::VectorXd::Zero(d.n_eq);
  l = Eigen::VectorXd::Zero(d.n_in);
  u = Eigen::VectorXd::Zero(d.n_in);
}

struct ProxQpSolver::Impl {
  explicit Impl(const QpDimensions& d) : dims(d), qp(d.n, d.n_eq, d.n_in, false, pq::DenseBackend::PrimalDualLDLT) {}
  QpDimensions dims;
  pq::dense::QP<double> qp;
  bool recompute_preconditioner = true;
};

ProxQpSolver::ProxQpSolver(const QpSolverSettings& settings) : settings_(settings) {}
ProxQpSolver::~ProxQpSolver() = default;

bool ProxQpSolver::setup(const QpDimensions& d) {
  if (d.n <= 0 || d.n_eq < 0 || d.n_in < 0) return false;
  impl_ = std::make_unique<Impl>(d);
  auto& qp = impl_->qp;
  qp.settings.eps_abs = settings_.eps_abs;
  qp.settings.eps_rel = 0.0;
  qp.settings.max_iter = settings_.max_iterations;
  qp.settings.verbose = false;
  qp.settings.compute_timings = false;
  qp.settings.initial_guess = pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT;
  // A well-posed placeholder problem so that init() sizes and builds everything here (setup time).
  QpProblem p;
  p.resize(d);
  p.H.setIdentity();
  for (int i = 0; i < d.n_eq; ++i) p.A(i, i % d.n) = 1.0;  // proxsuite's model checks reject a zero C
  for (int i = 0; i < d.n_in; ++i) p.C(i, i % d.n) = 1.0;
  p.l.setConstant(-1.0);
  p.u.setConstant(1.0);
  qp.init(p.H, p.g, p.A, p.b, p.C, p.l, p.u, true);
  qp.solve();
  impl_->recompute_preconditioner = true;
  return true;
}

void ProxQpSolver::resetWarmStart() {
  if (!impl_) return;
  impl_->qp.results.cleanup(impl_->qp.settings);
  impl_->recompute_preconditioner = true;
}

void ProxQpSolver::solve(const QpProblem& problem, QpResult& result) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!impl_ || problem.g.size() != impl_->dims.n || problem.b.size() != impl_->dims.n_eq ||
      problem.l.size() != impl_->dims.n_in) {
    result.status = QpStatus::NotRun;
    result.iterations = 0;
    result.solve_us = 0.0;
    return;
  }
  auto& qp = impl_->qp;
  const double big = proxsuite::helpers::infinite_bound<double>::value();
  qp.model.g = problem.g;
  qp.model.b = problem.b;
  qp.model.l = problem.l.cwiseMax(-big);
  qp.model.u = problem.u.cwiseMin(big);
  qp.update(problem.H, proxsuite::nullopt, problem.A, proxsuite::nullopt, problem.C, proxsuite::nullopt,
            proxsuite::nullopt, impl_->recompute_preconditioner);
  impl_->recompute_preconditioner = false;
  qp.solve();
  const auto& info = qp.results.info;
  switch (info.status) {
    case pq::QPSolverOutput::PROXQP_SOLVED:
      result.status = QpStatus::Solved;
      break;
    case pq::QPSolverOutput::PROXQP_MAX_ITER_REACHED:
      result.status = QpStatus::MaxIterations;
      break;
    case pq::QPSolverOutput::PROXQP_NOT_RUN:
      result.status = QpStatus::NotRun;
      break;
    default:  // primal / dual infeasible, closest feasible
      result.status = QpStatus::Infeasible;
      break;
  }
  result.iterations = static_cast<int>(info.iter);
  result.primal_residual = info.pri_res;
  result.dual_residual = info.dua_res;
  result.x = qp.results.x;
  if (result.status != QpStatus::Solved || !result.x.allFinite()) resetWarmStart();
  result.solve_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
}

std::unique_ptr<QpSolver> makeProxQpSolver(const QpSolverSettings& settings) {
  return std::make_unique<ProxQpSolver>(settings);
}

}  // namespace exoid::controller
