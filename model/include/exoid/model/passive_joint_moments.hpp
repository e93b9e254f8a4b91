#pragma once
// The passive moments of a wearer's leg joints (docs/wearer.md): the elastic moments of Riener & Edrich (1999),
// "Identification of passive elastic joint moments in the lower extremities", J. Biomech. 32:539-544 — a
// double exponential per joint with biarticular coupling (hip on knee, knee on hip and ankle, ankle on knee),
// angles in degrees, moments in N m — converted to exoid's joint conventions (docs/conventions.md: hip flexion +,
// knee flexion +, ankle dorsiflexion +), plus linear viscous damping. Allocation-free (run each sim tick).
#include <Eigen/Core>

namespace exoid {

/// The sagittal joints of one leg, in this order: hip flexion, knee flexion, ankle dorsiflexion (exoid's signs).
using LegJoints = Eigen::Vector3d;

/// Riener & Edrich 1999, in the paper's own convention: angles in degrees with hip phi_H + flexion, knee phi_K +
/// flexion, ankle phi_A + plantarflexion; moments in N m, each + in the direction of its joint's + angle:
///   M_H = exp(1.4655 - 0.0034 phi_K - 0.0750 phi_H) - exp(1.3403 - 0.0226 phi_K + 0.0305 phi_H) + 8.072
///   M_K = exp(1.800 - 0.0460 phi_A - 0.0352 phi_K + 0.0217 phi_H)
///         - exp(-3.971 - 0.0004 phi_A + 0.0495 phi_K - 0.0128 phi_H) - 4.820 + exp(2.220 - 0.150 phi_K)
///   M_A = exp(2.1016 - 0.0843 phi_A - 0.0176 phi_K) - exp(-7.9763 + 0.1949 phi_A + 0.0008 phi_K) - 1.792
/// Returns (M_H, M_K, M_A).
Eigen::Vector3d rienerEdrichPaperMoments(double phi_hip_deg, double phi_knee_deg, double phi_ankle_deg);

/// The same law in exoid's conventions: q = (hip flexion, knee flexion, ankle dorsiflexion) in rad, the moments
/// (N m) on those joints with exoid's signs: phi_H = deg(q0), phi_K = deg(q1), phi_A = -deg(q2);
/// tau = (M_H, M_K, -M_A).
LegJoints passiveElasticMoments(const LegJoints& q);

/// Viscous damping of the relaxed joints, N m s/rad per joint (hip, knee, ankle): tau = -b .* v.
struct PassiveJointDamping {
  LegJoints b = LegJoints(1.0, 0.5, 0.3);  ///< docs/wearer.md says where these come from and what is missing
};

/// Elastic (scaled by `elastic_scale`, 1 = the paper) plus viscous moments on one leg's joints.
LegJoints passiveJointMoments(const LegJoints& q, const LegJoints& v, const PassiveJointDamping& damping,
                              double elastic_scale = 1.0);

}  // namespace exoid
