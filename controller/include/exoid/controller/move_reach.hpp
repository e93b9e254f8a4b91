#pragma once
// How far the CoM moves may go from the start-up CoM on a robot of this mass (docs/controller.md, "Move reach").
// A CoM at horizontal offset d from the legs' carrying joints asks them a static moment m g |d|: about the world y
// axis for a forward offset d_x, about the world x axis for a sideways d_y. In each leg the joint that carries it
// is the actuated joint (effort limit > 0) nearest the sole whose axis, at the start-up posture, lies within 45
// degrees of that moment axis (the exoskeleton: ankle_pd for d_x; hip_aa for d_y, the ankle in/eversion being
// passive). The offset is measured from the point midway between the two legs' carrying joints (the ankles'
// line forward, the pelvis's middle sideways), where by the legs' symmetry the moment they share vanishes.
// Either leg may end up carrying the whole load, so the weaker leg's limit tau counts:
//   |c_a - centre_a| <= half_a = budget x tau_a / (m g),   a in {x, y}.
// The rest of the limit is for the moves' dynamics, model error, and what a wearer adds (trunk sway, reflexes,
// passive joint moments). A light robot gets a reach beyond its support polygon (the polygon margin then binds);
// a heavy wearer gets less (110 kg wearer in the 41 kg exoskeleton, budget 0.4: +-0.041 m sideways).
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>

#include "exoid/controller/base_state_observer.hpp"
#include "exoid/model/model.hpp"

namespace exoid::controller {

/// Where the moves' targets may go: |c - centre| <= half per world horizontal axis (x, y; m).
struct MoveReach {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d half = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  bool admits(const Eigen::Vector2d& c) const {
    return std::abs(c.x() - centre.x()) <= half.x() && std::abs(c.y() - centre.y()) <= half.y();
  }
};

/// The reach for `budget` (fraction of the carrying joints' effort limits; <= 0: no bound), from the model's
/// mass and gravity, the soles' bodies, and the kinematics `kin` (base frame, forward kinematics at the start-up
/// posture) with the base's world pose (R_wb, p_wb). half = +infinity on an axis where no leg has a carrying joint
/// (nothing to protect). Allocation-free.
MoveReach staticMomentReach(const Model& model, const Data& kin, const Eigen::Matrix3d& R_wb,
                            const Eigen::Vector3d& p_wb, const std::array<SoleFrame, 2>& soles, double budget);

}  // namespace exoid::controller
