#include "exoid/estimator/base_parameters.hpp"

#include <Eigen/QR>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>

#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid {

BaseParameters computeBaseParameters(const Model& model, const BaseParameterOptions& options) {
  const int p = model.nparams(), nv = model.nv;
  Eigen::MatrixXd W(options.samples * nv, p);
  Data data(model);
  std::mt19937_64 rng(options.seed);
  State s = State::zero(model);
  for (int k = 0; k < options.samples; ++k) {
    randomState(model, rng, s);
    computeJointTorqueRegressor(model, data, s);
    W.middleRows(k * nv, nv) = data.K;
  }
  for (int c = 0; c < p && c < static_cast<int>(options.held.size()); ++c)
    if (options.held[c]) W.col(c).setZero();
  BaseParameters out;
  out.nparams = p;
  out.column_norm.resize(p);
  for (int c = 0; c < p; ++c) out.column_norm[c] = W.col(c).norm();

  if (W.rows() == 0) {  // fixed base without joints: no generalized force, no parameter has an effect
    for (int i = 0; i < p; ++i) out.dependent.push_back(i);
    out.beta.resize(0, p);
    out.base_map.resize(0, p);
    out.nullspace = Eigen::MatrixXd::Identity(p, p);
    out.kind.assign(p, Identifiability::None);
    return out;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(W);
  const Eigen::MatrixXd R = qr.matrixR().topRows(std::min<int>(W.rows(), p)).template triangularView<Eigen::Upper>();
  const double r11 = p > 0 ? std::abs(R(0, 0)) : 0.0;
  int m = 0;
  while (m < std::min<int>(R.rows(), p) && std::abs(R(m, m)) > options.tolerance * r11) ++m;
  out.rank = m;
  out.pivot_ratio = m > 0 ? std::abs(R(m - 1, m - 1)) / r11 : 0.0;
  out.gap_ratio = (m < std::min<int>(R.rows(), p) && m > 0) ? std::abs(R(m, m)) / std::abs(R(m - 1, m - 1)) : 0.0;
  const auto& perm = qr.colsPermutation().indices();
  for (int i = 0; i < p; ++i) (i < m ? out.independent : out.dependent).push_back(perm[i]);

  // W P = Q [R11 R12] -> W_dep = W_ind R11^-1 R12.
  // No dependent column (e.g. one free body, 10 of 10): Eigen's triangular solve of an empty right-hand side
  // reads coefficient (0, 0) of it, undefined behaviour that the sanitizer build reports.
  if (p > m)
    out.beta = R.topLeftCorner(m, m).triangularView<Eigen::Upper>().solve(R.block(0, m, m, p - m));
  else
    out.beta.resize(m, 0);
  // Entries that are zero up to rounding are exactly zero (structural combinations have clean coefficients).
  const double clean = 1e-9 * std::max(1.0, out.beta.size() > 0 ? out.beta.cwiseAbs().maxCoeff() : 0.0);
  out.beta = out.beta.unaryExpr([&](double x) { return std::abs(x) < clean ? 0.0 : x; });

  out.base_map = Eigen::MatrixXd::Zero(m, p);
  out.nullspace = Eigen::MatrixXd::Zero(p, p - m);
  for (int i = 0; i < m; ++i) {
    out.base_map(i, out.independent[i]) = 1.0;
    for (int d = 0; d < p - m; ++d) out.base_map(i, out.dependent[d]) = out.beta(i, d);
  }
  for (int d = 0; d < p - m; ++d) {
    out.nullspace(out.dependent[d], d) = 1.0;
    for (int i = 0; i < m; ++i) out.nullspace(out.independent[i], d) = -out.beta(i, d);
  }
  out.kind.assign(p, Identifiability::Alone);
  for (int d = 0; d < p - m; ++d)
    out.kind[out.dependent[d]] = out.beta.col(d).isZero(0.0) ? Identifiability::None : Identifiability::InCombination;
  for (int i = 0; i < m; ++i)
    if (p > m && !out.beta.row(i).isZero(0.0)) out.kind[out.independent[i]] = Identifiability::InCombination;
  return out;
}

std::string describeBaseParameters(const Model& model, const BaseParameters& base) {
  const std::vector<std::string> names = model.paramNames();
  int alone = 0, none = 0;
  for (Identifiability k : base.kind) alone += k == Identifiability::Alone, none += k == Identifiability::None;
  std::ostringstream os;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "Base parameters of '%s' (%s base, %d bodies, %d joints): %d of %d standard parameters\n"
                "  (rank by column-pivoted QR of the regressor stacked over random states; smallest kept pivot "
                "%.1e of the largest, next pivot %.1e of it)\n",
                model.name.c_str(), model.floating_base ? "floating" : "fixed", model.nbodies, model.njoints,
                base.rank, base.nparams, base.pivot_ratio, base.gap_ratio);
  os << buf;
  os << "  identifiable alone: " << alone << ", only in combination: "
     << (base.nparams - alone - none) << ", not at all: " << none << "\n";
  os << "Identifiable alone:\n   ";
  for (int i = 0; i < base.nparams; ++i)
    if (base.kind[i] == Identifiability::Alone) os << " " << names[i];
  os << "\nBase parameters that combine several standard parameters:\n";
  for (int i = 0; i < base.rank; ++i) {
    if (base.beta.cols() == 0 || base.beta.row(i).isZero(0.0)) continue;  // row() of an empty matrix is UB
    os << "  b" << i << " = " << names[base.independent[i]];
    for (int d = 0; d < static_cast<int>(base.dependent.size()); ++d) {
      const double c = base.beta(i, d);
      if (c == 0.0) continue;
      std::snprintf(buf, sizeof buf, " %s %.6g %s", c < 0 ? "-" : "+", std::abs(c), names[base.dependent[d]].c_str());
      os << buf;
    }
    os << "\n";
  }
  os << "Not identifiable (no effect on any generalized force):\n   ";
  for (int i = 0; i < base.nparams; ++i)
    if (base.kind[i] == Identifiability::None) os << " " << names[i];
  if (none == 0) os << " (none)";
  os << "\n";
  return os.str();
}

}  // namespace exoid
