#pragma once
// The right-hand side y of K(q, v, dv) phi = y from measurements: joint torques and external contact
// wrenches (force plates) mapped into generalized forces (thesis eq. 4: tau = S^T f_a + J_g^T f_e).
#include <Eigen/Core>

#include "exoid/model/model.hpp"

namespace exoid {

/// An external wrench on a body: force (world) and its moment about the WORLD origin (world coordinates).
struct ExternalWrench {
  int body = -1;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment_world_origin = Eigen::Vector3d::Zero();
};

/// y [nv] = S^T tau_joints + sum_c J_c^T w_c.  Requires forwardKinematics(model, kin, state) for this state
/// (uses kin.p, kin.axis) and state.base_position / base_orientation to move world wrenches to the base.
/// tau_joints [njoints]: joint torques (0 on unactuated joints); contacts [ncontacts]. Allocation-free.
/// Base rows: sum_c [R^T (n_O - p_b x f); R^T f] (moment then force about the base origin, base coords).
/// Joint row j: tau_j + sum over contacts c in the subtree of joint j of S_j^T w_c, S_j = [axis; p x axis].
void generalizedForceFromMeasurements(const Model& model, const Data& kin, const State& state,
                                      const Eigen::VectorXd& tau_joints, const ExternalWrench* contacts,
                                      int ncontacts, Eigen::Ref<Eigen::VectorXd> y);

}  // namespace exoid
