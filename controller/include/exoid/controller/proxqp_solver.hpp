#pragma once
// ProxQpSolver: the QpSolver backed by ProxQP (proxsuite 0.8, dense backend). The proxsuite types stay in
// the .cpp (pimpl) so that nothing solver-specific reaches the control law.
//
// Allocation-free use of ProxQP (checked by controller/tests/test_no_allocation.cpp):
//  - the dense::QP object is built once in setup() for fixed (n, n_eq, n_in) and init()ialised there;
//  - matrices are passed to QP::update() as row-major Eigen matrices (proxsuite's MatRef is a Ref to a
//    row-major matrix: a column-major argument would be copied into a temporary);
//  - g, b, l, u are written straight into qp.model (QP::update() would .eval() each vector into a temporary,
//    i.e. allocate) and update() is called with nullopt for them: a matrix update still flags the
//    refactorisation and setup() rescales the whole model;
//  - warm start: InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT; the Ruiz preconditioner is recomputed
//    on the first real problem (and after resetWarmStart()), kept otherwise.
#include <memory>

#include "exoid/controller/qp_solver.hpp"

namespace exoid::controller {

class ProxQpSolver final : public QpSolver {
 public:
  explicit ProxQpSolver(const QpSolverSettings& settings);
  ~ProxQpSolver() override;
  bool setup(const QpDimensions& dims) override;
  void solve(const QpProblem& problem, QpResult& result) override;
  void resetWarmStart() override;
  const char* name() const override { return "proxqp"; }

 private:
  struct Impl;
  QpSolverSettings settings_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace exoid::controller
