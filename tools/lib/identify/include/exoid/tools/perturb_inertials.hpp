#pragma once
// A wrong-but-plausible prior: every body's inertial parameters perturbed at random, physically consistent,
// each physical quantity within +-relative of its nominal value (issue 8's "+-25 % prior" for the controller
// and the estimator). Per body with mass > 0, independent uniform factors (1 + u), |u| <= relative:
//   mass m' = m (1 + u_m); centre of mass c'_i = c_i (1 + u_i) per link-frame coordinate (a 0 stays 0);
//   principal moments about the CoM l'_k = l_k (1 + u_k) in the nominal principal axes, redrawn until they
//   satisfy the triangle inequality (so the pseudo-inertia stays positive definite, model/inertial.hpp).
// Joint friction entries are left as they are. Deterministic for a seed on every platform (mt19937_64's raw
// output, no standard distribution).
#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "exoid/model/model.hpp"

namespace exoid::tools {

/// The perturbed parameters [nparams]. False with *error when relative is not in [0, 0.9] or a body's
/// nominal parameters are not consistent (nothing to perturb around).
bool perturbInertials(const Model& model, double relative, uint64_t seed, Eigen::VectorXd& phi, std::string* error);

}  // namespace exoid::tools
