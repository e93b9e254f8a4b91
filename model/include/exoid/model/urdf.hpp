#pragma once
#include <string>

#include "exoid/model/model.hpp"

namespace exoid {

/// Builds a Model from a URDF file (urdfdom for the tree, document order for the numbering).
/// floating_base: the root link becomes body 0 on a 6-dof joint; otherwise the root is fixed to the world.
/// Supported joints: revolute, continuous (1 dof), fixed (lumped into the parent). Other types, a missing
/// file, malformed XML, a non-tree, no moving link, and any numeric attribute that is not whole, finite
/// numbers in range (negative mass, "13,5", "nan", "1e400", empty, ...; common::parseDouble) fail with a
/// one-line message in *error naming the link or joint, the element, the attribute, its value and line.
/// gravity_magnitude: |g| in m/s^2, gravity along -z of the world (root link for a fixed base).
bool buildModelFromUrdfFile(const std::string& path, bool floating_base, Model& model, std::string* error,
                            double gravity_magnitude = 9.81);
/// Same, from the URDF text.
bool buildModelFromUrdfString(const std::string& xml, bool floating_base, Model& model, std::string* error,
                              double gravity_magnitude = 9.81);

/// Standard parameters about a link origin (link coordinates) from a URDF-style inertial: mass, centre of
/// mass c, and inertia tensor about the centre of mass in a frame rotated by R_inertial from the link frame.
Vector10d paramsFromInertial(double mass, const Eigen::Vector3d& com, const Eigen::Matrix3d& R_inertial,
                             const Eigen::Matrix3d& inertia_com);
/// Parameters of a body moved rigidly into the frame of another: child frame at (R, p) in the parent.
Vector10d transformParams(const Vector10d& phi, const Eigen::Matrix3d& R, const Eigen::Vector3d& p);
/// Inertia tensor about the origin from the last six parameters.
Eigen::Matrix3d inertiaTensor(const Vector10d& phi);
/// 4x4 pseudo-inertia matrix [0.5 tr(I) E - I, h; h^T, m]; positive definite iff physically consistent.
Eigen::Matrix4d pseudoInertia(const Vector10d& phi);

}  // namespace exoid
