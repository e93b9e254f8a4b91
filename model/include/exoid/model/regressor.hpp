#pragma once
#include "exoid/model/model.hpp"

namespace exoid {

/// Joint torque regressor K(q, v, dv) of the seed thesis, eqs. (10)-(14) with the friction columns of
/// eqs. (2.48)-(2.49): K * phi = generalized force, for the parameters phi of Model::phi.
///
///   K = [K_phi  K_d],   K_phi[i, l] = beta_i . delta_i(l) . X^F(i <- l) . A_l,   size nv x (10 nb + 2 nj)
///
/// Rows: with a floating base, rows 0-2 are the moment and rows 3-5 the force on the base about its
/// origin in base coordinates (the six generalized forces of the free joint), then one row per joint
/// (torque about the joint axis). Columns: 10 per body in tree order, then (fv, fc) per joint with
/// K[j, fv] = v_j and K[j, fc] = sign(v_j) (sign(0) = 0).
/// Implementation: each body's 6x10 block A_l is expressed once about the reference origin (the thesis's
/// X^F of eq. (14) applied to the root), and joint row i is S_i^T of it with S_i = [axis_i; p_i x axis_i].
/// Writes data.K (structural zeros are set by the Data constructor and never touched). Allocation-free.
void computeJointTorqueRegressor(const Model& model, Data& data, const State& state);

}  // namespace exoid
