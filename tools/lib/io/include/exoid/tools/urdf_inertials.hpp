#pragma once
// Writes a copy of a URDF with each body's <inertial> replaced by identified parameters (mass, centre of
// mass, inertia about the centre of mass in link axes). Links lumped into a body by fixed joints lose their
// <inertial> (their share is inside the body's estimate). Joint friction is not written (the URDF loader
// reads none).
#include <Eigen/Core>
#include <string>

#include "exoid/model/model.hpp"

namespace exoid::tools {

/// phi: standard parameters of the model [nparams] (every body's mass must be > 0). False with *error on an
/// unreadable input, a link missing from the text, a non-positive mass, or an unwritable output.
bool writeUrdfWithInertials(const std::string& urdf_in, const Model& model, const Eigen::VectorXd& phi,
                            const std::string& urdf_out, std::string* error);

}  // namespace exoid::tools
