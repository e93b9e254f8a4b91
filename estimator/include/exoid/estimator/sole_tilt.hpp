#pragma once
// The soles' tilt on their contacts, from the plates (DatasetOptions::sole_tilt).
//
// With both soles flat and still, the legs give the base orientation with the encoders' precision,
// R_legs = R_ws R_bs(q)^T (dataset.hpp), except for how far the soles roll into their contacts. That roll
// follows the load: a sole (shoe, rubber, the contact's compliance) is a spring, so its tilt is about linear
// in the wrench on it. The IMU sees the roll, e = log(R_legs^T R_IMU) (base coordinates), under its own white
// noise (3.5 mrad at 1 kHz for an MTi-300-class AHRS). A low-pass keeps that noise's low band (about 0.3 mrad
// at 5 Hz); a linear fit over the whole run averages it over every sample:
//   e(t) ~ C x(t),  x = [1, f_0, n_0, f_1, n_1]  [13]
// f_k, n_k the force and moment on foot k about its plate's sensor origin (world axes; 0 where a sample has no
// contact k). C [3 x 13] by least squares on columns scaled to unit RMS, minimum-norm where the columns are
// dependent (the two vertical forces sum to the weight), each axis's columns chosen by BIC (forward selection from
// the constant: a column the tilt does not follow would only add the IMU's noise, sigma sqrt(k / n) per column).
// docs/identification.md "The soles' tilt from the plates".
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/dataset.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// x [13] of a sample: [1, f_0, n_0, f_1, n_1] (N, N m about the plate's sensor origin).
Eigen::Matrix<double, kSoleTiltRegressors, 1> soleTiltRegressor(const MeasuredSample& s);

/// Name of column k of x: "1", "right_fx" .. "right_nz", "left_fx" .. "left_nz" (contact 0 is the right foot).
std::string soleTiltColumnName(int k);

/// One line for a report: per axis the RMS the fit explains and the columns it kept, and what it leaves (mrad).
std::string describeSoleTilt(const SoleTilt& tilt);

/// The chordal mean of rotations: the rotation nearest (Frobenius) to M, a sum of rotations.
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& M);

/// R_wb from the legs: the chordal mean over the feet of R_ws R_bs^T. sole_world [feet] R_ws, Rbs [feet] R_bs(q).
Eigen::Matrix3d legsRotation(const std::vector<Eigen::Matrix3d>& sole_world, const Eigen::Matrix3d* Rbs);

/// Fits SoleTilt over a run, sample by sample (one pass; memory: the first 1000 samples' rotations).
/// The legs' rotation as DatasetBuilder forms it: R_ws per foot the chordal mean of R_IMU R_bs(q) over the
/// first 1000 samples, R_legs the chordal mean of R_ws R_bs(q)^T over the feet (from the encoders as read; the
/// builder's filtered q differ by the encoders' noise, and the fit's constant takes up any common offset).
class SoleTiltFit {
 public:
  SoleTiltFit(const Model& model, const std::vector<DatasetOptions::Foothold>& footholds);
  void add(const MeasuredSample& s);
  /// fitted false with fewer than 100 samples, without footholds, or when the fit is not finite.
  SoleTilt finish();

 private:
  /// R_ws from the buffered first samples, then their rows accumulated.
  void flushEarly();
  void accumulate(const std::vector<Eigen::Matrix3d>& Rbs, const Eigen::Quaterniond& imu,
                  const Eigen::Matrix<double, kSoleTiltRegressors, 1>& x);
  const Model& model_;
  std::vector<DatasetOptions::Foothold> footholds_;
  Data fk_;
  State state_;
  std::vector<Eigen::Matrix3d> sole_world_;  ///< [feet] R_ws once known
  struct Early {
    std::vector<Eigen::Matrix3d> Rbs;
    Eigen::Quaterniond imu;
    Eigen::Matrix<double, kSoleTiltRegressors, 1> x;
  };
  std::vector<Early> early_;  ///< the first samples, until R_ws is known
  Eigen::Matrix<double, kSoleTiltRegressors, kSoleTiltRegressors> xx_;
  Eigen::Matrix<double, kSoleTiltRegressors, 3> xe_;
  Eigen::Matrix3d ee_;
  long n_ = 0;
};

}  // namespace exoid::estimator
