#pragma once
// Kinematics of the tree: one forward pass (positions, velocities, accelerations of every body), the
// geometric Jacobian of a body point and its acceleration drift. Spatial 6-vectors are [angular; linear]
// (docs/conventions.md, "Spatial vectors").
#include "exoid/model/model.hpp"

namespace exoid {

/// Kinematics of every body in the reference frame (base frame if floating, root frame if fixed):
/// rotations, origins, joint axes, angular velocity/acceleration and the classical acceleration of each
/// origin minus gravity, by one forward pass over the tree. Gravity enters as an upward acceleration of the
/// root: acc_root = a_base - R_wb^T g (floating) or -g (fixed). Allocation-free.
void forwardKinematics(const Model& model, Data& data, const State& state);

/// Forward kinematics at zero acceleration and zero gravity (velocity-product terms only).
void forwardKinematicsDrift(const Model& model, Data& kin, const State& state);

/// Geometric Jacobian of a point fixed on a body (reference coordinates): J [6 x nv], rows
/// [angular velocity; linear velocity of the point], so that [omega; v_point] = J nu. Requires a prior
/// forwardKinematics (or rnea/crba) on out.kin for the same q. point_in_body: point in body coordinates.
void computePointJacobian(const Model& model, const Data& kin, int body, const Eigen::Vector3d& point_in_body,
                          Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J);

/// Classical acceleration drift of a body point: [angular acc; linear acc of the point] at dnu = 0 and no
/// gravity, i.e. dJ nu, so that the point's acceleration is J dnu + drift. Uses kin computed for the
/// state with zero accelerations; call forwardKinematicsDrift first.
Eigen::Matrix<double, 6, 1> pointAccelerationDrift(const Data& kin, int body, const Eigen::Vector3d& point_in_body);

}  // namespace exoid
