#include "exoid/controller/move_reach.hpp"

#include <cmath>
#include <limits>

namespace exoid::controller {

MoveReach staticMomentReach(const Model& model, const Data& kin, const Eigen::Matrix3d& R_wb,
                            const Eigen::Vector3d& p_wb, const std::array<SoleFrame, 2>& soles, double budget) {
  const double inf = std::numeric_limits<double>::infinity();
  const double weight = model.totalMass() * model.gravity.norm();
  MoveReach reach;
  if (!(budget > 0.0) || !(weight > 0.0)) return reach;
  // Moment axes: a forward offset loads world y, a sideways one world x.
  const Eigen::Vector3d moment_axis[2] = {Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX()};
  const double cos45 = std::sqrt(0.5);
  for (int a = 0; a < 2; ++a) {
    double weakest = inf, centre = 0.0;
    int carriers = 0;
    for (const SoleFrame& sole : soles) {
      for (int b = sole.body; b >= 0; b = model.parent[static_cast<size_t>(b)]) {
        const int j = model.jointOfBody(b);
        if (j < 0) break;  // the floating base: no joint of this leg carries it
        const double limit = model.effort_limit[j];
        const Eigen::Vector3d axis = R_wb * kin.axis[static_cast<size_t>(b)];
        if (limit > 0.0 && std::isfinite(limit) && std::abs(axis.dot(moment_axis[a])) >= cos45) {
          weakest = std::min(weakest, limit);
          centre += (p_wb + R_wb * kin.p[static_cast<size_t>(b)])[a];  // the axis passes through the body origin
          ++carriers;
          break;
        }
      }
    }
    if (carriers == 0) continue;
    reach.centre[a] = centre / carriers;
    reach.half[a] = budget * weakest / weight;
  }
  return reach;
}

}  // namespace exoid::controller
