#pragma once
// Synthetic fixed-base serial arms with joint friction, as test and benchmark data for the identification's
// rank rules (docs/identification.md, "Synthetic arms"): data sets whose truth is known and whose shape (joint
// count, link sizes, friction relative to the inertial torques, sensor noise, sample rate) is chosen, so that a
// default is judged on robots other than the ones in the repository.
//
// The arm (makeSyntheticArm): `joints` revolute joints in a chain on a fixed root; the first axis vertical, each
// next joint placed at a random length L ~ U(0.1, 0.45) m along a random direction of its parent, rotated by
// random multiples of 90 deg plus up to +-0.3 rad per axis (so axes are generic, neither all parallel nor
// all orthogonal); link masses 2-15 kg decreasing along the chain, centres of mass near the middle of the link
// (+-5 cm), inertia about the CoM that of a random box (sides 4-30 cm) in a random orientation: physically
// consistent by construction. Friction per joint, fv_j and fc_j, is drawn relative to that joint's inertial
// torque on a reference motion: fc_j = r U(0.5, 1.5) RMS(tau_rb,j), fv_j = r U(0.5, 1.5) RMS(tau_rb,j) / RMS(v_j)
// with r = friction_ratio (0.1-0.3 is a harmonic-drive arm; >= 1 an arm whose friction dominates, the issue's
// industrial arm). Optionally a constant torque offset per joint (a model error: exoid's model has none).
//
// A run (simulateArmRun): an exciting trajectory of `harmonics` sines per joint (base frequency 0.1 Hz,
// amplitudes ~1/k, random phases), scaled so that |q - q0| <= 1 rad and |v| <= max_velocity, within the URDF
// limits; torques tau = rnea(truth) (rigid body + fv v + fc sign v) + offset + white noise of sigma
// torque_noise RMS(tau_j) per joint (1-3 %: joint torque sensors; 10 %: torques from motor currents), encoder
// noise on q and white noise on the recorded v and a. Written as the measured-data CSV of `exoid identify`.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"

namespace exoid::tools {

struct SyntheticArmOptions {
  int joints = 6;               ///< revolute joints, 2-9
  uint64_t seed = 1;
  double friction_ratio = 0.2;  ///< r above: friction torques relative to the rigid-body torques
  double offset_ratio = 0.0;    ///< constant torque offset per joint, +-this x RMS(tau_rb,j) (0: none)
};

struct SyntheticArm {
  std::string urdf;         ///< the arm's URDF (no friction: a URDF carries none)
  Model model;              ///< built from urdf, fixed base; model.phi = the URDF's inertials, friction 0
  Eigen::VectorXd truth;    ///< [nparams] the true parameters: the URDF's inertials and the drawn friction
  Eigen::VectorXd offset;   ///< [njoints] true constant torque offsets (not a model parameter)
};

/// Draws an arm. False with *error for a joint count outside [2, 9] or a negative ratio.
bool makeSyntheticArm(const SyntheticArmOptions& options, SyntheticArm& arm, std::string* error);

struct ArmRunOptions {
  uint64_t seed = 1;            ///< the trajectory's and the noise's seed (another seed: another motion)
  double duration = 30.0;       ///< s
  double rate = 100.0;          ///< Hz
  int harmonics = 5;
  double max_velocity = 1.5;    ///< rad/s per joint
  double torque_noise = 0.02;   ///< sigma per joint as a fraction of that joint's RMS torque in this run
  double encoder_noise = 1e-5;  ///< rad
  double velocity_noise = 1e-3;     ///< rad/s on the recorded v
  double acceleration_noise = 5e-2;  ///< rad/s^2 on the recorded a
  double payload = 0.0;         ///< kg added at the last link's origin for this run only (a loaded run)
};

/// One run: t [N], q, v, a, tau [N x njoints] (recorded, noise included).
struct ArmRun {
  Eigen::VectorXd t;
  Eigen::MatrixXd q, v, a, tau;
};
ArmRun simulateArmRun(const SyntheticArm& arm, const ArmRunOptions& options);

/// Writes a run as the measured-data CSV of `exoid identify` (t, q_, v_, a_, tau_ per joint). False with
/// *error when the file cannot be written.
bool writeArmRunCsv(const std::string& path, const Model& model, const ArmRun& run, std::string* error);

}  // namespace exoid::tools
