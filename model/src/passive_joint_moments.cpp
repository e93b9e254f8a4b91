// Riener & Edrich (1999) passive elastic joint moments and linear damping, in exoid's joint conventions.
#include "exoid/model/passive_joint_moments.hpp"

#include <cmath>

namespace exoid {

Eigen::Vector3d rienerEdrichPaperMoments(double H, double K, double A) {
  const double mh = std::exp(1.4655 - 0.0034 * K - 0.0750 * H) - std::exp(1.3403 - 0.0226 * K + 0.0305 * H) + 8.072;
  const double mk = std::exp(1.800 - 0.0460 * A - 0.0352 * K + 0.0217 * H) -
                    std::exp(-3.971 - 0.0004 * A + 0.0495 * K - 0.0128 * H) - 4.820 + std::exp(2.220 - 0.150 * K);
  const double ma = std::exp(2.1016 - 0.0843 * A - 0.0176 * K) - std::exp(-7.9763 + 0.1949 * A + 0.0008 * K) - 1.792;
  return {mh, mk, ma};
}

LegJoints passiveElasticMoments(const LegJoints& q) {
  constexpr double kDeg = 180.0 / M_PI;
  // The paper's ankle angle is + in plantarflexion, exoid's in dorsiflexion: the angle and the moment flip.
  const Eigen::Vector3d m = rienerEdrichPaperMoments(kDeg * q[0], kDeg * q[1], -kDeg * q[2]);
  return {m[0], m[1], -m[2]};
}

LegJoints passiveJointMoments(const LegJoints& q, const LegJoints& v, const PassiveJointDamping& damping,
                              double elastic_scale) {
  return elastic_scale * passiveElasticMoments(q) - damping.b.cwiseProduct(v);
}

}  // namespace exoid
