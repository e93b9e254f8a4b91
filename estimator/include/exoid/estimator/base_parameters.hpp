#pragma once
// Structural base parameters (thesis section II-E; Gautier 1990, "Numerical calculation of the base inertial
// parameters of robots"): column-pivoted QR of the regressor stacked over random states.
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"

namespace exoid {

/// How a standard parameter enters the dynamics.
enum class Identifiability { Alone, InCombination, None };

struct BaseParameters {
  int nparams = 0;                 ///< standard parameters p
  int rank = 0;                    ///< number of base parameters m
  std::vector<int> independent;    ///< [m] standard-parameter indices kept as base parameters (pivot order)
  std::vector<int> dependent;      ///< [p - m] the others
  Eigen::MatrixXd beta;            ///< [m x (p - m)] W_dependent = W_independent * beta
  Eigen::MatrixXd base_map;        ///< [m x p] phi_base = base_map * phi  (row i: e_ind(i) + beta(i, :) on dependents)
  Eigen::MatrixXd nullspace;       ///< [p x (p - m)] K(q, v, dv) * nullspace = 0 for every state
  std::vector<Identifiability> kind;  ///< [p]
  std::vector<double> column_norm;    ///< [p] norm of each regressor column over the samples (0 = no effect)
  double pivot_ratio = 0.0;        ///< |R_mm| / |R_11| (smallest kept pivot, relative)
  double gap_ratio = 0.0;          ///< |R_(m+1)(m+1)| / |R_mm| (first dropped over last kept pivot)
};

/// Options: number of random states stacked, seed, relative pivot threshold.
struct BaseParameterOptions {
  int samples = 200;
  uint64_t seed = 1;
  double tolerance = 1e-9;  ///< pivots below tolerance * |R_11| count as zero
  /// [p] or empty: parameters held at known values (`exoid identify --only-links`). Their columns are left out
  /// (zeroed before the QR), so they are never base parameters and the map phi_base = base_map phi ignores them.
  std::vector<bool> held;
};

/// Computes the base parameters of a model. Random states: q uniform in [-pi, pi], velocities and
/// accelerations uniform, any base orientation and motion (structural, not trajectory-specific).
BaseParameters computeBaseParameters(const Model& model, const BaseParameterOptions& options = {});

/// Human-readable report: counts, then the parameters identifiable alone, the base combinations
/// ("b7 = right_thigh.Izz + 0.43 right_shank.mcx + ..."), and the parameters that do not enter at all.
std::string describeBaseParameters(const Model& model, const BaseParameters& base);

}  // namespace exoid
