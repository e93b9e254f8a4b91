#pragma once
// Calibration excitation with the pelvis held in a harness (the feet free; `exoid calibrate`, docs/diagnose.md
// "Calibration run"): every actuated joint follows a sum of sines about the middle of its range, and the drives
// track it by computed torque on the fixed-base model,
//   q_d(t) = c + w(t) sum_k A_k sin(2 pi f_k t + phi_k),   w: a quintic fade-in over ramp_s after the move from
//   the start pose to the centres c (mid-range; hip abduction: outward of the start) over another ramp_s,
//   tau = rnea(q_d, v_d, a_d; base at rest) + kp_j (q_d - q) + kd_j (v_d - v)   (gains per joint, below).
// Why: on a robot that balances on both feet, a constant joint torque (a torque-sensor offset) is a first-moment
// shift of the links around the joint; legs swinging through large angles against gravity separate the two.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/model.hpp"

namespace exoid::controller {

struct LegSwingOptions {
  /// Hz: the sines of every joint (incommensurate, so the joints' motions are not collinear).
  std::vector<double> frequencies_hz = {0.11, 0.23, 0.37};
  double ramp_s = 3.0;  ///< s: the sines fade in over this time (from the start pose, moved to the centres first)
  /// Peak excursion from the centre as a fraction of the half range of the joint's URDF limits. A hip abduction
  /// (name containing "hip_aa") swings outward only, between its start and twice its peak, so that the soles
  /// never meet.
  double fraction = 0.6;
  double fraction_hip_aa = 0.3;
  /// The PD's bandwidth: kp_j = M_jj w^2, kd_j = 2 zeta M_jj w with w = 2 pi bandwidth_hz and M_jj the joint's
  /// inertia at the swing's centre (crba). Scaled per joint because one gain for all would be too stiff for a
  /// foot (M_jj ~ 0.005 kg m^2: unstable under the sim's 1 ms explicit steps) or too soft for a hip (~1.5).
  double bandwidth_hz = 3.0;
  double damping_ratio = 1.0;
  uint64_t seed = 1;  ///< the sines' phases
};

/// The reference of every joint; built once (allocates), evaluated allocation-free.
struct LegSwingTrajectory {
  Eigen::VectorXd q_start;   ///< [nj] the start pose
  Eigen::VectorXd centre;    ///< [nj] the swing's centre (mid-range, hip abduction outward; unactuated: q_start)
  Eigen::MatrixXd amplitude; ///< [nj x nf] rad (0 rows for unactuated joints)
  Eigen::MatrixXd phase;     ///< [nj x nf] rad
  Eigen::VectorXd frequency; ///< [nf] Hz
  double ramp_s = 3.0;
  std::vector<char> driven;  ///< [nj] actuated (URDF effort limit > 0)
  Eigen::VectorXd kp, kd;    ///< [nj] N m/rad, N m s/rad (LegSwingOptions::bandwidth_hz)
};

/// From the model's limits (finite ones needed on the actuated joints) and the start pose q_start [nj].
bool makeLegSwingTrajectory(const Model& model, const Eigen::VectorXd& q_start, const LegSwingOptions& options,
                            LegSwingTrajectory& out, std::string* error);

/// q_d, v_d, a_d [nj] at time t (s). First the move from q_start to the centres (a quintic over ramp_s), then
/// the sines faded in by a quintic smoothstep over another ramp_s. Allocation-free.
void legSwingReference(const LegSwingTrajectory& trajectory, double t, Eigen::VectorXd& q, Eigen::VectorXd& v,
                       Eigen::VectorXd& a);

/// Scratch of the tracking law (one per thread, sized once).
struct LegSwingData {
  explicit LegSwingData(const Model& model);
  DynamicsData dynamics;
  State state;
  Eigen::VectorXd qd, vd, ad;  ///< [nj] the reference at the last call
};

/// Joint torques tau [nj] at time t from the measured q, v [nj]: computed torque on the model with its base at
/// rest and upright (the harness), plus the trajectory's PD; unactuated joints get 0. Allocation-free.
void legSwingTorque(const Model& model, const LegSwingTrajectory& trajectory, LegSwingData& data, double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::VectorXd& tau);

}  // namespace exoid::controller
